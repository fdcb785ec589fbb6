//! One stroke from its samples to friction on the position grid (steps 1-7): the splines,
//! the grid walk with the t(z) inversion, Eq. 5 and the stroke's summary and warnings.

use super::inversion::Solve;
use super::{
    floor, friction_sign, transient, Direction, EffortSign, EstimateError, EstimateParams,
    MoveKind, NoiseFloor, PositionSmoothing, Skip, StrokeFriction, StrokeOutcome, StrokeSpan,
    StrokeSummary, TimeOfPosition,
};
use crate::axis::AxisParams;
use crate::diag::{Code, Diagnostic};
use crate::spline::{CubicSpline, Piece, PieceTable};
use crate::trace::{EffortKind, Trace};
use crate::verdict::{judge_stroke, FrictionSign, StrokeEvidence};

/// Grid points a stroke may always have: 2^22 (200 MB of results), 4096 leads at 1024 points
/// per lead, e.g. 4 m of a 1 mm lead, however sparsely it was sampled.
pub const MAX_GRID_POINTS_FLOOR: usize = 1 << 22;
/// Beyond the floor, grid points allowed per position sample (a stroke of 10 M samples may
/// have 41 G points' worth of travel only if that many samples justify it).
pub const MAX_GRID_POINTS_PER_SAMPLE: usize = 4096;

/// Force per unit of effort (N per A or N per N·m), Eq. 5's first term.
fn effort_gain(axis: &AxisParams, kind: EffortKind) -> f64 {
    match kind {
        EffortKind::CurrentA => axis.force_per_torque_n_per_nm() * axis.torque_constant_nm_per_a,
        EffortKind::TorqueNm => axis.force_per_torque_n_per_nm(),
    }
}

