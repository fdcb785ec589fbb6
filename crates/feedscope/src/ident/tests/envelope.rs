//! The motion envelope of real controls (issue #30): triangular-wave tests with trapezoid,
//! jerk-limited S-curve (reaching a_max or not) and bell (cosine) ramps, sampled at 83 Hz to
//! 8 kHz and polled asynchronously every 70 ms, current or torque, on a drive unlike any
//! paper's.
//!
//! The wave is generated here, in closed form, independently of the project's planner
//! ([`crate::sim::NcPath`]) and of [`crate::plan`], so that the identification is tested on
//! motion it was not built around; the simulator's servo loop then drives the plant.

use std::f64::consts::PI;

use crate::sim::{Kinematics, MotionProfile};

/// How a control shapes each speed change.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Ramp {
    /// Constant acceleration a_max (a step of the acceleration at each corner).
    Trapezoid,
    /// Jerk-limited: the acceleration rises at the jerk limit j to a_max (if the speed
    /// change is large enough, else to √(Δv·j)), holds, and falls at −j.
    JerkLimited {
        /// Jerk limit (m/s³).
        jerk_m_s3: f64,
    },
    /// Bell (cosine) ramp: a = a_max·sin²(π·τ/T), T = 2·Δv/a_max.
    Bell,
}

/// One speed ramp from 0 to `v` (m/s), by `shape` with peak acceleration limit `a` (m/s²).
#[derive(Debug, Clone, Copy)]
struct RampPlan {
    shape: Ramp,
    v: f64,
    a: f64,
    /// duration (s)
    t: f64,
    /// jerk phase (s) for the S-curve
    tj: f64,
}

impl RampPlan {
    fn new(shape: Ramp, v: f64, a: f64) -> Self {
        let (t, tj) = match shape {
            Ramp::Trapezoid => (v / a, 0.0),
            Ramp::Bell => (2.0 * v / a, 0.0),
            Ramp::JerkLimited { jerk_m_s3: j } => {
                if v <= a * a / j {
                    let t = 2.0 * (v / j).sqrt();
                    (t, 0.5 * t)
                } else {
                    (v / a + a / j, a / j)
                }
            }
        };
        Self { shape, v, a, t, tj }
    }

    /// Distance covered by the ramp (m): v·T/2 for every symmetric shape.
    fn distance(&self) -> f64 {
        0.5 * self.v * self.t
    }

    /// (z, v, a) at τ ∈ [0, T] of the ramp from rest.
    fn at(&self, tau: f64) -> (f64, f64, f64) {
        let tau = tau.clamp(0.0, self.t);
        match self.shape {
            Ramp::Trapezoid => (0.5 * self.a * tau * tau, self.a * tau, self.a),
            Ramp::Bell => {
                let w = 2.0 * PI / self.t;
                let a = 0.5 * self.a * (1.0 - (w * tau).cos());
                let v = 0.5 * self.a * (tau - (w * tau).sin() / w);
                let z = 0.5 * self.a * (0.5 * tau * tau - (1.0 - (w * tau).cos()) / (w * w));
                (z, v, a)
            }
            Ramp::JerkLimited { jerk_m_s3: j } => {
                let (t, tj) = (self.t, self.tj);
                if tau <= tj {
                    (j * tau.powi(3) / 6.0, 0.5 * j * tau * tau, j * tau)
                } else if tau >= t - tj {
                    let u = t - tau;
                    let z = self.distance() - (self.v * u - j * u.powi(3) / 6.0);
                    (z, self.v - 0.5 * j * u * u, j * u)
                } else {
                    // the plateau at a_max (only when the ramp reaches it)
                    let ap = j * tj;
                    let d = tau - tj;
                    let z = j * tj.powi(3) / 6.0 + 0.5 * ap * tj * d + 0.5 * ap * d * d;
                    (z, 0.5 * ap * tj + ap * d, ap)
                }
            }
        }
    }
}

/// A rest-to-rest move at `feed` with the ramps of `plan`, cruising in between.
#[derive(Debug, Clone, Copy)]
struct ShapedMove {
    t0: f64,
    z0: f64,
    sign: f64,
    ramp: RampPlan,
    cruise_s: f64,
}

impl ShapedMove {
    fn duration(&self) -> f64 {
        2.0 * self.ramp.t + self.cruise_s
    }

    fn at(&self, t: f64) -> Kinematics {
        let r = &self.ramp;
        let tau = (t - self.t0).clamp(0.0, self.duration());
        let (z, v, a) = if tau <= r.t {
            r.at(tau)
        } else if tau <= r.t + self.cruise_s {
            (r.distance() + r.v * (tau - r.t), r.v, 0.0)
        } else {
            let u = tau - r.t - self.cruise_s;
            let (zr, vr, ar) = r.at(u);
            (
                r.distance() + r.v * self.cruise_s + r.v * u - zr,
                r.v - vr,
                -ar,
            )
        };
        Kinematics {
            position_m: self.z0 + self.sign * z,
            velocity_m_s: self.sign * v,
            accel_m_s2: self.sign * a,
        }
    }
}

