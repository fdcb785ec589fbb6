//! Simulator configuration (TOML, user units in every key name) and its validation.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use super::friction::{FrictionModel, FrictionParams};
use super::motion::{FeedModulation, FeedOverride, MotionLimits, NcPath, RampShape, StrokeConfig};
use super::SimError;
use crate::axis::{AxisError, AxisParams};
use crate::nc::{NcError, NcProgram, ParseOptions};
use crate::trace::EffortKind;

/// Rapid rate when neither `motion.rapid_rate_mm_min` nor `axis.rapid_rate_mm_min` is given
/// (mm/min).
pub const DEFAULT_RAPID_RATE_MM_MIN: f64 = 15_000.0;

/// Complete configuration of one simulation. `Default` is a plausible lathe Z axis (paper 000)
/// doing one forward and one backward stroke over 0-410 mm at 100 mm/min.
///
/// Every section is optional in TOML; missing ones take their defaults. A missing
/// `[friction]` table takes [`FrictionParams::default_for`] the configured axis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SimConfig {
    /// Seed of every random draw (jitter, dropouts, noise). Default 1.
    pub seed: u64,
    /// The mechanism (same keys as an axis file).
    pub axis: AxisParams,
    /// The friction truth; `None` = defaults for the axis.
    pub friction: Option<FrictionParams>,
    /// The NC program.
    pub motion: MotionConfig,
    /// Ideal (inverse dynamics) or servo-loop dynamics.
    pub dynamics: DynamicsConfig,
    /// How the controller samples position and effort.
    pub sampling: SamplingConfig,
    /// The decimated true-state series.
    pub truth: TruthConfig,
}

impl Default for SimConfig {
    fn default() -> Self {
        let axis = AxisParams {
            name: Some("simulated lathe Z".to_string()),
            lead_mm: 10.0,
            table_mass_kg: 425.0,
            inertia_kgm2: 0.004,
            damping_nms_per_rad: 0.002,
            torque_constant_nm_per_a: 1.82,
            screw_diameter_mm: Some(40.0),
            screw_ball_diameter_mm: Some(5.556),
            contact_angle_deg: Some(45.0),
            // ½·18·(40 − 5.556·cos45°)/40 = 8.12 ≈ 8 as in paper 000 Section 4
            screw_balls_per_turn: Some(18.0),
            guide_ball_diameter_mm: Some(6.0),
            guide_balls_per_raceway: Some(19.0),
            travel_min_mm: Some(0.0),
            travel_max_mm: Some(410.0),
            rapid_rate_mm_min: None,
            declared_orders: vec![crate::axis::DeclaredOrder {
                order: 0.56,
                cause: "rolling-tool mark".to_string(),
            }],
            thresholds: Default::default(),
        };
        let friction = Some(FrictionParams::default_for(&axis));
        Self {
            seed: 1,
            axis,
            friction,
            motion: MotionConfig::default(),
            dynamics: DynamicsConfig::default(),
            sampling: SamplingConfig::default(),
            truth: TruthConfig::default(),
        }
    }
}

/// The NC program (`[motion]`): start position, strokes or an NC program, kinematic limits,
/// modulation.
///
/// A program (`program` inline, or `program_file`) replaces `[[motion.stroke]]`: in TOML
/// give one of them (when `program` is given the strokes default to none); from Rust clear
/// `strokes` when setting a program (both is an error naming the keys).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "MotionToml", into = "MotionToml")]
pub struct MotionConfig {
    /// Position at t = 0 (mm), where the table is when the program starts. Default 0.
    pub start_mm: f64,
    /// Acceleration limit of feed moves (mm/s²), > 0. Default 1000.
    pub acceleration_mm_s2: f64,
    /// Shape of every speed change (TOML `ramp`: `"trapezoid"`, `"jerk_limited"` (default) or
    /// `"bell"`), see [`RampShape`].
    pub ramp: RampShape,
    /// Jerk limit of the jerk-limited ramp (mm/s³), > 0. Absent (default):
    /// [`super::DEFAULT_JERK_MM_S3`] (20 m/s³). Not used by the trapezoid and bell ramps: in
    /// TOML giving it with `ramp = "trapezoid"` or `"bell"` is an error naming both keys;
    /// from Rust it is ignored for those shapes. An old config with `jerk_mm_s3` alone keeps
    /// meaning jerk-limited.
    pub jerk_mm_s3: Option<f64>,
    /// Rapid traverse rate for G0 (mm/min), > 0. Absent (default): `axis.rapid_rate_mm_min`,
    /// else 15000.
    pub rapid_rate_mm_min: Option<f64>,
    /// Acceleration limit of rapids (mm/s²), > 0. Absent (default): `acceleration_mm_s2`.
    pub rapid_acceleration_mm_s2: Option<f64>,
    /// Standstill before the first stroke (s), ≥ 0. Default 0.5.
    pub lead_in_s: f64,
    /// Standstill after the last dwell (s), ≥ 0. Default 0.5.
    pub lead_out_s: f64,
    /// Strokes in program order (`[[motion.stroke]]`). Default: to 410 mm at 100 mm/min, dwell
    /// 1 s, back to 0 at 100 mm/min (none when a program is given in TOML).
    pub strokes: Vec<StrokeConfig>,
    /// An NC program (G-code text, FANUC or SINUMERIK 840D, read by [`crate::nc`]) instead of
    /// the strokes. Default none.
    pub program: Option<String>,
    /// A file holding the NC program instead of the strokes. A relative path is taken
    /// relative to the config file by `feedscope_io::sim` and the CLI. The simulator opens no
    /// file: it reads the program from [`MotionConfig::program_file_contents`]. Default none.
    pub program_file: Option<PathBuf>,
    /// The bytes of `program_file`, as read by `feedscope_io::sim::load_program_file` (or put
    /// here by the caller); not serialized. A `program_file` without them cannot be simulated
    /// (an error naming the file). Default none.
    pub program_file_contents: Option<Vec<u8>>,
    /// Address letter of the simulated axis in the program (X, Y, Z; or A, B, C, U, V, W).
    /// Default `'Z'`.
    pub program_axis: char,
    /// Read the program as a FANUC lathe's (G-code system A): U, V, W are the incremental
    /// addresses of X, Y, Z ([`ParseOptions::lathe_incremental_addresses`]). Default false.
    pub program_lathe_incremental: bool,
    /// Optional sinusoidal feed modulation of feed moves (`[motion.modulation]`).
    pub modulation: Option<FeedModulation>,
    /// Feed-override schedule of feed moves (TOML `[[motion.override]]`, `{at_s, percent}`),
    /// see [`FeedOverride`]; empty (default) = 100 % throughout. It stays in the config: the
    /// truth reports each move's programmed feed (`feed_mm_min`), the override it started
    /// under and the speed changes it made ([`super::CommandedStroke::feed_changes`]). Cannot
    /// be combined with `modulation` in a config.
    pub overrides: Vec<FeedOverride>,
}

