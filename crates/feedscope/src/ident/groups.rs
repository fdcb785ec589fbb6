//! The constant-speed comparison (paper 002 section 3.2): the same model fitted to the mean
//! friction of the strokes of a stroke test.

use std::f64::consts::PI;

use serde::{Deserialize, Serialize};

use super::fit::Separable;
use super::model::{Regressors, TorqueFit, TorqueStdError};
use super::{check_params, IdentError, IdentParams};
use crate::axis::AxisParams;
use crate::estimate::{estimate, Direction, EstimateParams};
use crate::lugre::sign;
use crate::trace::Trace;
use crate::units::{feed_m_s_to_mm_min, feed_mm_min_to_m_s};

/// One constant-speed group: the mean friction of one stroke of the traditional test.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Group {
    /// Stroke number in the trace.
    pub stroke: usize,
    /// Direction of travel.
    pub direction: Direction,
    /// Measured plateau feed (mm/min, unsigned).
    pub feed_mm_min: f64,
    /// Mean friction torque of the stroke, signed with the direction, bearing damping
    /// included so that it is comparable with the one-test σ (N·m).
    pub friction_torque_nm: f64,
}

/// The traditional identification (paper 002 Section 2.2.1): the same friction model fitted
/// to the mean friction of constant-speed strokes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GroupFit {
    /// The groups used.
    pub groups: Vec<Group>,
    /// The fit (J is not identified by constant-speed groups and is reported as 0).
    pub fit: TorqueFit,
}

/// Fit the friction model to constant-speed groups of a trace of idle strokes (paper 000's
/// test): each stroke's mean friction from [`crate::estimate::estimate`] at its feed.
///
/// Eq. 5 of paper 000 removes the bearing damping (4π²B/p²)·v from the friction; it is added
/// back so that σ means the same as in [`identify`](super::identify) (all viscous losses).
///
/// # Errors
/// Estimation errors; [`IdentError::NotIdentifiable`] with fewer than six groups, without
/// both directions, or with speeds spanning fewer than three distinct feeds.
pub fn fit_groups(
    trace: &Trace,
    axis: &AxisParams,
    params: &IdentParams,
    estimate_params: &EstimateParams,
) -> Result<GroupFit, IdentError> {
    check_params(params)?;
    let est = estimate(trace, axis, estimate_params)?;
    let to_torque = axis.lead_m() / (2.0 * PI);
    let b_eq = axis.equivalent_damping_n_s_per_m();
    let groups: Vec<Group> = est
        .strokes
        .iter()
        .map(|s| {
            let sgn = match s.summary.direction {
                Direction::Forward => 1.0,
                Direction::Backward => -1.0,
            };
            let v = feed_mm_min_to_m_s(sgn * s.summary.feed_mm_min);
            Group {
                stroke: s.summary.stroke,
                direction: s.summary.direction,
                feed_mm_min: s.summary.feed_mm_min,
                friction_torque_nm: (s.summary.mean_friction_n + b_eq * v) * to_torque,
            }
        })
        .collect();
    let mut r = Regressors::default();
    for g in &groups {
        let sgn = match g.direction {
            Direction::Forward => 1.0,
            Direction::Backward => -1.0,
        };
        r.push(
            feed_mm_min_to_m_s(sgn * g.feed_mm_min),
            0.0,
            g.friction_torque_nm,
        );
    }
    let fwd = r.velocity_m_s.iter().filter(|&&v| v > 0.0).count();
    let mut feeds: Vec<f64> = groups.iter().map(|g| g.feed_mm_min).collect();
    feeds.sort_by(f64::total_cmp);
    // Feeds within 5 % count as one speed.
    let distinct = feeds.windows(2).filter(|w| w[1] > 1.05 * w[0]).count() + 1;
    if groups.len() < 6 || fwd == 0 || fwd == groups.len() || distinct < 3 {
        return Err(IdentError::NotIdentifiable {
            reason: format!(
                "constant-speed groups: {} strokes ({fwd} forward) at {distinct} distinct \
                 feed(s); at least 6 strokes, both directions and 3 feeds are needed",
                groups.len()
            ),
        });
    }
    let mut fixed = vec![
        r.velocity_m_s
            .iter()
            .map(|&v| sign(v))
            .collect::<Vec<f64>>(),
        r.velocity_m_s.clone(),
    ];
    if params.fit_offset {
        fixed.push(vec![1.0; r.len()]);
    }
    let p = fixed.len() + 2;
    let sep = Separable {
        fixed,
        v: &r.velocity_m_s,
        y: &r.torque_nm,
        delta: params.delta,
        avg: None,
    };
    let (vs, sol, evals, at_bound) = sep.minimise(
        feed_mm_min_to_m_s(params.vs_min_mm_min),
        feed_mm_min_to_m_s(params.vs_max_mm_min),
        params.vs_grid_points,
    );
    let th = &sol.theta;
    let ds = th[th.len() - 1];
    let (cov, cond) = sep.covariance(vs, ds);
    let n = r.len();
    let s2 = if n > p {
        sol.rss / (n - p) as f64
    } else {
        f64::NAN
    };
    let var = |i: usize| (cov[(i, i)] * s2).max(0.0).sqrt();
    let ia = p - 2;
    let fit = TorqueFit {
        j_total_kgm2: 0.0,
        tc_nm: th[0],
        ts_nm: th[0] + ds,
        vs_mm_min: feed_m_s_to_mm_min(vs),
        sigma_nm_s_per_m: th[1],
        offset_nm: if params.fit_offset { th[2] } else { 0.0 },
        delta: params.delta,
        std_error: TorqueStdError {
            j_total_kgm2: 0.0,
            tc_nm: var(0),
            ts_nm: ((cov[(0, 0)] + cov[(ia, ia)] + 2.0 * cov[(0, ia)]) * s2)
                .max(0.0)
                .sqrt(),
            vs_mm_min: feed_m_s_to_mm_min(var(p - 1)),
            sigma_nm_s_per_m: var(1),
            offset_nm: if params.fit_offset { var(2) } else { 0.0 },
        },
        residual_rms_nm: (sol.rss / n as f64).sqrt(),
        condition_number: cond,
        iterations: evals,
        samples_used: n,
        vs_at_bound: at_bound,
    };
    Ok(GroupFit { groups, fit })
}
