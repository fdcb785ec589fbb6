//! Identification from one triangular-wave test trace (steps 1-3 of the method in the
//! [module docs](super): kernel rows, sample selection, then the joint fit).

use std::f64::consts::PI;

use super::fit::fit_kernel;
use super::kernel::kernel_series;
use super::model::{ForceSide, Regressors, TorqueFit};
use super::{check_params, IdentError, IdentParams};
use crate::axis::AxisParams;
use crate::lugre::sign;
use crate::trace::{EffortKind, Trace};
use crate::units::{feed_m_s_to_mm_min, feed_mm_min_to_m_s};

/// Result of [`identify`]: the fit, its force-side view, the series for plotting and
/// diagnostics.
#[derive(Debug, Clone, PartialEq)]
pub struct Identification {
    /// The motor-side fit.
    pub fit: TorqueFit,
    /// The same on the table side.
    pub force: ForceSide,
    /// J_total the axis file predicts, J + m_t·(p/2π)² (kg·m²), for comparison; `None` when
    /// the file does not give `inertia_kgm2`.
    pub axis_j_total_kgm2: Option<f64>,
    /// Half-width of the hat kernel used (s): m sampling intervals.
    pub kernel_half_width_s: f64,
    /// Half-width of the hat kernel in samples, m.
    pub kernel_samples: usize,
    /// Reversal guard used (s).
    pub reversal_guard_s: f64,
    /// Mean position sampling interval (s).
    pub sample_interval_s: f64,
    /// Position samples in the trace.
    pub samples_total: usize,
    /// Times of the position samples (s).
    pub time_s: Vec<f64>,
    /// The kernel rows at those times: v̂, (2π/p)·ā and the hat-averaged torque (NaN within
    /// 2m samples of the ends).
    pub regressors: Regressors,
    /// Whether each sample was used in the fit.
    pub used: Vec<bool>,
    /// Model torque at each sample, hat-averaged like the measured one (N·m).
    pub computed_torque_nm: Vec<f64>,
    /// Things the user should know (unresolved v_s, large standard errors, …).
    pub warnings: Vec<String>,
}

