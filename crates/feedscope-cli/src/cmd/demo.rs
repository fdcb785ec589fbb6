//! `feedscope demo`: the whole job on a built-in simulated lathe Z axis.
use crate::output::outln;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use feedscope::estimate::{Direction, EstimateParams};
use feedscope::history::Indicator;
use feedscope::plan::{
    strokes_program, triangle_program, Limits, StrokeTestParams, TestProgram, TriangleParams,
};
use feedscope::sim::{simulate, simulate_profile, FrictionParams, SamplingMode, SimConfig};
use feedscope::trace::EffortKind;
use feedscope::units::feed_mm_min_to_m_s;
use feedscope_io::trace::{write_csv, Layout, ReadReport};
use feedscope_store::{NewTest, SqliteStore, Store, TestKind};
use rayon::prelude::*;

use feedscope::study::{analyze_test, StrokeStudyParams, TestStudyParams};

use super::estimate::print_table;
use crate::front::Cli;
use crate::output::{bar, write_atomic};
use feedscope_app::estimate::estimate_to_csv;
use feedscope_app::plot::{Series, Style};
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
    let mut axis = SimConfig::default().axis;
    axis.name = Some("demo lathe Z (simulated)".into());
    let cfg = SimConfig {
        seed: args.seed,
        axis,
        ..SimConfig::default()
    };
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
    let mut truth_series: [Vec<Series>; 2] = [Vec::new(), Vec::new()];
    for (k, (dir, strokes)) in [
        (Direction::Forward, &outcome.plot.forward),
        (Direction::Backward, &outcome.plot.backward),
    ]
    .into_iter()
    .enumerate()
    {
        if let Some(pts) = strokes.first() {
            let v = feed_mm_min_to_m_s(dir.sign() * cfg.motion.strokes[0].feed_mm_min);
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
            outln!(
                "{name}: RMS difference from the true friction {:.2} N over {} points",
                (acc[k].0 / acc[k].1 as f64).sqrt(),
                acc[k].1
            );
        }
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

/// Start of the simulated history: Monday 2026-01-05 08:00 UTC.
const HISTORY_START_S: f64 = 1_767_600_000.0;
/// First week whose lubrication is worse than the one before.
const DRIFT_FROM_WEEK: usize = 5;
/// Every how many weeks a stroke test is run after the commissioning weeks (which have one
/// each, to set the baseline).
const STROKE_EVERY: usize = 3;

/// The friction of week `w`: steady for the first weeks, then lubrication degrading.
fn week_friction(axis: &feedscope::axis::AxisParams, w: usize) -> FrictionParams {
    let mut f = FrictionParams::default_for(axis);
    let d = w.saturating_sub(DRIFT_FROM_WEEK - 1) as f64;
    f.velocity.static_excess_n *= 1.0 + 0.07 * d;
    f.velocity.viscous_n_s_per_m *= 1.0 + 0.04 * d;
    f.velocity.stribeck_velocity_mm_min *= 1.0 - 0.02 * d;
    f
}

/// One simulated test: its trace written as CSV, analysed like `history add` does.
fn weekly_test(
    cfg: &SimConfig,
    prog: &TestProgram,
    kind: TestKind,
    path: &Path,
    week: usize,
) -> Result<NewTest> {
    let sim = simulate_profile(cfg, prog, &mut |_| {})
        .with_context(|| format!("simulating week {week}"))?;
    let mut bytes = Vec::new();
    write_csv(&sim.trace, &mut bytes, Layout::Long)?;
    write_atomic(path, &bytes)?;
    let params = TestStudyParams {
        strokes: StrokeStudyParams {
            interval_mm: 40.0,
            ..StrokeStudyParams::default()
        },
        ..TestStudyParams::default()
    };
    let analysis = analyze_test(&sim.trace, &cfg.axis, kind, &params)
        .with_context(|| format!("analysing the {} test of week {week}", kind.as_str()))?;
    let mut t = NewTest::from_analysis(&analysis, &cfg.axis, &bytes);
    t.machine = "demo lathe".into();
    t.axis = "Z".into();
    t.time_s = HISTORY_START_S
        + week as f64 * 7.0 * 86_400.0
        + if kind == TestKind::Strokes {
            1800.0
        } else {
            0.0
        };
    t.time_utc = feedscope_store::time::format_rfc3339(t.time_s);
    t.source = path.display().to_string();
    t.program = Some(match kind {
        TestKind::Triangle => "feedscope plan triangle (demo)".into(),
        TestKind::Strokes => "feedscope plan strokes (demo)".into(),
    });
    Ok(t)
}

/// Simulate the weekly tests, store them in `out/history.db`, write `out/report.html`.
fn weekly_history(out: &Path, seed: u64, weeks: usize) -> Result<()> {
    let dir = out.join("weekly");
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    let db = out.join("history.db");
    // A fresh history each run, so that the demo tells the same story.
    for ext in ["", "-wal", "-shm"] {
        let p = PathBuf::from(format!("{}{ext}", db.display()));
        match std::fs::remove_file(&p) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                return Err(e).with_context(|| format!("removing {}", p.display()))
            }
            _ => {}
        }
    }
    let mut base = SimConfig::default();
    base.axis.name = Some("demo lathe Z (simulated)".into());
    base.sampling.mode = SamplingMode::Synchronous;
    base.sampling.synchronous_rate_hz = 1000.0;
    base.sampling.effort_kind = EffortKind::TorqueNm;
    let triangle = triangle_program(
        &TriangleParams {
            window_min_mm: 120.0,
            window_max_mm: 200.0,
            feed_max_mm_min: 3000.0,
            levels: 6,
            min_cruise_s: 0.5,
            vs_guess_mm_min: 60.0,
            ..TriangleParams::default()
        },
        &Limits::default(),
    )
    .context("planning the weekly triangular test")?;
    let strokes = strokes_program(
        &StrokeTestParams {
            from_mm: 20.0,
            to_mm: 260.0,
            feeds_mm_min: vec![600.0],
            repeats: 1,
            dwell_s: 0.5,
            accel_mm_s2: 1000.0,
        },
        &Limits::default(),
    )
    .context("planning the stroke test")?;
    let mut jobs: Vec<(usize, TestKind)> = (0..weeks).map(|w| (w, TestKind::Triangle)).collect();
    jobs.extend(
        (0..weeks)
            .filter(|&w| {
                w < DRIFT_FROM_WEEK
                    || (w - DRIFT_FROM_WEEK) % STROKE_EVERY == STROKE_EVERY - 1
                    || w + 1 == weeks
            })
            .map(|w| (w, TestKind::Strokes)),
    );
    eprintln!(
        "simulating {weeks} weeks of tests ({} triangular, {} stroke tests), lubrication \
         degrading from week {} ...",
        weeks,
        jobs.len() - weeks,
        DRIFT_FROM_WEEK + 1
    );
    let pb = bar(jobs.len() as u64, "weekly tests");
    let mut tests: Vec<NewTest> = jobs
        .par_iter()
        .map(|&(w, kind)| {
            let cfg = SimConfig {
                seed: seed.wrapping_mul(1000).wrapping_add(w as u64),
                friction: Some(week_friction(&base.axis, w)),
                ..base.clone()
            };
            let (prog, name) = match kind {
                TestKind::Triangle => (&triangle, format!("week-{:02}-triangle.csv", w + 1)),
                TestKind::Strokes => (&strokes, format!("week-{:02}-strokes.csv", w + 1)),
            };
            let t = weekly_test(&cfg, prog, kind, &dir.join(name), w);
            pb.inc(1);
            t
        })
        .collect::<Result<_>>()?;
    pb.finish_and_clear();
    tests.sort_by(|a, b| a.time_s.total_cmp(&b.time_s));
    let mut store = SqliteStore::open_with(&db, &crate::store::cli_open_options()?)
        .map_err(anyhow::Error::new)?;
    for t in &tests {
        store.add(t).map_err(anyhow::Error::new)?;
    }
    // Thresholds a maintenance planner might set: 30 % above the first week's Fs, 50 % above
    // its σ.
    let first = tests
        .iter()
        .find_map(|t| t.identified.as_ref())
        .context("no identification in the demo history")?;
    let round10 = |x: f64| (x / 10.0).round() * 10.0;
    let th_path = out.join("thresholds.toml");
    let th = format!(
        "# Alarm levels per indicator (see docs/history.md).\n[thresholds]\n\
         fs_n = {{ upper = {} }}\nsigma_n_s_per_m = {{ upper = {} }}\n",
        round10(first.fs_n * 1.3),
        round10(first.sigma_n_s_per_m * 1.5)
    );
    write_atomic(&th_path, th.as_bytes())?;
    drop(store);
    let report = out.join("report.html");
    let detectors = super::history::DetectorArgs::default();
    super::report::write_report(
        &crate::store::StoreSpec::Sqlite(db.clone()),
        Some("demo lathe"),
        Some("Z"),
        5,
        &detectors,
        Some(&th_path),
        &report,
    )?;
    let store = super::history::open_sqlite(&db)?;
    let options = detectors.options(5, Some(&th_path));
    let from_file = options.file_thresholds()?;
    let front = crate::front::Cli::default();
    let t = feedscope_app::trend::axis_trend(
        &store,
        "demo lathe",
        Some("Z"),
        &options,
        from_file,
        &front,
    )?;
    outln!(
        "\ncondition history of the demo axis ({} tests):",
        t.tests.len()
    );
    for x in t.trends.iter().filter(|x| {
        matches!(
            x.indicator,
            Indicator::StaticFriction
                | Indicator::CoulombFriction
                | Indicator::Viscous
                | Indicator::StribeckVelocity
        )
    }) {
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
