//! Test planning: the motions that produce friction tests, their run time and sample counts,
//! and NC programs (G-code) that command them ([`gcode`]).
//!
//! Two tests:
//! - **idle strokes** (paper 000 Section 2): from a start to an end position and back at each
//!   of a list of feeds, with a dwell after every stroke, repeated ([`strokes_program`]);
//! - **triangular wave** of variable amplitude and velocity (paper 002 Eq. 8, Fig. 3): one
//!   trace from which [`crate::ident::identify`] separates J, F_c, F_s, v_s and σ
//!   ([`triangle_program`]).
//!
//! A program is a start position and a list of linear moves (target, feed, dwell after).
//! Timing assumes what the controller does with a G01 block that ends at a reversal or a
//! dwell: accelerate to the feed and decelerate to rest at the target with the control's ramp
//! shape ([`RampShape`]; by default jerk-limited at [`DEFAULT_JERK_MM_S3`], as the
//! simulator's default; [`TestProgram::with_ramp`] sets another), a shorter profile when the
//! move is too short to reach the feed. The same kinematics drive the simulator
//! ([`crate::sim::NcPath`]), so a planned program can be simulated through
//! [`crate::sim::MotionProfile`]. The amplitudes of the triangular wave are planned with the
//! trapezoid's distance v²/a ([`Move::motion_time_s`]).
//!
//! # Example
//! ```
//! use feedscope::plan::{strokes_program, Limits, StrokeTestParams};
//! use feedscope::sim::RampShape;
//! let p = StrokeTestParams {
//!     from_mm: 0.0,
//!     to_mm: 100.0,
//!     feeds_mm_min: vec![600.0],
//!     repeats: 1,
//!     dwell_s: 1.0,
//!     accel_mm_s2: 1000.0,
//! };
//! let prog = strokes_program(&p, &Limits::default()).unwrap();
//! // 2 strokes of 100 mm at 10 mm/s and 2 dwells of 1 s; the default jerk-limited ramps at
//! // 20 m/s³ do not reach 1000 mm/s² at this feed (v·j < a²): each ramp lasts 2·√(v/j)
//! let ramp = 2.0 * (10.0f64 / 20_000.0).sqrt();
//! assert!((prog.run_time_s() - 2.0 * (10.0 + ramp + 1.0)).abs() < 1e-9);
//! // with trapezoids (constant acceleration) a ramp lasts v/a = 0.01 s
//! let prog = prog.with_ramp(RampShape::Trapezoid, None).unwrap();
//! assert!((prog.run_time_s() - 2.0 * (10.0 + 0.01 + 1.0)).abs() < 1e-9);
//! ```
//!
//! # Reference
//! Paper 000 Section 2 (idle test over 0-410 mm with 1 s dwell; run time known before
//! acquisition so that enough samples are requested); paper 002 Eq. 8 and Fig. 3.

pub mod check;
pub mod gcode;

pub use check::{identifiability, identifiability_warning, Identifiability};

use serde::{Deserialize, Serialize};

use crate::sim::{
    Kinematics, MotionLimits, MotionProfile, NcPath, RampShape, StrokeConfig, DEFAULT_JERK_MM_S3,
};
use crate::units::feed_mm_min_to_mm_s;

