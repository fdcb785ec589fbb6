//! Commanded motion: the path an NC program asks the table to follow.
//!
//! [`NcPath`] plans strokes `{to_mm, feed_mm_min, dwell_s}` or the moves of an NC program
//! ([`crate::nc::NcProgram`]) block by block with exact stop: every move starts and ends at
//! rest. Without a jerk limit a move is a trapezoidal velocity profile (constant acceleration
//! limit); with one it is the 7-phase jerk-limited (S-curve) profile of [`NcPath::plan_strokes`].
//! Feed moves may carry a sinusoidal feed modulation in their constant-feed phase. Any other
//! profile can be simulated through [`MotionProfile`], e.g. a closure with [`FnProfile`].

use std::f64::consts::PI;

use serde::{Deserialize, Serialize};

use super::friction::Direction;
use crate::nc::{NcError, NcProgram, StepKind};
use crate::units::feed_mm_min_to_m_s;

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

/// Rapid traverse or feed move.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MoveKind {
    /// Rapid traverse (G0): the rapid rate and rapid acceleration.
    Rapid,
    /// Feed move (G1, `[[motion.stroke]]`): the programmed feed and the acceleration limit.
    #[default]
    Feed,
}

/// A commanded move as planned, reported in the truth: every stroke of `[[motion.stroke]]`,
/// or every move of a program (also those that do not move the axis, with equal start and end
/// and zero duration).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CommandedStroke {
    /// Direction of travel (forward for a move of zero length).
    pub direction: Direction,
    /// Speed limit of the move along the axis (mm/min): the programmed axis feed of a feed
    /// move, the rapid rate of a rapid; 0 for a program move that does not move the axis and
    /// whose axis feed is unknown.
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
    /// Rapid or feed (`feed` in truth files written before programs existed).
    #[serde(default)]
    pub kind: MoveKind,
    /// 1-based line of the program block; `None` for `[[motion.stroke]]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub line: Option<usize>,
    /// `N` number of the program block, if it has one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub block_number: Option<u64>,
}

/// Kinematic limits of the planned path.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MotionLimits {
    /// Acceleration limit of feed moves (mm/s²), > 0.
    pub acceleration_mm_s2: f64,
    /// Jerk limit of every move (mm/s³), > 0; `None` = no jerk limit (trapezoids).
    pub jerk_mm_s3: Option<f64>,
    /// Rapid traverse rate (mm/min), > 0.
    pub rapid_rate_mm_min: f64,
    /// Acceleration limit of rapids (mm/s²), > 0.
    pub rapid_acceleration_mm_s2: f64,
}

/// One move to plan, in user units.
#[derive(Debug, Clone)]
struct Block {
    kind: MoveKind,
    line: Option<usize>,
    block_number: Option<u64>,
    to_mm: f64,
    /// speed limit (mm/min) and the value reported as the move's feed
    speed_mm_min: f64,
    accel_mm_s2: f64,
    dwell_s: f64,
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
    /// S-curve: duration of each jerk phase (s) and the jerk (m/s³); `tj = 0` is the
    /// trapezoid, whose `acc` is then the constant acceleration and `ta` its duration. For an
    /// S-curve `acc` is the peak acceleration a_p = j·tj and `ta` the whole acceleration phase.
    tj: f64,
    jerk: f64,
}

