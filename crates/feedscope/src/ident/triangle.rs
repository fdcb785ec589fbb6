//! Identification from one triangular-wave test trace (steps 1-3 of the method in the
//! [module docs](super): smoothing, differentiation, sample selection, then the fit).

use std::f64::consts::PI;

use super::fit::fit_torque;
use super::model::{ForceSide, Regressors, TorqueFit};
use super::{check_params, IdentError, IdentParams};
use crate::axis::AxisParams;
use crate::lugre::sign;
use crate::spline::{alpha_for_cutoff, smoothing_moments, CubicSpline};
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
    /// J_total the axis file predicts, J + m_t·(p/2π)² (kg·m²), for comparison.
    pub axis_j_total_kgm2: f64,
    /// Smoothing cut-off used (Hz).
    pub cutoff_hz: f64,
    /// Reversal guard used (s).
    pub reversal_guard_s: f64,
    /// Mean position sampling interval (s).
    pub sample_interval_s: f64,
    /// Position samples in the trace.
    pub samples_total: usize,
    /// Times of the position samples (s).
    pub time_s: Vec<f64>,
    /// The smoothed regressors at those times.
    pub regressors: Regressors,
    /// Whether each sample was used in the fit.
    pub used: Vec<bool>,
    /// Model torque at each sample (N·m).
    pub computed_torque_nm: Vec<f64>,
    /// Things the user should know (unresolved v_s, large standard errors, …).
    pub warnings: Vec<String>,
}

/// Smoothed values and their first and second derivatives at the knots of one channel.
struct Smoothed {
    value: Vec<f64>,
    d1: Vec<f64>,
    d2: Vec<f64>,
}

fn smooth(
    t: &[f64],
    y: &[f64],
    cutoff_hz: f64,
    channel: &'static str,
) -> Result<Smoothed, IdentError> {
    let h = (t[t.len() - 1] - t[0]) / (t.len() - 1) as f64;
    // At or above ~0.4·f_sample the smoother would not smooth: interpolate.
    let alpha = if cutoff_hz * h >= 0.4 {
        0.0
    } else {
        alpha_for_cutoff(h, cutoff_hz)
    };
    let mut g = Vec::new();
    let m = smoothing_moments(t, y, alpha, &mut g)
        .map_err(|error| IdentError::Spline { channel, error })?;
    let s = CubicSpline::from_moments(t, &g, m)
        .map_err(|error| IdentError::Spline { channel, error })?;
    let mut v = Vec::with_capacity(t.len());
    let mut a = Vec::with_capacity(t.len());
    let mut val = Vec::with_capacity(t.len());
    let mut cur = s.cursor();
    for &tk in t {
        let (z, d1, d2) = cur.eval_all(tk);
        val.push(z);
        v.push(d1);
        a.push(d2);
    }
    Ok(Smoothed {
        value: val,
        d1: v,
        d2: a,
    })
}

