//! `feedscope demo`: the whole job on a built-in simulated lathe Z axis.
use std::path::PathBuf;

use anyhow::{Context, Result};
use feedscope::estimate::{Direction, EstimateParams};
use feedscope::sim::{simulate, SimConfig};
use feedscope::trace::{Layout, ReadReport};

use super::estimate::{estimate_to_csv, print_table};
use crate::output::{bar, write_atomic};
use crate::plot::{Series, Style};

/// Run feedscope on built-in example data: a simulated lathe Z axis with known friction.
///
/// Simulates the drive (lead 10 mm, 425 kg table, FANUC-like asynchronous sampling at about
/// 72 ms) doing the idle test of paper 000 — 0 → 410 mm and back at 100 mm/min — estimates
/// the friction along the travel and writes the trace, the truth, the estimate and a plot of
/// estimated against true friction into the output folder.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Output folder (created if missing).
    #[arg(long, default_value = "feedscope-demo")]
    pub out: PathBuf,
    /// Random seed of the simulated noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

pub fn run(args: Args) -> Result<()> {
    let mut axis = SimConfig::default().axis;
    axis.name = Some("demo lathe Z (simulated)".into());
    let cfg = SimConfig {
        seed: args.seed,
        axis,
        ..SimConfig::default()
    };
    eprintln!("simulating the demo lathe Z axis (0 -> 410 -> 0 mm at 100 mm/min) ...");
    let pb = bar(1000, "simulate");
    let sim = simulate(&cfg, &mut |f| pb.set_position((f * 1000.0) as u64));
    pb.finish_and_clear();
    let sim = sim.context("simulating the demo drive")?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    super::simulate::write_outputs(&args.out, &sim, Layout::Long)?;

    let params = EstimateParams::default();
    let csv = args.out.join("friction.csv");
    let outcome = estimate_to_csv(
        &sim.trace,
        &ReadReport::default(),
        &args.out.join("trace.csv").display().to_string(),
        &sim.truth.axis,
        &params,
        &csv,
    )?;
    // The truth beside the estimate, at the estimate's own positions.
    let model = &sim.truth.friction;
    let mut truth_series: [Vec<Series>; 2] = [Vec::new(), Vec::new()];
    for (k, (dir, strokes)) in [
        (Direction::Forward, &outcome.plot.forward),
        (Direction::Backward, &outcome.plot.backward),
    ]
    .into_iter()
    .enumerate()
    {
        if let Some(pts) = strokes.first() {
            let v = dir.sign() * cfg.motion.strokes[0].feed_mm_min / 60e3;
            truth_series[k].push(Series {
                name: format!("{} (true)", dir.as_str()),
                points: pts
                    .iter()
                    .map(|&(z_mm, _)| (z_mm, model.friction_n(z_mm * 1e-3, v)))
                    .collect(),
                style: Style::Dashed,
            });
        }
    }
    let [truth_fwd, truth_bwd] = truth_series;
    let svg = outcome
        .plot
        .svg("Demo lathe Z, estimated vs true", truth_fwd, truth_bwd)?;
    let json = serde_json::to_string_pretty(&outcome.summary)?;
    outcome.csv.commit()?;
    write_atomic(&args.out.join("friction.json"), json.as_bytes())?;
    write_atomic(&args.out.join("friction.svg"), svg.as_bytes())?;

    print_table(&outcome.summary);
    // How close the estimate is to the truth (the twin knows it).
    let text = std::fs::read_to_string(&csv)?;
    let mut acc = [(0.0f64, 0usize); 2];
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let (z_mm, v_mm_s, fr): (f64, f64, f64) = (f[2].parse()?, f[4].parse()?, f[7].parse()?);
        let k = usize::from(f[1] == "backward");
        let e = fr - model.friction_n(z_mm * 1e-3, v_mm_s * 1e-3);
        acc[k].0 += e * e;
        acc[k].1 += 1;
    }
    for (k, name) in ["forward", "backward"].iter().enumerate() {
        if acc[k].1 > 0 {
            println!(
                "{name}: RMS difference from the true friction {:.2} N over {} points",
                (acc[k].0 / acc[k].1 as f64).sqrt(),
                acc[k].1
            );
        }
    }
    println!("\nwrote to {}/:", args.out.display());
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
        println!("  {f:<14} {what}");
    }
    Ok(())
}
