//! Commanded motion: the path an NC program asks the table to follow.
//!
//! [`NcPath`] plans strokes `{to_mm, feed_mm_min, dwell_s}` or the moves of an NC program
//! ([`crate::nc::NcProgram`]) block by block with exact stop: every move starts and ends at
//! rest. Every speed change follows one [`RampShape`]: constant acceleration (trapezoid), the
//! 7-phase jerk-limited S-curve, or the bell (raised-cosine) ramp. Feed moves may carry a
//! sinusoidal feed modulation in their constant-feed phase, and follow a feed-override
//! schedule ([`FeedOverride`]) as a control's override switch makes them. Any other profile can
//! be simulated through [`MotionProfile`], e.g. a closure with [`FnProfile`].
//!
//! A move is a sequence of pieces, each with a closed form for (s, s', s'') in its own time:
//! speed-to-speed transitions of the ramp shape, cruises at constant (or modulated) speed, and
//! the final stop, the mirror image of a ramp from rest so that the move ends at its target to
//! the last bit.

use std::f64::consts::PI;

use serde::{Deserialize, Serialize};

use super::friction::Direction;
use crate::nc::{NcError, NcProgram, StepKind};
use crate::units::feed_mm_min_to_m_s;

/// Jerk limit of [`RampShape::JerkLimited`] when `jerk_mm_s3` is not given (mm/s³): 20 m/s³,
/// a common machine-data value for the feed axes of a mid-size machine tool.
pub const DEFAULT_JERK_MM_S3: f64 = 20_000.0;

/// How the control changes the speed of the axis (TOML `motion.ramp`: `"trapezoid"`,
/// `"jerk_limited"` or `"bell"`). For a speed change Δv at the acceleration limit a_max:
///
/// - `Trapezoid`: constant acceleration ±a_max for Δv/a_max (a steps at both ends; SINUMERIK
///   BRISK);
/// - `JerkLimited` (default): jerk ±j_max, 0, ∓j_max (the acceleration a trapezoid in time,
///   peak a_max or √(Δv·j_max) if lower; SINUMERIK SOFT, Heidenhain TNC, Beckhoff TwinCAT NC);
/// - `Bell`: a(τ) = a_max·sin²(π·τ/T) over T = 2·Δv/a_max, so v is a raised-cosine blend and
///   the acceleration is continuous and 0 at both ends, jerk at most π·a_max/T =
///   π·a_max²/(2·Δv) (FANUC's bell-shaped acceleration/deceleration before interpolation).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RampShape {
    /// Constant acceleration: trapezoidal velocity profiles.
    Trapezoid,
    /// Jerk-limited S-curve (7 phases from rest to rest).
    #[default]
    JerkLimited,
    /// Bell (raised-cosine) speed blend, sin² acceleration.
    Bell,
}

/// One entry of the feed-override schedule (TOML `[[motion.override]]`): from `at_s` on the
/// override switch stands at `percent`. Before the first entry the override is 100 %.
///
/// The override scales the feed of feed moves (not rapids): a change that falls in the
/// constant-feed phase of a move changes the speed there with the configured ramp shape and
/// limits, the deceleration to the target starts where it must; a change during an
/// acceleration (or a speed change) takes effect when it ends, one during the final
/// deceleration, a dwell or a rapid with the next feed move, which starts at the overridden
/// feed. An increase that does not fit in the distance left gets the highest speed that fits.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FeedOverride {
    /// Time of the change (s from the start of the program, t = 0), ≥ 0, strictly increasing
    /// over the schedule.
    pub at_s: f64,
    /// Override (% of the programmed feed), in (0, 200].
    pub percent: f64,
}

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

/// A speed change of a feed move made by the feed override (in the truth).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FeedChange {
    /// Start of the speed transition (s).
    pub start_time_s: f64,
    /// End of the transition (s); the new speed holds from here until the next change or the
    /// final deceleration.
    pub end_time_s: f64,
    /// Speed before the change (mm/min).
    pub from_mm_min: f64,
    /// Speed after the change (mm/min): percent/100 × the programmed feed, or the highest
    /// speed that still lets the move stop at its target when that is lower.
    pub to_mm_min: f64,
    /// The override asked for (%).
    pub percent: f64,
}

/// A commanded move as planned, reported in the truth: every stroke of `[[motion.stroke]]`,
/// or every move of a program (also those that do not move the axis, with equal start and end
/// and zero duration).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CommandedStroke {
    /// Direction of travel (forward for a move of zero length).
    pub direction: Direction,
    /// Speed limit of the move along the axis (mm/min): the programmed axis feed of a feed
    /// move (before any feed override, see `start_override_percent` and `feed_changes`), the
    /// rapid rate of a rapid; 0 for a program move that does not move the axis and whose axis
    /// feed is unknown.
    pub feed_mm_min: f64,
    /// Start position (mm).
    pub start_mm: f64,
    /// End position (mm).
    pub end_mm: f64,
    /// Start of the acceleration (s).
    pub start_time_s: f64,
    /// End of the deceleration, before the dwell (s).
    pub end_time_s: f64,
    /// Start of the constant-feed phase (s): the end of the first acceleration.
    pub cruise_start_time_s: f64,
    /// End of the constant-feed phase (s): the start of the final deceleration. Override
    /// changes in between are listed in `feed_changes`.
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
    /// The feed override in force when the feed move started (%), when a schedule sets one:
    /// the move accelerates towards this share of `feed_mm_min`. `None` = 100 %.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start_override_percent: Option<f64>,
    /// The speed changes the feed override made within the constant-feed phase, in order.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub feed_changes: Vec<FeedChange>,
}

/// Kinematic limits of the planned path.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MotionLimits {
    /// Acceleration limit of feed moves (mm/s²), > 0.
    pub acceleration_mm_s2: f64,
    /// Jerk limit of [`RampShape::JerkLimited`] (mm/s³), > 0; `None` =
    /// [`DEFAULT_JERK_MM_S3`]. Not used by the other shapes (ignored, whatever it holds).
    pub jerk_mm_s3: Option<f64>,
    /// Rapid traverse rate (mm/min), > 0.
    pub rapid_rate_mm_min: f64,
    /// Acceleration limit of rapids (mm/s²), > 0.
    pub rapid_acceleration_mm_s2: f64,
    /// Shape of every speed change, feed moves and rapids (default jerk-limited).
    #[serde(default)]
    pub ramp: RampShape,
}

