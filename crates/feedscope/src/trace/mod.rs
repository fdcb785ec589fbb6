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
    /// What the recording's source said about it (an importer, a file's header).
    pub facts: RecordingFacts,
}

/// What the source of a recording knows about it and the samples alone cannot show: written
/// by `feedscope import` into the trace file (a `# fact KEY = VALUE` line per key in CSV,
/// `feedscope.fact.KEY` metadata in Parquet) so that every later step knows it. Every field is
/// optional; absent means unknown.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct RecordingFacts {
    /// Resolution of the effort as recorded, in its SI unit (A or N·m): e.g. a drive load
    /// reported in whole percent times the torque per percent. Key `effort_quantum`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub effort_quantum: Option<f64>,
    /// `Some(false)` when the effort is a magnitude (drive load readings usually are): the sign
    /// of friction then comes from the direction of motion. Key `effort_signed`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub effort_signed: Option<bool>,
    /// `Some(true)` when the recording is of production work, so the effort may hold process
    /// (cutting) load besides friction. Key `process_load`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub process_load: Option<bool>,
    /// Number of separate recordings the trace was pieced together from. Key `recordings`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub recordings: Option<usize>,
}

impl RecordingFacts {
    /// The facts as `(key, value)` text pairs, in a fixed order, for file headers.
    pub fn to_pairs(&self) -> Vec<(&'static str, String)> {
        let mut v = Vec::new();
        if let Some(q) = self.effort_quantum {
            v.push(("effort_quantum", format!("{q:e}")));
        }
        if let Some(b) = self.effort_signed {
            v.push(("effort_signed", b.to_string()));
        }
        if let Some(b) = self.process_load {
            v.push(("process_load", b.to_string()));
        }
        if let Some(n) = self.recordings {
            v.push(("recordings", n.to_string()));
        }
        v
    }

    /// Set one fact from its header text.
    ///
    /// # Errors
    /// A message naming the key and what it expects when the key is unknown or its value does
    /// not parse (a positive finite number, `true`/`false`, a positive count).
    pub fn set(&mut self, key: &str, value: &str) -> Result<(), String> {
        let value = value.trim();
        let bool_of = |v: &str| match v {
            "true" => Ok(true),
            "false" => Ok(false),
            _ => Err(format!("fact `{key}` must be true or false, not `{v}`")),
        };
        match key.trim() {
            "effort_quantum" => match value.parse::<f64>() {
                Ok(q) if q.is_finite() && q > 0.0 => self.effort_quantum = Some(q),
                _ => {
                    return Err(format!(
                        "fact `effort_quantum` must be a positive number, not `{value}`"
                    ))
                }
            },
            "effort_signed" => self.effort_signed = Some(bool_of(value)?),
            "process_load" => self.process_load = Some(bool_of(value)?),
            "recordings" => match value.parse::<usize>() {
                Ok(n) if n > 0 => self.recordings = Some(n),
                _ => {
                    return Err(format!(
                        "fact `recordings` must be a positive whole number, not `{value}`"
                    ))
                }
            },
            other => {
                return Err(format!(
                    "unknown fact `{other}` (known: effort_quantum, effort_signed, \
                     process_load, recordings)"
                ))
            }
        }
        Ok(())
    }
}