/// Why a test cannot be planned.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum PlanError {
    /// A programmed position lies outside the travel.
    #[error("position {position_mm} mm lies outside the travel: {limit} = {limit_mm} mm")]
    OutsideTravel {
        /// The offending position (mm).
        position_mm: f64,
        /// Which limit, `travel_min_mm` or `travel_max_mm`.
        limit: &'static str,
        /// Its value (mm).
        limit_mm: f64,
    },
    /// A feed exceeds the feed limit.
    #[error("feed {feed_mm_min} mm/min exceeds the feed limit feed_max_mm_min = {limit_mm_min}")]
    FeedTooHigh {
        /// The feed (mm/min).
        feed_mm_min: f64,
        /// The limit (mm/min).
        limit_mm_min: f64,
    },
    /// A value is outside its range.
    #[error("`{name}` = {value}: {reason}")]
    InvalidValue {
        /// Parameter name.
        name: &'static str,
        /// The value.
        value: f64,
        /// Why it is rejected.
        reason: &'static str,
    },
    /// The travel window is too short to reach a feed and stop again.
    #[error(
        "feed {feed_mm_min} mm/min needs {needed_mm:.3} mm to accelerate and stop at \
         {accel_mm_s2} mm/s², the travel window allows {available_mm:.3} mm"
    )]
    FeedNotReachable {
        /// The feed (mm/min).
        feed_mm_min: f64,
        /// Distance needed v²/a (mm).
        needed_mm: f64,
        /// Stroke length available (mm).
        available_mm: f64,
        /// Acceleration assumed (mm/s²).
        accel_mm_s2: f64,
    },
}

impl PlanError {
    /// What the error means to a caller: always [`BadInput`](crate::ErrorKind::BadInput): the test asked for does not fit the axis.
    pub fn kind(&self) -> crate::ErrorKind {
        use crate::ErrorKind;
        ErrorKind::BadInput
    }
}

/// Travel and feed limits that a program must respect; `None` = not checked.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Limits {
    /// Lower end of the travel (mm).
    pub travel_min_mm: Option<f64>,
    /// Upper end of the travel (mm).
    pub travel_max_mm: Option<f64>,
    /// Highest feed allowed (mm/min).
    pub feed_max_mm_min: Option<f64>,
}

impl Limits {
    /// Check one programmed position.
    ///
    /// # Errors
    /// [`PlanError::OutsideTravel`] naming the limit.
    pub fn check_position(&self, position_mm: f64) -> Result<(), PlanError> {
        if let Some(lo) = self.travel_min_mm {
            if position_mm < lo - 1e-9 {
                return Err(PlanError::OutsideTravel {
                    position_mm,
                    limit: "travel_min_mm",
                    limit_mm: lo,
                });
            }
        }
        if let Some(hi) = self.travel_max_mm {
            if position_mm > hi + 1e-9 {
                return Err(PlanError::OutsideTravel {
                    position_mm,
                    limit: "travel_max_mm",
                    limit_mm: hi,
                });
            }
        }
        Ok(())
    }

    /// Check one feed.
    ///
    /// # Errors
    /// [`PlanError::FeedTooHigh`].
    pub fn check_feed(&self, feed_mm_min: f64) -> Result<(), PlanError> {
        match self.feed_max_mm_min {
            Some(l) if feed_mm_min > l * (1.0 + 1e-12) => Err(PlanError::FeedTooHigh {
                feed_mm_min,
                limit_mm_min: l,
            }),
            _ => Ok(()),
        }
    }
}

/// One linear move of a program.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Move {
    /// Start position (mm).
    pub from_mm: f64,
    /// Target position (mm).
    pub to_mm: f64,
    /// Feed (mm/min).
    pub feed_mm_min: f64,
    /// Standstill after reaching the target (s).
    pub dwell_s: f64,
}

impl Move {
    /// Time from start to rest at the target, without the dwell (s), for an acceleration
    /// `accel_mm_s2` with trapezoid ramps: L/v + v/a when L ≥ v²/a, else 2·√(L/a) (triangle).
    /// [`TestProgram::run_time_s`] takes the program's ramp shape.
    pub fn motion_time_s(&self, accel_mm_s2: f64) -> f64 {
        let l = (self.to_mm - self.from_mm).abs();
        let v = feed_mm_min_to_mm_s(self.feed_mm_min);
        if l <= 0.0 {
            0.0
        } else if l >= v * v / accel_mm_s2 {
            l / v + v / accel_mm_s2
        } else {
            2.0 * (l / accel_mm_s2).sqrt()
        }
    }