/// RMS of the values about their mean.
fn rms_about_mean(v: &[f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    (v.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / v.len() as f64).sqrt()
}

/// A stroke's mean friction is resolved when it lies more than this many standard errors from
/// zero (about 95 % two-sided); otherwise the stroke gets the `mean-not-resolved` warning.
pub const MEAN_RESOLVED_SE: f64 = 2.0;

/// Standard error of the mean of `n` effort samples of robust noise `std` and quantum `q`, in
/// the effort's unit (see [`StrokeSummary::mean_friction_se_n`]): the noise over √n, and the
/// rounding's bias that the dither σ_d² = std² − q²/12 leaves. Under Gaussian dither the mean
/// rounding error's k-th harmonic falls as exp(−2π²k²σ_d²/q²); its first, scaled to the
/// undithered q/√12, bounds the bias: at σ_d = q/2 it is 0.7 % of q/√12.
///
/// A quantum the recording declares (`declared_q`, e.g. a drive load in whole percent) keeps
/// its full q/√12: how the drive rounds (to nearest, or down) is not known, so its bias is
/// not assumed to average out.
fn mean_se(std: f64, q: f64, declared_q: f64, n: usize) -> f64 {
    let noise = std * std / n.max(1) as f64;
    let declared = declared_q * declared_q / 12.0;
    if q <= 0.0 {
        return (noise + declared).sqrt();
    }
    let dither = (std * std - q * q / 12.0).max(0.0);
    let bias = q * q / 12.0 * (-4.0 * std::f64::consts::PI.powi(2) * dither / (q * q)).exp();
    (noise + bias.max(declared)).sqrt()
}

/// Estimate one stroke (step 1-7), with the position treatment chosen from its samples
/// ([`floor`]).
///
/// # Errors
/// Spline failures and non-finite results.
pub fn estimate_stroke(
    trace: &Trace,
    axis: &AxisParams,
    params: &EstimateParams,
    index: usize,
    span: &StrokeSpan,
) -> Result<StrokeOutcome, EstimateError> {
    estimate_stroke_pieces(trace, axis, params, index, span, usize::MAX, &mut |_| {
        unreachable!("no piece is handed out when a stroke is kept whole")
    })
}

/// As [`estimate_stroke`], but handing the resampled rows to `emit` in pieces of
/// `piece_points` rows while the stroke is estimated, so that a long stroke's results need
/// not be held whole. The pieces' summaries are provisional (stroke number, direction, feed,
/// noise floor); the returned stroke holds the rows after the last piece (at least one) and
/// the complete summary, with its mean and scatter over every row.
///
/// # Errors
/// As [`estimate_stroke`], or what `emit` returns.
pub fn estimate_stroke_pieces<E: From<EstimateError>>(
    trace: &Trace,
    axis: &AxisParams,
    params: &EstimateParams,
    index: usize,
    span: &StrokeSpan,
    piece_points: usize,
    emit: &mut dyn FnMut(StrokeFriction) -> Result<(), E>,
) -> Result<StrokeOutcome, E> {
    let pos = &trace.position_m;
    let ts = &pos.time_s[span.first..=span.last];
    let zs_raw = &pos.value[span.first..=span.last];
    let (t_lo, t_hi) = (ts[0], ts[ts.len() - 1]);
    let te_all = &trace.effort.time_s;
    let e0 = te_all.partition_point(|&t| t < t_lo);
    let e1 = te_all.partition_point(|&t| t <= t_hi);
    if e1 < e0 + crate::trace::MIN_SAMPLES {
        return Ok(StrokeOutcome::Skipped(Skip::TooFewEffortSamples));
    }
    let lead = axis.lead_m();
    let m_eq = axis.equivalent_mass_kg();
    let b_eq = axis.equivalent_damping_n_s_per_m();
    let gain = effort_gain(axis, trace.effort_kind);
    let dir = span.direction;
    let s = dir.sign();
    // A magnitude takes the sign of the motion; the noise terms use |gain|.
    let force_gain = match friction_sign(trace, params) {
        FrictionSign::Signed if params.effort_sign == EffortSign::Negated => -gain,
        FrictionSign::Signed => gain,
        FrictionSign::FromDirection => gain * s,
    };

    // What the stroke's own samples say about their noise (floor module, step 1).
    let h = (t_hi - t_lo) / (ts.len() - 1) as f64;
    let ee_span = &trace.effort.value[e0..e1];
    // The effort's resolution: what its samples show, or what the recording declares (a whole
    // percent of load rounds however the signal moves), whichever is coarser.
    let effort_std = floor::robust_noise_std(&te_all[e0..e1], ee_span);
    let effort_step = floor::smallest_step(ee_span);
    let effort_q_seen = floor::quantum_from_step(ee_span, effort_step);
    // A coarse quantum can hold a whole steady stroke on one value, which shows no step: the
    // steps are then seen in the ramps of the enclosing move (turning point to turning point).
    let (m0, m1) = (pos.time_s[span.move_first], pos.time_s[span.move_last]);
    let ev = &trace.effort.value;
    let (f0, f1) = (
        te_all.partition_point(|&t| t < m0),
        te_all.partition_point(|&t| t <= m1),
    );
    // The move's smallest step: the stroke's, and those of the move's parts before and after
    // it (not a second pass over the stroke).
    let move_step = if f0 <= e0 && e1 <= f1 {
        effort_step
            .min(floor::smallest_step(&ev[f0..=e0]))
            .min(floor::smallest_step(&ev[e1 - 1..f1]))
    } else {
        floor::smallest_step(&ev[f0..f1])
    };
    let effort_q_move = floor::quantum_from_step(&ev[f0..f1], move_step);
    let effort_q = effort_q_seen
        .max(effort_q_move)
        .max(trace.facts.effort_quantum.unwrap_or(0.0));
    let effort_var = (effort_std * effort_std).max(effort_q * effort_q / 12.0);
    let noise = floor::SampleNoise {
        interval_s: h,
        position_var_m2: floor::channel_variance(ts, zs_raw),
        effort_n: gain * effort_var.sqrt(),
    };
    let interp_quant = floor::interpolated_quantisation_n(m_eq, noise.position_var_m2, h);
    let choice = match params.position_smoothing {
        PositionSmoothing::Auto => {
            floor::choose(&noise, m_eq, gain * rms_about_mean(ee_span), t_hi - t_lo)
        }
        PositionSmoothing::CutoffHz(f) if f > 0.0 && f < 0.5 / h => {
            floor::Differentiation::Smooth {
                cutoff_hz: f,
                quantisation_n: floor::smoothed_quantisation_n(m_eq, noise.position_var_m2, h, f),
            }
        }
        _ => floor::Differentiation::Interpolate {
            quantisation_n: interp_quant,
        },
    };
    let (cutoff_hz, quantisation_n) = match choice {
        floor::Differentiation::Interpolate { quantisation_n } => (None, quantisation_n),
        floor::Differentiation::Smooth {
            cutoff_hz,
            quantisation_n,
        } => (Some(cutoff_hz), quantisation_n),
    };

    // The smoother reaches a settling margin beyond the stroke on both sides (never across a
    // reversal), so that its natural ends lie outside the output.
    let (tau, margin_s) = match cutoff_hz {
        Some(f) => {
            let tau = floor::settle_time_constant_s(f);
            (tau, floor::SETTLE_TIME_CONSTANTS * tau)
        }
        None => (0.0, 0.0),
    };
    let extra = if cutoff_hz.is_some() {
        (margin_s / h).ceil() as usize + 2
    } else {
        0
    };
    let k0 = span.first.saturating_sub(extra).max(span.move_first);
    let k1 = (span.last + extra).min(span.move_last).max(span.last);
    let tz = &pos.time_s[k0..=k1];
    let zz = &pos.value[k0..=k1];
    let spline_err = |error| EstimateError::Spline {
        stroke: index,
        channel: "position",
        error,
    };
    let mut z_smooth = Vec::new();
    // A long stroke's smoothed position is solved one window at a time as it is read (the
    // t(z) inversion walks forward), so its values and moments are never held whole; the
    // paper's knot spline for t(z) needs them all at once.
    let windowed = tz.len() > params.spline_window_knots
        && params.time_of_position == TimeOfPosition::Invert
        && tz.len() >= 3;
    let mut zs = match cutoff_hz {
        Some(f_c) if windowed => {
            let h_w = (tz[tz.len() - 1] - tz[0]) / (tz.len() - 1) as f64;
            let alpha = crate::spline::alpha_for_cutoff(h_w, f_c);
            PositionSpline::Windowed(
                crate::spline::WindowedSmoothing::new(tz, zz, alpha, params.spline_window_knots)
                    .map_err(spline_err)?,
            )
        }
        Some(f_c) => {
            let h_w = (tz[tz.len() - 1] - tz[0]) / (tz.len() - 1) as f64;
            let alpha = crate::spline::alpha_for_cutoff(h_w, f_c);
            let m = crate::spline::smoothing_moments_windowed(
                tz,
                zz,
                alpha,
                params.spline_window_knots,
                &mut z_smooth,
            )
            .map_err(spline_err)?;
            PositionSpline::Whole(CubicSpline::from_moments(tz, &z_smooth, m).map_err(spline_err)?)
        }
        None => PositionSpline::Whole(
            CubicSpline::new_windowed(tz, zz, params.end_condition, params.spline_window_knots)
                .map_err(spline_err)?,
        ),
    };

    // Output window: the stroke, and with smoothing only where the ramps have settled.
    let (mut w_lo, mut w_hi) = (t_lo, t_hi);
    let mut inertia_n = 0.0;
    if cutoff_hz.is_some() {
        let n = ts.len() - 1;
        let (q1, q3) = (n / 4, 3 * n / 4);
        let v_mid = s * (zs_raw[q3] - zs_raw[q1]) / (ts[q3] - ts[q1]).max(1e-300);
        // The ramps end where the speed reaches 98 % of the feed held after them: the middle
        // half's mean at a steady feed; where the feed varies along the stroke (a feed
        // override, a modulated feed: its range beyond ±25 %), the fastest quarter of the
        // stroke's first (last) eighth, so that a later change of the feed moves neither end.
        let varies = span.feed_min_m_s < 0.75 * v_mid || span.feed_max_m_s > 1.25 * v_mid;
        let (reach_a, reach_b) = if varies && n >= 32 {
            let mean =
                |a: usize, b: usize| s * (zs_raw[b] - zs_raw[a]) / (ts[b] - ts[a]).max(1e-300);
            let e = n / 8;
            let fastest = |start: usize| {
                (0..4)
                    .map(|k| mean(start + k * e / 4, start + (k + 1) * e / 4))
                    .fold(f64::NEG_INFINITY, f64::max)
            };
            (0.98 * fastest(0), 0.98 * fastest(n - e))
        } else {
            (0.98 * v_mid, 0.98 * v_mid)
        };
        let (i_first, i_last) = (span.first - k0, span.last - k0);
        let mut speed = |i: usize| s * zs.eval_in(i.min(tz.len() - 2), tz[i]).1;
        let ramp_end = (i_first..=i_last).find(|&i| speed(i) >= reach_a);
        let decel_start = (i_first..=i_last).rev().find(|&i| speed(i) >= reach_b);
        let (Some(i_a), Some(i_b)) = (ramp_end, decel_start) else {
            return Ok(StrokeOutcome::Skipped(Skip::TooShortToSettle {
                left_mm: 0.0,
                margin_s,
            }));
        };
        w_lo = tz[i_a] + margin_s;
        w_hi = tz[i_b] - margin_s;
        let left_mm = (w_hi - w_lo) * v_mid * 1e3;
        if w_hi <= w_lo || left_mm < params.segment.min_stroke_mm {
            return Ok(StrokeOutcome::Skipped(Skip::TooShortToSettle {
                left_mm: left_mm.max(0.0),
                margin_s,
            }));
        }
        // The largest jerk of the smoothed ramps, whose transient the margin lets decay to
        // e^(−N): m_eq·j·τ·e^(−N) at the window's edges, spread over it as an RMS.
        let n_m = tz.len();
        let mut jerk = |range: std::ops::Range<usize>| {
            range
                .map(|i| ((zs.moment(i + 1) - zs.moment(i)) / (tz[i + 1] - tz[i])).abs())
                .fold(0.0, f64::max)
        };
        let j = jerk(0..i_a.min(n_m - 1)).max(jerk(i_b.min(n_m - 1)..n_m - 1));
        let edge = m_eq * j * tau * (-floor::SETTLE_TIME_CONSTANTS).exp();
        inertia_n = edge * (tau / (w_hi - w_lo)).min(1.0).sqrt();
    }
    // Effort knots over the whole spline window: no extrapolation of either channel, and the
    // effort spline's ends outside the output too.
    let e0 = te_all.partition_point(|&t| t < tz[0]);
    let e1 = te_all.partition_point(|&t| t <= tz[tz.len() - 1]);
    let te = &te_all[e0..e1];
    let ee = &trace.effort.value[e0..e1];
    // A long stroke's effort spline is solved one window at a time as the grid walks forward
    // (its moments would otherwise be held whole); a short one at once.
    let effort_err = |error| EstimateError::Spline {
        stroke: index,
        channel: trace.effort_kind.column(),
        error,
    };
    let es_whole;
    let mut effort_at = if te.len() > params.spline_window_knots {
        EffortEval::Windowed(
            crate::spline::WindowedSpline::new(
                te,
                ee,
                params.end_condition,
                params.spline_window_knots,
            )
            .map_err(effort_err)?,
        )
    } else {
        es_whole = CubicSpline::new(te, ee, params.end_condition).map_err(effort_err)?;
        EffortEval::Whole(es_whole.cursor())
    };
    w_lo = w_lo.max(te[0]);
    w_hi = w_hi.min(te[te.len() - 1]);
    let step = lead / f64::from(params.samples_per_lead);
    // Position range covered by the window, on the spline (exact at knots, else evaluated).
    let (z_a, z_b) = (zs.eval(w_lo), zs.eval(w_hi));
    // Grid indices strictly inside [z_a, z_b] in the direction of travel.
    let (k_first, k_last): (i64, i64) = match dir {
        Direction::Forward => ((z_a / step).ceil() as i64, (z_b / step).floor() as i64),
        Direction::Backward => ((z_a / step).floor() as i64, (z_b / step).ceil() as i64),
    };
    // Bound the grid before allocating six arrays of it: positions in µm read as mm, or a
    // lead of 1e-5 mm, would ask for gigabytes from a few kilobytes of trace.
    let points = ((z_b - z_a).abs() / step).floor() + 1.0;
    let limit = MAX_GRID_POINTS_FLOOR.max(MAX_GRID_POINTS_PER_SAMPLE * ts.len());
    if points.is_nan() || points > limit as f64 {
        return Err(EstimateError::GridTooLarge {
            stroke: index,
            length_mm: (z_b - z_a).abs() * 1e3,
            lead_mm: axis.lead_mm,
            samples_per_lead: params.samples_per_lead,
            points,
            samples: ts.len(),
            limit,
        }
        .into());
    }
    let count = ((k_last - k_first) as f64 * s) as i64 + 1;
    let mut warnings = Vec::new();
    if count < 2 {
        return Ok(StrokeOutcome::Skipped(Skip::TooFewEffortSamples));
    }
    let count = count as usize;
    let feed_m_s = span.plateau_speed_m_s;
    let mut out = StrokeFriction {
        summary: StrokeSummary {
            stroke: index,
            kind: MoveKind::Measuring,
            direction: dir,
            feed_mm_min: feed_m_s * 60e3,
            feed_min_mm_min: Some(span.feed_min_m_s * 60e3),
            feed_max_mm_min: Some(span.feed_max_m_s * 60e3),
            start_mm: 0.0,
            end_mm: 0.0,
            length_mm: 0.0,
            start_time_s: 0.0,
            end_time_s: 0.0,
            mean_friction_n: 0.0,
            friction_std_n: 0.0,
            position_samples: ts.len(),
            effort_samples: ee_span.len(),
            points: count,
            raw_samples_per_lead: 0.0,
            max_order: 0.0,
            position_cutoff_hz: cutoff_hz,
            position_cutoff_order: cutoff_hz.map(|f| f * lead / feed_m_s),
            settle_margin_s: margin_s,
            noise_floor: NoiseFloor::new(quantisation_n, noise.effort_n, inertia_n),
            mean_friction_se_n: Some(
                gain * mean_se(
                    effort_std,
                    effort_q,
                    trace.facts.effort_quantum.unwrap_or(0.0),
                    ee_span.len(),
                ),
            ),
            effort_quantum_n: gain * effort_q,
            verdict: None,
            program_line: None,
            programmed_feed_mm_min: None,
            warnings: Vec::new(),
        },
        position_m: Vec::new(),
        time_s: Vec::new(),
        velocity_m_s: Vec::new(),
        accel_m_s2: Vec::new(),
        effort: Vec::new(),
        friction_n: Vec::new(),
    };
    // Rows held at once: the whole stroke, or a piece and the block being filled.
    let held = if count > piece_points {
        piece_points + 256
    } else {
        count
    };
    for col in out.columns_mut() {
        col.reserve_exact(held);
    }
    // Rows already handed out, the first row's position and time, and the scatter of their
    // friction about the first value (shifted sums: the mean is not known until the end).
    let mut emitted = 0usize;
    let mut first_row = None;
    let (mut shift, mut s1, mut s2) = (0.0, 0.0, 0.0);
    // t(z) by the paper's knot spline, when asked for: a spline through (s·z_k, t_k), since its
    // abscissae must increase for either direction.
    let knot_x: Vec<f64> = match params.time_of_position {
        TimeOfPosition::Invert => Vec::new(),
        TimeOfPosition::KnotSpline => (0..tz.len()).map(|k| s * zs.value(k)).collect(),
    };
    let knot_spline = match params.time_of_position {
        TimeOfPosition::Invert => None,
        TimeOfPosition::KnotSpline => Some(
            CubicSpline::new(&knot_x, tz, params.end_condition).map_err(|error| {
                EstimateError::Spline {
                    stroke: index,
                    channel: "t(z)",
                    error,
                }
            })?,
        ),
    };
    let knot_cursor = knot_spline.as_ref().map(|k| k.cursor());
    let k_int = zs.interval(w_lo);
    let mut walk = GridWalk {
        k_first: k_first as f64,
        s,
        step,
        w_lo,
        w_hi,
        force_gain,
        m_eq,
        b_eq,
        knot_cursor,
        k_int,
        non_monotone: false,
        t_prev: w_lo,
        sum: 0.0,
    };
    // The six columns are filled a block at a time in arrays on the stack, each block then
    // appended with one copy per column: six pushes per point re-read and re-stored six
    // lengths and checked six capacities, a sizeable share of the loop's instructions.
    let mut cols = [[0.0f64; BLOCK]; 6];
    // Feed changes inside the stroke faster than the smoothing resolves (`transient`).
    let mut transients = cutoff_hz.map(|fc| {
        transient::TransientScan::new(m_eq, out.summary.noise_floor.total_n, fc, feed_m_s)
    });
    // The cubics of the knot intervals a block spans (see `GridWalk::invert`).
    let mut table = PieceTable::new();
    let mut j0 = 0;
    while j0 < count {
        let len = BLOCK.min(count - j0);
        let (block, sc) = (&mut cols, &mut *table);
        // One loop per kind of spline, chosen once a block (see `KnotRead`).
        let filled = match (&mut zs, &mut effort_at) {
            (PositionSpline::Whole(z), EffortEval::Whole(e)) => walk.fill(z, e, j0, len, block, sc),
            (PositionSpline::Whole(z), EffortEval::Windowed(e)) => {
                walk.fill(z, e, j0, len, block, sc)
            }
            (PositionSpline::Windowed(z), EffortEval::Whole(e)) => {
                walk.fill(z, e, j0, len, block, sc)
            }
            (PositionSpline::Windowed(z), EffortEval::Windowed(e)) => {
                walk.fill(z, e, j0, len, block, sc)
            }
        };
        if let Err(zg) = filled {
            return Err(EstimateError::NonFinite {
                stroke: index,
                quantity: "friction_n",
                position_mm: zg * 1e3,
            }
            .into());
        }
        if let Some(scan) = &mut transients {
            scan.push(&cols[0][..len], &cols[2][..len], &cols[3][..len]);
        }
        for (col, dst) in cols.iter().zip(out.columns_mut()) {
            dst.extend_from_slice(&col[..len]);
        }
        j0 += len;
        if out.friction_n.len() >= piece_points && j0 < count {
            if first_row.is_none() {
                first_row = Some((out.position_m[0], out.time_s[0]));
                shift = out.friction_n[0];
            }
            for f in &out.friction_n {
                let d = f - shift;
                s1 += d;
                s2 += d * d;
            }
            let mut piece = StrokeFriction {
                summary: out.summary.clone(),
                position_m: Vec::new(),
                time_s: Vec::new(),
                velocity_m_s: Vec::new(),
                accel_m_s2: Vec::new(),
                effort: Vec::new(),
                friction_n: Vec::new(),
            };
            for (src, dst) in out.columns_mut().into_iter().zip(piece.columns_mut()) {
                *dst = std::mem::replace(src, Vec::with_capacity(held));
            }
            emitted += piece.friction_n.len();
            emit(piece)?;
        }
    }
    if let (Some(scan), Some(fc)) = (transients, cutoff_hz) {
        let found = scan.finish();
        if !found.is_empty() {
            warnings.push(feed_changes_unresolved(&found, fc, feed_m_s, s));
        }
    }
    if walk.non_monotone {
        warnings.push(Diagnostic::new(
            Code::PositionNotMonotone,
            "the position spline is not monotone somewhere in this stroke (noisy or coarsely \
             quantised position at a low feed); t(z) took the nearest solution",
        ));
    }
    let mean = walk.sum / count as f64;
    let var = if emitted == 0 {
        out.friction_n
            .iter()
            .map(|f| (f - mean) * (f - mean))
            .sum::<f64>()
            / count as f64
    } else {
        for f in &out.friction_n {
            let d = f - shift;
            s1 += d;
            s2 += d * d;
        }
        let m1 = s1 / count as f64;
        (s2 / count as f64 - m1 * m1).max(0.0)
    };
    let (z_first, t_first) = first_row.unwrap_or((out.position_m[0], out.time_s[0]));
    let tail = out.friction_n.len();
    let (z_last, t_last) = (out.position_m[tail - 1], out.time_s[tail - 1]);
    let travel = (z_last - z_first).abs();
    // Raw samples per lead of each channel over the stroke.
    let mut z_span = |a: f64, b: f64| (zs.eval(b) - zs.eval(a)).abs().max(1e-12);
    let spl_z =
        (ts.len() - 1) as f64 * lead / (zs_raw[zs_raw.len() - 1] - zs_raw[0]).abs().max(1e-12);
    let spl_e = (te.len() - 1) as f64 * lead / z_span(te[0], te[te.len() - 1]);
    let spl = spl_z.min(spl_e);
    let sm = &mut out.summary;
    sm.start_mm = z_first * 1e3;
    sm.end_mm = z_last * 1e3;
    sm.length_mm = travel * 1e3;
    sm.start_time_s = t_first;
    sm.end_time_s = t_last;
    sm.mean_friction_n = mean;
    sm.friction_std_n = var.sqrt();
    sm.raw_samples_per_lead = spl;
    sm.max_order = spl / 2.5;
    if let Some(se) = sm.mean_friction_se_n {
        // Within two standard errors of zero the stroke says nothing about its friction, not
        // even its sign: the table would print it like any other mean.
        if mean.is_nan() || mean.abs() <= MEAN_RESOLVED_SE * se {
            warnings.push(Diagnostic::new(
                Code::MeanNotResolved,
                format!(
                    "the mean friction {mean:.2} N lies within {MEAN_RESOLVED_SE} standard \
                     errors ({se:.2} N) of zero: this stroke does not resolve its friction \
                     (the effort varies along it far more than friction does: process load, \
                     or too few samples for its noise)"
                ),
            ));
        }
    }
    let feed_mm_min = feed_m_s * 60e3;
    if spl < 8.0 {
        warnings.push(Diagnostic::new(
            Code::FewSamplesPerLead,
            format!(
                "only {spl:.1} raw samples per lead: fluctuation above order {:.1} cannot be \
             trusted; sample faster or feed slower (below {:.0} mm/min for 8 samples per lead)",
                spl / 2.5,
                feed_mm_min * spl / 8.0
            ),
        ));
    }
    if let Some(order) = sm.position_cutoff_order {
        if order < sm.max_order {
            sm.max_order = order;
            let (highest, cause) = highest_expected_order(axis);
            if order < highest {
                warnings.push(Diagnostic::new(
                    Code::PositionSmoothedBelowOrder,
                    format!(
                        "the position is smoothed above {:.1} Hz, order {order:.1} at this feed: \
                     the table acceleration of higher orders is not resolved, so their \
                     amplitudes lack the inertia term ({cause} at order {highest:.1} is among \
                     them); finer position quanta, faster sampling or a slower feed resolve more",
                        sm.position_cutoff_hz.unwrap_or(0.0)
                    ),
                ));
            }
        }
    }
    // The floor against the variation it has to be seen against: friction_std² holds both.
    let fl = sm.noise_floor;
    let variation = (sm.friction_std_n.powi(2) - fl.total_n.powi(2))
        .max(0.0)
        .sqrt();
    if fl.total_n > 0.1 * variation {
        // With no variation left above the floor a percentage means nothing.
        let share = if variation > 1e-3 * fl.total_n {
            format!(
                "is {:.0} % of the friction variation along this stroke ({variation:.2} N RMS)",
                100.0 * fl.total_n / variation
            )
        } else {
            "holds all of the friction variation along this stroke".to_string()
        };
        warnings.push(Diagnostic::new(
            Code::NoiseFloorHigh,
            format!(
                "predicted noise floor {:.2} N RMS (position quantisation {:.2}, effort noise \
             {:.2}, inertia {:.2}) {share}: the profile is only good to about ±{:.1} N",
                fl.total_n,
                fl.quantisation_n,
                fl.effort_n,
                fl.inertia_n,
                2.0 * fl.total_n
            ),
        ));
    }
    sm.verdict = Some(judge_stroke(&StrokeEvidence {
        length_leads: travel / lead,
        max_order: sm.max_order,
        floor_n: fl.total_n,
        mean_n: mean,
        process_load: trace.facts.process_load == Some(true),
    }));
    sm.warnings = warnings;
    Ok(StrokeOutcome::Estimated(Box::new(out)))
}

/// The position spline of a stroke as the estimator reads it: held whole, or (a long stroke's
/// smoothed position) solved one window at a time as it is read.
enum PositionSpline<'a> {
    Whole(CubicSpline<'a>),
    Windowed(crate::spline::WindowedSmoothing<'a>),
}

impl<'a> PositionSpline<'a> {
    #[inline(always)]
    fn value(&mut self, k: usize) -> f64 {
        match self {
            Self::Whole(s) => s.y()[k],
            Self::Windowed(w) => w.value(k),
        }
    }

    fn moment(&mut self, k: usize) -> f64 {
        match self {
            Self::Whole(s) => s.moments()[k],
            Self::Windowed(w) => w.moment(k),
        }
    }

    #[inline]
    fn eval_in(&mut self, k: usize, t: f64) -> (f64, f64, f64) {
        match self {
            Self::Whole(s) => s.eval_in(k, t),
            Self::Windowed(w) => w.eval_in(k, t),
        }
    }

    fn interval(&self, t: f64) -> usize {
        match self {
            Self::Whole(s) => s.interval(t),
            Self::Windowed(w) => w.interval(t),
        }
    }

    fn eval_all(&mut self, t: f64) -> (f64, f64, f64) {
        let k = self.interval(t);
        self.eval_in(k, t)
    }

    fn eval(&mut self, t: f64) -> f64 {
        self.eval_all(t).0
    }
}

/// The effort spline of a stroke as the grid loop reads it.
enum EffortEval<'s, 'a> {
    Whole(crate::spline::Cursor<'s, 'a>),
    Windowed(crate::spline::WindowedSpline<'a>),
}

/// A position spline read by knot index, as the t(z) inversion walks it. The grid loop is
/// generic over it (and over [`EffortRead`]) so that each kind of spline gets a loop of its
/// own: dispatching on [`PositionSpline`] at every read kept the current piece in memory,
/// stored in halves and reloaded whole, which stalled store forwarding once a point.
pub(super) trait KnotRead<'a> {
    /// The knots' abscissae (s).
    fn x(&self) -> &'a [f64];
    /// The spline's value at knot k (m).
    fn value(&mut self, k: usize) -> f64;
    /// The cubic of interval k.
    fn piece(&mut self, k: usize) -> crate::spline::Piece;
    /// Value, first and second derivative at t (s) on interval k.
    fn eval_in(&mut self, k: usize, t: f64) -> (f64, f64, f64);
    /// The interval holding t (s), clamped to the end intervals.
    fn interval(&self, t: f64) -> usize;
    /// Whether [`fill_table`](Self::fill_table) holds intervals in a [`PieceTable`]: else
    /// the inversion reads pieces one at a time, in the order it needs them (a windowed
    /// spline solves a window whenever a read leaves the one held).
    const TABLE: bool = false;
    /// Hold intervals `first..first + intervals` (at most [`PieceTable::INTERVALS`]) in
    /// `table` ([`TABLE`](Self::TABLE) splines only).
    fn fill_table(&mut self, _first: usize, _intervals: usize, _table: &mut PieceTable) {
        unreachable!("a spline without a piece table")
    }
    /// The first interval from k on, up to `limit`, whose right knot's value does not lie
    /// short of `zg` in the direction of travel (`FORWARD`), else `limit` (k ≤ `limit` ≤ the
    /// last interval).
    #[inline(always)]
    fn advance<const FORWARD: bool>(&mut self, mut k: usize, limit: usize, zg: f64) -> usize {
        while k < limit && short_of::<FORWARD>(self.value(k + 1), zg) {
            k += 1;
        }
        k
    }
}

/// Whether a spline value z lies short of the grid position zg in the direction of travel
/// (`FORWARD`): for s = ±1, s·(z − z_g) < 0 is exactly z < z_g forward and z > z_g backward.
#[inline(always)]
pub(super) fn short_of<const FORWARD: bool>(z: f64, zg: f64) -> bool {
    if FORWARD {
        z < zg
    } else {
        z > zg
    }
}

impl<'a> KnotRead<'a> for CubicSpline<'a> {
    #[inline(always)]
    fn x(&self) -> &'a [f64] {
        CubicSpline::x(self)
    }
    #[inline(always)]
    fn value(&mut self, k: usize) -> f64 {
        self.y()[k]
    }
    #[inline(always)]
    fn piece(&mut self, k: usize) -> crate::spline::Piece {
        CubicSpline::piece(self, k)
    }
    #[inline(always)]
    fn eval_in(&mut self, k: usize, t: f64) -> (f64, f64, f64) {
        CubicSpline::eval_in(self, k, t)
    }
    #[inline(always)]
    fn interval(&self, t: f64) -> usize {
        CubicSpline::interval(self, t)
    }
    const TABLE: bool = true;
    #[inline(always)]
    fn fill_table(&mut self, first: usize, intervals: usize, table: &mut PieceTable) {
        CubicSpline::fill_table(self, first, intervals, table);
    }
    #[inline(always)]
    fn advance<const FORWARD: bool>(&mut self, k: usize, limit: usize, zg: f64) -> usize {
        // The values at knots k + 1..=limit, one bounds check for the lot.
        let ahead = &self.y()[k + 1..=limit];
        k + ahead
            .iter()
            .position(|&z| !short_of::<FORWARD>(z, zg))
            .unwrap_or(ahead.len())
    }
}

