//! Identification from one triangular-wave test trace (steps 1-3 of the method in the
//! [module docs](super): kernel rows, sample selection, then the joint fit).

use std::f64::consts::PI;

use super::fit::fit_kernel;
use super::kernel::kernel_series;
use super::model::{ForceSide, Regressors, TorqueFit};
use super::{check_params, IdentError, IdentParams};
use crate::axis::AxisParams;
use crate::diag::{Code, Diagnostic};
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
    pub warnings: Vec<Diagnostic>,
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
    // The median interval, not the mean over the span: a recording with gaps (pieces of
    // several runs) would otherwise get a kernel and a guard of too few samples, and its
    // refusals would quote a rate it was never sampled at.
    let h = crate::trace::glitch::median_step(tp);
    if !(h.is_finite() && h > 0.0) {
        return Err(IdentError::NotIdentifiable {
            reason: format!("the position times do not increase (median interval {h} s)"),
        });
    }
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
    // The rows are exact for any motion except where the acceleration steps faster than the
    // sampling resolves (the corner of a trapezoidal ramp): there the torque quadrature errs
    // by up to J·Δθ''/(2m). Smooth ramps (jerk-limited S-curves, bell/cosine) keep their
    // rows; only rows whose quadrature spans a detected step are excluded (`kernel.rs`,
    // `acceleration_steps`).
    let a_max = ks
        .accel_m_s2
        .iter()
        .filter(|a| a.is_finite())
        .fold(0.0f64, |x, a| x.max(a.abs()));
    let steps = acceleration_steps(&ks.accel_m_s2, m, a_max);
    let mut near_step = vec![false; n];
    // the curvature correction below reads ā at k ± m, whose hats reach k ± 2m
    let mut near_step_wide = vec![false; n];
    for &j in &steps.at {
        near_step[j.saturating_sub(m + 1)..(j + m + 2).min(n)].fill(true);
        near_step_wide[j.saturating_sub(3 * m + 1)..(j + 3 * m + 2).min(n)].fill(true);
    }
    let mut clear_rows = Vec::new();
    for k in 3 * m..n.saturating_sub(3 * m) {
        let support_clear = events_before[k + 2 * m + 1] == events_before[k - 2 * m];
        let j = event_times.partition_point(|&t| t < tp[k] - guard);
        let guard_clear = event_times.get(j).is_none_or(|&t| t > tp[k] + guard);
        let finite =
            ks.accel_m_s2[k].is_finite() && torque[k - m..=k + m].iter().all(|x| x.is_finite());
        if support_clear && guard_clear && finite {
            clear_rows.push(k);
        }
    }
    let busy = |rows: &[usize]| {
        rows.iter()
            .filter(|&&k| ks.accel_m_s2[k].abs() > BUSY_FRACTION * a_max)
            .count()
    };
    let smooth_rows: Vec<usize> = clear_rows
        .iter()
        .copied()
        .filter(|&k| !near_step[k])
        .collect();
    // Rows across a step are not used even when that leaves too few: with ramps of a few
    // samples (70 ms polling of 0.2 s ramps) the rows clear of the reversal guard are all
    // at the ramp's outer corner, and their errors do not average out (J −17 % on the twin).
    let keep = smooth_rows;
    let mut used = vec![false; n];
    for &k in &keep {
        used[k] = true;
    }
    let selection = Selection {
        busy_in_trace: (2 * m..n.saturating_sub(2 * m))
            .filter(|&k| ks.accel_m_s2[k].abs() > BUSY_FRACTION * a_max)
            .count(),
        busy_clear: busy(&clear_rows),
        busy_kept: busy(&keep),
        steps: steps.at.len(),
        longest_phase_s: longest_accel_phase_s(tp, &ks.accel_m_s2, vel, BUSY_FRACTION * a_max),
        accel_max_m_s2: a_max,
        guard_s: guard,
        m,
        interval_s: h,
    };

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
    // The torque side is a quadrature of samples (and, for an effort channel on its own
    // clock, of samples interpolated linearly to the position times); both read a curved
    // torque too high by c_k·T'' to leading order, which biases J low by c·Σȧ²/Σā² (8 % for
    // bell ramps of 0.4 s polled every 70 ms). The same c_k applied to the acceleration's
    // curvature puts that error on the regressor's side, where it belongs: the row compares
    // like with like. Rows at a step keep the bare ā (a step has no curvature to speak of).
    let interp_err: Vec<f64> = if synchronous {
        vec![0.0; n]
    } else {
        tp.iter()
            .map(|&t| {
                let j = te.partition_point(|&x| x <= t);
                if j == 0 || j == te.len() {
                    0.0
                } else {
                    let he = te[j] - te[j - 1];
                    let d = (t - te[j - 1]) / he;
                    0.5 * d * (1.0 - d) * he * he
                }
            })
            .collect()
    };
    let interp_c = ks.averaging.apply(&interp_err);
    let accel_row = |k: usize| -> f64 {
        let a = &ks.accel_m_s2;
        if near_step_wide[k] || k < 3 * m || k + 3 * m >= n {
            return a[k];
        }
        let (t0, t1, t2) = (tp[k - m], tp[k], tp[k + m]);
        let curvature =
            2.0 * ((a[k + m] - a[k]) / (t2 - t1) - (a[k] - a[k - m]) / (t1 - t0)) / (t2 - t0);
        // quadrature part: Σ over the support's intervals of M_k(mid)·d³/12
        let height = 2.0 / (t2 - t0);
        let mut quad = 0.0;
        for i in k - m..k + m {
            let d = tp[i + 1] - tp[i];
            let mid = 0.5 * (tp[i] + tp[i + 1]);
            let hat = if mid <= t1 {
                height * (mid - t0) / (t1 - t0)
            } else {
                height * (t2 - mid) / (t2 - t1)
            };
            quad += hat * d * d * d / 12.0;
        }
        let c = quad + interp_c[k];
        if curvature.is_finite() {
            a[k] + c * curvature
        } else {
            a[k]
        }
    };
    let mut reg = Regressors::default();
    for k in 0..n {
        let (v, a) = if row_ok(k) {
            (vel[k], k_rad * accel_row(k))
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
    check_excitation(&sub, params, &selection)?;

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
        warnings.push(Diagnostic::new(
            Code::CoarseSampling,
            format!(
            "sampling every {:.0} ms: J rests on {} accelerating rows from acceleration phases \
             of up to {:.0} ms; its standard error says how well",
            1e3 * h,
            selection.busy_kept,
            1e3 * selection.longest_phase_s
        ),
        ));
    }
    if !synchronous {
        warnings.push(Diagnostic::new(
            Code::EffortInterpolated,
            "position and effort have different timestamps: the torque was interpolated to the \
             position times",
        ));
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

/// Sampling intervals above this (s) get a warning naming the rows J rests on.
const COARSE_SAMPLING_S: f64 = 0.025;

/// A row sees the acceleration when its |ā| exceeds this fraction of the largest.
const BUSY_FRACTION: f64 = 0.1;

/// Fewest rows that see the acceleration for J to be identified.
const MIN_BUSY_ROWS: usize = 10;

/// A step of the acceleration smaller than this fraction of the largest |ā| is not excluded:
/// its rows err by at most a twentieth of the largest inertia torque over m. A quarter let
/// the servo's transients after a trapezoid's corner through (paper 002's twin at 83 Hz:
/// J's SE doubled by the residual they left); smooth ramps stay below a tenth down to bell
/// ramps of 0.2 s at 83 Hz.
const STEP_FRACTION: f64 = 0.1;

/// What the row selection found, for the refusal and the warnings.
#[derive(Debug, Clone, Copy)]
struct Selection {
    /// Rows in the whole trace with |ā| above a tenth of the largest.
    busy_in_trace: usize,
    /// Of those, rows clear of standstills, reversals and their guard.
    busy_clear: usize,
    /// Of those, rows used in the fit.
    busy_kept: usize,
    /// Acceleration steps found.
    steps: usize,
    /// Longest run of accelerating samples in one direction (s).
    longest_phase_s: f64,
    /// Largest |ā| (m/s²).
    accel_max_m_s2: f64,
    /// Reversal guard (s).
    guard_s: f64,
    /// Kernel half-width (samples).
    m: usize,
    /// Mean sampling interval (s).
    interval_s: f64,
}

/// Steps of the acceleration that the sampling does not resolve.
#[derive(Debug, Clone, Default, PartialEq)]
struct Steps {
    /// Sample index nearest each step.
    at: Vec<usize>,
}

/// Find the steps of the acceleration in the hat averages ā (half-width m samples).
///
/// A step of size Δa at t_j makes ā rise over the 2m samples around j, while a ramp of
/// any smoothness that lasts several kernel widths makes ā vary smoothly. The combination
///
/// S_j = [3·(ā_{j+m} − ā_{j−m}) − (ā_{j+3m} − ā_{j−3m})] / 2
///
/// is 0 for an acceleration linear in time (a jerk phase), about −4·(m·Δt)³·z'''' for a
/// smooth one (a bell ramp lasting 0.2 s sampled at 83 Hz: about a tenth of its peak), and
/// Δa at a step (with side lobes of −Δa/2 at ±2m). A step is a local extreme of |S| over ±2m
/// samples (which suppresses the side lobes) above max(8 σ_S, [`STEP_FRACTION`]·max|ā|), σ_S
/// the scatter of S over the whole trace (1.4826·MAD: quantisation and encoder noise).
fn acceleration_steps(accel: &[f64], m: usize, accel_max: f64) -> Steps {
    let n = accel.len();
    let mut s = vec![f64::NAN; n];
    for j in 3 * m..n.saturating_sub(3 * m) {
        let (a, b, c, d) = (
            accel[j + m],
            accel[j - m],
            accel[j + 3 * m],
            accel[j - 3 * m],
        );
        s[j] = 0.5 * (3.0 * (a - b) - (c - d));
    }
    let mut abs: Vec<f64> = s
        .iter()
        .filter(|x| x.is_finite())
        .map(|x| x.abs())
        .collect();
    if abs.is_empty() {
        return Steps::default();
    }
    let mid = abs.len() / 2;
    let mad = *abs.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1;
    let threshold = (8.0 * 1.4826 * mad).max(STEP_FRACTION * accel_max);
    let mut at = Vec::new();
    for j in 0..n {
        let x = s[j].abs();
        // NaN (ends of the trace) is never a step
        if x.is_nan() || x <= threshold {
            continue;
        }
        let lo = j.saturating_sub(2 * m);
        let hi = (j + 2 * m).min(n - 1);
        // the first of equal extremes wins, so a flat top gives one step
        let is_peak = (lo..=hi).all(|i| {
            let y = s[i].abs();
            y.is_nan() || y < x || (y <= x && i >= j)
        });
        if is_peak {
            at.push(j);
        }
    }
    Steps { at }
}

/// Longest run of consecutive samples with |ā| above `level` and v̂ of one sign (s).
fn longest_accel_phase_s(t: &[f64], accel: &[f64], vel: &[f64], level: f64) -> f64 {
    let mut best = 0.0f64;
    let mut start: Option<usize> = None;
    for i in 0..t.len() {
        let busy = accel[i].abs() > level && vel[i].is_finite();
        let same = start.is_some_and(|s| sign(vel[s]) * sign(vel[i]) > 0.0);
        start = match (busy, start) {
            (true, Some(s)) if same => Some(s),
            (true, _) => Some(i),
            (false, _) => None,
        };
        if let Some(s) = start {
            best = best.max(t[i] - t[s]);
        }
    }
    best
}

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

fn fit_warnings(fit: &TorqueFit) -> Vec<Diagnostic> {
    let mut w = Vec::new();
    if fit.vs_at_bound {
        w.push(Diagnostic::new(
            Code::VsAtBound,
            format!(
            "the Stribeck velocity ended at a bound of its search ({:.3} mm/min): the test does \
             not resolve it; slower or faster levels are needed",
            fit.vs_mm_min
        ),
        ));
    }
    if fit.ts_nm < fit.tc_nm {
        w.push(Diagnostic::new(
            Code::NoStribeckDrop,
            "T_s < T_c: no Stribeck drop was found; v_s is meaningless",
        ));
    }
    let rel = |x: f64, se: f64| se > 0.5 * x.abs();
    if rel(fit.j_total_kgm2, fit.std_error.j_total_kgm2) {
        w.push(Diagnostic::new(
            Code::PoorlyIdentified,
            "J has a standard error above 50 %: too little acceleration",
        ));
    }
    if rel(fit.vs_mm_min, fit.std_error.vs_mm_min) {
        w.push(Diagnostic::new(
            Code::PoorlyIdentified,
            "v_s has a standard error above 50 %",
        ));
    }
    w
}

/// Reject data that cannot identify the model, with the figures that decide it.
fn check_excitation(
    r: &Regressors,
    params: &IdentParams,
    sel: &Selection,
) -> Result<(), IdentError> {
    let not = |reason: String| Err(IdentError::NotIdentifiable { reason });
    let n = r.len();
    let guard_s = sel.guard_s;
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
    // Rows that see the acceleration: |ā| above a tenth of the largest in the whole trace
    // (not of the used rows, which may hold only quantisation noise).
    if sel.accel_max_m_s2.is_finite() && sel.busy_kept >= MIN_BUSY_ROWS {
        return Ok(());
    }
    let h = sel.interval_s;
    let m = sel.m;
    let phase_ms = 1e3 * sel.longest_phase_s;
    let head = format!(
        "no usable acceleration: {} rows see the acceleration (|ā| above a tenth of the \
         largest, {:.3} m/s²; at least {MIN_BUSY_ROWS} needed), so the inertia J cannot be \
         identified. The trace has {} such rows; {} of them lie within {guard_s:.3} s of a \
         reversal or standstill or hold one within their support of ±{} samples, {} more \
         span one of the {} steps of the acceleration found. The longest acceleration phase in one direction \
         lasts {phase_ms:.0} ms ({:.1} samples at {:.1} Hz)",
        sel.busy_kept,
        sel.accel_max_m_s2,
        sel.busy_in_trace,
        sel.busy_in_trace - sel.busy_clear,
        2 * m,
        sel.busy_clear - sel.busy_kept,
        sel.steps,
        sel.longest_phase_s / h,
        1.0 / h
    );
    // A row needs its support (±2m samples) and the guard clear of the reversal: the phase
    // must outlast both by a few samples to give rows.
    let needed_s = guard_s.max(2.0 * m as f64 * h) + 2.0 * h;
    let advice = if sel.busy_in_trace < MIN_BUSY_ROWS {
        "; the test hardly accelerates: reversals at the axis's acceleration limit are needed"
            .to_string()
    } else if sel.longest_phase_s <= needed_s {
        // with m = 1 and the default guard of 3 samples a phase needs 5 samples to give a
        // row, 8 to give a few
        let rate_hz = 8.0 / sel.longest_phase_s.max(1e-9);
        let mut a = format!(
            "; a row needs {:.0} ms of acceleration clear of a reversal: plan gentler ramps \
             (a lower acceleration, so that each lasts over {:.0} ms)",
            1e3 * needed_s,
            1e3 * needed_s
        );
        if rate_hz > 1.0 / h {
            a.push_str(&format!(" or sample at {rate_hz:.0} Hz or more"));
        } else if params.reversal_guard_s.is_some() {
            a.push_str(" or shorten --guard-s");
        }
        a
    } else {
        format!(
            "; the acceleration phases outlast the {:.0} ms a row needs, but too few of them \
             do: add reversals (more levels or cycles)",
            1e3 * needed_s
        )
    };
    not(format!("{head}{advice}"))
}
