//! The demo (`feedscope demo`): the method on a simulated lathe Z axis whose friction is known.
//!
//! [`twin`] is the axis simulated for the one-stroke estimate, [`true_friction`] its true
//! friction drawn beside the estimate and [`difference_from_truth`] how far the estimate is
//! from it. [`WeeklyHistory`] is the condition history that follows: weekly tests of the same
//! axis whose lubrication degrades from week [`DRIFT_FROM_WEEK`]` + 1` on (static friction
//! excess +7 %, viscous coefficient +4 %, Stribeck velocity −2 % a week, [`week_friction`]),
//! stored in an SQLite history with alarm thresholds and the condition report.
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use feedscope::estimate::Direction;
use feedscope::history::{Indicator, IndicatorTrend};
use feedscope::plan::{
    strokes_program, triangle_program, Limits, StrokeTestParams, TestProgram, TriangleParams,
};
use feedscope::sim::{simulate_profile, FrictionModel, FrictionParams, SamplingMode, SimConfig};
use feedscope::study::{analyze_test, StrokeStudyParams, TestKind, TestStudyParams};
use feedscope::trace::EffortKind;
use feedscope::units::feed_mm_min_to_m_s;
use feedscope_io::trace::{write_csv, Layout};
use feedscope_store::{NewTest, SqliteStore, Store};
use rayon::prelude::*;

use crate::estimate::FrictionPlot;
use crate::output::{io_error, write_atomic};
use crate::plot::{Series, Style};
use crate::store::{Opener, StoreSpec};
use crate::trend::{axis_trend, AxisTrends, TrendOptions};
use crate::{AppError, FrontEnd};

/// The machine of the demo's history.
pub const MACHINE: &str = "demo lathe";
/// The axis of the demo's history.
pub const AXIS: &str = "Z";
/// The name of the simulated axis in its axis file and plots.
const AXIS_TITLE: &str = "demo lathe Z (simulated)";

/// Start of the simulated history: Monday 2026-01-05 08:00 UTC (s since the Unix epoch).
pub const HISTORY_START_S: f64 = 1_767_600_000.0;
/// The weeks (counted from 0) before this one have the commissioning friction; from this one
/// on the lubrication is worse each week than the week before.
pub const DRIFT_FROM_WEEK: usize = 5;
/// Every how many weeks a stroke test is run after the commissioning weeks (which have one
/// each, to set the baseline).
pub const STROKE_EVERY: usize = 3;
/// Baseline tests of the demo's trends and report.
pub const BASELINE_TESTS: usize = 5;

/// The demo's axis: the simulator's default lathe Z axis (lead 10 mm, 425 kg table,
/// FANUC-like asynchronous sampling at about 72 ms, the idle test 0 → 410 mm and back at
/// 100 mm/min), named for the demo, with the noise of `seed`.
pub fn twin(seed: u64) -> SimConfig {
    let mut axis = SimConfig::default().axis;
    axis.name = Some(AXIS_TITLE.into());
    SimConfig {
        seed,
        axis,
        ..SimConfig::default()
    }
}

/// The true friction of `model` at the positions of the estimate's first stroke each way, at
/// the commanded feed `feed_mm_min` (signed by the direction): a dashed series per direction
/// (forward, backward) to draw beside the estimate.
pub fn true_friction(
    plot: &FrictionPlot,
    model: &FrictionModel,
    feed_mm_min: f64,
) -> [Vec<Series>; 2] {
    let mut out: [Vec<Series>; 2] = [Vec::new(), Vec::new()];
    for (k, (dir, strokes)) in [
        (Direction::Forward, &plot.forward),
        (Direction::Backward, &plot.backward),
    ]
    .into_iter()
    .enumerate()
    {
        if let Some(pts) = strokes.first() {
            let v = feed_mm_min_to_m_s(dir.sign() * feed_mm_min);
            out[k].push(Series {
                name: format!("{} (true)", dir.as_str()),
                points: pts
                    .iter()
                    .map(|&(z_mm, _)| (z_mm, model.friction_n(z_mm * 1e-3, v)))
                    .collect(),
                style: Style::Dashed,
            });
        }
    }
    out
}

/// How close an estimate is to the twin's truth in one direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TruthDifference {
    /// Direction of travel.
    pub direction: Direction,
    /// Root mean square of estimate − truth over the points (N).
    pub rms_n: f64,
    /// Points compared.
    pub points: usize,
}

