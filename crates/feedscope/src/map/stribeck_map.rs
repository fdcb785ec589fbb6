//! Stribeck fits (Eq. 9) on the PPOCM values of every feed at chosen positions and along the
//! travel, and the spans of non-conventional behaviour.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::{DirectionMap, MapError, MapParams};
use crate::stribeck::{
    detect_nonconventional, NonConventional, StribeckFit, StribeckFitter, M_S_PER_MM_MIN,
};
use crate::stroke::Direction;

/// The Stribeck fit at one position.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StribeckAtPosition {
    /// Position (mm).
    pub position_mm: f64,
    /// The data points: |PPOCM(z)| at each feed of the profile (N).
    pub friction_n: Vec<f64>,
    /// The fit: the Stribeck curve, or the reduced model the feeds determine (see
    /// [`StribeckFit::model`]); `None` when it failed (see `error`).
    pub fit: Option<StribeckFit>,
    /// Non-conventional behaviour found at this position.
    pub nonconventional: Option<NonConventional>,
    /// Why the fit or the detection failed, if it did.
    pub error: Option<String>,
}

/// Stribeck fits along one direction.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StribeckProfile {
    /// Direction.
    pub direction: Direction,
    /// The measured feeds (mm/min), increasing.
    pub feeds_mm_min: Vec<f64>,
    /// One fit per requested position, in the order asked.
    pub positions: Vec<StribeckAtPosition>,
}

/// Fit Eq. 9 at each position (mm) of one direction's map, the data being the PPOCM of every
/// measured feed there (magnitudes). The fitter is planned once for the feeds.
///
/// # Errors
/// [`MapError::PositionOutside`] for a position outside the mapped span (checked before any
/// fit); [`MapError::Stribeck`] when the fit cannot be planned (e.g. bad settings). A fit that
/// fails at one position is reported in its [`StribeckAtPosition::error`].
pub fn stribeck_profile(
    map: &DirectionMap,
    positions_mm: &[f64],
    params: &MapParams,
) -> Result<StribeckProfile, MapError> {
    for &z in positions_mm {
        map.check_position(z)?;
    }
    let feeds = map.feeds_mm_min();
    let speeds: Vec<f64> = feeds.iter().map(|f| f * M_S_PER_MM_MIN).collect();
    let fitter = StribeckFitter::new(&speeds, &params.stribeck)?;
    let positions = positions_mm
        .par_iter()
        .map(|&z| {
            let friction_n: Vec<f64> = map
                .feeds
                .iter()
                .map(|g| g.ppocm.value_n(z * 1e-3).abs())
                .collect();
            let (fit, nonconventional, error) = match fitter.fit(&friction_n) {
                Ok(fit) => {
                    match detect_nonconventional(
                        &speeds,
                        &friction_n,
                        &fit,
                        &params.nonconventional,
                    ) {
                        Ok(nc) => (Some(fit), Some(nc), None),
                        Err(e) => (Some(fit), None, Some(e.to_string())),
                    }
                }
                Err(e) => (None, None, Some(e.to_string())),
            };
            StribeckAtPosition {
                position_mm: z,
                friction_n,
                fit,
                nonconventional,
                error,
            }
        })
        .collect();
    Ok(StribeckProfile {
        direction: map.direction,
        feeds_mm_min: feeds,
        positions,
    })
}

/// Positions next to each other (in the order of a profile) where friction falls with feed
/// beyond what the Stribeck curve predicts.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NonConventionalSpan {
    /// Direction.
    pub direction: Direction,
    /// First position of the span (mm).
    pub from_position_mm: f64,
    /// Last position of the span (mm).
    pub to_position_mm: f64,
    /// Positions of the profile in the span.
    pub positions: usize,
    /// Lowest feed where a fall starts in the span (mm/min).
    pub from_feed_mm_min: f64,
    /// Highest feed where a fall ends in the span (mm/min).
    pub to_feed_mm_min: f64,
    /// Largest drop in excess of the fitted curve's change (N).
    pub max_excess_drop_n: f64,
}

/// Gather the positions of a profile with non-conventional falls into spans of consecutive
/// positions (paper 000 Section 4.2.1, Figures 14-15).
pub fn nonconventional_spans(profile: &StribeckProfile) -> Vec<NonConventionalSpan> {
    let mut out: Vec<NonConventionalSpan> = Vec::new();
    let mut open = false;
    for p in &profile.positions {
        let ranges = p
            .nonconventional
            .as_ref()
            .map_or(&[][..], |n| &n.ranges[..]);
        if ranges.is_empty() {
            open = false;
            continue;
        }
        let lo = ranges
            .iter()
            .map(|r| r.from_mm_min())
            .fold(f64::INFINITY, f64::min);
        let hi = ranges.iter().map(|r| r.to_mm_min()).fold(0.0, f64::max);
        let ex = ranges.iter().map(|r| r.excess_drop_n).fold(0.0, f64::max);
        match out.last_mut() {
            Some(s) if open => {
                s.to_position_mm = p.position_mm;
                s.positions += 1;
                s.from_feed_mm_min = s.from_feed_mm_min.min(lo);
                s.to_feed_mm_min = s.to_feed_mm_min.max(hi);
                s.max_excess_drop_n = s.max_excess_drop_n.max(ex);
            }
            _ => out.push(NonConventionalSpan {
                direction: profile.direction,
                from_position_mm: p.position_mm,
                to_position_mm: p.position_mm,
                positions: 1,
                from_feed_mm_min: lo,
                to_feed_mm_min: hi,
                max_excess_drop_n: ex,
            }),
        }
        open = true;
    }
    out
}