impl MotionLimits {
    /// The jerk limit in use (mm/s³): `jerk_mm_s3` or [`DEFAULT_JERK_MM_S3`] for a
    /// jerk-limited ramp, `None` for the other shapes.
    pub fn effective_jerk_mm_s3(&self) -> Option<f64> {
        match self.ramp {
            RampShape::JerkLimited => Some(self.jerk_mm_s3.unwrap_or(DEFAULT_JERK_MM_S3)),
            RampShape::Trapezoid | RampShape::Bell => None,
        }
    }
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

/// A speed change by `dv` ≥ 0 from rest: the closed forms S(τ), V(τ), A(τ) on [0, T] of the
/// ramp shape. A transition v₀ → v₁ is s = v₀·τ ± S(τ), v = v₀ ± V(τ), a = ±A(τ) with
/// Δv = |v₁ − v₀|; it covers (v₀ + v₁)·T/2 (every shape is point-symmetric about T/2).
#[derive(Debug, Clone, Copy)]
struct Ramp {
    shape: RampShape,
    /// speed change Δv (m/s)
    dv: f64,
    /// duration T (s)
    t: f64,
    /// peak acceleration (m/s²): a_max (trapezoid, bell), a_p ≤ a_max (S-curve)
    a: f64,
    /// S-curve: duration of each jerk phase (s) and the jerk (m/s³)
    tj: f64,
    j: f64,
}

impl Ramp {
    /// The transition of `shape` for a speed change `dv` (m/s) with the acceleration limit
    /// `a` (m/s²) and, for the S-curve, the jerk `j` (m/s³):
    /// trapezoid T = Δv/a; bell T = 2·Δv/a; S-curve with Δv·j ≥ a²: t_j = a/j, T = t_j + Δv/a,
    /// else t_j = √(Δv/j), T = 2·t_j, a_p = j·t_j.
    fn transition(shape: RampShape, dv: f64, a: f64, j: f64) -> Self {
        let (t, a, tj) = match shape {
            RampShape::Trapezoid => (dv / a, a, 0.0),
            RampShape::Bell => (2.0 * dv / a, a, 0.0),
            RampShape::JerkLimited if dv * j >= a * a => {
                let tj = a / j;
                (tj + dv / a, a, tj)
            }
            RampShape::JerkLimited => {
                let tj = (dv / j).sqrt();
                (2.0 * tj, j * tj, tj)
            }
        };
        Self {
            shape,
            dv,
            t,
            a,
            tj,
            j,
        }
    }

    /// The acceleration of a rest-to-rest move over `dist` (m) towards the feed `v` (m/s): the
    /// transition 0 → v if the move is long enough to reach v and stop again, else the one
    /// to the largest peak speed v_p that fits (accelerating and stopping cover 2·S(T) = dist):
    /// trapezoid v_p = √(a·dist), bell v_p = √(a·dist/2) (dist = v_p·T, T = 2·v_p/a), S-curve
    /// [`s_curve`].
    fn rest_to_rest(shape: RampShape, dist: f64, v: f64, a: f64, j: f64) -> Self {
        match shape {
            RampShape::Trapezoid if dist < v * v / a => {
                Self::transition(shape, (dist * a).sqrt(), a, j)
            }
            RampShape::Bell if dist < 2.0 * v * v / a => {
                Self::transition(shape, (0.5 * a * dist).sqrt(), a, j)
            }
            RampShape::JerkLimited => {
                let (tj, ap, t, vp) = s_curve(dist, v, a, j);
                Self {
                    shape,
                    dv: vp,
                    t,
                    a: ap,
                    tj,
                    j,
                }
            }
            _ => Self::transition(shape, v, a, j),
        }
    }

    /// Distance covered by the whole ramp from rest, S(T) (m).
    fn distance(&self) -> f64 {
        self.eval(self.t).0
    }

    /// (S, V, A) at `tau` ∈ [0, T] (clamped), from rest.
    ///
    /// - trapezoid: S = a·τ²/2, V = a·τ, A = a;
    /// - bell: A = a·sin²(πτ/T), V = (a/2)·(τ − (T/2π)·sin(2πτ/T)),
    ///   S = a·(τ²/4 − (T/2π)²·sin²(πτ/T));
    /// - S-curve: jerk +j for t_j (S = jτ³/6, V = jτ²/2, A = jτ), constant a_p
    ///   (S = s₁ + v₁u + a_p·u²/2, u = τ − t_j), and by the point symmetry
    ///   V(τ) + V(T − τ) = Δv: S = Δv·T/2 − Δv·w + j·w³/6, V = Δv − j·w²/2, A = j·w with
    ///   w = T − τ in the last phase.
    fn eval(&self, tau: f64) -> (f64, f64, f64) {
        let tau = tau.clamp(0.0, self.t);
        match self.shape {
            RampShape::Trapezoid => (0.5 * self.a * tau * tau, self.a * tau, self.a),
            RampShape::Bell => {
                if self.t <= 0.0 {
                    return (0.0, 0.0, 0.0);
                }
                let k = self.t / (2.0 * PI);
                let sn = (PI * tau / self.t).sin();
                (
                    self.a * (0.25 * tau * tau - k * k * sn * sn),
                    0.5 * self.a * (tau - k * (2.0 * PI * tau / self.t).sin()),
                    self.a * sn * sn,
                )
            }
            RampShape::JerkLimited => {
                let (j, tj, ap, dv, ta) = (self.j, self.tj, self.a, self.dv, self.t);
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
                        0.5 * dv * ta - dv * w + j * w * w * w / 6.0,
                        dv - 0.5 * j * w * w,
                        j * w,
                    )
                }
            }
        }
    }
}