/// A sequence of rest-to-rest moves with no dwell between them (paper 002's wave).
#[derive(Debug, Clone)]
pub(crate) struct ShapedWave {
    moves: Vec<ShapedMove>,
    lead_s: f64,
    start_m: f64,
    duration_s: f64,
}

impl ShapedWave {
    /// Paper 002's variable-amplitude, variable-velocity wave about `centre_mm`: `levels`
    /// feeds geometric from `feed_min` to `feed_max` (mm/min), each one cycle
    /// c → c + A → c − A → c, with the amplitude giving `cruise_s` at the feed (within
    /// `half_window_mm`), ramps by `shape` limited to `accel_m_s2`. 0.3 s of rest before and
    /// after.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn triangle(
        shape: Ramp,
        accel_m_s2: f64,
        centre_mm: f64,
        half_window_mm: f64,
        feed_min_mm_min: f64,
        feed_max_mm_min: f64,
        levels: usize,
        cruise_s: f64,
    ) -> Self {
        let c = centre_mm * 1e-3;
        let half = half_window_mm * 1e-3;
        let lead_s = 0.3;
        let mut moves = Vec::new();
        let mut t = lead_s;
        let mut z = c;
        for i in 0..levels {
            let f = feed_min_mm_min
                * (feed_max_mm_min / feed_min_mm_min).powf(i as f64 / (levels - 1) as f64);
            let v = f / 60_000.0;
            let ramp = RampPlan::new(shape, v, accel_m_s2);
            // the first and last moves of a level run the amplitude once, the middle one twice
            let amp = (0.5 * v * cruise_s + 2.0 * ramp.distance()).min(half);
            for to in [c + amp, c - amp, c] {
                let dist = (to - z).abs();
                let cruise = (dist - 2.0 * ramp.distance()) / v;
                assert!(
                    cruise >= 0.0,
                    "level {i}: {f} mm/min needs {} mm to ramp, the window gives {} mm",
                    2e3 * ramp.distance(),
                    1e3 * dist
                );
                let mv = ShapedMove {
                    t0: t,
                    z0: z,
                    sign: (to - z).signum(),
                    ramp,
                    cruise_s: cruise,
                };
                t += mv.duration();
                z = to;
                moves.push(mv);
            }
        }
        Self {
            moves,
            lead_s,
            start_m: c,
            duration_s: t + lead_s,
        }
    }
}

impl MotionProfile for ShapedWave {
    fn duration_s(&self) -> f64 {
        self.duration_s
    }

    fn kinematics(&self, t_s: f64) -> Kinematics {
        if t_s < self.lead_s {
            return Kinematics {
                position_m: self.start_m,
                ..Kinematics::default()
            };
        }
        let i = self.moves.partition_point(|m| m.t0 <= t_s).max(1) - 1;
        self.moves[i].at(t_s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every shape: the closed forms are consistent (z' = v, v' = a by central differences),
    /// continuous across pieces, reach the targets exactly and respect the limits.
    #[test]
    fn shaped_wave_is_consistent() {
        for shape in [
            Ramp::Trapezoid,
            Ramp::JerkLimited { jerk_m_s3: 20.0 },
            Ramp::JerkLimited { jerk_m_s3: 200.0 },
            Ramp::Bell,
        ] {
            let w = ShapedWave::triangle(shape, 2.0, 100.0, 50.0, 20.0, 6000.0, 6, 0.5);
            let h = 1e-5;
            let mut t = 0.0;
            let mut a_peak = 0.0f64;
            while t + h < w.duration_s() {
                let (k0, k1, k2) = (w.kinematics(t - h), w.kinematics(t), w.kinematics(t + h));
                let v_fd = (k2.position_m - k0.position_m) / (2.0 * h);
                // O(h·Δa) at the corners of a trapezoid
                assert!((v_fd - k1.velocity_m_s).abs() < 1e-4, "{shape:?} t {t}: v");
                let a_fd = (k2.velocity_m_s - k0.velocity_m_s) / (2.0 * h);
                if shape != Ramp::Trapezoid {
                    // continuous acceleration: the difference quotient matches everywhere
                    assert!((a_fd - k1.accel_m_s2).abs() < 1e-2, "{shape:?} t {t}: a");
                }
                a_peak = a_peak.max(k1.accel_m_s2.abs());
                t += 0.000_731;
            }
            assert!(a_peak <= 2.0 + 1e-9, "{shape:?}: {a_peak}");
            for m in &w.moves {
                let end = m.at(m.t0 + m.duration());
                assert!(end.velocity_m_s.abs() < 1e-12);
            }
            let last = w.kinematics(w.duration_s());
            assert!((last.position_m - 0.1).abs() < 1e-12, "{shape:?}");
        }
    }
}