/// Identify J, T_c, T_s, v_s, σ (and T_0) from one trace of position and torque or current.
///
/// The joint fit of steps 1-5 of the [module docs](super): every kernel row away from a
/// standstill or a reversal is used, including the whole acceleration phases, and J comes
/// with the friction parameters from one least-squares problem.
///
/// The effort channel may have its own timestamps: it is then interpolated linearly to the
/// position times (samples outside its span are not used).
///
/// `axis` is read for the lead, the torque constant (current traces) and, when the file gave
/// them, the inertia and table mass for [`Identification::axis_j_total_kgm2`]; an axis whose
/// `inertia_kgm2` is not finite (read with [`AxisParams::parse_for_identification`] from a
/// file without it) is fine.
///
/// # Errors
/// [`IdentError::NotIdentifiable`] when the trace has no reversal (both directions are needed
/// to separate friction from a constant torque), fewer than
/// [`IdentParams::min_speed_octaves`] speed octaves, or no acceleration; parameter errors.
pub fn identify(
    trace: &Trace,
    axis: &AxisParams,
    params: &IdentParams,
) -> Result<Identification, IdentError> {
    check_params(params)?;
    let tp = &trace.position_m.time_s;
    let n = tp.len();
    if n < 8 || trace.effort.len() < 8 {
        return Err(IdentError::NotIdentifiable {
            reason: format!(
                "too few samples ({n} position, {} effort; at least 8 each)",
                trace.effort.len()
            ),
        });
    }
    let h = (tp[n - 1] - tp[0]) / (n - 1) as f64;
    let kernel_s = params.kernel_half_width_s.unwrap_or(DEFAULT_KERNEL_S);
    let m = ((kernel_s / h).round() as usize).clamp(1, (n - 1) / 4);
    let guard = params.reversal_guard_s.unwrap_or(3.0 * m as f64 * h);
    let z = &trace.position_m.value;

    // Step 1: the torque at the position times (raw: the kernel does the averaging).
    let ke = match trace.effort_kind {
        EffortKind::CurrentA => axis.torque_constant_nm_per_a,
        EffortKind::TorqueNm => 1.0,
    };
    let te = &trace.effort.time_s;
    let synchronous = te == tp;
    let torque: Vec<f64> = if synchronous {
        trace.effort.value.iter().map(|e| e * ke).collect()
    } else {
        let ev = &trace.effort.value;
        tp.iter()
            .map(|&t| {
                // te[j − 1] ≤ t < te[j]; NaN outside the effort's span
                let j = te.partition_point(|&x| x <= t);
                if j == 0 {
                    f64::NAN
                } else if j == te.len() {
                    if t - te[j - 1] <= 0.0 {
                        ke * ev[j - 1]
                    } else {
                        f64::NAN
                    }
                } else {
                    let u = (t - te[j - 1]) / (te[j] - te[j - 1]);
                    ke * (ev[j - 1] + u * (ev[j] - ev[j - 1]))
                }
            })
            .collect()
    };

    // Step 2: central-difference velocity, divided-difference acceleration, hat averages.
    let ks = kernel_series(tp, z, m);
    let vel = &ks.velocity_m_s;
    let k_rad = 2.0 * PI / axis.lead_m();

    // Step 3: events that the friction model cannot follow: standstill (slower than the
    // minimum speed, or moving less than 1.5 position quanta over the difference window:
    // quantisation flicker) and sign changes of v̂. Rows within the guard of an event, or
    // whose support [k − 2m, k + 2m] holds one, are excluded.
    let quantum = position_quantum(z);
    let v_min = feed_mm_min_to_m_s(params.min_speed_mm_min);
    let mut event = vec![false; n];
    let mut event_times = Vec::new();
    for i in m..n.saturating_sub(m) {
        let slow = vel[i].abs() < v_min || (z[i + m] - z[i - m]).abs() < 1.5 * quantum;
        let flip = i > m && sign(vel[i]) * sign(vel[i - 1]) < 0.0;
        if slow {
            event_times.push(tp[i]);
        } else if flip {
            event_times.push(0.5 * (tp[i] + tp[i - 1]));
        }
        event[i] = slow || flip;
    }
    let mut events_before = vec![0usize; n + 1];
    for i in 0..n {
        events_before[i + 1] = events_before[i] + usize::from(event[i]);
    }
    // The rows are exact only where the acceleration is constant over the row's support
    // [k − 2m, k + 2m] (then the torque is linear between the samples the quadrature uses
    // and v̂ is the velocity at each sample); across the corner of a move they carry a
    // quadrature error of order J·Δθ''. Such rows are recognised by the hat accelerations
    // ā_j, j ∈ [k − m, k + m], differing by more than the quantisation noise of ā
    // (q·√(1/2)/(m·Δt)² for a quantum q, 8σ) or 1 % of the largest |ā|.
    let a_max = ks
        .accel_m_s2
        .iter()
        .filter(|a| a.is_finite())
        .fold(0.0f64, |x, a| x.max(a.abs()));
    let a_tol = (8.0 * quantum * 0.5f64.sqrt() / (m as f64 * h).powi(2)).max(0.01 * a_max);
    let accel_steady = |k: usize| {
        let w = &ks.accel_m_s2[k - m..=k + m];
        let (lo, hi) = w
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, u), &a| {
                (l.min(a), u.max(a))
            });
        hi - lo <= a_tol
    };
    let mut used = vec![false; n];
    let mut keep = Vec::new();
    for k in 3 * m..n.saturating_sub(3 * m) {
        let support_clear = events_before[k + 2 * m + 1] == events_before[k - 2 * m];
        let j = event_times.partition_point(|&t| t < tp[k] - guard);
        let guard_clear = event_times.get(j).is_none_or(|&t| t > tp[k] + guard);
        let finite =
            ks.accel_m_s2[k].is_finite() && torque[k - m..=k + m].iter().all(|x| x.is_finite());
        if support_clear && guard_clear && finite && accel_steady(k) {
            used[k] = true;
            keep.push(k);
        }
    }

    // Rows for the plot (all samples) and for the fit (used rows).
    let row_ok = |k: usize| k >= 2 * m && k + 2 * m < n;
    let torque_bar: Vec<f64> = ks
        .averaging
        .apply(
            &torque
                .iter()
                .map(|x| if x.is_finite() { *x } else { 0.0 })
                .collect::<Vec<_>>(),
        )
        .into_iter()
        .enumerate()
        .map(|(k, x)| {
            let finite = row_ok(k) && torque[k - m..=k + m].iter().all(|x| x.is_finite());
            if finite {
                x
            } else {
                f64::NAN
            }
        })
        .collect();
    let mut reg = Regressors::default();
    for k in 0..n {
        let (v, a) = if row_ok(k) {
            (vel[k], k_rad * ks.accel_m_s2[k])
        } else {
            (f64::NAN, f64::NAN)
        };
        reg.push(v, a, torque_bar[k]);
    }
    let mut sub = Regressors::default();
    for &k in &keep {
        sub.push(
            reg.velocity_m_s[k],
            reg.angular_accel_rad_s2[k],
            reg.torque_nm[k],
        );
    }
    check_excitation(&sub, params, guard, k_rad * a_max, h)?;

    // Steps 4-5: the joint separable fit on the kernel rows.
    let avg = ks.averaging.select(&keep);
    let fit = fit_kernel(
        sub.angular_accel_rad_s2.clone(),
        vel,
        &sub.torque_nm,
        &avg,
        params,
    )?;

    let friction: Vec<f64> = vel
        .iter()
        .map(|&v| {
            if v.is_finite() {
                fit.friction_torque_nm(v)
            } else {
                0.0
            }
        })
        .collect();
    let friction_bar = ks.averaging.apply(&friction);
    let computed: Vec<f64> = (0..n)
        .map(|k| {
            if row_ok(k) {
                fit.j_total_kgm2 * reg.angular_accel_rad_s2[k] + friction_bar[k]
            } else {
                f64::NAN
            }
        })
        .collect();
    let mut warnings = fit_warnings(&fit);
    if h > COARSE_SAMPLING_S {
        warnings.push(format!(
            "sampling at {:.1} Hz: an acceleration phase spans few samples and the {guard:.2} s              guard around every reversal removes most of them, so J is unreliable; sample at              80 Hz or more for J",
            1.0 / h
        ));
    }
    if !synchronous {
        warnings.push(
            "position and effort have different timestamps: the torque was interpolated to the \
             position times"
                .to_string(),
        );
    }
    let p = axis.lead_m();
    let axis_j = axis.inertia_kgm2 + axis.table_mass_kg * (p / (2.0 * PI)).powi(2);
    Ok(Identification {
        force: ForceSide::from_fit(&fit, p),
        fit,
        axis_j_total_kgm2: axis_j.is_finite().then_some(axis_j),
        kernel_half_width_s: m as f64 * h,
        kernel_samples: m,
        reversal_guard_s: guard,
        sample_interval_s: h,
        samples_total: n,
        time_s: tp.clone(),
        regressors: reg,
        used,
        computed_torque_nm: computed,
        warnings,
    })
}

