//! `feedscope-fuzz`: run the fuzz targets for a number of inputs or seconds each, and report
//! per target the inputs run, accepted and refused, findings, and peak memory. Exit code 0
//! when nothing was found, 1 when something was (the inputs are written under
//! `--corpus-out`), 2 on a usage error, 3 when an input ran past `--time-limit-ms`.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::Parser;
use feedscope_fuzz::{alloc, quiet_panics, rng::Rng, run_one, targets, watchdog, Limits, Outcome};

#[derive(Parser, Debug)]
#[command(
    name = "feedscope-fuzz",
    about = "Fuzz feedscope's parsers and config readers"
)]
struct Args {
    /// A target name, or `all` (see `--list`).
    #[arg(long, default_value = "all")]
    target: String,
    /// Inputs per target.
    #[arg(long, conflicts_with = "seconds")]
    inputs: Option<u64>,
    /// Seconds per target.
    #[arg(long)]
    seconds: Option<f64>,
    /// Seed of the generator (the same seed gives the same inputs).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Where inputs that gave a finding (or a timeout) are written, one folder per target.
    #[arg(long, default_value = "target/fuzz-findings")]
    corpus_out: PathBuf,
    /// Time bound of one input (ms).
    #[arg(long, default_value_t = 5000)]
    time_limit_ms: u64,
    /// Memory bound of one input (MB of peak allocation above the harness's own).
    #[arg(long, default_value_t = 512)]
    mem_limit_mb: usize,
    /// List the targets and exit.
    #[arg(long)]
    list: bool,
}

struct Stats {
    inputs: u64,
    accepted: u64,
    rejected: u64,
    findings: u64,
    peak: usize,
    elapsed: Duration,
}

fn main() -> ExitCode {
    let args = Args::parse();
    if args.list {
        for t in targets::all() {
            println!("{:<16} {}", t.name, t.about);
        }
        return ExitCode::SUCCESS;
    }
    let chosen: Vec<targets::Target> = if args.target == "all" {
        targets::all()
    } else {
        match targets::by_name(&args.target) {
            Some(t) => vec![t],
            None => {
                eprintln!("feedscope-fuzz: no target `{}` (see --list)", args.target);
                return ExitCode::from(2);
            }
        }
    };
    let limits = Limits {
        time: Duration::from_millis(args.time_limit_ms),
        mem_bytes: args.mem_limit_mb << 20,
    };
    if let Err(e) = std::fs::create_dir_all(&args.corpus_out) {
        eprintln!(
            "feedscope-fuzz: cannot create {}: {e}",
            args.corpus_out.display()
        );
        return ExitCode::from(2);
    }
    let dump = args.corpus_out.join("refused-allocation.bin");
    match std::fs::File::create(&dump) {
        Ok(f) => alloc::set_dump(f),
        Err(e) => eprintln!("feedscope-fuzz: cannot create {}: {e}", dump.display()),
    }
    watchdog::start(args.corpus_out.clone(), limits.time);
    let scratch = match targets::scratch_dir() {
        Ok(d) => d,
        Err(e) => {
            eprintln!("feedscope-fuzz: no temporary directory: {e}");
            return ExitCode::from(1);
        }
    };
    let ctx = targets::Ctx {
        dir: scratch.path().to_path_buf(),
    };
    let budget = args
        .inputs
        .map(Budget::Inputs)
        .unwrap_or(Budget::Seconds(args.seconds.unwrap_or(10.0)));
    println!(
        "{:<16} {:>10} {:>10} {:>10} {:>8} {:>6} {:>10} {:>9}",
        "target", "inputs", "accepted", "refused", "findings", "hangs", "peak MB", "inputs/s"
    );
    let mut total_findings = 0;
    for t in &chosen {
        watchdog::set_target(t.name);
        let s = fuzz(t, &ctx, &args, &limits, &budget);
        total_findings += s.findings;
        println!(
            "{:<16} {:>10} {:>10} {:>10} {:>8} {:>6} {:>10.1} {:>9.0}",
            t.name,
            s.inputs,
            s.accepted,
            s.rejected,
            s.findings,
            0,
            s.peak as f64 / f64::from(1 << 20),
            s.inputs as f64 / s.elapsed.as_secs_f64().max(1e-9)
        );
    }
    if total_findings > 0 {
        eprintln!(
            "feedscope-fuzz: {total_findings} finding(s); inputs written under {}",
            args.corpus_out.display()
        );
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    }
}

enum Budget {
    Inputs(u64),
    Seconds(f64),
}

fn fuzz(
    t: &targets::Target,
    ctx: &targets::Ctx,
    args: &Args,
    limits: &Limits,
    budget: &Budget,
) -> Stats {
    // Seeds are made with the default panic hook: a failing seed is the harness's own bug.
    let _ = std::panic::take_hook();
    let seeds = t.seeds();
    let mutator = t.mutator();
    quiet_panics();
    let mut rng = Rng::new(args.seed ^ watchdog::fnv(t.name.as_bytes()));
    let start = Instant::now();
    let mut s = Stats {
        inputs: 0,
        accepted: 0,
        rejected: 0,
        findings: 0,
        peak: 0,
        elapsed: Duration::ZERO,
    };
    let mut shown = 0;
    loop {
        let done = match budget {
            Budget::Inputs(n) => s.inputs >= *n,
            // Checking the clock every input costs little next to a parse.
            Budget::Seconds(secs) => start.elapsed().as_secs_f64() >= *secs,
        };
        if done {
            break;
        }
        // Seeds run as they are first, then mutations of a random seed.
        let input = if (s.inputs as usize) < seeds.len() {
            seeds[s.inputs as usize].clone()
        } else {
            let seed = rng.pick(&seeds).clone();
            targets::mutate(&mutator, &mut rng, &seed)
        };
        let run = run_one(t, &input, ctx, limits);
        s.inputs += 1;
        s.peak = s.peak.max(run.peak_bytes);
        match run.outcome {
            Outcome::Accepted => s.accepted += 1,
            Outcome::Rejected => s.rejected += 1,
            Outcome::Finding(f) => {
                s.findings += 1;
                let dir = args.corpus_out.join(t.name);
                let _ = std::fs::create_dir_all(&dir);
                let file = dir.join(format!("finding-{:016x}", watchdog::fnv(&input)));
                let _ = std::fs::write(&file, &input);
                if shown < 10 {
                    shown += 1;
                    let short: String = f.chars().take(300).collect();
                    eprintln!("{}: {short}\n  input: {}", t.name, file.display());
                }
            }
        }
    }
    s.elapsed = start.elapsed();
    s
}