impl<'a> KnotRead<'a> for crate::spline::WindowedSmoothing<'a> {
    #[inline(always)]
    fn x(&self) -> &'a [f64] {
        crate::spline::WindowedSmoothing::x(self)
    }
    #[inline(always)]
    fn value(&mut self, k: usize) -> f64 {
        crate::spline::WindowedSmoothing::value(self, k)
    }
    #[inline(always)]
    fn piece(&mut self, k: usize) -> crate::spline::Piece {
        crate::spline::WindowedSmoothing::piece(self, k)
    }
    #[inline(always)]
    fn eval_in(&mut self, k: usize, t: f64) -> (f64, f64, f64) {
        crate::spline::WindowedSmoothing::eval_in(self, k, t)
    }
    #[inline(always)]
    fn interval(&self, t: f64) -> usize {
        crate::spline::WindowedSmoothing::interval(self, t)
    }
}

/// The effort spline read at non-decreasing times, as the grid loop reads it.
trait EffortRead {
    /// The effort at times `ts` (s), in its unit, into `es`.
    fn eval_block(&mut self, ts: &[f64], es: &mut [f64], table: &mut PieceTable);
}

impl EffortRead for crate::spline::Cursor<'_, '_> {
    #[inline(always)]
    fn eval_block(&mut self, ts: &[f64], es: &mut [f64], table: &mut PieceTable) {
        crate::spline::Cursor::eval_block(self, ts, es, table);
    }
}

