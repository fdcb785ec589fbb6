//! `feedscope demo`: the whole job on a built-in simulated lathe Z axis. The twin, its truth
//! and the weekly history are `feedscope_app::demo`; this runs them and says what was written.
use crate::output::outln;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use feedscope::estimate::EstimateParams;
use feedscope::sim::simulate;
use feedscope_app::demo::{self, WeeklyHistory};
use feedscope_io::trace::{Layout, ReadReport};

use super::estimate::print_table;
use crate::front::Cli;
use crate::output::{bar, write_atomic};
use feedscope_app::estimate::estimate_to_csv;
use feedscope_app::Recording;

/// Run feedscope on built-in example data: a simulated lathe Z axis with known friction.
///
/// Simulates the drive (lead 10 mm, 425 kg table, FANUC-like asynchronous sampling at about
/// 72 ms) doing the idle test of paper 000 — 0 → 410 mm and back at 100 mm/min — estimates
/// the friction along the travel and writes the trace, the truth, the estimate and a plot of
/// estimated against true friction into the output folder. Then it simulates 16 weekly tests
/// of the same axis whose lubrication slowly degrades from week 6 on (static friction excess
/// +7 %, viscous coefficient +4 %, Stribeck velocity −2 % a week): a short triangular-wave
/// test every week (one-test identification) and a short stroke test in each of the first 5
/// weeks and every 3 weeks after (friction profile and spectra), stores them in history.db, and ends with report.html, the
/// condition report of the axis.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Output folder (created if missing).
    #[arg(long, default_value = "feedscope-demo")]
    pub out: PathBuf,
    /// Random seed of the simulated noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Weeks of simulated condition history (0: skip the history and the report).
    #[arg(long, default_value_t = 16)]
    pub weeks: usize,
}

pub fn run(args: Args) -> Result<()> {
    let cfg = demo::twin(args.seed);
    eprintln!(
        "simulating the demo lathe Z axis (0 -> 410 -> 0 mm at 100 mm/min, jerk-limited ramps \
         as real controls make them) ..."
    );
    let pb = bar(1000, "simulate");
    let sim = simulate(&cfg, &mut |f| pb.set_position((f * 1000.0) as u64));
    pb.finish_and_clear();
    let sim = sim.context("simulating the demo drive")?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    super::simulate::write_outputs(&args.out, &sim, Layout::Long)?;

    let params = EstimateParams::default();
    let csv = args.out.join("friction.csv");
    let source = args.out.join("trace.csv").display().to_string();
    let recording = Recording::borrowed(&sim.trace, source, ReadReport::default());
    let outcome = estimate_to_csv(&recording, &sim.truth.axis, &params, &csv, &Cli::default())?;
    // The truth beside the estimate, at the estimate's own positions.
    let model = &sim.truth.friction;
    let [truth_fwd, truth_bwd] =
        demo::true_friction(&outcome.plot, model, cfg.motion.strokes[0].feed_mm_min);
    let svg = feedscope_app::plot::friction_svg(
        &outcome.plot,
        "Demo lathe Z, estimated vs true",
        truth_fwd,
        truth_bwd,
    )?;
    let json = serde_json::to_string_pretty(&outcome.report)?;
    outcome.csv.commit()?;
    write_atomic(&args.out.join("friction.json"), json.as_bytes())?;
    write_atomic(&args.out.join("friction.svg"), svg.as_bytes())?;

    print_table(&outcome.report)?;
    for d in demo::difference_from_truth(&csv, model)? {
        outln!(
            "{}: RMS difference from the true friction {:.2} N over {} points",
            d.direction.as_str(),
            d.rms_n,
            d.points
        );
    }
    outln!("\nwrote to {}/:", args.out.display());
    for (f, what) in [
        ("trace.csv", "the simulated controller trace (long layout)"),
        ("axis.toml", "the axis parameters"),
        (
            "truth.json",
            "the true friction model and commanded strokes",
        ),
        ("truth.csv", "the true state every 10 ms"),
        ("friction.csv", "estimated friction along the travel"),
        ("friction.json", "per-stroke summary"),
        ("friction.svg", "plot: estimated vs true friction"),
    ] {
        outln!("  {f:<14} {what}");
    }
    if args.weeks > 0 {
        weekly_history(&args.out, args.seed, args.weeks)?;
    }
    Ok(())
}

/// [`WeeklyHistory`] planned, run into `out` and summed up.
fn weekly_history(out: &Path, seed: u64, weeks: usize) -> Result<()> {
    let history = WeeklyHistory::plan(seed, weeks)?;
    eprintln!(
        "simulating {weeks} weeks of tests ({} triangular, {} stroke tests), lubrication \
         degrading from week {} ...",
        history.triangle_tests(),
        history.stroke_tests(),
        demo::DRIFT_FROM_WEEK + 1
    );
    let t = history.run(out, &crate::store::opener(), &Cli::default())?;
    outln!(
        "\ncondition history of the demo axis ({} tests):",
        t.tests.len()
    );
    for x in demo::friction_trends(&t) {
        outln!(
            "  {:<24} {:>+6.1} % since the baseline  {}{}",
            x.indicator.label(),
            x.change_percent,
            x.status.as_str(),
            x.first_alarm.map_or(String::new(), |i| format!(
                " (first flagged at test {} of the series)",
                i + 1
            ))
        );
    }
    outln!("diagnosis:");
    for s in &t.diagnosis {
        outln!("  - {s}");
    }
    outln!("\nwrote to {}/:", out.display());
    for (f, what) in [
        ("weekly/", "the simulated weekly test traces"),
        (
            "history.db",
            "the condition history (SQLite, docs/history.md)",
        ),
        ("thresholds.toml", "alarm levels used by the report"),
        ("report.html", "the condition report: open it in a browser"),
    ] {
        outln!("  {f:<16} {what}");
    }
    Ok(())
}