/// Default kernel half-width (s): 10 ms, one sample at paper 002's 83.33 Hz; at kHz rates
/// several samples, which divides the quantisation noise of θ̄'' by m².
const DEFAULT_KERNEL_S: f64 = 0.010;

/// Sampling intervals above this (s) get the "J is unreliable" warning.
const COARSE_SAMPLING_S: f64 = 0.025;

/// The position quantum: the smallest non-zero step between consecutive samples (0 when the
/// positions are not quantised, i.e. no step repeats on a grid).
fn position_quantum(z: &[f64]) -> f64 {
    let q = z
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .filter(|&d| d > 1e-12)
        .fold(f64::INFINITY, f64::min);
    if q.is_finite() {
        q
    } else {
        0.0
    }
}

fn fit_warnings(fit: &TorqueFit) -> Vec<String> {
    let mut w = Vec::new();
    if fit.vs_at_bound {
        w.push(format!(
            "the Stribeck velocity ended at a bound of its search ({:.3} mm/min): the test does \
             not resolve it; slower or faster levels are needed",
            fit.vs_mm_min
        ));
    }
    if fit.ts_nm < fit.tc_nm {
        w.push("T_s < T_c: no Stribeck drop was found; v_s is meaningless".to_string());
    }
    let rel = |x: f64, se: f64| se > 0.5 * x.abs();
    if rel(fit.j_total_kgm2, fit.std_error.j_total_kgm2) {
        w.push("J has a standard error above 50 %: too little acceleration".to_string());
    }
    if rel(fit.vs_mm_min, fit.std_error.vs_mm_min) {
        w.push("v_s has a standard error above 50 %".to_string());
    }
    w
}