    /// Time at constant feed (s).
    pub fn cruise_time_s(&self, accel_mm_s2: f64) -> f64 {
        let l = (self.to_mm - self.from_mm).abs();
        let v = feed_mm_min_to_mm_s(self.feed_mm_min);
        ((l - v * v / accel_mm_s2) / v).max(0.0)
    }
}

/// Which test a program performs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TestKind {
    /// Forward and backward idle strokes at a list of feeds (paper 000).
    Strokes,
    /// Variable-amplitude, variable-velocity triangular wave (paper 002).
    Triangle,
}

/// A planned test: start position and moves, with the acceleration assumed for timing.
/// Implements [`MotionProfile`] (no lead-in or lead-out) so it can be simulated.
#[derive(Debug, Clone)]
pub struct TestProgram {
    /// What the program is for.
    pub kind: TestKind,
    /// Position at program start (mm); the program first moves there.
    pub start_mm: f64,
    /// The moves in order.
    pub moves: Vec<Move>,
    /// Acceleration assumed for timing (mm/s²).
    pub accel_mm_s2: f64,
    /// Notes for the header and the user (e.g. shortened cruise phases).
    pub notes: Vec<String>,
    /// Ramp shape assumed for timing. Default jerk-limited, as the simulator's.
    pub ramp: RampShape,
    /// Jerk limit assumed for timing with the jerk-limited ramp (mm/s³); `None` for the other
    /// shapes. Default [`DEFAULT_JERK_MM_S3`].
    pub jerk_mm_s3: Option<f64>,
    path: NcPath,
}

impl TestProgram {
    fn new(
        kind: TestKind,
        start_mm: f64,
        moves: Vec<Move>,
        accel_mm_s2: f64,
        notes: Vec<String>,
    ) -> Self {
        let mut p = Self {
            kind,
            start_mm,
            moves,
            accel_mm_s2,
            notes,
            ramp: RampShape::JerkLimited,
            jerk_mm_s3: Some(DEFAULT_JERK_MM_S3),
            path: NcPath::plan(start_mm, &[], accel_mm_s2, None, 0.0, 0.0),
        };
        p.replan();
        p
    }

    /// The program timed with the ramp shape `ramp` and, for [`RampShape::JerkLimited`], the
    /// jerk limit `jerk_mm_s3` (mm/s³; `None` = [`DEFAULT_JERK_MM_S3`]; ignored by the other
    /// shapes): set these to the control's, so that the run time is what the control takes.
    ///
    /// # Errors
    /// [`PlanError::InvalidValue`] (`jerk_mm_s3`) for a jerk that is not finite and > 0.
    pub fn with_ramp(
        mut self,
        ramp: RampShape,
        jerk_mm_s3: Option<f64>,
    ) -> Result<Self, PlanError> {
        if let Some(j) = jerk_mm_s3 {
            positive("jerk_mm_s3", j)?;
        }
        self.ramp = ramp;
        self.jerk_mm_s3 = match ramp {
            RampShape::JerkLimited => Some(jerk_mm_s3.unwrap_or(DEFAULT_JERK_MM_S3)),
            RampShape::Trapezoid | RampShape::Bell => None,
        };
        self.replan();
        Ok(self)
    }

    /// The simulator's path of the moves with the program's ramp (no lead-in or lead-out).
    fn replan(&mut self) {
        let strokes: Vec<StrokeConfig> = self
            .moves
            .iter()
            .map(|m| StrokeConfig {
                to_mm: m.to_mm,
                feed_mm_min: m.feed_mm_min,
                dwell_s: m.dwell_s,
            })
            .collect();
        let limits = MotionLimits {
            acceleration_mm_s2: self.accel_mm_s2,
            jerk_mm_s3: self.jerk_mm_s3,
            rapid_rate_mm_min: 1.0,
            rapid_acceleration_mm_s2: self.accel_mm_s2,
            ramp: self.ramp,
        };
        self.path = NcPath::plan_strokes(self.start_mm, &strokes, &limits, None, &[], 0.0, 0.0);
    }