impl Default for MotionConfig {
    fn default() -> Self {
        Self {
            start_mm: 0.0,
            acceleration_mm_s2: 1000.0,
            ramp: RampShape::JerkLimited,
            jerk_mm_s3: None,
            rapid_rate_mm_min: None,
            rapid_acceleration_mm_s2: None,
            lead_in_s: 0.5,
            lead_out_s: 0.5,
            strokes: vec![
                StrokeConfig {
                    to_mm: 410.0,
                    feed_mm_min: 100.0,
                    dwell_s: 1.0,
                },
                StrokeConfig {
                    to_mm: 0.0,
                    feed_mm_min: 100.0,
                    dwell_s: 0.0,
                },
            ],
            program: None,
            program_file: None,
            program_file_contents: None,
            program_axis: 'Z',
            program_lathe_incremental: false,
            modulation: None,
            overrides: Vec::new(),
        }
    }
}

impl MotionConfig {
    /// The limits with their defaults resolved against `axis`.
    pub fn limits(&self, axis: &AxisParams) -> MotionLimits {
        MotionLimits {
            acceleration_mm_s2: self.acceleration_mm_s2,
            jerk_mm_s3: self.jerk_mm_s3,
            rapid_rate_mm_min: self
                .rapid_rate_mm_min
                .or(axis.rapid_rate_mm_min)
                .unwrap_or(DEFAULT_RAPID_RATE_MM_MIN),
            rapid_acceleration_mm_s2: self
                .rapid_acceleration_mm_s2
                .unwrap_or(self.acceleration_mm_s2),
            ramp: self.ramp,
        }
    }

    /// How the program is read.
    pub fn parse_options(&self) -> ParseOptions {
        ParseOptions {
            axis_letter: self.program_axis,
            lathe_incremental_addresses: self.program_lathe_incremental,
        }
    }

    /// The NC program of `program`, or of `program_file` from its
    /// [`MotionConfig::program_file_contents`], parsed; `None` for strokes.
    ///
    /// # Errors
    /// [`SimError::Program`] naming `motion.program` or the file and the line; line 0 when the
    /// contents of `program_file` are not there (the file was not read).
    pub fn read_program(&self) -> Result<Option<NcProgram>, SimError> {
        let opts = self.parse_options();
        Ok(match (&self.program, &self.program_file) {
            (Some(text), _) => Some(NcProgram::parse_named(text, "motion.program", &opts)?),
            (None, Some(path)) => {
                let name = path.display().to_string();
                match &self.program_file_contents {
                    Some(bytes) => Some(NcProgram::parse_bytes(bytes, &name, &opts)?),
                    None => {
                        return Err(SimError::Program(NcError {
                            source_name: name,
                            line: 0,
                            message: "the file has not been read (the simulator opens no file: \
                                      load the config with feedscope_io::sim, or set \
                                      motion.program_file_contents)"
                                .to_string(),
                        }))
                    }
                }
            }
            (None, None) => None,
        })
    }

    /// Name of the program's source in messages: the key, or the file.
    fn program_source(&self) -> String {
        match (&self.program, &self.program_file) {
            (None, Some(p)) => p.display().to_string(),
            _ => "motion.program".to_string(),
        }
    }
}

/// `[motion]` as written in TOML: `stroke` absent is not the same as `stroke = []`, so that a
/// program can replace the default strokes and both given is an error.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
struct MotionToml {
    start_mm: f64,
    acceleration_mm_s2: f64,
    ramp: RampShape,
    #[serde(skip_serializing_if = "Option::is_none")]
    jerk_mm_s3: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    rapid_rate_mm_min: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    rapid_acceleration_mm_s2: Option<f64>,
    lead_in_s: f64,
    lead_out_s: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    stroke: Option<Vec<StrokeConfig>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    program: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    program_file: Option<PathBuf>,
    program_axis: char,
    program_lathe_incremental: bool,
    #[serde(skip_serializing_if = "Option::is_none")]
    modulation: Option<FeedModulation>,
    #[serde(rename = "override", skip_serializing_if = "Vec::is_empty")]
    overrides: Vec<FeedOverride>,
}

impl Default for MotionToml {
    fn default() -> Self {
        let m = MotionConfig::default();
        Self {
            stroke: None,
            ..Self::from(m)
        }
    }
}