/// Identify J, T_c, T_s, v_s, σ (and T_0) from one trace of position and torque or current.
///
/// The effort channel may have its own timestamps: it is smoothed on its own knots and read
/// at the position times (samples outside its span are not used).
///
/// # Errors
/// [`IdentError::NotIdentifiable`] when the trace has no reversal (both directions are needed
/// to separate friction from a constant torque), fewer than
/// [`IdentParams::min_speed_octaves`] speed octaves, or no acceleration; parameter and spline
/// errors.
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
    let cutoff = params
        .cutoff_hz
        .unwrap_or_else(|| (30.0f64).min(1.0 / (8.0 * h)));
    let guard = params.reversal_guard_s.unwrap_or(1.5 / cutoff);

    // Step 1: velocity and acceleration from the smoothed position.
    let Smoothed {
        d1: vel, d2: acc, ..
    } = smooth(tp, &trace.position_m.value, cutoff, "position")?;
    // Step 2: the torque through the same smoother.
    let ke = match trace.effort_kind {
        EffortKind::CurrentA => axis.torque_constant_nm_per_a,
        EffortKind::TorqueNm => 1.0,
    };
    let te = &trace.effort.time_s;
    let torque_raw: Vec<f64> = trace.effort.value.iter().map(|e| e * ke).collect();
    let torque_s = smooth(te, &torque_raw, cutoff, "torque")?.value;
    let synchronous = te == tp;
    let mut torque = vec![f64::NAN; n];
    if synchronous {
        torque.copy_from_slice(&torque_s);
    } else {
        let s = CubicSpline::new(te, &torque_s, crate::spline::EndCondition::NotAKnot).map_err(
            |error| IdentError::Spline {
                channel: "torque",
                error,
            },
        )?;
        let mut c = s.cursor();
        for (k, &t) in tp.iter().enumerate() {
            if t >= te[0] && t <= te[te.len() - 1] {
                torque[k] = c.eval(t);
            }
        }
    }

    let k_rad = 2.0 * PI / axis.lead_m();
    let mut reg = Regressors::default();
    for k in 0..n {
        reg.push(vel[k], k_rad * acc[k], torque[k]);
    }

    // Step 3: exclude slow samples and those near them (reversals, starts, stops) and the
    // spline's end regions.
    let v_min = feed_mm_min_to_m_s(params.min_speed_mm_min);
    let slow: Vec<bool> = vel.iter().map(|v| v.abs() < v_min).collect();
    let mut used = vec![true; n];
    let mut last_slow = f64::NEG_INFINITY;
    for k in 0..n {
        if slow[k] {
            last_slow = tp[k];
        }
        if tp[k] - last_slow < guard {
            used[k] = false;
        }
    }
    let mut next_slow = f64::INFINITY;
    for k in (0..n).rev() {
        if slow[k] {
            next_slow = tp[k];
        }
        if next_slow - tp[k] < guard
            || tp[k] - tp[0] < guard
            || tp[n - 1] - tp[k] < guard
            || !torque[k].is_finite()
        {
            used[k] = false;
        }
    }
    // A sign change between two samples without a slow sample (fast reversal at coarse
    // sampling) is guarded too.
    for k in 1..n {
        // (Slow samples are guarded already; skipping them keeps a noisy standstill cheap.)
        if !slow[k] && !slow[k - 1] && sign(vel[k]) * sign(vel[k - 1]) < 0.0 {
            let tr = 0.5 * (tp[k] + tp[k - 1]);
            let lo = tp.partition_point(|&t| t < tr - guard);
            let hi = tp.partition_point(|&t| t <= tr + guard);
            used[lo..hi].iter_mut().for_each(|u| *u = false);
        }
    }

    let mut sub = Regressors::default();
    for k in (0..n).filter(|&k| used[k]) {
        sub.push(
            reg.velocity_m_s[k],
            reg.angular_accel_rad_s2[k],
            reg.torque_nm[k],
        );
    }
    check_excitation(&sub, params, guard, true)?;

    // Step 4-5.
    let mut fit = fit_torque(&sub, params)?;
    let used_time: f64 = (1..n)
        .filter(|&k| used[k] && used[k - 1])
        .map(|k| tp[k] - tp[k - 1])
        .sum();
    let n_eff = (2.0 * cutoff * used_time).max(8.0);
    let inflate = (sub.len() as f64 / n_eff).max(1.0).sqrt();
    let se = &mut fit.std_error;
    for x in [
        &mut se.j_total_kgm2,
        &mut se.tc_nm,
        &mut se.ts_nm,
        &mut se.vs_mm_min,
        &mut se.sigma_nm_s_per_m,
        &mut se.offset_nm,
    ] {
        *x *= inflate;
    }

    let computed: Vec<f64> = (0..n)
        .map(|k| fit.torque_nm(reg.velocity_m_s[k], reg.angular_accel_rad_s2[k]))
        .collect();
    let mut warnings = fit_warnings(&fit);
    if cutoff < 5.0 {
        warnings.push(format!(
            "the smoothing cut-off is {cutoff:.2} Hz (sampling {:.1} Hz): acceleration phases \
             shorter than the {guard:.2} s guard are excluded or smeared, so J is unreliable; \
             sample at 80 Hz or more for J",
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
        axis_j_total_kgm2: axis_j,
        cutoff_hz: cutoff,
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
    need_accel: bool,
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
    if need_accel {
        let amax = r
            .angular_accel_rad_s2
            .iter()
            .fold(0.0f64, |m, a| m.max(a.abs()));
        let busy = r
            .angular_accel_rad_s2
            .iter()
            .filter(|a| a.abs() > 0.1 * amax)
            .count();
        if amax <= 0.0 || busy < 10 {
            return not(
                "no acceleration in the used samples: the inertia J cannot be identified"
                    .to_string(),
            );
        }
    }
    Ok(())
}