    /// Expected run time: motion plus dwells (s), from the start position, with the
    /// program's ramp shape (the duration of [`TestProgram::path`]).
    pub fn run_time_s(&self) -> f64 {
        self.path.duration_s()
    }

    /// Samples of one channel sampled every `interval_s` over the run: ⌊T/Δt⌋ + 1.
    pub fn expected_samples(&self, interval_s: f64) -> u64 {
        (self.run_time_s() / interval_s).floor() as u64 + 1
    }

    /// Lowest and highest programmed position (mm).
    pub fn span_mm(&self) -> (f64, f64) {
        self.moves
            .iter()
            .map(|m| m.to_mm)
            .fold((self.start_mm, self.start_mm), |(lo, hi), z| {
                (lo.min(z), hi.max(z))
            })
    }

    /// Distinct feeds in order of first use (mm/min).
    pub fn feeds_mm_min(&self) -> Vec<f64> {
        let mut out: Vec<f64> = Vec::new();
        for m in &self.moves {
            if !out.iter().any(|f| (f - m.feed_mm_min).abs() < 1e-9) {
                out.push(m.feed_mm_min);
            }
        }
        out
    }

    /// The simulator's path of this program (no lead-in or lead-out).
    pub fn path(&self) -> &NcPath {
        &self.path
    }
}

impl MotionProfile for TestProgram {
    fn duration_s(&self) -> f64 {
        self.path.duration_s()
    }
    fn kinematics(&self, t_s: f64) -> Kinematics {
        self.path.kinematics(t_s)
    }
}

fn positive(name: &'static str, value: f64) -> Result<(), PlanError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(PlanError::InvalidValue {
            name,
            value,
            reason: "must be finite and > 0",
        })
    }
}

fn non_negative(name: &'static str, value: f64) -> Result<(), PlanError> {
    if value.is_finite() && value >= 0.0 {
        Ok(())
    } else {
        Err(PlanError::InvalidValue {
            name,
            value,
            reason: "must be finite and ≥ 0",
        })
    }
}

/// The idle-stroke test of paper 000 Section 2.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StrokeTestParams {
    /// Start of each forward stroke (mm).
    pub from_mm: f64,
    /// End of each forward stroke (mm).
    pub to_mm: f64,
    /// Feeds in test order (mm/min).
    pub feeds_mm_min: Vec<f64>,
    /// Forward + backward pairs per feed.
    pub repeats: u32,
    /// Dwell after every stroke (s). Paper 000: 1 s.
    pub dwell_s: f64,
    /// Acceleration assumed for timing (mm/s²).
    pub accel_mm_s2: f64,
}

impl Default for StrokeTestParams {
    fn default() -> Self {
        Self {
            from_mm: 0.0,
            to_mm: 410.0,
            feeds_mm_min: vec![5.0, 20.0, 80.0],
            repeats: 3,
            dwell_s: 1.0,
            accel_mm_s2: 1000.0,
        }
    }
}

