//! NC programs (G-code) of the friction tests, with their run time and sample counts: idle
//! strokes at a list of feeds (paper 000, for [`estimate`](crate::estimate)) and the
//! variable-amplitude, variable-velocity triangular wave (paper 002 Eq. 8, for
//! [`identify`](crate::identify)).
//!
//! [`PlanRequest`] is one test with the options both tests share: the travel and feed limits
//! the program must respect (an axis file's `travel_min_mm` / `travel_max_mm`, overridden by
//! the request's), the dialect, and the control's acceleration, ramp and the acquisition's
//! sampling that the timing assumes. [`PlanRequest::run`] reads the axis file, plans, writes
//! the program (whole or not at all) and returns a [`Planned`]: the G-code and its
//! [`PlanReport`], which is the JSON layout (`feedscope plan ... --format json`) and has a
//! plain-text view ([`PlanReport::text`]). [`PlanRequest::plan`] does the same from an axis
//! already read, without writing (the Python module's `Plan.write` writes on demand).
use std::fmt::Write as _;
use std::path::PathBuf;

use feedscope::axis::AxisParams;
use feedscope::plan::gcode::{write_gcode, Dialect, FanucMachine, GcodeOptions};
use feedscope::plan::{
    identifiability_warning, strokes_program, triangle_program, Limits, Move, StrokeTestParams,
    TestKind, TestProgram, TriangleParams,
};
use feedscope::sim::{RampShape, DEFAULT_JERK_MM_S3};
use feedscope::units::s_to_min;
use serde::{Deserialize, Serialize};

use crate::output::write_atomic;
use crate::{AppError, FrontEnd};

/// Sampling interval assumed when the request gives neither an interval nor a rate (ms): the
/// polling of an MTConnect agent.
pub const DEFAULT_SAMPLE_INTERVAL_MS: f64 = 72.0;

/// Which test to plan, with its own settings (serialised with the test as its key:
/// `{"strokes": {"from_mm": 0, "to_mm": 410, ...}}`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum PlanTest {
    /// Idle strokes from `from_mm` to `to_mm` and back at each feed (paper 000).
    Strokes(StrokesTest),
    /// The triangular wave in the window `from_mm`..`to_mm` (paper 002 Eq. 8).
    Triangle(TriangleTest),
}

impl Default for PlanTest {
    fn default() -> Self {
        PlanTest::Strokes(StrokesTest::default())
    }
}

/// The idle-stroke test of paper 000 Section 2. Defaults: paper 000's test, 0 → 410 mm at 5,
/// 20 and 80 mm/min, 3 pairs per feed, 1 s dwells.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StrokesTest {
    /// Start of the forward strokes (mm).
    pub from_mm: f64,
    /// End of the forward strokes (mm).
    pub to_mm: f64,
    /// Feeds in test order (mm/min).
    pub feeds_mm_min: Vec<f64>,
    /// Forward + backward pairs per feed.
    pub repeats: u32,
    /// Dwell after every stroke (s).
    pub dwell_s: f64,
}

impl Default for StrokesTest {
    fn default() -> Self {
        let p = StrokeTestParams::default();
        Self {
            from_mm: p.from_mm,
            to_mm: p.to_mm,
            feeds_mm_min: p.feeds_mm_min,
            repeats: p.repeats,
            dwell_s: p.dwell_s,
        }
    }
}

/// The variable-amplitude, variable-velocity triangular wave of paper 002 (Eq. 8, Fig. 3):
/// feeds geometric from `feed_min_mm_min` to `feed_max_mm_min`, each stroke cruising
/// `cruise_s` where the window allows. Defaults as [`TriangleParams`]'s.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TriangleTest {
    /// Lower end of the test window (mm); default: the lower travel limit.
    pub from_mm: Option<f64>,
    /// Upper end of the test window (mm); default: the upper travel limit.
    pub to_mm: Option<f64>,
    /// Highest feed of the wave (mm/min); default: the feed limit.
    pub feed_max_mm_min: Option<f64>,
    /// Lowest feed (mm/min); default: `vs_guess_mm_min` / 5.
    pub feed_min_mm_min: Option<f64>,
    /// Guess of the Stribeck velocity (mm/min).
    pub vs_guess_mm_min: f64,
    /// Number of feed levels.
    pub levels: usize,
    /// Full cycles per level.
    pub cycles: usize,
    /// Wanted constant-feed time per stroke (s).
    pub cruise_s: f64,
    /// Dwell after every stroke (s).
    pub dwell_s: f64,
}

