//! Digital twin of a ball-screw feed drive: traces of a drive whose friction is known.
//!
//! [`simulate`] plans the motion of a [`SimConfig`] (`[[motion.stroke]]` entries, or an NC
//! program read by [`crate::nc`]: [`MotionConfig::program`], [`simulate_program`]) block by
//! block with exact stop, every speed change of one [`RampShape`] (trapezoid, jerk-limited
//! S-curve by default, bell) and under an optional feed-override schedule ([`FeedOverride`])
//! ([`NcPath`]), moves the table
//! through the plant of paper 000 Eq. 5 with a [`FrictionModel`] (ideal inverse dynamics or a
//! cascaded servo loop), samples position and effort as a controller does (jitter, offsets,
//! dropouts, stamp errors, noise, quantisation) and returns the [`Trace`] with its [`Truth`],
//! which lists every commanded move with its kind and program line.
//!
//! Sign convention: friction is positive while the table moves forward (z increasing), as in
//! Eq. 5: (m_t + 4π²J/p²)·z'' + (4π²B/p²)·z' = (2π/p)·k_e·i − F_f. The effort is the current
//! i (A) or the torque k_e·i (N·m).
//!
//! # Example
//! ```
//! use feedscope::sim::{simulate, SimConfig, StrokeConfig};
//! let mut cfg = SimConfig::default();
//! cfg.motion.strokes = vec![StrokeConfig { to_mm: 20.0, feed_mm_min: 600.0, dwell_s: 0.0 }];
//! let out = simulate(&cfg, &mut |_| {}).unwrap();
//! assert!(out.trace.position_m.len() > 20);
//! // friction is known at every true state
//! let s = &out.truth.states[out.truth.states.len() / 2];
//! let f = out.truth.friction.friction_n(s.position_m, s.velocity_m_s);
//! assert!((f - s.friction_n).abs() < 1e-9 && f > 0.0);
//! ```
//!
//! # Reference
//! Paper 000 Sections 2-3: Eq. 1-5 (drive model), Eq. 7 (ball-refeed orders), sampling of
//! 70-75 ms with asynchronous position and current channels.

mod config;
mod friction;
mod motion;
mod sampling;
mod servo;

pub use config::{
    DynamicsConfig, DynamicsMode, EffortSampling, MotionConfig, PositionSampling, SamplingConfig,
    SamplingMode, SimConfig, TruthConfig, DEFAULT_RAPID_RATE_MM_MIN, MAX_FRICTION_N,
};
pub use friction::{
    Bump, Component, ComponentDirection, Direction, FrictionModel, FrictionParams, MeanLevel,
    VelocityTerm,
};
pub use motion::{
    CommandedStroke, FeedChange, FeedModulation, FeedOverride, FnProfile, Kinematics, MotionLimits,
    MotionProfile, MoveKind, NcPath, RampShape, StrokeConfig, DEFAULT_JERK_MM_S3,
};
pub use servo::{RunStats, StateSample, MAX_INTEGRATION_STEPS};

use serde::{Deserialize, Serialize};

use crate::axis::{AxisError, AxisParams};
use crate::nc::{NcError, NcProgram};
use crate::trace::{Channel, EffortKind, Trace};

