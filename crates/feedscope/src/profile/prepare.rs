//! Validation of a [`StrokeView`] and its normalised form: increasing position, u in leads
//! from the start, the step checked uniform.

use super::ProfileError;
use crate::stroke::StrokeView;

/// Minimum number of samples of a stroke.
pub const MIN_POINTS: usize = 16;

pub(super) fn check_finite(channel: &'static str, v: &[f64]) -> Result<(), ProfileError> {
    match v.iter().position(|x| !x.is_finite()) {
        Some(index) => Err(ProfileError::NonFinite { channel, index }),
        None => Ok(()),
    }
}

/// A validated stroke in increasing position, u = leads from the start.
pub(super) struct Prepared {
    pub(super) x0_mm: f64,
    pub(super) x1_mm: f64,
    pub(super) lead_mm: f64,
    /// Leads per sample.
    pub(super) du: f64,
    pub(super) u: Vec<f64>,
    pub(super) y: Vec<f64>,
}

impl Prepared {
    pub(super) fn to_mm(&self, u: f64) -> f64 {
        self.x0_mm + u * self.lead_mm
    }
    pub(super) fn to_u(&self, mm: f64) -> f64 {
        (mm - self.x0_mm) / self.lead_mm
    }
}

pub(super) fn prepare(s: &StrokeView<'_>) -> Result<Prepared, ProfileError> {
    let n = s.position_m.len();
    if n != s.friction_n.len() {
        return Err(ProfileError::LengthMismatch {
            position: n,
            friction: s.friction_n.len(),
        });
    }
    if n < MIN_POINTS {
        return Err(ProfileError::TooFewPoints {
            needed: MIN_POINTS,
            got: n,
        });
    }
    if !(s.lead_m.is_finite() && s.lead_m > 0.0) {
        return Err(ProfileError::InvalidParameter {
            name: "lead_m",
            value: s.lead_m,
            reason: "must be a finite number > 0",
        });
    }
    if s.max_trusted_order.is_nan() || s.max_trusted_order <= 0.0 {
        return Err(ProfileError::InvalidParameter {
            name: "max_trusted_order",
            value: s.max_trusted_order,
            reason: "must be > 0 (infinity means no limit)",
        });
    }
    check_finite("position_m", s.position_m)?;
    check_finite("friction_n", s.friction_n)?;
    let step = (s.position_m[n - 1] - s.position_m[0]) / (n - 1) as f64;
    if step.is_nan() || step == 0.0 {
        return Err(ProfileError::NotMonotonic { index: 1 });
    }
    if let Some(i) = (1..n).find(|&i| (s.position_m[i] - s.position_m[i - 1]) * step <= 0.0) {
        return Err(ProfileError::NotMonotonic { index: i });
    }
    for i in 1..n {
        let d = s.position_m[i] - s.position_m[i - 1];
        if (d - step).abs() > 1e-6 * step.abs() {
            return Err(ProfileError::NonUniformGrid {
                index: i,
                step_m: d,
                expected_m: step,
            });
        }
    }
    let reversed = step < 0.0;
    let mut y = s.friction_n.to_vec();
    let (x0, x1) = if reversed {
        y.reverse();
        (s.position_m[n - 1], s.position_m[0])
    } else {
        (s.position_m[0], s.position_m[n - 1])
    };
    let lead_mm = s.lead_m * 1e3;
    let du = step.abs() / s.lead_m;
    Ok(Prepared {
        x0_mm: x0 * 1e3,
        x1_mm: x1 * 1e3,
        lead_mm,
        du,
        u: (0..n).map(|i| i as f64 * du).collect(),
        y,
    })
}