/// Plan the idle strokes: for each feed, `repeats` times forward to `to_mm` and back to
/// `from_mm`, each stroke followed by the dwell.
///
/// # Errors
/// [`PlanError::OutsideTravel`] / [`PlanError::FeedTooHigh`] against `limits`;
/// [`PlanError::InvalidValue`] for empty feeds, zero repeats, equal ends or non-finite values.
pub fn strokes_program(p: &StrokeTestParams, limits: &Limits) -> Result<TestProgram, PlanError> {
    if !(p.from_mm.is_finite() && p.to_mm.is_finite()) || (p.from_mm - p.to_mm).abs() < 1e-6 {
        return Err(PlanError::InvalidValue {
            name: "to_mm",
            value: p.to_mm,
            reason: "must be finite and differ from from_mm",
        });
    }
    if p.feeds_mm_min.is_empty() {
        return Err(PlanError::InvalidValue {
            name: "feeds_mm_min",
            value: 0.0,
            reason: "at least one feed is needed",
        });
    }
    if p.repeats == 0 {
        return Err(PlanError::InvalidValue {
            name: "repeats",
            value: 0.0,
            reason: "must be at least 1",
        });
    }
    non_negative("dwell_s", p.dwell_s)?;
    positive("accel_mm_s2", p.accel_mm_s2)?;
    limits.check_position(p.from_mm)?;
    limits.check_position(p.to_mm)?;
    let mut moves = Vec::new();
    for &f in &p.feeds_mm_min {
        positive("feeds_mm_min", f)?;
        limits.check_feed(f)?;
        for _ in 0..p.repeats {
            for (a, b) in [(p.from_mm, p.to_mm), (p.to_mm, p.from_mm)] {
                moves.push(Move {
                    from_mm: a,
                    to_mm: b,
                    feed_mm_min: f,
                    dwell_s: p.dwell_s,
                });
            }
        }
    }
    Ok(TestProgram::new(
        TestKind::Strokes,
        p.from_mm,
        moves,
        p.accel_mm_s2,
        Vec::new(),
    ))
}

/// The variable-amplitude, variable-velocity triangular wave (paper 002 Eq. 8, Fig. 3).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TriangleParams {
    /// Lower end of the travel window (mm).
    pub window_min_mm: f64,
    /// Upper end of the travel window (mm); the wave is centred in the window.
    pub window_max_mm: f64,
    /// Highest feed, the feed limit of the test (mm/min); V_max of Eq. 8.
    pub feed_max_mm_min: f64,
    /// Lowest feed (mm/min). `None` (default) = v_s guess / 5, so that the Stribeck drop is
    /// sampled well below v_s.
    pub feed_min_mm_min: Option<f64>,
    /// Guess of the Stribeck velocity (mm/min). Default 60.
    pub vs_guess_mm_min: f64,
    /// Number of feed levels, geometrically spaced from the lowest to the highest. Default 10.
    pub levels: usize,
    /// Full cycles (forward + backward stroke) per level. Default 1.
    pub cycles_per_level: usize,
    /// Wanted time at constant feed per stroke (s); sets the amplitude of slow levels.
    /// Default 2.
    pub min_cruise_s: f64,
    /// Dwell after every stroke (s). Default 0 (a reversal, as in Fig. 3).
    pub dwell_s: f64,
    /// Acceleration assumed (mm/s²), the controller's setting for the axis. Default 1000.
    pub accel_mm_s2: f64,
}

impl Default for TriangleParams {
    fn default() -> Self {
        Self {
            window_min_mm: 0.0,
            window_max_mm: 120.0,
            feed_max_mm_min: 10_000.0,
            feed_min_mm_min: None,
            vs_guess_mm_min: 60.0,
            levels: 10,
            cycles_per_level: 1,
            min_cruise_s: 2.0,
            dwell_s: 0.0,
            accel_mm_s2: 1000.0,
        }
    }
}