/// Reject data that cannot identify the model, with a reason a user can act on.
fn check_excitation(
    r: &Regressors,
    params: &IdentParams,
    guard_s: f64,
    accel_ref_rad_s2: f64,
    interval_s: f64,
) -> Result<(), IdentError> {
    let not = |reason: String| Err(IdentError::NotIdentifiable { reason });
    let n = r.len();
    if n < 20 {
        return not(format!(
            "only {n} samples remain after excluding speeds below {} mm/min and {guard_s:.3} s \
             around every slow sample (reversals, starts, stops); the strokes must cruise well \
             over {guard_s:.3} s: plan a longer --cruise-s, sample faster, or shorten the guard",
            params.min_speed_mm_min
        ));
    }
    let fwd = r.velocity_m_s.iter().filter(|&&v| v > 0.0).count();
    let bwd = n - fwd;
    if fwd.min(bwd) < 10 {
        return not(format!(
            "no motion reversal: {fwd} samples forward and {bwd} backward; friction and a \
             constant torque separate only when the axis moves both ways"
        ));
    }
    // Speed octaves that hold a real share of the samples.
    let mut bins = std::collections::BTreeMap::<i64, usize>::new();
    for v in &r.velocity_m_s {
        *bins
            .entry(feed_m_s_to_mm_min(v.abs()).log2().floor() as i64)
            .or_default() += 1;
    }
    let min_count = (n / 200).max(5);
    let octaves = bins.values().filter(|&&c| c >= min_count).count();
    if octaves < params.min_speed_octaves {
        return not(format!(
            "the speeds span only {octaves} octave(s) (at least {} needed): a Stribeck curve \
             cannot be fitted to one speed; run the test at several feeds",
            params.min_speed_octaves
        ));
    }
    // Rows that see the acceleration: |θ̄''| above a tenth of the largest in the whole trace
    // (not of the used rows, which may hold only quantisation noise).
    let busy = r
        .angular_accel_rad_s2
        .iter()
        .filter(|a| a.abs() > 0.1 * accel_ref_rad_s2)
        .count();
    if accel_ref_rad_s2.is_nan() || accel_ref_rad_s2 <= 0.0 || busy < 10 {
        return not(format!(
            "no usable acceleration: {busy} rows at constant acceleration away from reversals \
             (at least 10 needed), so the inertia J cannot be identified; at {:.1} Hz \
             sampling the acceleration phases must span several samples: sample at 80 Hz or \
             more, or lower the acceleration",
            1.0 / interval_s
        ));
    }
    Ok(())
}