/// The estimate of the friction CSV `csv` (the layout `estimate` writes) against `model` at
/// each row's position and velocity: per direction with points (forward, then backward).
///
/// # Errors
/// Reading the file; a row whose position, velocity or friction is no number.
pub fn difference_from_truth(
    csv: &Path,
    model: &FrictionModel,
) -> Result<Vec<TruthDifference>, AppError> {
    let text = std::fs::read_to_string(csv)
        .map_err(|e| io_error(format!("reading {}", csv.display()), e))?;
    let mut acc = [(0.0f64, 0usize); 2];
    for (n, line) in text.lines().enumerate().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let number = |i: usize| {
            f.get(i).and_then(|s| s.parse::<f64>().ok()).ok_or_else(|| {
                AppError::failed(format!(
                    "{}: line {}: column {} is no number",
                    csv.display(),
                    n + 1,
                    i + 1
                ))
            })
        };
        let (z_mm, v_mm_s, friction_n) = (number(2)?, number(4)?, number(7)?);
        let k = usize::from(f[1] == "backward");
        let e = friction_n - model.friction_n(z_mm * 1e-3, v_mm_s * 1e-3);
        acc[k].0 += e * e;
        acc[k].1 += 1;
    }
    Ok([Direction::Forward, Direction::Backward]
        .into_iter()
        .zip(acc)
        .filter(|(_, (_, n))| *n > 0)
        .map(|(direction, (sum_sq, points))| TruthDifference {
            direction,
            rms_n: (sum_sq / points as f64).sqrt(),
            points,
        })
        .collect())
}

/// The friction of week `w` (from 0): the axis's default friction for the first
/// [`DRIFT_FROM_WEEK`] weeks, then lubrication degrading week by week (static friction excess
/// +7 %, viscous coefficient +4 %, Stribeck velocity −2 % of the commissioning value a week).
pub fn week_friction(axis: &feedscope::axis::AxisParams, w: usize) -> FrictionParams {
    let mut f = FrictionParams::default_for(axis);
    let d = w.saturating_sub(DRIFT_FROM_WEEK - 1) as f64;
    f.velocity.static_excess_n *= 1.0 + 0.07 * d;
    f.velocity.viscous_n_s_per_m *= 1.0 + 0.04 * d;
    f.velocity.stribeck_velocity_mm_min *= 1.0 - 0.02 * d;
    f
}

/// The demo's weekly condition history, planned: a short triangular-wave test every week
/// (one-test identification, paper 002) and a short stroke test in each commissioning week and
/// every [`STROKE_EVERY`] weeks after, and in the last week (friction profile and spectra,
/// paper 000), on the twin sampled synchronously at 1 kHz with the effort as torque.
#[derive(Debug, Clone)]
pub struct WeeklyHistory {
    seed: u64,
    weeks: usize,
    base: SimConfig,
    triangle: TestProgram,
    strokes: TestProgram,
    /// (week, kind) of every test.
    jobs: Vec<(usize, TestKind)>,
}

impl WeeklyHistory {
    /// Plan `weeks` weeks of tests with the noise of `seed`.
    ///
    /// # Errors
    /// Planning the test programs (their settings are fixed; an error is a bug).
    pub fn plan(seed: u64, weeks: usize) -> Result<Self, AppError> {
        let mut base = SimConfig::default();
        base.axis.name = Some(AXIS_TITLE.into());
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
        .map_err(|e| AppError::within("planning the weekly triangular test", e))?;
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
        .map_err(|e| AppError::within("planning the stroke test", e))?;
        let mut jobs: Vec<(usize, TestKind)> =
            (0..weeks).map(|w| (w, TestKind::Triangle)).collect();
        jobs.extend(
            (0..weeks)
                .filter(|&w| {
                    w < DRIFT_FROM_WEEK
                        || (w - DRIFT_FROM_WEEK) % STROKE_EVERY == STROKE_EVERY - 1
                        || w + 1 == weeks
                })
                .map(|w| (w, TestKind::Strokes)),
        );
        Ok(Self {
            seed,
            weeks,
            base,
            triangle,
            strokes,
            jobs,
        })
    }

    /// Weeks of history.
    pub fn weeks(&self) -> usize {
        self.weeks
    }

    /// Triangular-wave tests planned (one a week).
    pub fn triangle_tests(&self) -> usize {
        self.count(TestKind::Triangle)
    }

    /// Stroke tests planned.
    pub fn stroke_tests(&self) -> usize {
        self.count(TestKind::Strokes)
    }

    fn count(&self, kind: TestKind) -> usize {
        self.jobs.iter().filter(|(_, k)| *k == kind).count()
    }