impl TryFrom<MotionToml> for MotionConfig {
    type Error = String;
    fn try_from(t: MotionToml) -> Result<Self, String> {
        let has_program = t.program.is_some() || t.program_file.is_some();
        if has_program && t.stroke.is_some() {
            return Err(PROGRAM_AND_STROKES.to_string());
        }
        if let (Some(j), RampShape::Trapezoid | RampShape::Bell) = (t.jerk_mm_s3, t.ramp) {
            return Err(format!(
                "keys `motion.jerk_mm_s3` = {j} and `motion.ramp` = \"{}\" are both given: \
                 only the jerk-limited ramp has a jerk limit (drop `motion.jerk_mm_s3`, or \
                 set `motion.ramp = \"jerk_limited\"`)",
                match t.ramp {
                    RampShape::Trapezoid => "trapezoid",
                    _ => "bell",
                }
            ));
        }
        let strokes = match t.stroke {
            Some(s) => s,
            None if has_program => Vec::new(),
            None => MotionConfig::default().strokes,
        };
        Ok(Self {
            start_mm: t.start_mm,
            acceleration_mm_s2: t.acceleration_mm_s2,
            ramp: t.ramp,
            jerk_mm_s3: t.jerk_mm_s3,
            rapid_rate_mm_min: t.rapid_rate_mm_min,
            rapid_acceleration_mm_s2: t.rapid_acceleration_mm_s2,
            lead_in_s: t.lead_in_s,
            lead_out_s: t.lead_out_s,
            strokes,
            program: t.program,
            program_file: t.program_file,
            program_file_contents: None,
            program_axis: t.program_axis,
            program_lathe_incremental: t.program_lathe_incremental,
            modulation: t.modulation,
            overrides: t.overrides,
        })
    }
}

impl From<MotionConfig> for MotionToml {
    fn from(m: MotionConfig) -> Self {
        let has_program = m.program.is_some() || m.program_file.is_some();
        Self {
            start_mm: m.start_mm,
            acceleration_mm_s2: m.acceleration_mm_s2,
            ramp: m.ramp,
            // a jerk the shape does not use is not written (TOML would refuse it)
            jerk_mm_s3: m.jerk_mm_s3.filter(|_| m.ramp == RampShape::JerkLimited),
            rapid_rate_mm_min: m.rapid_rate_mm_min,
            rapid_acceleration_mm_s2: m.rapid_acceleration_mm_s2,
            lead_in_s: m.lead_in_s,
            lead_out_s: m.lead_out_s,
            stroke: (!(has_program && m.strokes.is_empty())).then_some(m.strokes),
            program: m.program,
            program_file: m.program_file,
            program_axis: m.program_axis,
            program_lathe_incremental: m.program_lathe_incremental,
            modulation: m.modulation,
            overrides: m.overrides,
        }
    }
}

const PROGRAM_AND_STROKES: &str = "keys `motion.stroke` and `motion.program` (or \
                                   `motion.program_file`) are both given: a program replaces \
                                   the strokes, give one of them";

/// How the table motion is produced.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DynamicsMode {
    /// The table follows the commanded path exactly; the current is the inverse dynamics of
    /// paper 000 Eq. 5.
    Ideal,
    /// A cascaded position/velocity loop drives the plant of Eq. 5 (default).
    #[default]
    Servo,
}

/// Dynamics and servo loop (`[dynamics]`).
///
/// The servo is a P position loop (gain K_p) cascaded with a PI velocity loop whose
/// proportional gain is chosen so that the velocity loop has the bandwidth ω_v on the rigid
/// plant of Eq. 5: K_v = ω_v·m_eq/((2π/p)·k_e) (A per m/s), K_i = K_v·ω_i (A per m), plus
/// velocity feed-forward k_ff·v_cmd (into the velocity reference) and acceleration + viscous
/// feed-forward k_ff·(m_eq·a_cmd + b_eq·v_cmd) as current, k_ff = `velocity_feedforward`.
/// Without feed-forward (k_ff = 0) the table trails the command at constant speed v by the
/// following error v/K_p, K_p = `position_gain_per_s`. The current follows its command with a first-order
/// lag τ. The controller runs every `step_ms` with zero-order hold; the plant is integrated by
/// RK4 with sub-steps where the friction sign change makes it stiff.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DynamicsConfig {
    /// `"servo"` (default) or `"ideal"`.
    pub mode: DynamicsMode,
    /// Controller period and base integration step (ms), > 0. Default 0.1.
    pub step_ms: f64,
    /// Position loop gain K_p (1/s), > 0. Default 30. This is the K_v factor of real controls
    /// (velocity per following error), e.g. SINUMERIK's servo gain factor, given there in
    /// (m/min)/mm: 1 (m/min)/mm = 16.67/s.
    pub position_gain_per_s: f64,
    /// Velocity loop bandwidth ω_v/2π (Hz), > 0. Default 50.
    pub velocity_bandwidth_hz: f64,
    /// Velocity PI corner ω_i/2π (Hz), ≥ 0. Default 10.
    pub velocity_integral_corner_hz: f64,
    /// Current loop time constant τ (ms), > 0. Default 0.2.
    pub current_time_constant_ms: f64,
    /// Velocity feed-forward k_ff (fraction, in [0, 1]). Default 1 (full feed-forward: the
    /// table follows the command up to the loop's dynamic error). It scales the velocity fed
    /// into the velocity reference and the acceleration and viscous current feed-forward
    /// alike; with 0 the steady following error at speed v is v/K_p (servo lag).
    pub velocity_feedforward: f64,
}

impl Default for DynamicsConfig {
    fn default() -> Self {
        Self {
            mode: DynamicsMode::Servo,
            step_ms: 0.1,
            position_gain_per_s: 30.0,
            velocity_bandwidth_hz: 50.0,
            velocity_integral_corner_hz: 10.0,
            current_time_constant_ms: 0.2,
            velocity_feedforward: 1.0,
        }
    }
}

/// Asynchronous (own clock per channel) or synchronous (shared timestamps) sampling.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SamplingMode {
    /// Each channel has its own interval, jitter, offset and dropouts (default; paper 000).
    #[default]
    Asynchronous,
    /// Both channels at `synchronous_rate_hz` on the same instants.
    Synchronous,
}

/// Sampling (`[sampling]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SamplingConfig {
    /// `"asynchronous"` (default) or `"synchronous"`.
    pub mode: SamplingMode,
    /// What the effort channel carries: `"current_a"` (default) or `"torque_nm"`.
    pub effort_kind: EffortKind,
    /// Rate of synchronous sampling (Hz), > 0. Default 1000.
    pub synchronous_rate_hz: f64,
    /// Probability that a synchronous row is dropped, in [0, 1). Default 0.
    pub synchronous_dropout_probability: f64,
    /// Position channel (`[sampling.position]`).
    pub position: PositionSampling,
    /// Effort channel (`[sampling.effort]`).
    pub effort: EffortSampling,
}