impl Default for TriangleTest {
    fn default() -> Self {
        let p = TriangleParams::default();
        Self {
            from_mm: None,
            to_mm: None,
            feed_max_mm_min: None,
            feed_min_mm_min: p.feed_min_mm_min,
            vs_guess_mm_min: p.vs_guess_mm_min,
            levels: p.levels,
            cycles: p.cycles_per_level,
            cruise_s: p.min_cruise_s,
            dwell_s: p.dwell_s,
        }
    }
}

/// Plan one test and write its program.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PlanRequest {
    /// The test and its settings.
    pub test: PlanTest,
    /// Axis file (TOML/JSON) whose `travel_min_mm` / `travel_max_mm` are the travel limits.
    pub axis: Option<PathBuf>,
    /// Lower travel limit (mm); overrides the axis file's.
    pub travel_min_mm: Option<f64>,
    /// Upper travel limit (mm); overrides the axis file's.
    pub travel_max_mm: Option<f64>,
    /// Highest feed the test may use (mm/min).
    pub feed_limit_mm_min: Option<f64>,
    /// Control dialect. Default FANUC.
    pub dialect: Dialect,
    /// FANUC machine type (decides `G98` vs `G90 G94`). Default lathe.
    pub fanuc_machine: FanucMachine,
    /// Axis address letter. Default `Z`.
    pub axis_letter: char,
    /// FANUC program number (O number, 1-9999). Default 1000.
    pub program_number: u32,
    /// Feed of the first move to the start position (mm/min); default: the highest feed.
    pub approach_feed_mm_min: Option<f64>,
    /// Acceleration the control uses for the axis (mm/s²), for planning and the run time.
    /// Default 1000.
    pub accel_mm_s2: f64,
    /// Shape of the control's speed changes, for the run time. Default jerk-limited, as the
    /// simulator's.
    pub ramp: RampShape,
    /// Jerk limit of the control (mm/s³), with the jerk-limited ramp only; default
    /// [`DEFAULT_JERK_MM_S3`].
    pub jerk_mm_s3: Option<f64>,
    /// Sampling interval of the acquisition (ms), for the sample counts and the check that a
    /// triangular wave can be identified at it; default [`DEFAULT_SAMPLE_INTERVAL_MS`].
    pub sample_interval_ms: Option<f64>,
    /// Sampling rate of the acquisition (Hz); when given it is used instead of
    /// `sample_interval_ms`.
    pub sample_rate_hz: Option<f64>,
    /// The NC program to write (whole or not at all); none: the program is only returned.
    pub output: Option<PathBuf>,
}

impl Default for PlanRequest {
    fn default() -> Self {
        let g = GcodeOptions::default();
        Self {
            test: PlanTest::default(),
            axis: None,
            travel_min_mm: None,
            travel_max_mm: None,
            feed_limit_mm_min: None,
            dialect: g.dialect,
            fanuc_machine: g.fanuc_machine,
            axis_letter: g.axis_letter,
            program_number: g.program_number,
            approach_feed_mm_min: g.approach_feed_mm_min,
            accel_mm_s2: StrokeTestParams::default().accel_mm_s2,
            ramp: RampShape::JerkLimited,
            jerk_mm_s3: None,
            sample_interval_ms: None,
            sample_rate_hz: None,
            output: None,
        }
    }
}