/// Errors of the simulator configuration and run.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SimError {
    /// The TOML is invalid, or a key is unknown or has the wrong type.
    #[error("simulator config: {message}")]
    Parse {
        /// What the parser reported (names the key).
        message: String,
    },
    /// A key holds a value outside its range.
    #[error("simulator config: key `{key}` = {value}: {reason}")]
    InvalidValue {
        /// Dotted key, e.g. `motion.stroke[1].feed_mm_min`.
        key: String,
        /// The value found.
        value: f64,
        /// Why it is rejected.
        reason: String,
    },
    /// The axis section is invalid (the [`AxisError`] is the message, not a source, as for
    /// [`SimError::Program`]).
    #[error("simulator config: {0}")]
    Axis(AxisError),
    /// The servo run is too stiff to integrate: the friction is so large against its sign
    /// smoothing and the equivalent mass that a control step at rest needs more than 10,000
    /// RK4 sub-steps (no stable integration), or the run could need more than
    /// [`MAX_INTEGRATION_STEPS`] in all and more than 16 per control step (hours of work for
    /// a table that sticks).
    #[error(
        "simulator config: the friction (up to {friction_bound_n:.3e} N on an equivalent mass of \
         {mass_kg:.3e} kg) is too stiff to integrate with `friction.sign_smoothing_mm_s` = \
         {sign_smoothing_mm_s}: a control step at rest needs {sub_steps:.0} RK4 sub-steps (at \
         most 10000) and the {control_steps} control steps up to {integration_steps:.3e} (at \
         most 5e8, about 5 minutes, or 16 per control step); lower the friction, raise \
         friction.sign_smoothing_mm_s, or shorten the run"
    )]
    TooStiff {
        /// Bound of |F_f| over the run (N).
        friction_bound_n: f64,
        /// Equivalent mass m_eq (kg).
        mass_kg: f64,
        /// v_ε (mm/s).
        sign_smoothing_mm_s: f64,
        /// RK4 sub-steps of a control step at rest.
        sub_steps: f64,
        /// Control steps of the run.
        control_steps: u64,
        /// RK4 steps of the run in the worst case.
        integration_steps: f64,
    },
    /// The config asks for more samples, steps or time than the simulator allows.
    #[error("simulator config: key `{key}` asks for {count:.3e}, more than the limit {limit:.1e}")]
    TooLarge {
        /// The key that sets the size.
        key: String,
        /// Samples, steps or seconds asked for.
        count: f64,
        /// The limit.
        limit: f64,
    },
    /// A key other than a number holds something invalid, or keys contradict each other.
    #[error("simulator config: key `{key}`: {message}")]
    InvalidSetting {
        /// Dotted key, e.g. `motion.program_axis`.
        key: String,
        /// What is wrong.
        message: String,
    },
    /// The NC program cannot be read or timed (names the program and the line). The
    /// [`NcError`] is the message itself, not a source, so that a chain of causes printed
    /// with `{:#}` does not repeat it.
    #[error("simulator config: {0}")]
    Program(NcError),
    /// The servo simulation became non-finite or ran away from the command.
    #[error(
        "the servo simulation diverged at t = {time_s} s (|z − z_cmd| > 0.1 m or non-finite); \
         check dynamics.* gains and dynamics.step_ms"
    )]
    Diverged {
        /// Simulated time (s).
        time_s: f64,
    },
}

impl SimError {
    /// What the error means to a caller: always [`BadInput`](crate::ErrorKind::BadInput): the simulator config is wrong (a diverging servo
    /// simulation comes from its gains and step).
    pub fn kind(&self) -> crate::ErrorKind {
        use crate::ErrorKind;
        ErrorKind::BadInput
    }
}

impl From<AxisError> for SimError {
    fn from(e: AxisError) -> Self {
        SimError::Axis(e)
    }
}

impl From<NcError> for SimError {
    fn from(e: NcError) -> Self {
        SimError::Program(e)
    }
}

/// What the estimator must recover, and what the simulation actually did.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Truth {
    /// The friction model used.
    pub friction: FrictionModel,
    /// The axis simulated.
    pub axis: AxisParams,
    /// The commanded strokes or program moves with their times (empty for
    /// [`simulate_profile`]).
    pub strokes: Vec<CommandedStroke>,
    /// Dynamics mode used.
    pub dynamics: DynamicsMode,
    /// Seed used.
    pub seed: u64,
    /// Length of the simulation (s).
    pub duration_s: f64,
    /// True state every `truth.interval_ms` from t = 0 (not serialized; written as CSV).
    #[serde(skip)]
    pub states: Vec<StateSample>,
    /// Noise-free values at the true instants of the position samples (m), one per sample of
    /// the trace, in the same order (not serialized).
    #[serde(skip)]
    pub position_clean: Channel,
    /// Noise-free effort (A or N·m) at the true instants of the effort samples (not
    /// serialized).
    #[serde(skip)]
    pub effort_clean: Channel,
}

/// Result of a simulation.
#[derive(Debug, Clone, PartialEq)]
pub struct SimOutput {
    /// What the controller would have recorded.
    pub trace: Trace,
    /// The known truth.
    pub truth: Truth,
    /// Step counts and the largest following error.
    pub stats: RunStats,
}

/// Simulate the NC program of `cfg`. `progress` receives the fraction done in [0, 1].
///
/// # Errors
/// Any validation error of [`SimConfig::validate`] (naming the key), or
/// [`SimError::Diverged`] when the servo loop does not hold the table.
pub fn simulate(cfg: &SimConfig, progress: &mut dyn FnMut(f64)) -> Result<SimOutput, SimError> {
    cfg.validate_settings()?;
    let path = cfg.path()?;
    cfg.validate_path(&path)?;
    let mut out = run(cfg, &path, progress)?;
    out.truth.strokes = path.strokes().to_vec();
    Ok(out)
}