impl Segment {
    fn kinematics(&self, t: f64) -> Kinematics {
        if self.tj > 0.0 {
            return self.s_curve_kinematics(t);
        }
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

    /// Distance, speed and acceleration at `tau` ∈ [0, ta] of the acceleration phase of an
    /// S-curve (jerk +j for tj, constant a_p, jerk −j for tj):
    /// s = j·τ³/6, v = j·τ²/2, a = j·τ in the first phase; s₁ + v₁·u + a_p·u²/2 in the
    /// second (u = τ − tj); and by the point symmetry v(τ) + v(ta − τ) = v_p of the phase,
    /// s = v_p·ta/2 − v_p·w + j·w³/6, v = v_p − j·w²/2, a = j·w with w = ta − τ in the third.
    fn accel_phase(&self, tau: f64) -> (f64, f64, f64) {
        let (j, tj, ap, vp, ta) = (self.jerk, self.tj, self.acc, self.vp, self.ta);
        if tau < tj {
            (j * tau * tau * tau / 6.0, 0.5 * j * tau * tau, j * tau)
        } else if tau < ta - tj {
            let u = tau - tj;
            let v1 = 0.5 * ap * tj;
            let s1 = j * tj * tj * tj / 6.0;
            (s1 + v1 * u + 0.5 * ap * u * u, v1 + ap * u, ap)
        } else {
            let w = (ta - tau).max(0.0);
            (
                0.5 * vp * ta - vp * w + j * w * w * w / 6.0,
                vp - 0.5 * j * w * w,
                j * w,
            )
        }
    }

    /// The S-curve: acceleration phase, cruise (modulated like the trapezoid's), and the
    /// deceleration as the mirror image of the acceleration, s(t) = L − s_acc(t_end − t), so
    /// that the move ends at its target to the last bit.
    fn s_curve_kinematics(&self, t: f64) -> Kinematics {
        let tau = t - self.t0;
        let dist = (self.z1 - self.z0).abs();
        let (s, v, a) = if tau <= 0.0 {
            (0.0, 0.0, 0.0)
        } else if tau < self.ta {
            self.accel_phase(tau)
        } else if tau < self.ta + self.tc {
            let u = tau - self.ta;
            let sa = 0.5 * self.vp * self.ta;
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
            let (s, v, a) = self.accel_phase(self.t_end - t);
            (dist - s, v, -a)
        } else {
            return Kinematics {
                position_m: self.z1,
                ..Kinematics::default()
            };
        };
        Kinematics {
            position_m: self.z0 + self.sign * s,
            velocity_m_s: self.sign * v,
            accel_m_s2: self.sign * a,
        }
    }
}

/// The rest-to-rest jerk-limited profile over `dist` (m) with limits v (m/s), a (m/s²),
/// j (m/s³): (tj, a_p, ta, v_p) with ta the whole acceleration phase.
///
/// - v·j ≥ a²: the acceleration limit is reached, tj = a/j, ta = tj + v/a; else
///   tj = √(v/j), ta = 2·tj, a_p = √(v·j) < a. The feed is reached if dist ≥ v·ta.
/// - Otherwise (short move) with a reached: ta solves dist = a·(ta − tj)·ta, i.e.
///   ta = (tj + √(tj² + 4·dist/a))/2, valid while ta ≥ 2·tj (dist ≥ 2a³/j²);
/// - else neither is reached: tj = (dist/(2j))^⅓, ta = 2·tj, v_p = j·tj².
///
/// In every case dist = v_p·ta + v_p·tc with tc ≥ 0 the cruise.
///
/// # Reference
/// L. Biagiotti, C. Melchiorri, *Trajectory Planning for Automatic Machines and Robots*,
/// Springer 2008, Section 3.4 (double S trajectory), with zero initial and final speed.
fn s_curve(dist: f64, v: f64, a: f64, j: f64) -> (f64, f64, f64, f64) {
    let (tj, ap, ta, vp) = if v * j >= a * a {
        let tj = a / j;
        (tj, a, tj + v / a, v)
    } else {
        let tj = (v / j).sqrt();
        (tj, j * tj, 2.0 * tj, v)
    };
    if dist >= vp * ta {
        return (tj, ap, ta, vp);
    }
    if dist >= 2.0 * a * a * a / (j * j) {
        let tj = a / j;
        let ta = 0.5 * (tj + (tj * tj + 4.0 * dist / a).sqrt());
        return (tj, a, ta, a * (ta - tj));
    }
    let tj = (dist / (2.0 * j)).cbrt();
    (tj, j * tj, 2.0 * tj, j * tj * tj)
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
    /// Plan the strokes as trapezoids (no jerk limit). Inputs are assumed validated (finite,
    /// feed and acceleration > 0).
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
        let blocks = stroke_blocks(strokes, acceleration_mm_s2);
        Self::plan_blocks(start_mm, &blocks, None, modulation, lead_in_s, lead_out_s)
    }