impl EffortRead for crate::spline::WindowedSpline<'_> {
    #[inline(always)]
    fn eval_block(&mut self, ts: &[f64], es: &mut [f64], _: &mut PieceTable) {
        for (&t, e) in ts.iter().zip(es) {
            *e = crate::spline::WindowedSpline::eval(self, t);
        }
    }
}

/// Grid points filled at a time by [`GridWalk::fill`].
const BLOCK: usize = 256;

/// The resampling of one stroke on the position grid (steps 3-6) between blocks of points:
/// the grid, the output window, Eq. 5's constants, where the t(z) inversion stands and the
/// running sum of the friction.
pub(super) struct GridWalk<'s, 'a> {
    /// Index of the first grid point: point j lies at (k_first + s·j)·step.
    k_first: f64,
    /// The direction's sign.
    s: f64,
    /// Grid step lead/m (m).
    step: f64,
    /// Output window (s).
    w_lo: f64,
    w_hi: f64,
    /// Force per unit of effort, signed as the friction is (N per A or N per N·m).
    force_gain: f64,
    /// Equivalent mass (kg) and damping (N·s/m) of Eq. 5.
    m_eq: f64,
    b_eq: f64,
    /// t(z) from the paper's knot spline, when asked for; else the inversion below.
    knot_cursor: Option<crate::spline::Cursor<'s, 'a>>,
    /// Knot interval of the last point.
    k_int: usize,
    /// Whether the inversion found no bracketing interval somewhere.
    non_monotone: bool,
    /// Time of the last point (s).
    t_prev: f64,
    /// Sum of the friction so far (N).
    sum: f64,
}