/// What a piece of a move does.
#[derive(Debug, Clone, Copy)]
enum PieceKind {
    /// Speed transition from `v0` up (`up`) or down by the ramp's Δv.
    Ramp { v0: f64, up: bool, ramp: Ramp },
    /// Constant speed `v`, or modulated v·(1 + r·sin(2πu/period)) when `period > 0`.
    Cruise { v: f64, r: f64, period: f64 },
    /// The final deceleration to rest at the target: the mirror image of `ramp` (0 → v),
    /// s(t) = L − S(t_end − t).
    Stop { ramp: Ramp },
}

/// A piece of a move from `t0` (s), at the distance `s0` (m) from the start of the move.
#[derive(Debug, Clone, Copy)]
struct Piece {
    t0: f64,
    s0: f64,
    kind: PieceKind,
}

/// One planned move, SI: distance along the move s ≥ 0, z = z0 + sign·s.
#[derive(Debug, Clone)]
struct Segment {
    t0: f64,
    z0: f64,
    z1: f64,
    sign: f64,
    /// length L = |z1 − z0| (m)
    dist: f64,
    /// end of motion, end of dwell (s)
    t_end: f64,
    t_dwell_end: f64,
    /// in time order, the first starting at `t0`
    pieces: Vec<Piece>,
}