impl Default for SamplingConfig {
    fn default() -> Self {
        Self {
            mode: SamplingMode::Asynchronous,
            effort_kind: EffortKind::CurrentA,
            synchronous_rate_hz: 1000.0,
            synchronous_dropout_probability: 0.0,
            position: PositionSampling::default(),
            effort: EffortSampling::default(),
        }
    }
}

/// Position channel sampling. Timing keys apply to asynchronous mode only; noise and
/// quantisation to both.
///
/// Sample instants: t₀ = offset, t_{n+1} = t_n + interval + U(−jitter, jitter); each sample is
/// dropped with the dropout probability; the reported stamp is t_n + delay +
/// U(−timestamp_jitter, timestamp_jitter). Value = round((z + N(0, σ²))/q)·q.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PositionSampling {
    /// Mean interval (ms), > 0. Default 72.
    pub interval_ms: f64,
    /// Half-width of the uniform interval jitter (ms), < interval. Default 1.5 (70.5-73.5 ms).
    pub jitter_ms: f64,
    /// Time of the first sample (ms), ≥ 0. Default 0.
    pub start_offset_ms: f64,
    /// Probability that a sample is dropped, in [0, 1). Default 0.
    pub dropout_probability: f64,
    /// Quantum q (mm), ≥ 0 (0 = none). Default 0.001 (1 µm).
    pub quantum_mm: f64,
    /// Gaussian noise std σ (mm), ≥ 0. Default 0.
    pub noise_std_mm: f64,
    /// Constant delay of the reported stamp after the true instant (ms), ≥ 0. Default 0.
    pub timestamp_delay_ms: f64,
    /// Half-width of the uniform stamp error (ms), ≥ 0, < (interval − jitter)/2. Default 0.
    pub timestamp_jitter_ms: f64,
}

impl Default for PositionSampling {
    fn default() -> Self {
        Self {
            interval_ms: 72.0,
            jitter_ms: 1.5,
            start_offset_ms: 0.0,
            dropout_probability: 0.0,
            quantum_mm: 0.001,
            noise_std_mm: 0.0,
            timestamp_delay_ms: 0.0,
            timestamp_jitter_ms: 0.0,
        }
    }
}

/// Effort channel sampling; timing as [`PositionSampling`]. The quantum and noise keys of the
/// configured `effort_kind` are used (current in A, torque in N·m).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EffortSampling {
    /// Mean interval (ms), > 0. Default 72.
    pub interval_ms: f64,
    /// Half-width of the uniform interval jitter (ms), < interval. Default 1.5.
    pub jitter_ms: f64,
    /// Time of the first sample (ms), ≥ 0. Default 36 (half an interval after position).
    pub start_offset_ms: f64,
    /// Probability that a sample is dropped, in [0, 1). Default 0.
    pub dropout_probability: f64,
    /// Current quantum (A), ≥ 0. Default 0.001 (≈ 1.1 N of table force on the default axis).
    pub current_quantum_a: f64,
    /// Current noise std (A), ≥ 0. Default 0.002.
    pub current_noise_std_a: f64,
    /// Torque quantum (N·m), ≥ 0. Default 0.002.
    pub torque_quantum_nm: f64,
    /// Torque noise std (N·m), ≥ 0. Default 0.004.
    pub torque_noise_std_nm: f64,
    /// Constant delay of the reported stamp (ms), ≥ 0. Default 0.
    pub timestamp_delay_ms: f64,
    /// Half-width of the uniform stamp error (ms), ≥ 0, < (interval − jitter)/2. Default 0.
    pub timestamp_jitter_ms: f64,
}

impl Default for EffortSampling {
    fn default() -> Self {
        Self {
            interval_ms: 72.0,
            jitter_ms: 1.5,
            start_offset_ms: 36.0,
            dropout_probability: 0.0,
            current_quantum_a: 0.001,
            current_noise_std_a: 0.002,
            torque_quantum_nm: 0.002,
            torque_noise_std_nm: 0.004,
            timestamp_delay_ms: 0.0,
            timestamp_jitter_ms: 0.0,
        }
    }
}

/// The decimated true-state series (`[truth]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TruthConfig {
    /// Interval of the true-state series (ms), > 0. Default 10.
    pub interval_ms: f64,
}

impl Default for TruthConfig {
    fn default() -> Self {
        Self { interval_ms: 10.0 }
    }
}

/// Timing of one channel in SI, shared by both channel kinds.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Timing {
    pub interval_s: f64,
    pub jitter_s: f64,
    pub offset_s: f64,
    pub dropout: f64,
    pub delay_s: f64,
    pub stamp_jitter_s: f64,
}

impl PositionSampling {
    pub(crate) fn timing(&self) -> Timing {
        Timing {
            interval_s: self.interval_ms * 1e-3,
            jitter_s: self.jitter_ms * 1e-3,
            offset_s: self.start_offset_ms * 1e-3,
            dropout: self.dropout_probability,
            delay_s: self.timestamp_delay_ms * 1e-3,
            stamp_jitter_s: self.timestamp_jitter_ms * 1e-3,
        }
    }
}

impl EffortSampling {
    pub(crate) fn timing(&self) -> Timing {
        Timing {
            interval_s: self.interval_ms * 1e-3,
            jitter_s: self.jitter_ms * 1e-3,
            offset_s: self.start_offset_ms * 1e-3,
            dropout: self.dropout_probability,
            delay_s: self.timestamp_delay_ms * 1e-3,
            stamp_jitter_s: self.timestamp_jitter_ms * 1e-3,
        }
    }

    /// (quantum, noise std) in the unit of `kind`.
    pub(crate) fn quantum_and_noise(&self, kind: EffortKind) -> (f64, f64) {
        match kind {
            EffortKind::CurrentA => (self.current_quantum_a, self.current_noise_std_a),
            EffortKind::TorqueNm => (self.torque_quantum_nm, self.torque_noise_std_nm),
        }
    }
}