    /// Simulate the tests (in parallel, progress as `weekly tests`), write their traces to
    /// `out/weekly/`, store them in a fresh `out/history.db` (an earlier one is removed, so
    /// that the demo tells the same story), write alarm thresholds a maintenance planner might
    /// set to `out/thresholds.toml` and the condition report to `out/report.html`; the trends
    /// of the axis, as the report shows them.
    ///
    /// # Errors
    /// Creating or removing files under `out`; a simulation or analysis (naming the week);
    /// the store's.
    pub fn run(
        &self,
        out: &Path,
        opener: &Opener,
        front: &dyn FrontEnd,
    ) -> Result<AxisTrends, AppError> {
        let dir = out.join("weekly");
        std::fs::create_dir_all(&dir)
            .map_err(|e| io_error(format!("creating {}", dir.display()), e))?;
        let db = out.join("history.db");
        for ext in ["", "-wal", "-shm"] {
            let p = PathBuf::from(format!("{}{ext}", db.display()));
            match std::fs::remove_file(&p) {
                Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                    return Err(io_error(format!("removing {}", p.display()), e))
                }
                _ => {}
            }
        }
        let total = self.jobs.len();
        let done = Mutex::new(0usize);
        front.progress("weekly tests", 0, total);
        let mut tests: Vec<NewTest> = self
            .jobs
            .par_iter()
            .map(|&(w, kind)| {
                let t = self.test(w, kind, &dir);
                // Counted under the lock, so that the front end sees the steps in order.
                let mut n = done.lock().unwrap_or_else(|p| p.into_inner());
                *n += 1;
                front.progress("weekly tests", *n, total);
                t
            })
            .collect::<Result<_, AppError>>()?;
        tests.sort_by(|a, b| a.time_s.total_cmp(&b.time_s));
        let mut store =
            SqliteStore::open_with(&db, &opener.options()?).map_err(AppError::from_error)?;
        for t in &tests {
            store.add(t).map_err(AppError::from_error)?;
        }
        drop(store);
        // Thresholds a maintenance planner might set: 30 % above the first week's Fs, 50 %
        // above its σ, rounded to 10.
        let first = tests
            .iter()
            .find_map(|t| t.identified.as_ref())
            .ok_or_else(|| AppError::failed("no identification in the demo history"))?;
        let round10 = |x: f64| (x / 10.0).round() * 10.0;
        let th_path = out.join("thresholds.toml");
        let th = format!(
            "# Alarm levels per indicator (see docs/history.md).\n[thresholds]\n\
             fs_n = {{ upper = {} }}\nsigma_n_s_per_m = {{ upper = {} }}\n",
            round10(first.fs_n * 1.3),
            round10(first.sigma_n_s_per_m * 1.5)
        );
        write_atomic(&th_path, th.as_bytes())?;
        let options = TrendOptions {
            baseline_tests: BASELINE_TESTS,
            thresholds: Some(th_path),
            ..TrendOptions::default()
        };
        options.validate(front)?;
        let from_file = options.file_thresholds()?;
        let store = opener.open(&StoreSpec::Sqlite(db))?;
        let t = axis_trend(&*store, MACHINE, Some(AXIS), &options, from_file, front)?;
        let html = crate::report::render(&*store, &t, BASELINE_TESTS)?;
        write_atomic(&out.join("report.html"), html.as_bytes())?;
        Ok(t)
    }

    /// One simulated test of week `w`: its trace written as CSV into `dir`, analysed as
    /// `history add` analyses it (mean friction per 40 mm interval) and timed in its week.
    fn test(&self, w: usize, kind: TestKind, dir: &Path) -> Result<NewTest, AppError> {
        let cfg = SimConfig {
            seed: self.seed.wrapping_mul(1000).wrapping_add(w as u64),
            friction: Some(week_friction(&self.base.axis, w)),
            ..self.base.clone()
        };
        let (prog, name) = match kind {
            TestKind::Triangle => (&self.triangle, format!("week-{:02}-triangle.csv", w + 1)),
            _ => (&self.strokes, format!("week-{:02}-strokes.csv", w + 1)),
        };
        let path = dir.join(name);
        let sim = simulate_profile(&cfg, prog, &mut |_| {})
            .map_err(|e| AppError::within(format!("simulating week {w}"), e))?;
        let mut bytes = Vec::new();
        write_csv(&sim.trace, &mut bytes, Layout::Long).map_err(AppError::from_error)?;
        write_atomic(&path, &bytes)?;
        let params = TestStudyParams {
            strokes: StrokeStudyParams {
                interval_mm: 40.0,
                ..StrokeStudyParams::default()
            },
            ..TestStudyParams::default()
        };
        let analysis = analyze_test(&sim.trace, &cfg.axis, kind, &params).map_err(|e| {
            AppError::within(
                format!("analysing the {} test of week {w}", kind.as_str()),
                e,
            )
        })?;
        let mut t = NewTest::from_analysis(&analysis, &cfg.axis, &bytes);
        t.machine = MACHINE.into();
        t.axis = AXIS.into();
        t.time_s = HISTORY_START_S
            + w as f64 * 7.0 * 86_400.0
            + if kind == TestKind::Strokes {
                1800.0
            } else {
                0.0
            };
        t.time_utc = feedscope_store::time::format_rfc3339(t.time_s);
        t.source = path.display().to_string();
        t.program = Some(match kind {
            TestKind::Triangle => "feedscope plan triangle (demo)".into(),
            _ => "feedscope plan strokes (demo)".into(),
        });
        Ok(t)
    }
}

/// The trends of the friction model's parameters among `t`'s (Fs, Fc, σ, vs): what the demo
/// sums up.
pub fn friction_trends(t: &AxisTrends) -> impl Iterator<Item = &IndicatorTrend> {
    t.trends.iter().filter(|x| {
        matches!(
            x.indicator,
            Indicator::StaticFriction
                | Indicator::CoulombFriction
                | Indicator::Viscous
                | Indicator::StribeckVelocity
        )
    })
}