/// A planned test: the program text and its report.
#[derive(Debug, Clone)]
pub struct Planned {
    /// The G-code, as written to the request's `output`.
    pub gcode: String,
    /// Its summary: the JSON layout.
    pub report: PlanReport,
}

/// What a planned program does, and what to know before running it (the JSON layout of
/// `feedscope plan ... --format json`; Python's `Plan.to_dict()` is it without `output`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PlanReport {
    /// Which test the program performs.
    pub test: TestKind,
    /// The program file written, when the request named one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub output: Option<String>,
    /// Control dialect of the program.
    pub dialect: Dialect,
    /// Position at program start (mm).
    pub start_mm: f64,
    /// Lowest and highest programmed position (mm).
    pub span_mm: (f64, f64),
    /// The feeds of the test, in order (mm/min).
    pub feeds_mm_min: Vec<f64>,
    /// Expected run time with the ramp shape and limits assumed (s).
    pub run_time_s: f64,
    /// Sampling interval of the acquisition assumed (s).
    pub sample_interval_s: f64,
    /// Expected samples per channel at that interval.
    pub samples_per_channel: u64,
    /// Acceleration assumed (mm/s²).
    pub accel_mm_s2: f64,
    /// Ramp shape assumed.
    pub ramp: RampShape,
    /// Jerk limit assumed (mm/s³); `None` for ramps without one.
    pub jerk_mm_s3: Option<f64>,
    /// Notes of the planner (e.g. shortened cruise phases).
    pub notes: Vec<String>,
    /// What the user must know before running the test (a front end shows them as warnings).
    pub warnings: Vec<String>,
    /// The moves of the program.
    pub moves: Vec<Move>,
}

impl PlanReport {
    /// The program in a few lines: its moves and span, the expected run time with the ramps
    /// it assumes, the expected samples per channel, and the planner's notes (warnings are
    /// not part of it: a front end shows them on their own). What `feedscope plan` prints.
    pub fn text(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "{}: {} moves over {:.3} to {:.3} mm at {} feed(s)",
            self.output.as_deref().unwrap_or("the program"),
            self.moves.len(),
            self.span_mm.0,
            self.span_mm.1,
            self.feeds_mm_min.len()
        );
        let ramp = match (self.ramp, self.jerk_mm_s3) {
            (RampShape::JerkLimited, j) => {
                format!(
                    "jerk-limited ramps, {:.0} mm/s³",
                    j.unwrap_or(DEFAULT_JERK_MM_S3)
                )
            }
            (RampShape::Bell, _) => "bell-shaped ramps".to_string(),
            _ => "trapezoid ramps".to_string(),
        };
        let _ = writeln!(
            s,
            "expected run time {:.1} s ({:.2} min) at {:.0} mm/s², {ramp}",
            self.run_time_s,
            s_to_min(self.run_time_s),
            self.accel_mm_s2
        );
        let _ = writeln!(
            s,
            "expected samples per channel {} at {:.3} ms",
            self.samples_per_channel,
            self.sample_interval_s * 1e3
        );
        for n in &self.notes {
            let _ = writeln!(s, "note: {n}");
        }
        s
    }
}

/// `value` of `field` is a positive finite number, else an invalid-parameter error
/// `{field} {value}: must be > 0` in the front end's spelling.
fn positive(field: &'static str, value: Option<f64>, front: &dyn FrontEnd) -> Result<(), AppError> {
    match value {
        Some(x) if !(x.is_finite() && x > 0.0) => Err(AppError::invalid(
            field,
            format!("{} {x}: must be > 0", front.name(field)),
        )),
        _ => Ok(()),
    }
}

/// A planner's error: bad input with its message (it names the limit or the setting).
fn bad(e: impl std::fmt::Display) -> AppError {
    AppError::bad_input(e.to_string())
}