/// At most this many samples per channel (and truth records), to keep memory bounded.
pub(crate) const MAX_SAMPLES: f64 = 2e7;
/// Largest friction term (N; N/mm × 10³ for the trend, N·s/m for the viscous coefficient)
/// the simulator accepts.
pub const MAX_FRICTION_N: f64 = 1e5;

/// At most this many controller steps.
pub(crate) const MAX_STEPS: f64 = 2e10;

impl SimConfig {
    /// Parse a TOML config and validate it.
    ///
    /// # Errors
    /// [`SimError::Parse`] for syntax errors, unknown or mistyped keys; the validation errors
    /// of [`SimConfig::validate`].
    /// A `motion.program_file` is not read here (the library opens no file), so validating it
    /// fails naming the file; `feedscope_io::sim` parses a config and reads its program file.
    pub fn from_toml_str(text: &str) -> Result<Self, SimError> {
        let cfg = Self::parse_toml(text)?;
        cfg.validate()?;
        Ok(cfg)
    }

    /// Parse a TOML config without validating it (strokes default as in
    /// [`MotionConfig::strokes`]); [`SimConfig::validate`] checks it.
    ///
    /// # Errors
    /// [`SimError::Parse`] for syntax errors, unknown or mistyped keys.
    pub fn parse_toml(text: &str) -> Result<Self, SimError> {
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        toml::from_str(text).map_err(|e| SimError::Parse {
            message: e.to_string().trim_end().to_string(),
        })
    }

    /// The config as TOML (for `--print-default-config`).
    ///
    /// # Errors
    /// [`SimError::Parse`] if serialization fails (it does not for valid configs).
    pub fn to_toml_string(&self) -> Result<String, SimError> {
        toml::to_string_pretty(self).map_err(|e| SimError::Parse {
            message: e.to_string(),
        })
    }

    /// The friction truth of this config (the `[friction]` table or the axis defaults).
    pub fn friction_model(&self) -> FrictionModel {
        let params = self
            .friction
            .clone()
            .unwrap_or_else(|| FrictionParams::default_for(&self.axis));
        FrictionModel::new(self.axis.lead_mm, params)
    }

    /// Check every value, naming the first offending key (`motion.stroke[1].feed_mm_min`),
    /// parse the program if there is one, and check the sizes of the run.
    ///
    /// # Errors
    /// [`SimError::InvalidValue`] / [`SimError::InvalidSetting`] naming the key,
    /// [`SimError::Program`] naming the program line, [`SimError::TooLarge`].
    pub fn validate(&self) -> Result<(), SimError> {
        self.validate_settings()?;
        let path = self.path()?;
        self.validate_path(&path)
    }