    /// Plan the strokes with `limits`: trapezoids without a jerk limit (as [`NcPath::plan`]),
    /// else jerk-limited S-curves. Each stroke is a feed move from rest to rest: with
    /// v_max = its feed, a_max = `limits.acceleration_mm_s2` and j_max = `limits.jerk_mm_s3`
    /// the 7 phases are jerk +j, 0, −j (acceleration to v_p), cruise, jerk −j, 0, +j; short
    /// moves that cannot reach a_max or v_max get the reduced profile (see the simulator
    /// docs), solved exactly. Inputs are assumed validated (finite, limits > 0).
    pub fn plan_strokes(
        start_mm: f64,
        strokes: &[StrokeConfig],
        limits: &MotionLimits,
        modulation: Option<&FeedModulation>,
        lead_in_s: f64,
        lead_out_s: f64,
    ) -> Self {
        let blocks = stroke_blocks(strokes, limits.acceleration_mm_s2);
        Self::plan_blocks(
            start_mm,
            &blocks,
            limits.jerk_mm_s3,
            modulation,
            lead_in_s,
            lead_out_s,
        )
    }

    /// Plan an NC program from `start_mm`: every move with exact stop (at rest at its end),
    /// rapids at `limits.rapid_rate_mm_min` and `limits.rapid_acceleration_mm_s2`, feed moves at
    /// their axis feed and `limits.acceleration_mm_s2`, dwells as standstill (a dwell before
    /// the first move lengthens the lead-in). The modulation applies to feed moves only.
    /// Moves that do not move the axis take no time (the twin models this axis only).
    ///
    /// # Errors
    /// [`NcError`] (source `program`) naming the line of a move along the axis whose axis feed
    /// is unknown or zero ([`crate::nc::NcStep::Move`]).
    pub fn plan_program(
        start_mm: f64,
        program: &NcProgram,
        limits: &MotionLimits,
        modulation: Option<&FeedModulation>,
        lead_in_s: f64,
        lead_out_s: f64,
    ) -> Result<Self, NcError> {
        let mut blocks: Vec<Block> = Vec::with_capacity(program.steps.len());
        let mut lead_in_s = lead_in_s;
        for st in program.resolve(start_mm) {
            let moves = (st.to_mm - st.from_mm).abs() > 0.0;
            let (kind, speed, accel) = match st.kind {
                StepKind::Dwell => {
                    match blocks.last_mut() {
                        Some(b) => b.dwell_s += st.dwell_s,
                        None => lead_in_s += st.dwell_s,
                    }
                    continue;
                }
                StepKind::Rapid => (
                    MoveKind::Rapid,
                    limits.rapid_rate_mm_min,
                    limits.rapid_acceleration_mm_s2,
                ),
                StepKind::Feed => match st.feed_mm_min {
                    Some(f) if f > 0.0 || !moves => (MoveKind::Feed, f, limits.acceleration_mm_s2),
                    None if !moves => (MoveKind::Feed, 0.0, limits.acceleration_mm_s2),
                    other => {
                        return Err(NcError {
                            source_name: "program".to_string(),
                            line: st.line,
                            message: match other {
                                None => "the feed along the axis is unknown (the block moves                                          other axes too, see feedscope::nc), so the twin                                          cannot time the move"
                                    .to_string(),
                                Some(f) => format!(
                                    "feed along the axis {f} mm/min: the twin needs a feed                                      greater than 0 for a move"
                                ),
                            },
                        })
                    }
                },
            };
            blocks.push(Block {
                kind,
                line: Some(st.line),
                block_number: st.block_number,
                to_mm: st.to_mm,
                speed_mm_min: speed,
                accel_mm_s2: accel,
                dwell_s: 0.0,
            });
        }
        Ok(Self::plan_blocks(
            start_mm,
            &blocks,
            limits.jerk_mm_s3,
            modulation,
            lead_in_s,
            lead_out_s,
        ))
    }

