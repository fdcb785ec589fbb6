//! An estimated stroke seen as a [`StrokeView`], the input of the profile and order analyses.
//! The conversion lives here, beside the owned type, so that [`crate::stroke`] depends on
//! nothing.

use super::StrokeFriction;
use crate::stroke::StrokeView;

impl<'a> StrokeView<'a> {
    /// View an estimated stroke ([`crate::estimate::StrokeFriction`]) for analysis.
    pub fn from_estimate(s: &'a StrokeFriction, lead_m: f64) -> Self {
        Self {
            direction: s.summary.direction,
            position_m: &s.position_m,
            friction_n: &s.friction_n,
            lead_m,
            max_trusted_order: s.summary.max_order,
            feed_mm_min: Some(s.summary.feed_mm_min),
        }
    }
}
