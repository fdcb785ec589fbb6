//! Commanded motion: the path an NC program asks the table to follow.
//!
//! [`NcPath`] plans strokes `{to_mm, feed_mm_min, dwell_s}` as trapezoidal velocity profiles
//! (constant acceleration limit, no jerk limit), optionally with a sinusoidal feed modulation in
//! the constant-feed phase. Any other profile can be simulated through [`MotionProfile`], e.g.
//! a closure with [`FnProfile`].

use std::f64::consts::PI;

use serde::{Deserialize, Serialize};

use super::friction::Direction;

/// Position, velocity and acceleration of the table at one instant (SI).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Kinematics {
    /// Position z (m).
    pub position_m: f64,
    /// Velocity z' (m/s).
    pub velocity_m_s: f64,
    /// Acceleration z'' (m/s²).
    pub accel_m_s2: f64,
}

/// A commanded position profile z(t) with its first two derivatives, defined on
/// [0, `duration_s`]; before 0 and after the end the table is held at the end positions.
pub trait MotionProfile {
    /// Length of the profile (s).
    fn duration_s(&self) -> f64;
    /// The commanded state at time `t_s` (s).
    fn kinematics(&self, t_s: f64) -> Kinematics;
}

/// A [`MotionProfile`] from a closure t ↦ (z, z', z'') (for tests and special motions).
pub struct FnProfile<F: Fn(f64) -> Kinematics> {
    duration_s: f64,
    f: F,
}

impl<F: Fn(f64) -> Kinematics> FnProfile<F> {
    /// Wrap `f`, valid on [0, `duration_s`] (clamped outside).
    pub fn new(duration_s: f64, f: F) -> Self {
        Self { duration_s, f }
    }
}

impl<F: Fn(f64) -> Kinematics> MotionProfile for FnProfile<F> {
    fn duration_s(&self) -> f64 {
        self.duration_s
    }
    fn kinematics(&self, t_s: f64) -> Kinematics {
        (self.f)(t_s.clamp(0.0, self.duration_s))
    }
}

/// One programmed stroke (TOML `[[motion.stroke]]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StrokeConfig {
    /// Target position (mm).
    pub to_mm: f64,
    /// Feed rate (mm/min), > 0.
    pub feed_mm_min: f64,
    /// Standstill after reaching the target (s), ≥ 0.
    #[serde(default)]
    pub dwell_s: f64,
}

/// Sinusoidal feed modulation in the constant-feed phase of each stroke:
/// v = F·(1 + r·sin(2π·τ/T')), with T' the configured period adjusted per stroke to an integer
/// number of periods of the constant-feed phase, so that the stroke ends where programmed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FeedModulation {
    /// r, relative amplitude in [0, 1).
    pub relative_amplitude: f64,
    /// Nominal period T (s), > 0.
    pub period_s: f64,
}

/// A commanded stroke as planned, reported in the truth.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CommandedStroke {
    /// Direction of travel.
    pub direction: Direction,
    /// Programmed feed (mm/min).
    pub feed_mm_min: f64,
    /// Start position (mm).
    pub start_mm: f64,
    /// End position (mm).
    pub end_mm: f64,
    /// Start of the acceleration (s).
    pub start_time_s: f64,
    /// End of the deceleration, before the dwell (s).
    pub end_time_s: f64,
    /// Start of the constant-feed phase (s).
    pub cruise_start_time_s: f64,
    /// End of the constant-feed phase (s).
    pub cruise_end_time_s: f64,
}

/// One planned stroke, SI.
#[derive(Debug, Clone)]
struct Segment {
    t0: f64,
    z0: f64,
    sign: f64,
    /// peak speed (m/s)
    vp: f64,
    /// acceleration (m/s²)
    acc: f64,
    /// accel, cruise durations (s)
    ta: f64,
    tc: f64,
    /// modulation: relative amplitude and adjusted period (0 = none)
    r: f64,
    period: f64,
    /// end of motion, end of dwell (s)
    t_end: f64,
    t_dwell_end: f64,
    z1: f64,
}

impl Segment {
    fn kinematics(&self, t: f64) -> Kinematics {
        let tau = t - self.t0;
        let (s, v, a) = if tau <= 0.0 {
            (0.0, 0.0, 0.0)
        } else if tau < self.ta {
            (0.5 * self.acc * tau * tau, self.acc * tau, self.acc)
        } else if tau < self.ta + self.tc {
            let u = tau - self.ta;
            let sa = 0.5 * self.acc * self.ta * self.ta;
            if self.period > 0.0 {
                let w = 2.0 * PI / self.period;
                let s = sa + self.vp * u + self.vp * self.r * (1.0 - (w * u).cos()) / w;
                let v = self.vp * (1.0 + self.r * (w * u).sin());
                let a = self.vp * self.r * w * (w * u).cos();
                (s, v, a)
            } else {
                (sa + self.vp * u, self.vp, 0.0)
            }
        } else if t < self.t_end {
            let d = self.t_end - t;
            let dist = (self.z1 - self.z0).abs();
            (dist - 0.5 * self.acc * d * d, self.acc * d, -self.acc)
        } else {
            ((self.z1 - self.z0).abs(), 0.0, 0.0)
        };
        Kinematics {
            position_m: self.z0 + self.sign * s,
            velocity_m_s: self.sign * v,
            accel_m_s2: self.sign * a,
        }
    }
}

/// A planned NC program: lead-in standstill, strokes with dwells, lead-out standstill.
#[derive(Debug, Clone)]
pub struct NcPath {
    start_m: f64,
    segments: Vec<Segment>,
    duration_s: f64,
    strokes: Vec<CommandedStroke>,
}