impl GridWalk<'_, '_> {
    /// Resample grid points `j0..j0 + len` into `cols` (position m, time s, velocity m/s,
    /// acceleration m/s², effort, friction N by Eq. 5).
    ///
    /// # Errors
    /// The grid position (m) of the first point whose friction is not finite.
    #[inline(never)]
    fn fill<'a, Z: KnotRead<'a>, E: EffortRead>(
        &mut self,
        zs: &mut Z,
        effort: &mut E,
        j0: usize,
        len: usize,
        cols: &mut [[f64; BLOCK]; 6],
        table: &mut PieceTable,
    ) -> Result<(), f64> {
        let (force_gain, m_eq, b_eq) = (self.force_gain, self.m_eq, self.b_eq);
        match self.knot_cursor.take() {
            Some(mut ks) => {
                self.fill_knot_spline(zs, &mut ks, j0, len, cols);
                self.knot_cursor = Some(ks);
            }
            // The direction as a constant: the interval search compares instead of forming
            // s·(z − z_g), and each loop keeps only its own comparison.
            None if self.s > 0.0 => self.invert::<true, Z>(zs, j0, len, cols, table),
            None => self.invert::<false, Z>(zs, j0, len, cols, table),
        }
        // The effort, then Eq. 5, in passes of their own over the block: each loop is short
        // enough that the processor overlaps several points' dependency chains (t(z)'s
        // divisions and Newton steps, then the effort's seek and cubic), which one long loop
        // body did not let it do. Eq. 5 keeps the running sum: in a loop of its own (Eq. 5
        // then vectorises) the chain of additions was all the loop did, and it took longer.
        let [zgs, ts, vs, accs, es, fs] = cols;
        let (es, fs) = (&mut es[..len], &mut fs[..len]);
        effort.eval_block(&ts[..len], es, table);
        let mut sum = self.sum;
        for i in 0..len {
            let f = force_gain * es[i] - m_eq * accs[i] - b_eq * vs[i];
            if !f.is_finite() {
                return Err(zgs[i]);
            }
            sum += f;
            fs[i] = f;
        }
        self.sum = sum;
        Ok(())
    }