    /// Every key on its own (without reading the program): the first step of
    /// [`SimConfig::validate`].
    ///
    /// # Errors
    /// [`SimError::InvalidValue`] / [`SimError::InvalidSetting`] naming the key.
    pub fn validate_settings(&self) -> Result<(), SimError> {
        self.axis.validate("axis").map_err(|e| match e {
            AxisError::InvalidValue {
                key, value, reason, ..
            } => bad(&format!("axis.{key}"), value, reason),
            other => SimError::Axis(other),
        })?;
        let finite = |key: &str, v: f64| {
            if v.is_finite() {
                Ok(())
            } else {
                Err(bad(key, v, "must be a finite number"))
            }
        };
        let positive = |key: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(bad(key, v, "must be a finite number greater than zero"))
            }
        };
        let non_negative = |key: &str, v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(bad(key, v, "must be a finite number, zero or greater"))
            }
        };
        let probability = |key: &str, v: f64| {
            if v.is_finite() && (0.0..1.0).contains(&v) {
                Ok(())
            } else {
                Err(bad(key, v, "must lie in [0, 1)"))
            }
        };

        // friction: finite, and within what a feed drive can push (a ball screw's nut is
        // rated for about 100 kN, its friction a few per cent of that); beyond, the servo run
        // only grinds through the stiffness sub-steps of a stuck table
        let f = self.friction_model();
        let fp = &f.params;
        let force = |key: &str, v: f64, limit: f64, unit: &str| {
            finite(key, v)?;
            if v.abs() <= limit {
                Ok(())
            } else {
                Err(bad(
                    key,
                    v,
                    &format!("must lie within ±{limit:e} {unit} (no feed drive has such friction)"),
                ))
            }
        };
        positive("friction.sign_smoothing_mm_s", fp.sign_smoothing_mm_s)?;
        for (name, l) in [("forward", &fp.forward), ("backward", &fp.backward)] {
            force(
                &format!("friction.{name}.offset_n"),
                l.offset_n,
                MAX_FRICTION_N,
                "N",
            )?;
            force(
                &format!("friction.{name}.trend_n_per_mm"),
                l.trend_n_per_mm,
                MAX_FRICTION_N / 1e3,
                "N/mm",
            )?;
            for (k, b) in l.bumps.iter().enumerate() {
                finite(&format!("friction.{name}.bump[{k}].center_mm"), b.center_mm)?;
                positive(&format!("friction.{name}.bump[{k}].width_mm"), b.width_mm)?;
                force(
                    &format!("friction.{name}.bump[{k}].height_n"),
                    b.height_n,
                    MAX_FRICTION_N,
                    "N",
                )?;
            }
        }
        let v = &fp.velocity;
        non_negative("friction.velocity.static_excess_n", v.static_excess_n)?;
        force(
            "friction.velocity.static_excess_n",
            v.static_excess_n,
            MAX_FRICTION_N,
            "N",
        )?;
        force(
            "friction.velocity.viscous_n_s_per_m",
            v.viscous_n_s_per_m,
            MAX_FRICTION_N,
            "N·s/m",
        )?;
        positive(
            "friction.velocity.stribeck_velocity_mm_min",
            v.stribeck_velocity_mm_min,
        )?;
        positive("friction.velocity.shape_exponent", v.shape_exponent)?;
        non_negative("friction.velocity.viscous_n_s_per_m", v.viscous_n_s_per_m)?;
        for (k, c) in fp.components.iter().enumerate() {
            positive(&format!("friction.component[{k}].order"), c.order)?;
            non_negative(
                &format!("friction.component[{k}].amplitude_n"),
                c.amplitude_n,
            )?;
            force(
                &format!("friction.component[{k}].amplitude_n"),
                c.amplitude_n,
                MAX_FRICTION_N,
                "N",
            )?;
            finite(&format!("friction.component[{k}].phase_deg"), c.phase_deg)?;
        }

        // motion
        let m = &self.motion;
        let travel = (self.axis.travel_min_mm, self.axis.travel_max_mm);
        let in_travel = |key: &str, z: f64| {
            finite(key, z)?;
            if let Some(lo) = travel.0 {
                if z < lo {
                    return Err(bad(key, z, "lies below axis.travel_min_mm"));
                }
            }
            if let Some(hi) = travel.1 {
                if z > hi {
                    return Err(bad(key, z, "lies beyond axis.travel_max_mm"));
                }
            }
            Ok(())
        };
        in_travel("motion.start_mm", m.start_mm)?;
        positive("motion.acceleration_mm_s2", m.acceleration_mm_s2)?;
        // Below 1 mm/s² (1 mm/s³) a ramp to any feed lasts minutes and its closed forms lose
        // every digit (a subnormal limit makes them NaN): no feed axis moves like that.
        let physical = |key: &str, v: f64, unit: &str| {
            if v >= 1.0 {
                Ok(())
            } else {
                Err(SimError::InvalidValue {
                    key: key.to_string(),
                    value: v,
                    reason: format!("must be at least 1 {unit} (no feed axis ramps slower)"),
                })
            }
        };
        physical("motion.acceleration_mm_s2", m.acceleration_mm_s2, "mm/s²")?;
        non_negative("motion.lead_in_s", m.lead_in_s)?;
        non_negative("motion.lead_out_s", m.lead_out_s)?;
        for (k, s) in m.strokes.iter().enumerate() {
            in_travel(&format!("motion.stroke[{k}].to_mm"), s.to_mm)?;
            positive(&format!("motion.stroke[{k}].feed_mm_min"), s.feed_mm_min)?;
            non_negative(&format!("motion.stroke[{k}].dwell_s"), s.dwell_s)?;
        }
        if let Some(j) = m.jerk_mm_s3 {
            positive("motion.jerk_mm_s3", j)?;
            physical("motion.jerk_mm_s3", j, "mm/s³")?;
        }
        if let Some(v) = m.rapid_rate_mm_min {
            positive("motion.rapid_rate_mm_min", v)?;
        }
        if let Some(a) = m.rapid_acceleration_mm_s2 {
            positive("motion.rapid_acceleration_mm_s2", a)?;
            physical("motion.rapid_acceleration_mm_s2", a, "mm/s²")?;
        }
        let axes = if m.program_lathe_incremental {
            "XYZ"
        } else {
            "ABCUVWXYZ"
        };
        if !axes.contains(m.program_axis) {
            return Err(SimError::InvalidSetting {
                key: "motion.program_axis".to_string(),
                message: format!(
                    "{:?} is not an axis letter: use one of {axes}{}",
                    m.program_axis,
                    if m.program_lathe_incremental {
                        " with motion.program_lathe_incremental"
                    } else {
                        ""
                    }
                ),
            });
        }
        if m.program.is_some() && m.program_file.is_some() {
            return Err(SimError::InvalidSetting {
                key: "motion.program_file".to_string(),
                message: "`motion.program` and `motion.program_file` are both given: give one"
                    .to_string(),
            });
        }
        if (m.program.is_some() || m.program_file.is_some()) && !m.strokes.is_empty() {
            return Err(SimError::InvalidSetting {
                key: "motion.stroke".to_string(),
                message: PROGRAM_AND_STROKES.to_string(),
            });
        }
        let mut prev_at: Option<f64> = None;
        for (k, o) in m.overrides.iter().enumerate() {
            let key = format!("motion.override[{k}].at_s");
            non_negative(&key, o.at_s)?;
            if let Some(p) = prev_at {
                if o.at_s <= p {
                    return Err(bad(
                        &key,
                        o.at_s,
                        "must be later than the previous entry's at_s (strictly increasing)",
                    ));
                }
            }
            prev_at = Some(o.at_s);
            if !(o.percent.is_finite() && o.percent > 0.0 && o.percent <= 200.0) {
                return Err(bad(
                    &format!("motion.override[{k}].percent"),
                    o.percent,
                    "must lie in (0, 200] (% of the programmed feed)",
                ));
            }
        }
        if !m.overrides.is_empty() && m.modulation.is_some() {
            return Err(SimError::InvalidSetting {
                key: "motion.override".to_string(),
                message: "`motion.override` and `motion.modulation` are both given: the twin \
                          modulates only an unbroken constant-feed phase, give one of them"
                    .to_string(),
            });
        }
        if let Some(md) = &m.modulation {
            probability(
                "motion.modulation.relative_amplitude",
                md.relative_amplitude,
            )?;
            positive("motion.modulation.period_s", md.period_s)?;
        }

        // dynamics
        let d = &self.dynamics;
        positive("dynamics.step_ms", d.step_ms)?;
        positive("dynamics.position_gain_per_s", d.position_gain_per_s)?;
        positive("dynamics.velocity_bandwidth_hz", d.velocity_bandwidth_hz)?;
        non_negative(
            "dynamics.velocity_integral_corner_hz",
            d.velocity_integral_corner_hz,
        )?;
        positive(
            "dynamics.current_time_constant_ms",
            d.current_time_constant_ms,
        )?;
        if !(d.velocity_feedforward.is_finite() && (0.0..=1.0).contains(&d.velocity_feedforward)) {
            return Err(bad(
                "dynamics.velocity_feedforward",
                d.velocity_feedforward,
                "must lie in [0, 1] (a fraction of the commanded velocity)",
            ));
        }
        if d.mode == DynamicsMode::Servo {
            if self.axis.equivalent_mass_kg() <= 0.0 {
                return Err(bad(
                    "axis.table_mass_kg",
                    self.axis.table_mass_kg,
                    "the servo mode needs m_t + 4π²J/p² > 0 (table mass or inertia)",
                ));
            }
            // The discrete loop must be much faster than its bandwidth (ZOH at 10 samples per
            // period of the velocity loop is the minimum a drive would use).
            if d.step_ms * 1e-3 * d.velocity_bandwidth_hz > 0.1 {
                return Err(bad(
                    "dynamics.step_ms",
                    d.step_ms,
                    "must be at most 1/(10·velocity_bandwidth_hz) for a stable discrete loop",
                ));
            }
        }

        // sampling
        let s = &self.sampling;
        positive("sampling.synchronous_rate_hz", s.synchronous_rate_hz)?;
        probability(
            "sampling.synchronous_dropout_probability",
            s.synchronous_dropout_probability,
        )?;
        for (name, t) in [
            ("position", s.position.timing()),
            ("effort", s.effort.timing()),
        ] {
            positive(&format!("sampling.{name}.interval_ms"), t.interval_s)?;
            non_negative(&format!("sampling.{name}.jitter_ms"), t.jitter_s)?;
            if t.jitter_s >= t.interval_s {
                return Err(bad(
                    &format!("sampling.{name}.jitter_ms"),
                    t.jitter_s * 1e3,
                    "must be smaller than interval_ms",
                ));
            }
            non_negative(&format!("sampling.{name}.start_offset_ms"), t.offset_s)?;
            probability(&format!("sampling.{name}.dropout_probability"), t.dropout)?;
            non_negative(&format!("sampling.{name}.timestamp_delay_ms"), t.delay_s)?;
            non_negative(
                &format!("sampling.{name}.timestamp_jitter_ms"),
                t.stamp_jitter_s,
            )?;
            if 2.0 * t.stamp_jitter_s >= t.interval_s - t.jitter_s {
                return Err(bad(
                    &format!("sampling.{name}.timestamp_jitter_ms"),
                    t.stamp_jitter_s * 1e3,
                    "must be below (interval_ms − jitter_ms)/2 so that stamps keep increasing",
                ));
            }
        }
        // Quanta and noise as a controller can have them: 0 (none) or within a span that
        // keeps every reading finite and meaningful. A subnormal quantum (1e-320) made the
        // rounding divide to inf and a noise of 1e308 wrote inf into the trace.
        let reading = |key: &str, v: f64, lo: f64, hi: f64, unit: &str| {
            if v == 0.0 || (v.is_finite() && (lo..=hi).contains(&v)) {
                Ok(())
            } else {
                Err(bad(
                    key,
                    v,
                    &format!("must be 0 (none) or lie in [{lo:e}, {hi:e}] {unit}"),
                ))
            }
        };
        let p = &s.position;
        reading(
            "sampling.position.quantum_mm",
            p.quantum_mm,
            1e-7,
            10.0,
            "mm",
        )?;
        reading(
            "sampling.position.noise_std_mm",
            p.noise_std_mm,
            1e-9,
            10.0,
            "mm",
        )?;
        let e = &s.effort;
        reading(
            "sampling.effort.current_quantum_a",
            e.current_quantum_a,
            1e-9,
            100.0,
            "A",
        )?;
        reading(
            "sampling.effort.current_noise_std_a",
            e.current_noise_std_a,
            1e-12,
            1e3,
            "A",
        )?;
        reading(
            "sampling.effort.torque_quantum_nm",
            e.torque_quantum_nm,
            1e-9,
            1e3,
            "N·m",
        )?;
        reading(
            "sampling.effort.torque_noise_std_nm",
            e.torque_noise_std_nm,
            1e-12,
            1e4,
            "N·m",
        )?;
        positive("truth.interval_ms", self.truth.interval_ms)?;
        Ok(())
    }

    /// Sizes of a run of `path`: bounded memory and time.
    pub(crate) fn validate_path(&self, path: &NcPath) -> Result<(), SimError> {
        let s = &self.sampling;
        let d = &self.dynamics;
        let duration = super::motion::MotionProfile::duration_s(path);
        let count = |key: &str, n: f64, limit: f64| {
            if n.is_finite() && n <= limit {
                Ok(())
            } else {
                Err(SimError::TooLarge {
                    key: key.to_string(),
                    count: n,
                    limit,
                })
            }
        };
        count("motion (total duration)", duration, 1e7)?;
        match s.mode {
            SamplingMode::Asynchronous => {
                for (name, t) in [
                    ("position", s.position.timing()),
                    ("effort", s.effort.timing()),
                ] {
                    count(
                        &format!("sampling.{name}.interval_ms"),
                        duration / (t.interval_s - t.jitter_s),
                        MAX_SAMPLES,
                    )?;
                }
            }
            SamplingMode::Synchronous => count(
                "sampling.synchronous_rate_hz",
                duration * s.synchronous_rate_hz,
                MAX_SAMPLES,
            )?,
        }
        count(
            "truth.interval_ms",
            duration / (self.truth.interval_ms * 1e-3),
            MAX_SAMPLES,
        )?;
        if d.mode == DynamicsMode::Servo {
            count("dynamics.step_ms", duration / (d.step_ms * 1e-3), MAX_STEPS)?;
        }
        Ok(())
    }

    /// The planned path of `[motion]`: its strokes, or its program (read here).
    ///
    /// # Errors
    /// [`SimError::Program`] when the program cannot be read or timed, naming its line;
    /// [`SimError::InvalidValue`] for a program position outside the travel.
    pub fn path(&self) -> Result<NcPath, SimError> {
        let m = &self.motion;
        match m.read_program()? {
            Some(prog) => self.program_path(&prog, &m.program_source()),
            None => Ok(NcPath::plan_strokes(
                m.start_mm,
                &m.strokes,
                &m.limits(&self.axis),
                m.modulation.as_ref(),
                &m.overrides,
                m.lead_in_s,
                m.lead_out_s,
            )),
        }
    }

    /// The planned path of `program` with the limits, start and lead times of `[motion]`;
    /// every position must lie within the travel of the axis. `source` names the program in
    /// errors.
    pub(crate) fn program_path(
        &self,
        program: &NcProgram,
        source: &str,
    ) -> Result<NcPath, SimError> {
        let m = &self.motion;
        for st in program.resolve(m.start_mm) {
            let key = || format!("{source}, line {}", st.line);
            if let Some(lo) = self.axis.travel_min_mm {
                if st.to_mm < lo {
                    return Err(bad(&key(), st.to_mm, "lies below axis.travel_min_mm"));
                }
            }
            if let Some(hi) = self.axis.travel_max_mm {
                if st.to_mm > hi {
                    return Err(bad(&key(), st.to_mm, "lies beyond axis.travel_max_mm"));
                }
            }
        }
        NcPath::plan_program(
            m.start_mm,
            program,
            &m.limits(&self.axis),
            m.modulation.as_ref(),
            &m.overrides,
            m.lead_in_s,
            m.lead_out_s,
        )
        .map_err(|mut e| {
            e.source_name = source.to_string();
            SimError::Program(e)
        })
    }
}

