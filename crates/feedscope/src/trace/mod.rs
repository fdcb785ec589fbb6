//! Controller traces: axis position and servo effort (motor current or torque), each channel
//! with its own timestamps.
//!
//! Inside the library every value is SI: time in seconds, position in metres, current in
//! amperes, torque in newton-metres. This module holds the traces in memory and screens their
//! position for logger glitches ([`glitch`]); reading and writing trace files (CSV and Parquet,
//! the two layouts, the checks every reader ends with) is the crate `feedscope-io`
//! (`feedscope_io::trace`).
//!
//! # Position glitches
//! Every reader of `feedscope-io` ends by screening the position for samples that imply a speed
//! the axis cannot reach ([`screen_position`]): above [`GlitchParams::max_axis_speed_m_s`],
//! 200 m/min by default, or 1.25 × the axis' `rapid_rate_mm_min` with
//! [`GlitchParams::for_axis`]. Allowing either time stamp to be off by one typical sampling
//! interval and 10 µm of quantisation, a sample must jump by more than about v_lim × 3 sampling
//! intervals to count. A run of 1-3 samples that jumps away and back (a logger glitch such as
//! `1e308`) is dropped; a jump that does not come back (re-homing, recordings joined) is
//! refused. The effort channel is not screened: current and torque jump legitimately
//! (acceleration, reversal, saturation) and the axis description gives no bound for them.

pub mod glitch;
pub use glitch::{screen_position, GlitchParams};

/// Fewest samples a channel needs (a not-a-knot cubic needs four knots).
pub const MIN_SAMPLES: usize = 4;

/// What the effort channel measures.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EffortKind {
    /// Servo motor torque current (A); friction needs the torque constant k_e.
    CurrentA,
    /// Motor torque (N·m); k_e is not used.
    TorqueNm,
}

impl EffortKind {
    /// The column / channel name used in files.
    pub fn column(self) -> &'static str {
        match self {
            Self::CurrentA => "current_a",
            Self::TorqueNm => "torque_nm",
        }
    }
}

/// One sampled channel: strictly increasing times and the values taken at them.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Channel {
    /// Sample times (s), strictly increasing.
    pub time_s: Vec<f64>,
    /// Sample values in the channel's SI unit.
    pub value: Vec<f64>,
}

impl Channel {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.time_s.len()
    }

    /// True when the channel holds no sample.
    pub fn is_empty(&self) -> bool {
        self.time_s.is_empty()
    }
}

/// A trace of one axis: position and effort, each with its own timestamps.
#[derive(Debug, Clone, PartialEq)]
pub struct Trace {
    /// Table position (m).
    pub position_m: Channel,
    /// Motor current (A) or torque (N·m), see [`Trace::effort_kind`].
    pub effort: Channel,
    /// What [`Trace::effort`] measures.
    pub effort_kind: EffortKind,
}