    /// The first pass of [`fill`](Self::fill) by t(z) inversion: position, time, velocity and
    /// acceleration of points `j0..j0 + len` (`FORWARD`: the direction of travel).
    ///
    /// The intervals the block spans are known before its points: the walk passes them on its
    /// way to the last point's. When they fit a [`PieceTable`], their cubics are formed there
    /// together (grid points come about once an interval, so forming each point's cubic as it
    /// arrived cost a division and a dozen loads and checks a point), and the walk steps
    /// through the table by offsets.
    #[inline(always)]
    fn invert<'a, const FORWARD: bool, Z: KnotRead<'a>>(
        &mut self,
        zs: &mut Z,
        j0: usize,
        len: usize,
        cols: &mut [[f64; BLOCK]; 6],
        table: &mut PieceTable,
    ) {
        let tz = zs.x();
        let last = tz.len().saturating_sub(2);
        let (w_lo, w_hi) = (self.w_lo, self.w_hi);
        let (k_first, s, step) = (self.k_first, self.s, self.step);
        let [zgs, ts, vs, accs, _, _] = cols;
        // The walk's state rides in locals through the block.
        let mut k_int = self.k_int;
        let mut solve = Solve {
            tz,
            w_lo,
            w_hi,
            t_prev: self.t_prev,
            non_monotone: false,
        };
        // j as a float: exact below 2⁵³, and cheaper to step than to convert.
        let mut jf = j0 as f64;
        for zg in &mut zgs[..len] {
            *zg = (k_first + s * jf) * step;
            jf += 1.0;
        }
        let zgs = &zgs[..len];
        // The walk advances while the next knot lies short of the target, and the targets
        // advance too (step > 0), so the block spans the intervals up to the last point's.
        // Where that interval's end is not short of the last target, no point's walk passes
        // it, and the walk through the table needs no bound.
        let spanned = match zgs.last() {
            Some(&zg_last) if Z::TABLE && step > 0.0 => {
                let limit = (k_int + PieceTable::INTERVALS - 1).min(last);
                let k_end = zs.advance::<FORWARD>(k_int, limit, zg_last);
                (!short_of::<FORWARD>(zs.value(k_end + 1), zg_last)).then_some(k_end)
            }
            _ => None,
        };
        if let Some(k_end) = spanned {
            // The walk by offsets into the table.
            let first = k_int;
            zs.fill_table(first, k_end - first + 1, table);
            let mut o = 0;
            for (i, &zg) in zgs.iter().enumerate() {
                while short_of::<FORWARD>(table.value(o + 1), zg) {
                    o += 1;
                }
                let (t, v, a) = solve.at(zs, first + o, &table.piece(o), table.value(o + 1), zg);
                ts[i] = t;
                vs[i] = v;
                accs[i] = a;
            }
            k_int = first + o;
        } else {
            // Points sparser than knots (or a spline without a table): a piece when the
            // interval changes.
            let mut held: Option<(usize, Piece)> = None;
            for (i, &zg) in zgs.iter().enumerate() {
                k_int = zs.advance::<FORWARD>(k_int, last, zg);
                let p = match held {
                    Some((k, p)) if k == k_int => p,
                    _ => {
                        let p = zs.piece(k_int);
                        held = Some((k_int, p));
                        p
                    }
                };
                let z1 = zs.value(k_int + 1);
                let (t, v, a) = solve.at(zs, k_int, &p, z1, zg);
                ts[i] = t;
                vs[i] = v;
                accs[i] = a;
            }
        }
        (self.k_int, self.t_prev) = (k_int, solve.t_prev);
        self.non_monotone |= solve.non_monotone;
    }

