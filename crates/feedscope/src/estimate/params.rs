//! Estimation settings: how t(z) is found, how the position is smoothed, how the effort is
//! signed, and their defaults.

use serde::{Deserialize, Serialize};

#[cfg(doc)]
use super::{estimate_pieces_streaming, floor, moves};
use super::{ProgrammedMove, SegmentParams};
use crate::spline::EndCondition;
use crate::trace::Trace;
use crate::verdict::FrictionSign;

/// How the run time t(z) of step 3 is obtained.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TimeOfPosition {
    /// Invert the position spline z(t) exactly (default).
    #[default]
    Invert,
    /// Interpolate the knots (z_k, t_k) with a spline, as the paper does.
    KnotSpline,
}

/// How the position is prepared for differentiation (see [`floor`]).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PositionSmoothing {
    /// Chosen per stroke from its samples (default): the interpolating spline of paper 000
    /// when it is quiet enough, else a Reinsch smoother whose cut-off (Hz) balances the
    /// position noise against the effort noise and the settling time ([`floor`]).
    #[default]
    Auto,
    /// A Reinsch smoother with this cut-off (Hz) on every stroke that samples above it.
    CutoffHz(f64),
    /// Always the interpolating spline (paper 000).
    Off,
}

/// Whether the effort carries its sign (see [`crate::verdict::FrictionSign`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum EffortSign {
    /// As the trace's facts say ([`crate::trace::RecordingFacts::effort_signed`]); signed when
    /// they say nothing (with a warning when a never-negative effort suggests a magnitude).
    #[default]
    Auto,
    /// Signed current or torque: friction as Eq. 5.
    Signed,
    /// A magnitude (a drive load reading): friction takes the sign of the direction of motion.
    Magnitude,
    /// A signed current or torque counted against the position (negative for motion towards
    /// +z, as some drives record it): its sign is turned, then friction as Eq. 5.
    Negated,
}

/// Estimation settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EstimateParams {
    /// Resampling points per lead, m (the position step is p/m). Default 1024.
    pub samples_per_lead: u32,
    /// Spline end condition. Default not-a-knot.
    pub end_condition: EndCondition,
    /// How t(z) is obtained. Default: exact inversion.
    pub time_of_position: TimeOfPosition,
    /// Position smoothing before differentiation. Default: chosen per stroke.
    pub position_smoothing: PositionSmoothing,
    /// Whether the effort carries its sign. Default: [`EffortSign::Auto`].
    pub effort_sign: EffortSign,
    /// Also estimate the steady parts of rapids and jogs (marked with their kind). Default
    /// false: only measuring strokes are estimated.
    pub include_rapids: bool,
    /// The NC program's motion blocks, when known: they label the moves (see [`moves`]).
    #[serde(skip)]
    pub program: Vec<ProgrammedMove>,
    /// Stroke segmentation.
    pub segment: SegmentParams,
    /// Knots a spline is solved over at once: a longer stroke is solved in overlapping windows
    /// ([`crate::spline::smoothing_moments_windowed`]), equal to the whole solve to rounding,
    /// so that its work arrays stay bounded. Default [`crate::spline::DEFAULT_WINDOW_KNOTS`].
    /// A stroke with more position samples than this is also handed out in pieces of
    /// [`piece_points`](Self::piece_points) rows by [`estimate_pieces_streaming`].
    #[serde(skip, default = "default_window_knots")]
    pub spline_window_knots: usize,
    /// Resampled rows per piece of a long stroke ([`estimate_pieces_streaming`]). Default
    /// 2¹⁴ (about 1.3 MB of CSV text per piece).
    #[serde(skip, default = "default_piece_points")]
    pub piece_points: usize,
}

fn default_window_knots() -> usize {
    crate::spline::DEFAULT_WINDOW_KNOTS
}

fn default_piece_points() -> usize {
    1 << 14
}

impl Default for EstimateParams {
    fn default() -> Self {
        Self {
            samples_per_lead: 1024,
            end_condition: EndCondition::NotAKnot,
            time_of_position: TimeOfPosition::Invert,
            position_smoothing: PositionSmoothing::Auto,
            effort_sign: EffortSign::Auto,
            include_rapids: false,
            program: Vec::new(),
            segment: SegmentParams::default(),
            spline_window_knots: default_window_knots(),
            piece_points: default_piece_points(),
        }
    }
}

/// How the friction of `trace` gets its sign under `params`.
pub fn friction_sign(trace: &Trace, params: &EstimateParams) -> FrictionSign {
    let magnitude = match params.effort_sign {
        EffortSign::Signed | EffortSign::Negated => false,
        EffortSign::Magnitude => true,
        EffortSign::Auto => trace.facts.effort_signed == Some(false),
    };
    if magnitude {
        FrictionSign::FromDirection
    } else {
        FrictionSign::Signed
    }
}