impl NcPath {
    /// Plan the strokes. Inputs are assumed validated (finite, feed and acceleration > 0).
    ///
    /// `lead_in_s` of standstill precede the first stroke, `lead_out_s` follow the last dwell.
    pub fn plan(
        start_mm: f64,
        strokes: &[StrokeConfig],
        acceleration_mm_s2: f64,
        modulation: Option<&FeedModulation>,
        lead_in_s: f64,
        lead_out_s: f64,
    ) -> Self {
        let acc = acceleration_mm_s2 * 1e-3;
        let mut t = lead_in_s;
        let mut z = start_mm * 1e-3;
        let mut segments = Vec::with_capacity(strokes.len());
        let mut out = Vec::with_capacity(strokes.len());
        for s in strokes {
            let z1 = s.to_mm * 1e-3;
            let dist = (z1 - z).abs();
            let feed = s.feed_mm_min / 60_000.0;
            // Trapezoid: accelerate to the feed if the distance allows, else a triangle.
            let (vp, ta, tc) = if dist <= 0.0 {
                (0.0, 0.0, 0.0)
            } else if dist >= feed * feed / acc {
                (feed, feed / acc, (dist - feed * feed / acc) / feed)
            } else {
                let vp = (dist * acc).sqrt();
                (vp, vp / acc, 0.0)
            };
            let (r, period) = match modulation {
                Some(m) if m.relative_amplitude > 0.0 && tc > 0.0 => {
                    let n = (tc / m.period_s).round();
                    if n >= 1.0 {
                        (m.relative_amplitude, tc / n)
                    } else {
                        (0.0, 0.0)
                    }
                }
                _ => (0.0, 0.0),
            };
            let t_end = t + 2.0 * ta + tc;
            let sign = if z1 >= z { 1.0 } else { -1.0 };
            segments.push(Segment {
                t0: t,
                z0: z,
                sign,
                vp,
                acc,
                ta,
                tc,
                r,
                period,
                t_end,
                t_dwell_end: t_end + s.dwell_s,
                z1,
            });
            out.push(CommandedStroke {
                direction: if sign > 0.0 {
                    Direction::Forward
                } else {
                    Direction::Backward
                },
                feed_mm_min: s.feed_mm_min,
                start_mm: z * 1e3,
                end_mm: s.to_mm,
                start_time_s: t,
                end_time_s: t_end,
                cruise_start_time_s: t + ta,
                cruise_end_time_s: t + ta + tc,
            });
            t = t_end + s.dwell_s;
            z = z1;
        }
        Self {
            start_m: start_mm * 1e-3,
            segments,
            duration_s: t + lead_out_s,
            strokes: out,
        }
    }

    /// The planned strokes with their times.
    pub fn strokes(&self) -> &[CommandedStroke] {
        &self.strokes
    }
}

impl MotionProfile for NcPath {
    fn duration_s(&self) -> f64 {
        self.duration_s
    }

    fn kinematics(&self, t_s: f64) -> Kinematics {
        // The active segment is the first whose dwell has not ended; binary search keeps a
        // call O(log strokes).
        let k = self.segments.partition_point(|s| s.t_dwell_end <= t_s);
        match self.segments.get(k) {
            Some(s) => s.kinematics(t_s),
            None => Kinematics {
                position_m: self.segments.last().map_or(self.start_m, |s| s.z1),
                ..Kinematics::default()
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stroke(to_mm: f64, feed_mm_min: f64, dwell_s: f64) -> StrokeConfig {
        StrokeConfig {
            to_mm,
            feed_mm_min,
            dwell_s,
        }
    }

    #[test]
    fn trapezoid_reaches_targets_and_is_consistent() {
        let m = FeedModulation {
            relative_amplitude: 0.3,
            period_s: 0.7,
        };
        for modulation in [None, Some(&m)] {
            let p = NcPath::plan(
                5.0,
                &[
                    stroke(25.0, 600.0, 0.5),
                    stroke(24.9, 600.0, 0.2),
                    stroke(0.0, 1200.0, 0.0),
                ],
                100.0,
                modulation,
                0.3,
                0.4,
            );
            assert!((p.kinematics(0.0).position_m - 0.005).abs() < 1e-15);
            for s in p.strokes() {
                let k = p.kinematics(s.end_time_s + 1e-9);
                assert!(
                    (k.position_m - s.end_mm * 1e-3).abs() < 1e-12,
                    "{s:?} {k:?}"
                );
            }
            // z' and z'' are the derivatives of z (central differences, O(h²) with h = 1 µs;
            // skip instants where z'' jumps)
            let h = 1e-6;
            let n = 20_000;
            for k in 1..n {
                let t = p.duration_s() * k as f64 / n as f64;
                let (a, b, c) = (p.kinematics(t - h), p.kinematics(t), p.kinematics(t + h));
                let v = (c.position_m - a.position_m) / (2.0 * h);
                assert!((v - b.velocity_m_s).abs() < 1e-7, "t = {t}");
                if (c.accel_m_s2 - a.accel_m_s2).abs() < 1e-3 {
                    let acc = (c.velocity_m_s - a.velocity_m_s) / (2.0 * h);
                    assert!((acc - b.accel_m_s2).abs() < 1e-5, "t = {t}");
                }
                assert!(b.velocity_m_s.abs() <= 1200.0 / 60_000.0 * 1.3 + 1e-12);
            }
        }
    }
}