    /// The first pass of [`fill`](Self::fill) with t(z) from the paper's knot spline.
    fn fill_knot_spline<'a, Z: KnotRead<'a>>(
        &mut self,
        zs: &mut Z,
        ks: &mut crate::spline::Cursor<'_, '_>,
        j0: usize,
        len: usize,
        cols: &mut [[f64; BLOCK]; 6],
    ) {
        let [zgs, ts, vs, accs, _, _] = cols;
        let (k_first, s, step) = (self.k_first, self.s, self.step);
        let mut jf = j0 as f64;
        for i in 0..len {
            let zg = (k_first + s * jf) * step;
            jf += 1.0;
            let t = ks.eval(s * zg).clamp(self.w_lo, self.w_hi);
            let (_, v, a) = zs.eval_in(zs.interval(t), t);
            self.t_prev = t;
            zgs[i] = zg;
            ts[i] = t;
            vs[i] = v;
            accs[i] = a;
        }
    }
}

/// The warning for feed changes inside a stroke that the position cut-off `fc` (Hz) does not
/// resolve ([`transient`]); `feed_m_s` the stroke's feed, `s` its direction's sign.
fn feed_changes_unresolved(
    found: &[transient::FeedChange],
    fc: f64,
    feed_m_s: f64,
    s: f64,
) -> Diagnostic {
    const LISTED: usize = 6;
    let reach_mm = 2.0 * feed_m_s / fc * 1e3;
    let mut at: Vec<String> = found
        .iter()
        .take(LISTED)
        .map(|c| {
            format!(
                "{:.1} mm ({:+.0} mm/min)",
                c.position_m * 1e3,
                s * c.delta_v_m_s * 60e3
            )
        })
        .collect();
    if found.len() > LISTED {
        at.push(format!("and {} more", found.len() - LISTED));
    }
    let peak = found.iter().map(|c| c.peak_inertia_n).fold(0.0, f64::max);
    Diagnostic::new(
        Code::FeedChangeUnresolved,
        format!(
            "the feed changed inside the stroke faster than the position smoothing resolves \
             (cut-off {fc:.1} Hz) at {}: the effort shows the inertia of each change at once, \
             the smoothed acceleration spreads it over about {:.0} ms (up to {peak:.0} N), so \
             the friction within about ±{reach_mm:.2} mm of each is off; the rest of the stroke \
             is not affected. A gentler override change, finer position quanta or faster \
             sampling (a higher cut-off) narrow it",
            at.join(", "),
            1e3 / fc
        ),
    )
}

