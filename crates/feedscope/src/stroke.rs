//! The words every analysis of a stroke shares: its [`Direction`] of travel and a borrowed
//! [`StrokeView`] of its friction on a uniform position grid.
//!
//! A *stroke* is one traverse of the axis at a steady feed in one direction, the unit in
//! which friction is estimated ([`crate::estimate`]), profiled ([`crate::profile`]), analysed
//! in screw orders ([`crate::order`]) and mapped over feed ([`crate::map`]). This module
//! depends on no other module of the crate, so each of those can use it without importing
//! the others.
//!
//! # Sign convention
//! Forward means increasing position. Friction is signed as in paper 000 Eq. 5: positive
//! while moving forward, negative while moving backward ([`Direction::sign`]).

use serde::{Deserialize, Serialize};

/// Direction of travel. Forward means increasing position.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Direction {
    /// Position increasing.
    Forward,
    /// Position decreasing.
    Backward,
}

impl Direction {
    /// Direction of a velocity: forward for v ≥ 0, backward for v < 0.
    pub fn of_velocity(velocity_m_s: f64) -> Self {
        if velocity_m_s < 0.0 {
            Self::Backward
        } else {
            Self::Forward
        }
    }

    /// +1 forward, −1 backward.
    pub fn sign(self) -> f64 {
        match self {
            Self::Forward => 1.0,
            Self::Backward => -1.0,
        }
    }

    /// `"forward"` or `"backward"`.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Forward => "forward",
            Self::Backward => "backward",
        }
    }
}

/// Friction of one stroke on a uniform position grid, borrowed: what the profile and order
/// analyses read. An estimated stroke ([`crate::estimate::StrokeFriction`], which owns its
/// arrays) is viewed with [`StrokeView::from_estimate`]; a friction CSV or a test builds one
/// from its own slices.
#[derive(Debug, Clone, Copy)]
pub struct StrokeView<'a> {
    /// Direction of travel.
    pub direction: Direction,
    /// Positions (m), uniformly spaced, increasing or decreasing.
    pub position_m: &'a [f64],
    /// Friction (N) at those positions, signed as in Eq. 5.
    pub friction_n: &'a [f64],
    /// Screw lead p (m).
    pub lead_m: f64,
    /// Highest order resolvable without aliasing: raw samples per lead / 2 (cycles per lead).
    pub max_trusted_order: f64,
    /// Feed of the stroke (mm/min) if known; used to phrase the aliasing advice.
    pub feed_mm_min: Option<f64>,
}