impl PlanRequest {
    /// Check the settings that need no file and no planning.
    ///
    /// # Errors
    /// [`AppError::invalid`] naming the field as the front end spells it: a jerk limit with a
    /// ramp other than jerk-limited; a sampling rate, sampling interval or approach feed that
    /// is not a positive number. (The jerk's value and the test's own settings are checked
    /// when the program is planned, naming the setting.)
    pub fn validate(&self, front: &dyn FrontEnd) -> Result<(), AppError> {
        if self.jerk_mm_s3.is_some() && self.ramp != RampShape::JerkLimited {
            return Err(AppError::invalid(
                "jerk_mm_s3",
                format!(
                    "{} applies only to {} (trapezoid and bell ramps have no jerk limit)",
                    front.name("jerk_mm_s3"),
                    front.spell("ramp", "jerk_limited")
                ),
            ));
        }
        positive("sample_rate_hz", self.sample_rate_hz, front)?;
        positive("sample_interval_ms", self.sample_interval_ms, front)?;
        positive("approach_feed_mm_min", self.approach_feed_mm_min, front)
    }

    /// The sampling interval the counts and the identifiability check assume (s): the rate's,
    /// else the interval's, else [`DEFAULT_SAMPLE_INTERVAL_MS`].
    pub fn sample_interval_s(&self) -> f64 {
        match self.sample_rate_hz {
            Some(r) => 1.0 / r,
            None => {
                self.sample_interval_ms
                    .unwrap_or(DEFAULT_SAMPLE_INTERVAL_MS)
                    * 1e-3
            }
        }
    }

    /// The limits the program must respect: the request's travel limits, else `axis`'s; the
    /// request's feed limit.
    pub fn limits(&self, axis: Option<&AxisParams>) -> Limits {
        Limits {
            travel_min_mm: self.travel_min_mm.or(axis.and_then(|a| a.travel_min_mm)),
            travel_max_mm: self.travel_max_mm.or(axis.and_then(|a| a.travel_max_mm)),
            feed_max_mm_min: self.feed_limit_mm_min,
        }
    }

    /// Read the axis file (when given), plan, and write the program to `output` (when given).
    ///
    /// # Errors
    /// As [`validate`](Self::validate) and [`plan`](Self::plan); the axis file's errors; I/O
    /// errors writing `output` (nothing is left there).
    pub fn run(&self, front: &dyn FrontEnd) -> Result<Planned, AppError> {
        self.validate(front)?;
        let axis = match &self.axis {
            Some(p) => Some(feedscope_io::axis::load(p).map_err(AppError::from_error)?),
            None => None,
        };
        let planned = self.build(axis.as_ref(), front)?;
        if let Some(out) = &self.output {
            write_atomic(out, planned.gcode.as_bytes())
                .map_err(|e| AppError::caused(e.kind(), format!("writing {}", out.display()), e))?;
        }
        Ok(planned)
    }

    /// Plan with the travel limits of `axis` (an axis already read; the request's `axis` file
    /// is not read), writing nothing.
    ///
    /// # Errors
    /// As [`validate`](Self::validate); a triangular wave with no window end or highest feed
    /// (given or from the limits), naming the field; the planner's errors naming the limit or
    /// the setting: a position outside the travel, a feed above the limit, a window too short
    /// for the highest feed, a jerk that is not positive.
    pub fn plan(
        &self,
        axis: Option<&AxisParams>,
        front: &dyn FrontEnd,
    ) -> Result<Planned, AppError> {
        self.validate(front)?;
        self.build(axis, front)
    }