impl Segment {
    fn kinematics(&self, t: f64) -> Kinematics {
        if t >= self.t_end {
            return Kinematics {
                position_m: self.z1,
                ..Kinematics::default()
            };
        }
        if t <= self.t0 || self.pieces.is_empty() {
            return Kinematics {
                position_m: self.z0,
                ..Kinematics::default()
            };
        }
        let k = self.pieces.partition_point(|p| p.t0 <= t).max(1) - 1;
        let p = &self.pieces[k];
        let (s, v, a) = match p.kind {
            PieceKind::Ramp { v0, up, ramp } => {
                let u = t - p.t0;
                let (s, v, a) = ramp.eval(u);
                if up {
                    (p.s0 + v0 * u + s, v0 + v, a)
                } else {
                    (p.s0 + v0 * u - s, v0 - v, -a)
                }
            }
            PieceKind::Cruise { v, r, period } => {
                let u = t - p.t0;
                if period > 0.0 {
                    let w = 2.0 * PI / period;
                    (
                        p.s0 + v * u + v * r * (1.0 - (w * u).cos()) / w,
                        v * (1.0 + r * (w * u).sin()),
                        v * r * w * (w * u).cos(),
                    )
                } else {
                    (p.s0 + v * u, v, 0.0)
                }
            }
            PieceKind::Stop { ramp } => {
                let (s, v, a) = ramp.eval(self.t_end - t);
                (self.dist - s, v, -a)
            }
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

/// The override (%) in force at `t` (s): the last entry at or before `t`, else 100.
fn override_at(schedule: &[FeedOverride], t: f64) -> f64 {
    let k = schedule.partition_point(|o| o.at_s <= t);
    if k == 0 {
        100.0
    } else {
        schedule[k - 1].percent
    }
}

/// Whether two overrides or speeds differ by more than rounding (relative 1e-12).
fn differs(a: f64, b: f64) -> bool {
    (a - b).abs() > 1e-12 * a.abs().max(b.abs())
}

/// The pieces of one move, with its end and the times of the move's report.
struct MovePlan {
    pieces: Vec<Piece>,
    t_end: f64,
    cruise_start: f64,
    cruise_end: f64,
    changes: Vec<FeedChange>,
}

/// Shape, limits and what shapes the feed of one move.
struct MoveSpec<'a> {
    shape: RampShape,
    /// acceleration limit (m/s²), jerk limit (m/s³; unused but for the S-curve)
    a: f64,
    j: f64,
    /// programmed speed (m/s)
    feed: f64,
    /// override schedule (empty for rapids)
    schedule: &'a [FeedOverride],
    modulation: Option<&'a FeedModulation>,
}

/// Plan a move of length `dist` (m) from rest at `t0` (s) to rest at its target.
///
/// Steps: the override in force at `t0` sets the first target speed; accelerate towards it
/// (or to the largest peak that fits, then stop: a short move takes no override change);
/// then cruise, and at each override change (or, for changes during a speed transition, at
/// its end) change speed to the new target u if s + D(v → u) + S_stop(u) ≤ L, D = (v + u)·T/2
/// the distance of the transition, else to the speed closest to u that fits (bisection; the
/// current speed always fits); finally stop as the mirror image of the ramp 0 → v, starting
/// where the cruise reaches L − S_stop(v).
fn plan_move(t0: f64, dist: f64, m: &MoveSpec) -> MovePlan {
    let mut plan = MovePlan {
        pieces: Vec::new(),
        t_end: t0,
        cruise_start: t0,
        cruise_end: t0,
        changes: Vec::new(),
    };
    if dist <= 0.0 {
        return plan;
    }
    let (shape, a, j) = (m.shape, m.a, m.j);
    let mut applied = override_at(m.schedule, t0);
    let target = m.feed * applied / 100.0;
    let acc = Ramp::rest_to_rest(shape, dist, target, a, j);
    plan.pieces.push(Piece {
        t0,
        s0: 0.0,
        kind: PieceKind::Ramp {
            v0: 0.0,
            up: true,
            ramp: acc,
        },
    });
    let stop_dist = |v: f64| Ramp::transition(shape, v, a, j).distance();
    let mut v = acc.dv;
    let mut sc = acc.distance();
    let mut tc = t0 + acc.t;
    plan.cruise_start = tc;
    // a short move: stop at once (the stop's distance is the acceleration's, 2·S(T) = L)
    let reached = !differs(v, target);
    let stop = if reached {
        let mut t_seen = tc;
        let mut check_now = true;
        loop {
            let t_ce = tc + ((dist - stop_dist(v) - sc) / v).max(0.0);
            // the override now in force (set during the preceding speed change), else the
            // next change before the end of this cruise
            let p_now = override_at(m.schedule, tc);
            let event = if check_now && differs(p_now, applied) {
                Some((tc, p_now))
            } else {
                m.schedule
                    .iter()
                    .find(|o| o.at_s > t_seen && o.at_s < t_ce && differs(o.percent, applied))
                    .map(|o| (o.at_s, o.percent))
            };
            check_now = false;
            let Some((te, p)) = event else {
                break;
            };
            applied = p;
            t_seen = te;
            let se = sc + v * (te - tc);
            let fits = |u: f64| {
                let d = 0.5 * (v + u) * Ramp::transition(shape, (u - v).abs(), a, j).t;
                se + d + stop_dist(u) <= dist
            };
            let want = m.feed * p / 100.0;
            let u = if fits(want) {
                want
            } else {
                // lo fits, hi does not
                let (mut lo, mut hi) = (v, want);
                for _ in 0..100 {
                    let mid = 0.5 * (lo + hi);
                    if fits(mid) {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                lo
            };
            if (u - v).abs() <= 1e-9 * m.feed {
                // the speed cannot be changed in the distance left: keep it
                continue;
            }
            let ramp = Ramp::transition(shape, (u - v).abs(), a, j);
            if te > tc {
                plan.pieces.push(Piece {
                    t0: tc,
                    s0: sc,
                    kind: PieceKind::Cruise {
                        v,
                        r: 0.0,
                        period: 0.0,
                    },
                });
            }
            plan.pieces.push(Piece {
                t0: te,
                s0: se,
                kind: PieceKind::Ramp {
                    v0: v,
                    up: u > v,
                    ramp,
                },
            });
            plan.changes.push(FeedChange {
                start_time_s: te,
                end_time_s: te + ramp.t,
                from_mm_min: v * 60_000.0,
                to_mm_min: u * 60_000.0,
                percent: p,
            });
            sc = se + 0.5 * (v + u) * ramp.t;
            tc = te + ramp.t;
            v = u;
            t_seen = tc;
            check_now = true;
        }
        let t_ce = tc + ((dist - stop_dist(v) - sc) / v).max(0.0);
        let (r, period) = match m.modulation {
            Some(md) if md.relative_amplitude > 0.0 && plan.changes.is_empty() => {
                let n = ((t_ce - tc) / md.period_s).round();
                if n >= 1.0 && t_ce > tc {
                    (md.relative_amplitude, (t_ce - tc) / n)
                } else {
                    (0.0, 0.0)
                }
            }
            _ => (0.0, 0.0),
        };
        if t_ce > tc {
            plan.pieces.push(Piece {
                t0: tc,
                s0: sc,
                kind: PieceKind::Cruise { v, r, period },
            });
        }
        plan.cruise_end = t_ce;
        Ramp::transition(shape, v, a, j)
    } else {
        plan.cruise_end = tc;
        acc
    };
    plan.pieces.push(Piece {
        t0: plan.cruise_end,
        s0: dist - stop.distance(),
        kind: PieceKind::Stop { ramp: stop },
    });
    plan.t_end = plan.cruise_end + stop.t;
    plan
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
    /// Plan the strokes as trapezoids (constant acceleration, whatever the default ramp
    /// shape), without a feed override. Inputs are assumed validated (finite, feed and
    /// acceleration > 0).
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
        Self::plan_blocks(
            start_mm,
            &blocks,
            RampShape::Trapezoid,
            None,
            modulation,
            &[],
            lead_in_s,
            lead_out_s,
        )
    }

    /// Plan the strokes with `limits`, every speed change of the shape `limits.ramp`. Each
    /// stroke is a feed move from rest to rest at v_max = its feed (times the override of
    /// `overrides` in force) and a_max = `limits.acceleration_mm_s2`; for the jerk-limited
    /// shape with j_max = [`MotionLimits::effective_jerk_mm_s3`] the 7 phases are jerk +j, 0,
    /// −j (acceleration to v_p), cruise, jerk −j, 0, +j. Short moves that cannot reach v_max
    /// (or a_max) get the reduced profile with the largest peak speed that fits (see the
    /// simulator docs), solved exactly. `overrides` is the feed-override schedule
    /// ([`FeedOverride`], sorted by `at_s`; empty = 100 % throughout); the modulation applies
    /// only to moves whose constant-feed phase the override does not change. Inputs are
    /// assumed validated (finite, limits > 0, overrides > 0).
    pub fn plan_strokes(
        start_mm: f64,
        strokes: &[StrokeConfig],
        limits: &MotionLimits,
        modulation: Option<&FeedModulation>,
        overrides: &[FeedOverride],
        lead_in_s: f64,
        lead_out_s: f64,
    ) -> Self {
        let blocks = stroke_blocks(strokes, limits.acceleration_mm_s2);
        Self::plan_blocks(
            start_mm,
            &blocks,
            limits.ramp,
            limits.effective_jerk_mm_s3(),
            modulation,
            overrides,
            lead_in_s,
            lead_out_s,
        )
    }

    /// Plan an NC program from `start_mm`: every move with exact stop (at rest at its end),
    /// rapids at `limits.rapid_rate_mm_min` and `limits.rapid_acceleration_mm_s2`, feed moves at
    /// their axis feed and `limits.acceleration_mm_s2`, dwells as standstill (a dwell before
    /// the first move lengthens the lead-in). Every speed change has the shape
    /// `limits.ramp`. The modulation and the feed override `overrides` apply to feed moves
    /// only (as in [`NcPath::plan_strokes`]). Moves that do not move the axis take no time
    /// (the twin models this axis only).
    ///
    /// # Errors
    /// [`NcError`] (source `program`) naming the line of a move along the axis whose axis feed
    /// is unknown or zero ([`crate::nc::NcStep::Move`]).
    pub fn plan_program(
        start_mm: f64,
        program: &NcProgram,
        limits: &MotionLimits,
        modulation: Option<&FeedModulation>,
        overrides: &[FeedOverride],
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
            limits.ramp,
            limits.effective_jerk_mm_s3(),
            modulation,
            overrides,
            lead_in_s,
            lead_out_s,
        ))
    }

    #[allow(clippy::too_many_arguments)]
    fn plan_blocks(
        start_mm: f64,
        blocks: &[Block],
        shape: RampShape,
        jerk_mm_s3: Option<f64>,
        modulation: Option<&FeedModulation>,
        overrides: &[FeedOverride],
        lead_in_s: f64,
        lead_out_s: f64,
    ) -> Self {
        let jerk = jerk_mm_s3.map_or(0.0, |j| j * 1e-3);
        let mut t = lead_in_s;
        let mut z = start_mm * 1e-3;
        let mut segments = Vec::with_capacity(blocks.len());
        let mut out = Vec::with_capacity(blocks.len());
        for s in blocks {
            let z1 = s.to_mm * 1e-3;
            let dist = (z1 - z).abs();
            let feed_move = s.kind == MoveKind::Feed;
            let spec = MoveSpec {
                shape,
                a: s.accel_mm_s2 * 1e-3,
                j: jerk,
                feed: feed_mm_min_to_m_s(s.speed_mm_min),
                schedule: if feed_move { overrides } else { &[] },
                modulation: if feed_move { modulation } else { None },
            };
            let mv = plan_move(t, dist, &spec);
            let start_override = override_at(spec.schedule, t);
            let sign = if z1 >= z { 1.0 } else { -1.0 };
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
                end_time_s: mv.t_end,
                cruise_start_time_s: mv.cruise_start,
                cruise_end_time_s: mv.cruise_end,
                kind: s.kind,
                line: s.line,
                block_number: s.block_number,
                start_override_percent: (dist > 0.0 && differs(start_override, 100.0))
                    .then_some(start_override),
                feed_changes: mv.changes,
            });
            segments.push(Segment {
                t0: t,
                z0: z,
                z1,
                sign,
                dist,
                t_end: mv.t_end,
                t_dwell_end: mv.t_end + s.dwell_s,
                pieces: mv.pieces,
            });
            t = mv.t_end + s.dwell_s;
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
            ramp: RampShape::JerkLimited,
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
        let p = NcPath::plan_strokes(5.0, &strokes, &lim, None, &[], 0.3, 0.4);
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

    /// The distance (m, signed) the speed of `p` integrates to over stroke `s`, by the
    /// trapezoidal rule with steps of about `h_s` (s): a slow reference independent of the
    /// closed-form positions.
    fn integrated_distance_m(p: &NcPath, s: &CommandedStroke, h_s: f64) -> f64 {
        let n = ((s.end_time_s - s.start_time_s) / h_s).ceil().max(1.0) as usize;
        let h = (s.end_time_s - s.start_time_s) / n as f64;
        let mut dist = 0.0;
        let mut prev = p.kinematics(s.start_time_s).velocity_m_s;
        for k in 1..=n {
            let v = p.kinematics(s.start_time_s + k as f64 * h).velocity_m_s;
            dist += 0.5 * h * (prev + v);
            prev = v;
        }
        dist
    }

    /// The distance covered is the integral of the speed (trapezoidal rule over 1 µs, a
    /// slow reference independent of the closed-form positions).
    #[test]
    fn s_curve_speed_integrates_to_the_distance() {
        let p = NcPath::plan_strokes(5.0, &s_strokes(), &limits(), None, &[], 0.0, 0.0);
        for s in p.strokes() {
            let dist = integrated_distance_m(&p, s, 1e-6);
            // error of the trapezoidal rule: T·h²/12·max|z'''| ≤ 2 s·1e-12/12·20
            assert!(
                (dist * 1e3 - (s.end_mm - s.start_mm)).abs() < 1e-6,
                "{s:?}: {}",
                dist * 1e3
            );
        }
    }

    /// The trapezoid ramp of `plan_strokes` is `plan`, to the bit (its jerk is ignored).
    #[test]
    fn trapezoid_ramp_is_plan() {
        let lim = MotionLimits {
            ramp: RampShape::Trapezoid,
            ..limits()
        };
        let a = NcPath::plan_strokes(5.0, &s_strokes(), &lim, None, &[], 0.3, 0.4);
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

    /// Limits of the ramp-shape tests: a_max = 1.5 m/s², j_max = 20 m/s³.
    fn shape_limits(ramp: RampShape) -> MotionLimits {
        MotionLimits { ramp, ..limits() }
    }

    const SHAPES: [RampShape; 3] = [
        RampShape::Trapezoid,
        RampShape::JerkLimited,
        RampShape::Bell,
    ];

    /// A long move reaching its feed (100 mm at 6000 mm/min = 0.1 m/s; the S-curve needs
    /// 0.1·(0.075 + 0.067) = 14 mm to reach it), a short one that cannot (2 mm at
    /// 12 000 mm/min: the trapezoid would need 26.7 mm), and a long one backwards, each on its
    /// own (start position, stroke).
    fn shape_cases() -> [(f64, StrokeConfig); 3] {
        [
            (5.0, stroke(105.0, 6000.0, 0.2)),
            (105.0, stroke(107.0, 12_000.0, 0.2)),
            (107.0, stroke(7.0, 6000.0, 0.3)),
        ]
    }

    /// Jerk bound of one move from the speed changes it makes: j_max for the S-curve; for the
    /// bell the largest of π·a_max/T = π·a_max²/(2·Δv) over its transitions (the start from
    /// rest to v₀, each override change, the stop from the last speed); `None` for the
    /// trapezoid (z'' jumps).
    fn jerk_bound(shape: RampShape, a_max: f64, j_max: f64, dvs: &[f64]) -> Option<f64> {
        match shape {
            RampShape::Trapezoid => None,
            RampShape::JerkLimited => Some(j_max),
            RampShape::Bell => {
                let dv = dvs.iter().copied().fold(f64::INFINITY, f64::min);
                Some(PI * a_max * a_max / (2.0 * dv))
            }
        }
    }

    /// The checks every planned path must pass: each move ends at its target to the bit and
    /// at rest (also within its dwell); z' and z'' are the derivatives of z; |z''| ≤ a_max;
    /// with a jerk bound z'' is continuous with its slope within the bound; the distance is
    /// the integral of the speed. `jerk` is the bound (None: z'' may jump, trapezoid).
    fn check_path(p: &NcPath, a_max: f64, jerk: Option<f64>, what: &str) {
        let m = p.strokes();
        for (i, s) in m.iter().enumerate() {
            // at the end and in the middle of the standstill (dwell) after it
            let next = m.get(i + 1).map_or(p.duration_s(), |n| n.start_time_s);
            for t in [s.end_time_s, 0.5 * (s.end_time_s + next)] {
                let k = p.kinematics(t);
                assert_eq!(
                    k.position_m.to_bits(),
                    (s.end_mm * 1e-3).to_bits(),
                    "{what}: {s:?}"
                );
                assert!(k.velocity_m_s == 0.0 && k.accel_m_s2 == 0.0, "{what}");
            }
        }
        let h = 1e-6;
        let n = 100_000;
        let mut peak_a: f64 = 0.0;
        for k in 1..n {
            let t = p.duration_s() * k as f64 / n as f64;
            let (a, b, c) = (p.kinematics(t - h), p.kinematics(t), p.kinematics(t + h));
            // z' against the central difference of z: the error is h²/6·|z'''| (at most
            // 3e-11 m/s for the steepest bell jerk here, 180 m/s³) plus the rounding of
            // z ≈ 0.1 m (1e-17/h); where z'' jumps (trapezoid) z is only C¹ and the
            // difference errs by up to |Δz''|·h/2 ≤ a_max·h
            let v = (c.position_m - a.position_m) / (2.0 * h);
            let tol_v = if jerk.is_some() {
                1e-8
            } else {
                a_max * h + 1e-8
            };
            assert!((v - b.velocity_m_s).abs() < tol_v, "{what}: t = {t}");
            let jump = (c.accel_m_s2 - a.accel_m_s2).abs();
            match jerk {
                Some(j) => {
                    // z' is C¹ with |z'''| ≤ j: the difference errs by at most j·h (at a
                    // switch of the jerk), and z'' changes over 2h by at most 2h·j
                    let acc = (c.velocity_m_s - a.velocity_m_s) / (2.0 * h);
                    assert!(
                        (acc - b.accel_m_s2).abs() < j * h + 1e-7,
                        "{what}: t = {t}: {acc} {b:?}"
                    );
                    assert!(
                        jump / (2.0 * h) <= j * (1.0 + 1e-6) + 1e-6,
                        "{what}: t = {t}: jerk {} > {j}",
                        jump / (2.0 * h)
                    );
                }
                None if jump < 1e-9 => {
                    // constant z'' over [t − h, t + h]: z' is linear there, the difference
                    // exact up to rounding (1e-16/h)
                    let acc = (c.velocity_m_s - a.velocity_m_s) / (2.0 * h);
                    assert!((acc - b.accel_m_s2).abs() < 1e-8, "{what}: t = {t}");
                }
                None => {}
            }
            assert!(
                b.accel_m_s2.abs() <= a_max * (1.0 + 1e-12),
                "{what}: t = {t}"
            );
            peak_a = peak_a.max(b.accel_m_s2.abs());
        }
        // the limit is used, not just respected (the 2 mm S-curve reaches only
        // a_p = j·(L/(2j))^⅓ = 0.74 m/s²)
        assert!(peak_a > 0.45 * a_max, "{what}: {peak_a}");
        for s in p.strokes() {
            let dist = integrated_distance_m(p, s, 1e-5);
            // trapezoidal rule: error ≤ T·h²/12·max|z'''| ≤ 2 s·1e-10 s²/12·180 m/s³ =
            // 3e-9 m, plus |Δz''|·h²/8 per jump of z''; 1e-5 mm = 1e-8 m
            assert!(
                (dist * 1e3 - (s.end_mm - s.start_mm)).abs() < 1e-5,
                "{what}: {s:?}: {}",
                dist * 1e3
            );
        }
    }

    /// The speed changes of a move (m/s) for the bell's jerk bound: from rest to the first
    /// speed, every override change, and the stop from the last speed; a short move's peak is
    /// the largest sampled speed (below the true peak, so the bound is if anything larger).
    fn speed_changes(p: &NcPath, s: &CommandedStroke) -> Vec<f64> {
        let feed = feed_mm_min_to_m_s(s.feed_mm_min);
        if s.cruise_end_time_s - s.cruise_start_time_s <= 0.0 {
            let peak = (0..=1000)
                .map(|k| {
                    let t = s.start_time_s + (s.end_time_s - s.start_time_s) * k as f64 / 1000.0;
                    p.kinematics(t).velocity_m_s.abs()
                })
                .fold(0.0, f64::max);
            return vec![peak];
        }
        let v0 = feed * s.start_override_percent.unwrap_or(100.0) / 100.0;
        let mut dvs = vec![v0];
        let mut last = v0;
        for c in &s.feed_changes {
            dvs.push((c.to_mm_min - c.from_mm_min).abs() / 60_000.0);
            last = c.to_mm_min / 60_000.0;
        }
        dvs.push(last);
        dvs
    }

    /// Every shape × {long, short, backwards} without an override: the checks of
    /// [`check_path`], the feed reached on the long moves and not on the short one, and
    /// the closed-form durations of the trapezoid (L/v + v/a) and the bell (L/v + 2v/a;
    /// short: 2·T with v_p = √(a·L/2), T = 2·v_p/a).
    #[test]
    fn every_shape_reaches_its_targets_without_override() {
        let (a_max, j_max) = (1.5, 20.0);
        for shape in SHAPES {
            for (k, (z0, st)) in shape_cases().into_iter().enumerate() {
                let lim = shape_limits(shape);
                let p =
                    NcPath::plan_strokes(z0, std::slice::from_ref(&st), &lim, None, &[], 0.3, 0.4);
                let s = &p.strokes()[0];
                let what = format!("{shape:?} case {k}");
                let j = jerk_bound(shape, a_max, j_max, &speed_changes(&p, s));
                check_path(&p, a_max, j, &what);
                let l = (st.to_mm - z0).abs() * 1e-3;
                let v = feed_mm_min_to_m_s(st.feed_mm_min);
                let d = s.end_time_s - s.start_time_s;
                let cruise = s.cruise_end_time_s - s.cruise_start_time_s;
                let expect = match (shape, k) {
                    (RampShape::Trapezoid, 1) => Some(2.0 * (l / a_max).sqrt()),
                    (RampShape::Trapezoid, _) => Some(l / v + v / a_max),
                    (RampShape::Bell, 1) => Some(2.0 * 2.0 * (a_max * l / 2.0).sqrt() / a_max),
                    (RampShape::Bell, _) => Some(l / v + 2.0 * v / a_max),
                    _ => None,
                };
                if let Some(e) = expect {
                    assert!((d - e).abs() < 1e-12, "{what}: {d} {e}");
                }
                if k == 1 {
                    assert!(cruise.abs() < 1e-12, "{what}");
                } else {
                    assert!(cruise > 0.5, "{what}");
                    let mid = 0.5 * (s.cruise_start_time_s + s.cruise_end_time_s);
                    let vm = p.kinematics(mid).velocity_m_s.abs();
                    assert!((vm - v).abs() < 1e-15, "{what}");
                }
            }
        }
    }

    /// The override schedule of a move from its cruise window [c0, c1] without override:
    /// 80 % during the acceleration (takes effect at its end), 150 % at 20 % of the window,
    /// 60 % at 50 % (the increase has shortened the move, this still falls in its cruise).
    fn schedule(s: &CommandedStroke) -> Vec<FeedOverride> {
        let (c0, c1) = (s.cruise_start_time_s, s.cruise_end_time_s);
        vec![
            FeedOverride {
                at_s: 0.5 * (s.start_time_s + c0),
                percent: 80.0,
            },
            FeedOverride {
                at_s: c0 + 0.2 * (c1 - c0),
                percent: 150.0,
            },
            FeedOverride {
                at_s: c0 + 0.5 * (c1 - c0),
                percent: 60.0,
            },
        ]
    }

    /// Every shape × {long, short, backwards} with an override schedule that lowers the
    /// feed during the acceleration, raises it and lowers it mid-cruise: the checks of
    /// [`check_path`]; each change reaches percent/100 × the programmed feed and holds it;
    /// the truth keeps the programmed feed; the short move makes no change.
    #[test]
    fn every_shape_follows_the_override_schedule() {
        let (a_max, j_max) = (1.5, 20.0);
        for shape in SHAPES {
            for (k, (z0, st)) in shape_cases().into_iter().enumerate() {
                let lim = shape_limits(shape);
                let plain =
                    NcPath::plan_strokes(z0, std::slice::from_ref(&st), &lim, None, &[], 0.3, 0.4);
                let sched = schedule(&plain.strokes()[0]);
                let p = NcPath::plan_strokes(
                    z0,
                    std::slice::from_ref(&st),
                    &lim,
                    None,
                    &sched,
                    0.3,
                    0.4,
                );
                let s = &p.strokes()[0];
                let what = format!("{shape:?} case {k}");
                assert_eq!(s.feed_mm_min.to_bits(), st.feed_mm_min.to_bits(), "{what}");
                assert_eq!(s.start_override_percent, None, "{what}");
                let j = jerk_bound(shape, a_max, j_max, &speed_changes(&p, s));
                check_path(&p, a_max, j, &what);
                if k == 1 {
                    assert!(s.feed_changes.is_empty(), "{what}");
                    let e = plain.strokes()[0].end_time_s;
                    assert_eq!(s.end_time_s.to_bits(), e.to_bits(), "{what}");
                    continue;
                }
                let pct: Vec<f64> = s.feed_changes.iter().map(|c| c.percent).collect();
                assert!(
                    pct.len() == 3
                        && pct
                            .iter()
                            .zip([80.0, 150.0, 60.0])
                            .all(|(a, b)| (a - b).abs() < 1e-12),
                    "{what}: {pct:?}"
                );
                // the change during the acceleration starts when the acceleration ends
                let c0 = &s.feed_changes[0];
                assert_eq!(c0.start_time_s.to_bits(), s.cruise_start_time_s.to_bits());
                for (c, o) in s.feed_changes.iter().zip(&sched).skip(1) {
                    assert_eq!(c.start_time_s.to_bits(), o.at_s.to_bits(), "{what}");
                }
                for c in &s.feed_changes {
                    let want = st.feed_mm_min * c.percent / 100.0;
                    assert!((c.to_mm_min - want).abs() < 1e-9 * want, "{what}: {c:?}");
                    // the new speed holds right after the transition
                    let v = p.kinematics(c.end_time_s + 1e-6).velocity_m_s.abs() * 60_000.0;
                    assert!((v - want).abs() < 1e-9 * want, "{what}: {v} {want}");
                    assert!(c.end_time_s > c.start_time_s, "{what}");
                }
                // the last speed holds up to the start of the deceleration
                let v = p.kinematics(s.cruise_end_time_s - 1e-6).velocity_m_s.abs() * 60_000.0;
                let want = 0.6 * st.feed_mm_min;
                assert!((v - want).abs() < 1e-9 * want, "{what}: {v}");
                assert!(s.cruise_end_time_s > s.feed_changes[2].end_time_s, "{what}");
            }
        }
    }

    /// An increase to 200 % shortly before the deceleration must begin does not fit: the move
    /// gets the highest speed that still stops at its target (above the old one, below the
    /// asked one) and decelerates at once; when not even that fits (1 µs before, S-curve:
    /// a speed change Δv needs about 2v·√(Δv/j) more distance) the speed is kept.
    #[test]
    fn an_increase_that_does_not_fit_gets_the_highest_speed_that_does() {
        let (a_max, j_max) = (1.5, 20.0);
        for shape in SHAPES {
            for (k, (z0, st)) in shape_cases().into_iter().enumerate() {
                let lim = shape_limits(shape);
                let plain =
                    NcPath::plan_strokes(z0, std::slice::from_ref(&st), &lim, None, &[], 0.3, 0.4);
                let c1 = plain.strokes()[0].cruise_end_time_s;
                let sched = [FeedOverride {
                    at_s: c1 - 0.05,
                    percent: 200.0,
                }];
                let p = NcPath::plan_strokes(
                    z0,
                    std::slice::from_ref(&st),
                    &lim,
                    None,
                    &sched,
                    0.3,
                    0.4,
                );
                let s = &p.strokes()[0];
                let what = format!("{shape:?} case {k}");
                let j = jerk_bound(shape, a_max, j_max, &speed_changes(&p, s));
                check_path(&p, a_max, j, &what);
                if k == 1 {
                    assert!(s.feed_changes.is_empty(), "{what}");
                    continue;
                }
                assert_eq!(s.feed_changes.len(), 1, "{what}");
                let c = &s.feed_changes[0];
                assert!(
                    c.to_mm_min > st.feed_mm_min && c.to_mm_min < 2.0 * st.feed_mm_min,
                    "{what}: {c:?}"
                );
                // the highest speed that fits: the deceleration follows the transition at
                // once (the bisection leaves a cruise of rounding size)
                assert!(s.cruise_end_time_s - c.end_time_s < 1e-9, "{what}: {s:?}");
                let v = p.kinematics(c.end_time_s).velocity_m_s.abs() * 60_000.0;
                assert!((v - c.to_mm_min).abs() < 1e-6 * v, "{what}");
                assert!(s.end_time_s < plain.strokes()[0].end_time_s, "{what}");

                let late = [FeedOverride {
                    at_s: c1 - 1e-6,
                    percent: 200.0,
                }];
                let q = NcPath::plan_strokes(
                    z0,
                    std::slice::from_ref(&st),
                    &lim,
                    None,
                    &late,
                    0.3,
                    0.4,
                );
                let qs = &q.strokes()[0];
                if shape == RampShape::JerkLimited {
                    assert!(qs.feed_changes.is_empty(), "{what}");
                    let e = plain.strokes()[0].end_time_s;
                    assert_eq!(qs.end_time_s.to_bits(), e.to_bits(), "{what}");
                }
                let j = jerk_bound(shape, a_max, j_max, &speed_changes(&q, qs));
                check_path(&q, a_max, j, &what);
            }
        }
    }

    /// A move that starts under an override starts at the overridden feed; rapids ignore the
    /// override; a change during a dwell takes effect with the next feed move.
    #[test]
    fn overrides_apply_from_the_next_move_and_not_to_rapids() {
        let prog = NcProgram::parse(
            "G21 G90 G94 G61\nG01 Z20. F600\nG04 P500\nG00 Z40.\nG01 Z10. F600\n",
            &crate::nc::ParseOptions::default(),
        )
        .unwrap();
        for shape in SHAPES {
            let lim = shape_limits(shape);
            // 50 % from within the lead-in on; 120 % in the dwell after the first move
            let half = [FeedOverride {
                at_s: 0.1,
                percent: 50.0,
            }];
            let first = NcPath::plan_program(0.0, &prog, &lim, None, &half, 0.3, 0.4).unwrap();
            let sched = [
                half[0],
                FeedOverride {
                    at_s: first.strokes()[0].end_time_s + 0.25,
                    percent: 120.0,
                },
            ];
            let p = NcPath::plan_program(0.0, &prog, &lim, None, &sched, 0.3, 0.4).unwrap();
            let m = p.strokes();
            let what = format!("{shape:?}");
            assert_eq!(m[0].start_override_percent, Some(50.0), "{what}");
            assert!(m[0].feed_changes.is_empty(), "{what}");
            let mid = 0.5 * (m[0].cruise_start_time_s + m[0].cruise_end_time_s);
            let v = p.kinematics(mid).velocity_m_s * 60_000.0;
            assert!((v - 300.0).abs() < 1e-9, "{what}: {v}");
            assert_eq!(m[0].feed_mm_min.to_bits(), 600.0f64.to_bits());
            // the rapid: no override
            assert_eq!(m[1].kind, MoveKind::Rapid);
            assert_eq!(m[1].start_override_percent, None, "{what}");
            assert_eq!(m[2].start_override_percent, Some(120.0), "{what}");
            let mid = 0.5 * (m[2].cruise_start_time_s + m[2].cruise_end_time_s);
            let v = p.kinematics(mid).velocity_m_s * 60_000.0;
            assert!((v + 720.0).abs() < 1e-9, "{what}: {v}");
            // the bell's steepest jerk is on its smallest speed change: the 15 m/min rapid
            // over 20 mm does not reach its rate, so the smallest is the 300 mm/min feed
            let j = jerk_bound(shape, 1.5, 20.0, &[0.005]);
            check_path(&p, 1.5, j, &what);
        }
    }

    /// The sinusoidal modulation keeps working with every shape: the move ends at its
    /// target to the bit, z' is the derivative of z, and the cruise speed is modulated.
    #[test]
    fn modulation_works_with_every_shape() {
        let m = FeedModulation {
            relative_amplitude: 0.3,
            period_s: 0.2,
        };
        for shape in SHAPES {
            let (z0, st) = shape_cases()[0].clone();
            let lim = shape_limits(shape);
            let p = NcPath::plan_strokes(z0, &[st], &lim, Some(&m), &[], 0.3, 0.4);
            let s = &p.strokes()[0];
            let k = p.kinematics(s.end_time_s);
            assert_eq!(k.position_m.to_bits(), (s.end_mm * 1e-3).to_bits());
            let (c0, c1) = (s.cruise_start_time_s, s.cruise_end_time_s);
            let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
            let h = 1e-6;
            for i in 1..10_000 {
                let t = c0 + (c1 - c0) * i as f64 / 10_000.0;
                let (a, b, c) = (p.kinematics(t - h), p.kinematics(t), p.kinematics(t + h));
                let v = (c.position_m - a.position_m) / (2.0 * h);
                // h²/6·|z'''| with |z'''| = v·r·w² ≤ 0.1·0.3·1000 = 30 m/s³
                assert!((v - b.velocity_m_s).abs() < 1e-8, "{shape:?}: t = {t}");
                lo = lo.min(b.velocity_m_s);
                hi = hi.max(b.velocity_m_s);
            }
            assert!(lo < 0.071 && hi > 0.129, "{shape:?}: {lo} {hi}");
        }
    }
}