/// The order a friction fluctuation of this axis is expected to reach (cycles per lead) and
/// what causes it: the shaft orders 1-4, the ball-refeed orders of nut and guides (paper 000
/// Eq. 7) with their second harmonics, the groups of significant components of paper 000
/// section 4.1.2, and the declared orders. Without the geometry of nut or guides, order 10,
/// where the refeed orders of common drives lie (z/2 of 14-30 balls a turn, less the
/// contact-angle term).
fn highest_expected_order(axis: &AxisParams) -> (f64, String) {
    use crate::order::{kinematic_orders, Cause};
    // The kinematic orders less the refeeds' third harmonics, which section 4.1.2 does not
    // find significant.
    let kin = kinematic_orders(axis);
    let geometry = kin
        .iter()
        .any(|k| matches!(k.cause, Cause::NutRefeed(_) | Cause::GuideRefeed(_)));
    let mut best = if geometry {
        (0.0, String::new())
    } else {
        (
            10.0,
            "the ball refeed of a typical nut or guide (no geometry in the axis file)".to_string(),
        )
    };
    for k in kin {
        let significant = !matches!(k.cause, Cause::NutRefeed(h) | Cause::GuideRefeed(h) if h > 2);
        if significant && k.order.is_finite() && k.order > best.0 {
            best = (k.order, k.cause.to_string());
        }
    }
    best
}