/// The most RK4 steps the servo run of `cfg` may take (every control step as stiff as at
/// rest), 0 in ideal mode: what [`simulate`] refuses above [`MAX_INTEGRATION_STEPS`] before
/// it starts, and what bounds its work.
///
/// # Errors
/// As [`simulate`] before the run: validation and the program.
pub fn integration_steps_bound(cfg: &SimConfig) -> Result<f64, SimError> {
    cfg.validate_settings()?;
    let path = cfg.path()?;
    cfg.validate_path(&path)?;
    if cfg.dynamics.mode == DynamicsMode::Ideal {
        return Ok(0.0);
    }
    let friction = cfg.friction_model();
    let plant = servo::Plant::new(&cfg.axis, &friction);
    Ok(servo::WorkBound::of(&plant, &cfg.dynamics, &path).integration_steps_max())
}

/// Simulate an NC program read by [`crate::nc`] on the drive of `cfg`: the `[motion]` start,
/// limits (acceleration, jerk, rapid rate), modulation and lead times of `cfg` apply, its
/// strokes and program keys are ignored. The truth lists every move of the program with its
/// line ([`CommandedStroke::line`]).
///
/// # Example
/// ```
/// use feedscope::nc::{NcProgram, ParseOptions};
/// use feedscope::sim::{simulate_program, DynamicsMode, MoveKind, SimConfig};
/// let prog = NcProgram::parse(
///     "G71 G90 G94 G60\nG0 Z10\nG1 Z30 F600\nG4 F0.5\nG0 Z10\nM30\n",
///     &ParseOptions::default(),
/// )
/// .unwrap();
/// let mut cfg = SimConfig::default();
/// cfg.dynamics.mode = DynamicsMode::Ideal;
/// cfg.motion.jerk_mm_s3 = Some(20_000.0);
/// let out = simulate_program(&cfg, &prog, &mut |_| {}).unwrap();
/// let moves = &out.truth.strokes;
/// assert_eq!(moves.len(), 3);
/// assert_eq!((moves[1].kind, moves[1].line), (MoveKind::Feed, Some(3)));
/// // 20 mm at 10 mm/s plus the ramps, then 0.5 s of dwell before the rapid back
/// assert!(moves[2].start_time_s - moves[1].end_time_s > 0.5 - 1e-9);
/// ```
///
/// # Errors
/// As [`simulate`]; [`SimError::Program`] (source `program`) for a move whose axis feed is
/// unknown, [`SimError::InvalidValue`] for a position outside the travel.
pub fn simulate_program(
    cfg: &SimConfig,
    program: &NcProgram,
    progress: &mut dyn FnMut(f64),
) -> Result<SimOutput, SimError> {
    let mut cfg = cfg.clone();
    cfg.motion.strokes.clear();
    cfg.motion.program = None;
    cfg.motion.program_file = None;
    cfg.validate_settings()?;
    let path = cfg.program_path(program, "program")?;
    cfg.validate_path(&path)?;
    let mut out = run(&cfg, &path, progress)?;
    out.truth.strokes = path.strokes().to_vec();
    Ok(out)
}

/// Simulate an arbitrary commanded profile z(t) (on [0, `profile.duration_s()`]) instead of
/// the `[motion]` program of `cfg`; everything else as [`simulate`].
///
/// # Errors
/// As [`simulate`]; also [`SimError::InvalidValue`] for a non-finite or negative duration.
pub fn simulate_profile(
    cfg: &SimConfig,
    profile: &dyn MotionProfile,
    progress: &mut dyn FnMut(f64),
) -> Result<SimOutput, SimError> {
    cfg.validate()?;
    let d = profile.duration_s();
    if !(d.is_finite() && (0.0..=1e7).contains(&d)) {
        return Err(SimError::InvalidValue {
            key: "profile.duration_s".to_string(),
            value: d,
            reason: "must be finite, ≥ 0 and at most 1e7 s".to_string(),
        });
    }
    run(cfg, profile, progress)
}