    fn plan_blocks(
        start_mm: f64,
        blocks: &[Block],
        jerk_mm_s3: Option<f64>,
        modulation: Option<&FeedModulation>,
        lead_in_s: f64,
        lead_out_s: f64,
    ) -> Self {
        let jerk = jerk_mm_s3.map(|j| j * 1e-3);
        let mut t = lead_in_s;
        let mut z = start_mm * 1e-3;
        let mut segments = Vec::with_capacity(blocks.len());
        let mut out = Vec::with_capacity(blocks.len());
        for s in blocks {
            let acc = s.accel_mm_s2 * 1e-3;
            let z1 = s.to_mm * 1e-3;
            let dist = (z1 - z).abs();
            let feed = feed_mm_min_to_m_s(s.speed_mm_min);
            // (jerk phase, peak acceleration, acceleration phase, peak speed, cruise)
            let (tj, acc, vp, ta, tc) = match jerk {
                _ if dist <= 0.0 => (0.0, acc, 0.0, 0.0, 0.0),
                // Trapezoid: accelerate to the feed if the distance allows, else a triangle.
                None => {
                    let (vp, ta, tc) = if dist >= feed * feed / acc {
                        (feed, feed / acc, (dist - feed * feed / acc) / feed)
                    } else {
                        let vp = (dist * acc).sqrt();
                        (vp, vp / acc, 0.0)
                    };
                    (0.0, acc, vp, ta, tc)
                }
                Some(j) => {
                    let (tj, ap, ta, vp) = s_curve(dist, feed, acc, j);
                    (tj, ap, vp, ta, ((dist - vp * ta) / vp).max(0.0))
                }
            };
            let (r, period) = match modulation {
                Some(m) if m.relative_amplitude > 0.0 && tc > 0.0 && s.kind == MoveKind::Feed => {
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
                tj,
                jerk: jerk.unwrap_or(0.0),
            });
            out.push(CommandedStroke {
                direction: if sign > 0.0 {
                    Direction::Forward
                } else {
                    Direction::Backward
                },
                feed_mm_min: s.speed_mm_min,
                start_mm: z * 1e3,
                end_mm: s.to_mm,
                start_time_s: t,
                end_time_s: t_end,
                cruise_start_time_s: t + ta,
                cruise_end_time_s: t + ta + tc,
                kind: s.kind,
                line: s.line,
                block_number: s.block_number,
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

/// `[[motion.stroke]]` entries as feed moves.
fn stroke_blocks(strokes: &[StrokeConfig], acceleration_mm_s2: f64) -> Vec<Block> {
    strokes
        .iter()
        .map(|s| Block {
            kind: MoveKind::Feed,
            line: None,
            block_number: None,
            to_mm: s.to_mm,
            speed_mm_min: s.feed_mm_min,
            accel_mm_s2: acceleration_mm_s2,
            dwell_s: s.dwell_s,
        })
        .collect()
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

    /// Limits of the S-curve tests: 1.5 m/s², 20 m/s³ (a/j = 75 ms of jerk phase).
    fn limits() -> MotionLimits {
        MotionLimits {
            acceleration_mm_s2: 1500.0,
            jerk_mm_s3: Some(20_000.0),
            rapid_rate_mm_min: 15_000.0,
            rapid_acceleration_mm_s2: 1500.0,
        }
    }

    /// Strokes covering the four cases of the S-curve with a = 1.5 m/s², j = 20 m/s³
    /// (a reached at full feed from a²/j = 6750 mm/min; 2a³/j² = 16.9 mm): feed and
    /// acceleration reached (100 mm at 12 000 mm/min, needs 200·(0.075 + 0.133) = 41.7 mm);
    /// feed reached below a (60 and 3000 mm/min: v·j < a², a_p = √(v·j)); a reached but not
    /// the feed (30 mm at 12 000 mm/min); neither (2 mm); a zero-length move; backwards.
    fn s_strokes() -> Vec<StrokeConfig> {
        vec![
            stroke(105.0, 12_000.0, 0.2),
            stroke(106.0, 60.0, 0.0),
            stroke(76.0, 12_000.0, 0.3),
            stroke(78.0, 12_000.0, 0.0),
            stroke(78.0, 600.0, 0.1),
            stroke(5.0, 3000.0, 0.0),
        ]
    }

    /// Every case: the move ends exactly at its target, z' and z'' are the derivatives of z
    /// and z'' is continuous with slope within ±j (central differences), |z'| ≤ v_max,
    /// |z''| ≤ a_max, and the durations are the closed forms of each case.
    #[test]
    fn s_curve_reaches_targets_and_is_consistent() {
        let lim = limits();
        let (a_max, j_max) = (1.5, 20.0);
        let strokes = s_strokes();
        let p = NcPath::plan_strokes(5.0, &strokes, &lim, None, 0.3, 0.4);
        assert_eq!(p.strokes().len(), strokes.len());
        for (s, c) in p.strokes().iter().zip(&strokes) {
            // exact end, and during the dwell (without one the next move starts at once)
            let during = if c.dwell_s > 0.0 { 1e-9 } else { 0.0 };
            for t in [s.end_time_s, s.end_time_s + during] {
                let k = p.kinematics(t);
                assert_eq!(k.position_m.to_bits(), (c.to_mm * 1e-3).to_bits(), "{s:?}");
                assert!(
                    k.velocity_m_s.abs() < 1e-15 && k.accel_m_s2.abs() < 1e-12,
                    "{s:?} {k:?} {t}"
                );
            }
        }
        // durations (s): closed forms
        let d = |k: usize| p.strokes()[k].end_time_s - p.strokes()[k].start_time_s;
        let ta_full = 0.2 / a_max + a_max / j_max; // 12 000 mm/min = 0.2 m/s
        assert!((d(0) - (0.1 / 0.2 + ta_full)).abs() < 1e-12, "{}", d(0));
        // 3000 mm/min = 0.05 m/s: tj = √(v/j) = 0.05 s, ta = 0.1 s
        assert!((d(5) - (0.073 / 0.05 + 0.1)).abs() < 1e-12, "{}", d(5));
        let tj = (0.001 / j_max).sqrt(); // 60 mm/min = 0.001 m/s, a_p = √(v·j) = 0.141 m/s²
        assert!(
            (d(1) - (0.001 / 0.001 + 2.0 * tj)).abs() < 1e-12,
            "{}",
            d(1)
        );
        let tj = a_max / j_max;
        let ta = 0.5 * (tj + (tj * tj + 4.0 * 0.03 / a_max).sqrt());
        assert!((d(2) - 2.0 * ta).abs() < 1e-12, "{}", d(2));
        assert!(
            (d(3) - 4.0 * (0.002 / (2.0 * j_max)).cbrt()).abs() < 1e-12,
            "{}",
            d(3)
        );
        assert!(d(4).abs() < 1e-15);
        // the short moves never cruise
        for k in [2, 3] {
            let s = &p.strokes()[k];
            assert!((s.cruise_end_time_s - s.cruise_start_time_s).abs() < 1e-12);
        }

        let h = 1e-6;
        let n = 200_000;
        let v_max = |t: f64| {
            p.strokes()
                .iter()
                .find(|s| t >= s.start_time_s && t <= s.end_time_s)
                .map_or(0.0, |s| feed_mm_min_to_m_s(s.feed_mm_min))
        };
        let (mut peak_a, mut peak_j): (f64, f64) = (0.0, 0.0);
        for k in 1..n {
            let t = p.duration_s() * k as f64 / n as f64;
            let (a, b, c) = (p.kinematics(t - h), p.kinematics(t), p.kinematics(t + h));
            // central differences: error h²/6·|z'''| ≤ 1e-12·20/6 for z' (plus rounding of
            // z ≈ 0.1 m: 1e-17/1e-6); z' is piecewise quadratic, so its difference is exact
            // except within h of a jerk switch, where it errs by at most |Δj|·h/2 ≤ j_max·h
            let v = (c.position_m - a.position_m) / (2.0 * h);
            assert!((v - b.velocity_m_s).abs() < 1e-8, "t = {t}");
            let acc = (c.velocity_m_s - a.velocity_m_s) / (2.0 * h);
            assert!(
                (acc - b.accel_m_s2).abs() < j_max * h + 1e-7,
                "t = {t}: {acc} {b:?}"
            );
            // z'' continuous: its change over 2h bounded by the jerk (+ rounding)
            let jerk = (c.accel_m_s2 - a.accel_m_s2) / (2.0 * h);
            assert!(
                jerk.abs() <= j_max * (1.0 + 1e-6) + 1e-6,
                "t = {t}: jerk {jerk}"
            );
            assert!(
                b.velocity_m_s.abs() <= v_max(t) * (1.0 + 1e-12) + 1e-15,
                "t = {t}"
            );
            assert!(b.accel_m_s2.abs() <= a_max * (1.0 + 1e-12), "t = {t}");
            peak_a = peak_a.max(b.accel_m_s2.abs());
            peak_j = peak_j.max(jerk.abs());
        }
        // the limits are used, not just respected
        assert!(
            peak_a > 0.999 * a_max && peak_j > 0.99 * j_max,
            "{peak_a} {peak_j}"
        );
    }

    /// The distance covered is the integral of the speed (trapezoidal rule over 1 µs, a
    /// slow reference independent of the closed-form positions).
    #[test]
    fn s_curve_speed_integrates_to_the_distance() {
        let p = NcPath::plan_strokes(5.0, &s_strokes(), &limits(), None, 0.0, 0.0);
        for s in p.strokes() {
            let n = ((s.end_time_s - s.start_time_s) / 1e-6).ceil().max(1.0) as usize;
            let h = (s.end_time_s - s.start_time_s) / n as f64;
            let mut dist = 0.0;
            let mut prev = p.kinematics(s.start_time_s).velocity_m_s;
            for k in 1..=n {
                let v = p.kinematics(s.start_time_s + k as f64 * h).velocity_m_s;
                dist += 0.5 * h * (prev + v);
                prev = v;
            }
            // error of the trapezoidal rule: T·h²/12·max|z'''| ≤ 2 s·1e-12/12·20
            assert!(
                (dist * 1e3 - (s.end_mm - s.start_mm)).abs() < 1e-6,
                "{s:?}: {}",
                dist * 1e3
            );
        }
    }

    /// Without a jerk limit `plan_strokes` is `plan`, to the bit.
    #[test]
    fn no_jerk_limit_is_the_trapezoid() {
        let lim = MotionLimits {
            jerk_mm_s3: None,
            ..limits()
        };
        let a = NcPath::plan_strokes(5.0, &s_strokes(), &lim, None, 0.3, 0.4);
        let b = NcPath::plan(5.0, &s_strokes(), 1500.0, None, 0.3, 0.4);
        assert_eq!(a.strokes(), b.strokes());
        for k in 0..1000 {
            let t = a.duration_s() * k as f64 / 1000.0;
            assert_eq!(a.kinematics(t), b.kinematics(t));
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