fn bad(key: &str, value: f64, reason: &str) -> SimError {
    SimError::InvalidValue {
        key: key.to_string(),
        value,
        reason: reason.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err_of(toml_text: &str) -> String {
        SimConfig::from_toml_str(toml_text).unwrap_err().to_string()
    }

    #[test]
    fn readings_outside_what_a_controller_gives_are_refused_naming_the_key() {
        let e = err_of("[sampling.position]\nquantum_mm = 1e-320\n");
        assert!(
            e.contains("sampling.position.quantum_mm") && e.contains("1e-7"),
            "{e}"
        );
        let e = err_of("[sampling.effort]\ncurrent_noise_std_a = 1e308\n");
        assert!(e.contains("sampling.effort.current_noise_std_a"), "{e}");
        let e = err_of("[sampling.effort]\ntorque_quantum_nm = -1\n");
        assert!(e.contains("sampling.effort.torque_quantum_nm"), "{e}");
        // none and the usual values pass
        SimConfig::from_toml_str("[sampling.position]\nquantum_mm = 0\nnoise_std_mm = 0\n")
            .unwrap();
        SimConfig::from_toml_str("[sampling.position]\nquantum_mm = 1e-4\n").unwrap();
    }

    #[test]
    fn default_round_trips_through_toml() {
        let d = SimConfig::default();
        d.validate().unwrap();
        let text = d.to_toml_string().unwrap();
        let back = SimConfig::from_toml_str(&text).unwrap();
        assert_eq!(back, d);
        // an empty file is the default
        assert_eq!(SimConfig::from_toml_str("").unwrap(), d);
    }

    #[test]
    fn bad_values_name_their_key() {
        let cases = [
            (
                "[[motion.stroke]]\nto_mm = 10\nfeed_mm_min = -100\n",
                "motion.stroke[0].feed_mm_min",
            ),
            (
                "[[motion.stroke]]\nto_mm = 10\nfeed_mm_min = 100\n[[motion.stroke]]\nto_mm = 500\nfeed_mm_min = 100\n",
                "motion.stroke[1].to_mm",
            ),
            ("[motion]\nstart_mm = -1\n", "motion.start_mm"),
            ("[sampling.position]\ninterval_ms = 0\n", "sampling.position.interval_ms"),
            ("[sampling.effort]\njitter_ms = 80\n", "sampling.effort.jitter_ms"),
            (
                "[sampling.effort]\ndropout_probability = 1.0\n",
                "sampling.effort.dropout_probability",
            ),
            (
                "[sampling.position]\ntimestamp_jitter_ms = 40\n",
                "sampling.position.timestamp_jitter_ms",
            ),
            ("[dynamics]\nstep_ms = 0\n", "dynamics.step_ms"),
            ("[dynamics]\nstep_ms = 5\n", "dynamics.step_ms"),
            ("[truth]\ninterval_ms = -1\n", "truth.interval_ms"),
            (
                "[axis]\nlead_mm = 0\ntable_mass_kg = 1\ninertia_kgm2 = 0\ndamping_nms_per_rad = 0\ntorque_constant_nm_per_a = 1\n",
                "axis.lead_mm",
            ),
            ("[motion]\nacceleration_mm_s2 = nan\n", "motion.acceleration_mm_s2"),
            // a subnormal limit once made the ramp's closed forms NaN (a fuzz finding)
            ("[motion]\nacceleration_mm_s2 = 4.9e-324\n", "motion.acceleration_mm_s2"),
            ("[motion]\njerk_mm_s3 = 1e-300\n", "motion.jerk_mm_s3"),
            ("[motion]\nrapid_acceleration_mm_s2 = 0.5\n", "motion.rapid_acceleration_mm_s2"),
            ("[sampling]\nsynchronous_rate_hz = 0\n", "sampling.synchronous_rate_hz"),
            ("[sampling.position]\ninterval_ms = 1e-6\njitter_ms = 0\n", "sampling.position.interval_ms"),
            ("[motion]\nfeedd = 3\n", "feedd"),
        ];
        for (text, key) in cases {
            let e = err_of(text);
            assert!(e.contains(key), "expected `{key}` in: {e}");
        }
    }

    #[test]
    fn bad_friction_names_key() {
        let mut c = SimConfig::default();
        if let Some(f) = c.friction.as_mut() {
            f.components[2].order = 0.0;
        }
        let e = c.validate().unwrap_err().to_string();
        assert!(e.contains("friction.component[2].order"), "{e}");
        let mut c = SimConfig::default();
        if let Some(f) = c.friction.as_mut() {
            f.backward.bumps[0].width_mm = 0.0;
        }
        let e = c.validate().unwrap_err().to_string();
        assert!(e.contains("friction.backward.bump[0].width_mm"), "{e}");
    }
}