fn run(
    cfg: &SimConfig,
    profile: &dyn MotionProfile,
    progress: &mut dyn FnMut(f64),
) -> Result<SimOutput, SimError> {
    let friction = cfg.friction_model();
    let duration_s = profile.duration_s();
    let s = &cfg.sampling;

    // Sample instants first (independent random streams per channel), then one pass of the
    // dynamics evaluates every requested instant.
    let (pos_times, eff_times) = match s.mode {
        SamplingMode::Asynchronous => (
            sampling::asynchronous(
                &s.position.timing(),
                duration_s,
                &mut sampling::stream(cfg.seed, 0),
            ),
            sampling::asynchronous(
                &s.effort.timing(),
                duration_s,
                &mut sampling::stream(cfg.seed, 1),
            ),
        ),
        SamplingMode::Synchronous => {
            let t = sampling::synchronous(
                s.synchronous_rate_hz,
                s.synchronous_dropout_probability,
                duration_s,
                &mut sampling::stream(cfg.seed, 0),
            );
            (t.clone(), t)
        }
    };
    let dt_truth = cfg.truth.interval_ms * 1e-3;
    let n_truth = (duration_s / dt_truth).floor() as usize + 1;
    let truth_times: Vec<f64> = (0..n_truth).map(|k| k as f64 * dt_truth).collect();

    let plant = servo::Plant::new(&cfg.axis, &friction);
    // Synchronous channels share their instants: their states are evaluated once (the same
    // instants give the same states, so this only saves time and memory).
    let synchronous = s.mode == SamplingMode::Synchronous;
    let requests: Vec<&[f64]> = if synchronous {
        vec![&pos_times.true_s, &truth_times]
    } else {
        vec![&pos_times.true_s, &eff_times.true_s, &truth_times]
    };
    let (mut states, stats) = match cfg.dynamics.mode {
        DynamicsMode::Ideal => servo::run_ideal(&plant, profile, &requests, progress),
        DynamicsMode::Servo => servo::run_servo(
            &plant,
            &cfg.dynamics,
            profile,
            duration_s,
            &requests,
            progress,
        )?,
    };
    let truth_states = states.pop().unwrap_or_default();
    let eff_own = if synchronous {
        None
    } else {
        Some(states.pop().unwrap_or_default())
    };
    let pos_states = states.pop().unwrap_or_default();
    let eff_states: &[StateSample] = eff_own.as_deref().unwrap_or(&pos_states);

    let kind = s.effort_kind;
    let effort_of = |st: &StateSample| match kind {
        EffortKind::CurrentA => st.current_a,
        EffortKind::TorqueNm => st.current_a * cfg.axis.torque_constant_nm_per_a,
    };
    let position_clean = Channel {
        time_s: pos_times.true_s.clone(),
        value: pos_states.iter().map(|st| st.position_m).collect(),
    };
    let effort_clean = Channel {
        time_s: eff_times.true_s.clone(),
        value: eff_states.iter().map(effort_of).collect(),
    };

    let mut pos_values = position_clean.value.clone();
    sampling::measure(
        &mut pos_values,
        s.position.noise_std_mm * 1e-3,
        s.position.quantum_mm * 1e-3,
        &mut sampling::stream(cfg.seed, 2),
    );
    let (q, sigma) = s.effort.quantum_and_noise(kind);
    let mut eff_values = effort_clean.value.clone();
    sampling::measure(
        &mut eff_values,
        sigma,
        q,
        &mut sampling::stream(cfg.seed, 3),
    );

    Ok(SimOutput {
        trace: Trace {
            position_m: Channel {
                time_s: pos_times.stamp_s,
                value: pos_values,
            },
            effort: Channel {
                time_s: eff_times.stamp_s,
                value: eff_values,
            },
            effort_kind: kind,
            facts: Default::default(),
        },
        truth: Truth {
            friction,
            axis: cfg.axis.clone(),
            strokes: Vec::new(),
            dynamics: cfg.dynamics.mode,
            seed: cfg.seed,
            duration_s,
            states: truth_states,
            position_clean,
            effort_clean,
        },
        stats,
    })
}

impl Truth {
    /// Write the true-state series as CSV with the header
    /// `time_s,position_mm,velocity_mm_s,accel_mm_s2,friction_n`.
    ///
    /// # Errors
    /// I/O errors.
    pub fn write_states_csv<W: std::io::Write>(&self, w: W) -> std::io::Result<()> {
        use std::io::Write as _;
        let mut w = std::io::BufWriter::new(w);
        writeln!(w, "time_s,position_mm,velocity_mm_s,accel_mm_s2,friction_n")?;
        for s in &self.states {
            writeln!(
                w,
                "{},{},{},{},{}",
                s.time_s,
                s.position_m * 1e3,
                s.velocity_m_s * 1e3,
                s.accel_m_s2 * 1e3,
                s.friction_n
            )?;
        }
        w.flush()
    }
}

#[cfg(test)]
mod tests;