    /// [`plan`](Self::plan) of a validated request.
    fn build(&self, axis: Option<&AxisParams>, front: &dyn FrontEnd) -> Result<Planned, AppError> {
        let lim = self.limits(axis);
        let prog = self.program(&lim, front)?;
        let prog = prog.with_ramp(self.ramp, self.jerk_mm_s3).map_err(|e| {
            AppError::invalid("jerk_mm_s3", format!("{}: {e}", front.name("jerk_mm_s3")))
        })?;
        if let Some(f) = self.approach_feed_mm_min {
            lim.check_feed(f).map_err(bad)?;
        }
        let opts = GcodeOptions {
            dialect: self.dialect,
            fanuc_machine: self.fanuc_machine,
            axis_letter: self.axis_letter,
            program_number: self.program_number,
            sample_interval_s: self.sample_interval_s(),
            approach_feed_mm_min: self.approach_feed_mm_min,
        };
        let gcode = write_gcode(&prog, &opts).map_err(bad)?;
        let mut warnings = Vec::new();
        if let Some(w) = identifiability_warning(&prog, opts.sample_interval_s) {
            let assumed = self.sample_interval_ms.is_none() && self.sample_rate_hz.is_none();
            warnings.push(if assumed {
                format!(
                    "{w} (no {} or {} was given: {DEFAULT_SAMPLE_INTERVAL_MS} ms polling was \
                     assumed)",
                    front.name("sample_interval_ms"),
                    front.name("sample_rate_hz")
                )
            } else {
                w
            });
        }
        let report = PlanReport {
            test: prog.kind,
            output: self.output.as_ref().map(|p| p.display().to_string()),
            dialect: opts.dialect,
            start_mm: prog.start_mm,
            span_mm: prog.span_mm(),
            feeds_mm_min: prog.feeds_mm_min(),
            run_time_s: prog.run_time_s(),
            sample_interval_s: opts.sample_interval_s,
            samples_per_channel: prog.expected_samples(opts.sample_interval_s),
            accel_mm_s2: prog.accel_mm_s2,
            ramp: prog.ramp,
            jerk_mm_s3: prog.jerk_mm_s3,
            notes: prog.notes.clone(),
            warnings,
            moves: prog.moves.clone(),
        };
        Ok(Planned { gcode, report })
    }

    /// The test's program within `lim`, before the ramp is chosen.
    fn program(&self, lim: &Limits, front: &dyn FrontEnd) -> Result<TestProgram, AppError> {
        match &self.test {
            PlanTest::Strokes(s) => {
                let p = StrokeTestParams {
                    from_mm: s.from_mm,
                    to_mm: s.to_mm,
                    feeds_mm_min: s.feeds_mm_min.clone(),
                    repeats: s.repeats,
                    dwell_s: s.dwell_s,
                    accel_mm_s2: self.accel_mm_s2,
                };
                strokes_program(&p, lim).map_err(bad)
            }
            PlanTest::Triangle(t) => {
                let name = |f: &str| front.name(f);
                let from = t.from_mm.or(lim.travel_min_mm).ok_or_else(|| {
                    AppError::invalid(
                        "from_mm",
                        format!(
                            "{} is needed (or travel_min_mm in the axis file / {})",
                            name("from_mm"),
                            name("travel_min_mm")
                        ),
                    )
                })?;
                let to = t.to_mm.or(lim.travel_max_mm).ok_or_else(|| {
                    AppError::invalid(
                        "to_mm",
                        format!(
                            "{} is needed (or travel_max_mm in the axis file / {})",
                            name("to_mm"),
                            name("travel_max_mm")
                        ),
                    )
                })?;
                let feed_max = t.feed_max_mm_min.or(lim.feed_max_mm_min).ok_or_else(|| {
                    AppError::invalid(
                        "feed_max_mm_min",
                        format!(
                            "{} or {} is needed",
                            name("feed_max_mm_min"),
                            name("feed_limit_mm_min")
                        ),
                    )
                })?;
                let p = TriangleParams {
                    window_min_mm: from,
                    window_max_mm: to,
                    feed_max_mm_min: feed_max,
                    feed_min_mm_min: t.feed_min_mm_min,
                    vs_guess_mm_min: t.vs_guess_mm_min,
                    levels: t.levels,
                    cycles_per_level: t.cycles,
                    min_cruise_s: t.cruise_s,
                    dwell_s: t.dwell_s,
                    accel_mm_s2: self.accel_mm_s2,
                };
                triangle_program(&p, lim).map_err(bad)
            }
        }
    }
}