/// Plan the triangular wave.
///
/// Rule (paper 002 Eq. 8 with an explicit amplitude law): feeds
/// f_i = f_min·(f_max/f_min)^(i/(N−1)), i = 0…N−1; centre c of the window, half-window P;
/// level i oscillates c → c + A_i → c − A_i (× cycles) → c with amplitude
/// A_i = γ_i·P, γ_i = min(1, (v_i·t_cruise + v_i²/a)/(2P)): each full stroke 2A_i holds
/// t_cruise at constant feed plus the acceleration and deceleration distances, as long as the
/// window allows; faster levels use the whole window. The amplitude grows with the feed, as in
/// Fig. 3. Every reversal accelerates at ±a, which identifies J.
///
/// # Errors
/// [`PlanError::InvalidValue`] for bad settings, [`PlanError::FeedTooHigh`] /
/// [`PlanError::OutsideTravel`] against `limits`, [`PlanError::FeedNotReachable`] when
/// the window cannot hold the acceleration and deceleration distance at the highest feed.
pub fn triangle_program(p: &TriangleParams, limits: &Limits) -> Result<TestProgram, PlanError> {
    positive("feed_max_mm_min", p.feed_max_mm_min)?;
    positive("vs_guess_mm_min", p.vs_guess_mm_min)?;
    positive("min_cruise_s", p.min_cruise_s)?;
    positive("accel_mm_s2", p.accel_mm_s2)?;
    non_negative("dwell_s", p.dwell_s)?;
    if !(p.window_min_mm.is_finite()
        && p.window_max_mm.is_finite()
        && p.window_max_mm > p.window_min_mm)
    {
        return Err(PlanError::InvalidValue {
            name: "window_max_mm",
            value: p.window_max_mm,
            reason: "must be finite and greater than window_min_mm",
        });
    }
    if p.levels < 2 {
        return Err(PlanError::InvalidValue {
            name: "levels",
            value: p.levels as f64,
            reason: "at least 2 feed levels are needed",
        });
    }
    if p.cycles_per_level == 0 {
        return Err(PlanError::InvalidValue {
            name: "cycles_per_level",
            value: 0.0,
            reason: "must be at least 1",
        });
    }
    let f_min = p.feed_min_mm_min.unwrap_or(p.vs_guess_mm_min / 5.0);
    positive("feed_min_mm_min", f_min)?;
    if f_min >= p.feed_max_mm_min {
        return Err(PlanError::InvalidValue {
            name: "feed_min_mm_min",
            value: f_min,
            reason: "must be below feed_max_mm_min",
        });
    }
    limits.check_feed(p.feed_max_mm_min)?;
    limits.check_position(p.window_min_mm)?;
    limits.check_position(p.window_max_mm)?;

    // Positions on the 0.001 mm and feeds on the 0.1 mm/min grid of the G-code, so that the
    // program, its timing and its simulation agree.
    let round3 = |x: f64| (x * 1e3).round() / 1e3;
    let c = round3(0.5 * (p.window_min_mm + p.window_max_mm));
    let half = (c - p.window_min_mm).min(p.window_max_mm - c);
    let a = p.accel_mm_s2;
    let n = p.levels;
    let mut moves = Vec::new();
    let mut notes = Vec::new();
    let mut z = c;
    for i in 0..n {
        let f = f_min * (p.feed_max_mm_min / f_min).powf(i as f64 / (n - 1) as f64);
        let f = ((f * 10.0).round() / 10.0).clamp(0.1, p.feed_max_mm_min);
        let v = feed_mm_min_to_mm_s(f);
        let need = v * p.min_cruise_s + v * v / a;
        let gamma = (need / (2.0 * half)).min(1.0);
        let amp = ((gamma * half * 1e3).ceil() / 1e3).clamp(0.001, half);
        if v * v / a > 2.0 * amp {
            return Err(PlanError::FeedNotReachable {
                feed_mm_min: f,
                needed_mm: v * v / a,
                available_mm: 2.0 * amp,
                accel_mm_s2: a,
            });
        }
        let cruise = (2.0 * amp - v * v / a) / v;
        if cruise < p.min_cruise_s * (1.0 - 1e-9) {
            notes.push(format!(
                "level {i} ({f:.1} mm/min) cruises {cruise:.2} s per stroke, less than the \
                 {:.2} s asked for: the window is the limit",
                p.min_cruise_s
            ));
        }
        let mut push = |to: f64, z: &mut f64| {
            moves.push(Move {
                from_mm: *z,
                to_mm: to,
                feed_mm_min: f,
                dwell_s: p.dwell_s,
            });
            *z = to;
        };
        for _ in 0..p.cycles_per_level {
            push(c + amp, &mut z);
            push(c - amp, &mut z);
        }
        push(c, &mut z);
    }
    Ok(TestProgram::new(TestKind::Triangle, c, moves, a, notes))
}

#[cfg(test)]
mod tests;
