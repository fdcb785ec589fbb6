//! Dynamics of the simulated drive: the plant of paper 000 Eq. 5 under ideal inverse dynamics
//! or a cascaded servo loop, evaluated at requested instants.
//!
//! Plant (Eq. 5, friction signed as in [`super::friction`]):
//! m_eq·z'' + b_eq·z' = K·i − F_f(z, z'), with m_eq = m_t + 4π²J/p², b_eq = 4π²B/p² and
//! K = (2π/p)·k_e (N per A). In servo mode the current is a state that follows its command
//! with a first-order lag, i' = (i_cmd − i)/τ.

use super::config::DynamicsConfig;
use super::friction::FrictionModel;
use super::motion::MotionProfile;
use super::SimError;
use crate::axis::AxisParams;

/// The true state at one instant.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StateSample {
    /// Time (s).
    pub time_s: f64,
    /// Table position z (m).
    pub position_m: f64,
    /// Table velocity z' (m/s).
    pub velocity_m_s: f64,
    /// Table acceleration z'' (m/s²), from Eq. 5 at this state.
    pub accel_m_s2: f64,
    /// Friction F_f(z, z') (N), signed.
    pub friction_n: f64,
    /// Motor current i (A); the motor force on the table is K·i.
    pub current_a: f64,
    /// Commanded position (m).
    pub commanded_position_m: f64,
    /// Commanded velocity (m/s).
    pub commanded_velocity_m_s: f64,
}

/// Counters of a run.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RunStats {
    /// Controller steps (servo mode; 0 in ideal mode).
    pub control_steps: u64,
    /// RK4 steps including stiffness sub-steps.
    pub integration_steps: u64,
    /// Largest |z − z_cmd| over the integration grid (m).
    pub max_following_error_m: f64,
}

/// The rigid plant of Eq. 5.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Plant<'a> {
    /// m_eq (kg)
    pub m: f64,
    /// b_eq (N·s/m)
    pub b: f64,
    /// K = (2π/p)·k_e (N/A)
    pub k: f64,
    pub friction: &'a FrictionModel,
}

impl<'a> Plant<'a> {
    pub fn new(axis: &AxisParams, friction: &'a FrictionModel) -> Self {
        Self {
            m: axis.equivalent_mass_kg(),
            b: axis.equivalent_damping_n_s_per_m(),
            k: axis.force_per_torque_n_per_nm() * axis.torque_constant_nm_per_a,
            friction,
        }
    }

    /// z'' from Eq. 5.
    fn accel(&self, z: f64, v: f64, i: f64) -> f64 {
        (self.k * i - self.b * v - self.friction.friction_n(z, v)) / self.m
    }

    /// Inverse dynamics of Eq. 5: i = (m_eq·z'' + b_eq·z' + F_f(z, z'))/K.
    pub fn inverse_current_a(&self, z: f64, v: f64, a: f64) -> f64 {
        (self.m * a + self.b * v + self.friction.friction_n(z, v)) / self.k
    }
}

/// Ideal mode: the table follows `profile` exactly; the state at each requested instant, with
/// the current from the inverse dynamics of Eq. 5.
pub(crate) fn run_ideal(
    plant: &Plant,
    profile: &dyn MotionProfile,
    requests: &[&[f64]],
    progress: &mut dyn FnMut(f64),
) -> (Vec<Vec<StateSample>>, RunStats) {
    let total: usize = requests.iter().map(|r| r.len()).sum::<usize>().max(1);
    let mut done = 0usize;
    let mut out = Vec::with_capacity(requests.len());
    for times in requests {
        let mut states = Vec::with_capacity(times.len());
        for &t in *times {
            let k = profile.kinematics(t);
            let (z, v, a) = (k.position_m, k.velocity_m_s, k.accel_m_s2);
            states.push(StateSample {
                time_s: t,
                position_m: z,
                velocity_m_s: v,
                accel_m_s2: a,
                friction_n: plant.friction.friction_n(z, v),
                current_a: plant.inverse_current_a(z, v, a),
                commanded_position_m: z,
                commanded_velocity_m_s: v,
            });
            done += 1;
            if done.is_multiple_of(4096) {
                progress(done as f64 / total as f64);
            }
        }
        out.push(states);
    }
    progress(1.0);
    (out, RunStats::default())
}

/// Integrated state: position, velocity, current (and the PI integrator outside).
#[derive(Debug, Clone, Copy)]
struct X {
    z: f64,
    v: f64,
    i: f64,
}

/// One integration step [t0, t1] with the state and its derivative at both ends (the end
/// derivative with the current command of this step, i.e. the left limit).
struct Span {
    t0: f64,
    t1: f64,
    x0: X,
    d0: X,
    x1: X,
    d1: X,
}

impl Span {
    /// Cubic Hermite interpolation of the state at `t` in [t0, t1].
    fn at(&self, t: f64) -> X {
        let hs = self.t1 - self.t0;
        let th = if hs > 0.0 {
            ((t - self.t0) / hs).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let (t2, t3) = (th * th, th * th * th);
        let (h00, h10, h01, h11) = (
            2.0 * t3 - 3.0 * t2 + 1.0,
            (t3 - 2.0 * t2 + th) * hs,
            -2.0 * t3 + 3.0 * t2,
            (t3 - t2) * hs,
        );
        let herm = |p0: f64, m0: f64, p1: f64, m1: f64| h00 * p0 + h10 * m0 + h01 * p1 + h11 * m1;
        X {
            z: herm(self.x0.z, self.d0.z, self.x1.z, self.d1.z),
            v: herm(self.x0.v, self.d0.v, self.x1.v, self.d1.v),
            i: herm(self.x0.i, self.d0.i, self.x1.i, self.d1.i),
        }
    }
}

/// The requested instants (sorted lists) and the states found for them so far.
struct Collector<'r> {
    requests: &'r [&'r [f64]],
    cursor: Vec<usize>,
    out: Vec<Vec<StateSample>>,
}

impl<'r> Collector<'r> {
    fn new(requests: &'r [&'r [f64]]) -> Self {
        Self {
            requests,
            cursor: vec![0; requests.len()],
            out: requests
                .iter()
                .map(|r| Vec::with_capacity(r.len()))
                .collect(),
        }
    }

    /// Record every requested instant up to `span.t1` (all remaining ones if `all`).
    fn take(&mut self, span: &Span, plant: &Plant, profile: &dyn MotionProfile, all: bool) {
        for (r, times) in self.requests.iter().enumerate() {
            let c = &mut self.cursor[r];
            while *c < times.len() && (all || times[*c] <= span.t1) {
                let te = times[*c];
                let x = span.at(te);
                let cmd = profile.kinematics(te);
                self.out[r].push(StateSample {
                    time_s: te,
                    position_m: x.z,
                    velocity_m_s: x.v,
                    accel_m_s2: plant.accel(x.z, x.v, x.i),
                    friction_n: plant.friction.friction_n(x.z, x.v),
                    current_a: x.i,
                    commanded_position_m: cmd.position_m,
                    commanded_velocity_m_s: cmd.velocity_m_s,
                });
                *c += 1;
            }
        }
    }
}

/// Most RK4 sub-steps per control step: beyond, h·λ of the stiff friction cannot be brought
/// below 1 and the integration is not stable.
const MAX_SUB_STEPS: f64 = 10_000.0;

/// Most RK4 steps a servo run may need in the worst case (every control step as stiff as at
/// rest), unless that is at most 16 per control step: about 5 minutes of integration.
pub const MAX_INTEGRATION_STEPS: f64 = 5e8;

/// Sub-steps at rest up to which a run is never refused for its worst case (the default
/// lathe axis needs 4).
const ORDINARY_SUB_STEPS: f64 = 16.0;

/// The servo run's work, known before it starts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct WorkBound {
    /// Bound of |F_f| over the run (N).
    pub friction_bound_n: f64,
    /// Control steps.
    pub control_steps: u64,
    /// Most RK4 sub-steps of one control step (at rest, where the smooth sign is stiffest).
    pub sub_steps_max: f64,
}

impl WorkBound {
    /// Of the run of `profile` on `plant` with `dyn_cfg`.
    pub(crate) fn of(plant: &Plant, dyn_cfg: &DynamicsConfig, profile: &dyn MotionProfile) -> Self {
        let duration_s = profile.duration_s();
        let h = dyn_cfg.step_ms * 1e-3;
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        let mut vmax = 0.0f64;
        let probes = 1000;
        for k in 0..=probes {
            let c = profile.kinematics(duration_s * k as f64 / probes as f64);
            lo = lo.min(c.position_m);
            hi = hi.max(c.position_m);
            vmax = vmax.max(c.velocity_m_s.abs());
        }
        let friction_bound_n = plant.friction.magnitude_bound_n(lo, hi, 2.0 * vmax + 1.0);
        let sub_steps_max = (h
            * (lam_base(plant, dyn_cfg)
                + friction_bound_n / (plant.m * plant.friction.sign_smoothing_m_s())))
        .ceil()
        .max(1.0);
        Self {
            friction_bound_n,
            // + 1: t advances by sums of h, whose rounding can leave a last sliver of a step
            // (found by the `sim_run` fuzz target: 2001 steps for 0.2 s at 0.1 ms)
            control_steps: (duration_s / h).ceil() as u64 + 1,
            sub_steps_max,
        }
    }

    /// Most RK4 steps of the whole run.
    pub(crate) fn integration_steps_max(&self) -> f64 {
        self.control_steps as f64 * self.sub_steps_max
    }

    /// [`SimError::TooStiff`] when the integration cannot be stable or the worst case exceeds
    /// [`MAX_INTEGRATION_STEPS`].
    pub(crate) fn check(&self, plant: &Plant) -> Result<(), SimError> {
        let worst = self.integration_steps_max();
        // A drive stiff only as the default one (a few sub-steps at rest) costs a small
        // multiple of its control steps, which the run's length already bounds: only a
        // stiffer one is held to MAX_INTEGRATION_STEPS (a 5 mm/min test over the whole travel
        // is 10⁸ control steps, 4·10⁸ RK4 steps in the worst case).
        let allowed = MAX_INTEGRATION_STEPS.max(ORDINARY_SUB_STEPS * self.control_steps as f64);
        if self.sub_steps_max.is_finite() && self.sub_steps_max <= MAX_SUB_STEPS && worst <= allowed
        {
            return Ok(());
        }
        Err(SimError::TooStiff {
            friction_bound_n: self.friction_bound_n,
            mass_kg: plant.m,
            sign_smoothing_mm_s: plant.friction.sign_smoothing_m_s() * 1e3,
            sub_steps: self.sub_steps_max,
            control_steps: self.control_steps,
            integration_steps: worst,
        })
    }
}

/// Eigenvalue magnitudes of the loop, the current lag and the viscous terms (1/s); the
/// friction adds F_bound·sech²(v/v_ε)/(m·v_ε) near v = 0.
fn lam_base(plant: &Plant, dyn_cfg: &DynamicsConfig) -> f64 {
    let tau = dyn_cfg.current_time_constant_ms * 1e-3;
    let w_v = 2.0 * std::f64::consts::PI * dyn_cfg.velocity_bandwidth_hz;
    1.0 / tau + 2.0 * w_v + (plant.b + 1.0) / plant.m
}

/// Servo mode: the cascaded loop described on [`DynamicsConfig`] drives the plant from
/// t = 0 to `duration_s`; the state at each requested instant (each list sorted) is the cubic
/// Hermite interpolation of (z, z'), (z', z'') and (i, i') between integration steps, so the
/// requested instants cost O(1) each and nothing else is stored.
///
/// # Errors
/// [`SimError::Diverged`] if the state becomes non-finite or runs away (|z − z_cmd| > 0.1 m).
pub(crate) fn run_servo(
    plant: &Plant,
    dyn_cfg: &DynamicsConfig,
    profile: &dyn MotionProfile,
    duration_s: f64,
    requests: &[&[f64]],
    progress: &mut dyn FnMut(f64),
) -> Result<(Vec<Vec<StateSample>>, RunStats), SimError> {
    use std::f64::consts::PI;
    let h = dyn_cfg.step_ms * 1e-3;
    let tau = dyn_cfg.current_time_constant_ms * 1e-3;
    let w_v = 2.0 * PI * dyn_cfg.velocity_bandwidth_hz;
    let kv = w_v * plant.m / plant.k; // A per m/s
    let ki = kv * 2.0 * PI * dyn_cfg.velocity_integral_corner_hz; // A per m
    let kp = dyn_cfg.position_gain_per_s;
    let k_ff = dyn_cfg.velocity_feedforward;
    let v_eps = plant.friction.sign_smoothing_m_s();

    // Bound of |F_f| for the stiffness estimate near reversals; the whole run's work.
    let work = WorkBound::of(plant, dyn_cfg, profile);
    work.check(plant)?;
    let f_bound = work.friction_bound_n;
    let lam_base = lam_base(plant, dyn_cfg);

    let mut collector = Collector::new(requests);

    // Start in equilibrium with the command at t = 0: current from the inverse dynamics, the
    // integrator holding the friction share.
    let c0 = profile.kinematics(0.0);
    let mut x = X {
        z: c0.position_m,
        v: c0.velocity_m_s,
        i: plant.inverse_current_a(c0.position_m, c0.velocity_m_s, c0.accel_m_s2),
    };
    let mut integ = plant.friction.friction_n(x.z, x.v) / plant.k;
    let mut stats = RunStats::default();
    let mut t = 0.0f64;
    let mut step: u64 = 0;
    let n_steps = (duration_s / h).ceil() as u64;
    let report_every = (n_steps / 200).max(1);
    let mut a_prev = c0.accel_m_s2;

    let deriv = |x: &X, i_cmd: f64| -> X {
        X {
            z: x.v,
            v: plant.accel(x.z, x.v, x.i),
            i: (i_cmd - x.i) / tau,
        }
    };

    while t < duration_s {
        // Controller update (zero-order hold over the step).
        let c = profile.kinematics(t);
        // velocity reference k_ff·v_cmd + K_p·(z_cmd − z); k_ff also scales the current
        // feed-forward, so that k_ff = 0 is a plain cascade (steady lag v/K_p)
        let e_v = k_ff * c.velocity_m_s + kp * (c.position_m - x.z) - x.v;
        let i_cmd =
            kv * e_v + integ + k_ff * (plant.m * c.accel_m_s2 + plant.b * c.velocity_m_s) / plant.k;
        integ += ki * e_v * h;

        // Sub-steps where the smooth sign makes the friction stiff (|v| within a few v_ε of 0
        // during this step).
        let slack = 2.0 * h * (a_prev.abs() + c.accel_m_s2.abs()) + v_eps;
        let s_eff = (x.v.abs() - slack).max(0.0) / v_eps;
        let sech2 = if s_eff > 20.0 {
            0.0
        } else {
            1.0 / s_eff.cosh().powi(2)
        };
        let lam = lam_base + f_bound * sech2 / (plant.m * v_eps);
        let n_sub = (h * lam).ceil().clamp(1.0, MAX_SUB_STEPS) as u64;
        let t_end = (t + h).min(duration_s);
        let hs = (t_end - t) / n_sub as f64;

        for s in 0..n_sub {
            let t0 = t + s as f64 * hs;
            let t1 = if s + 1 == n_sub { t_end } else { t0 + hs };
            let d0 = deriv(&x, i_cmd);
            // RK4
            let k1 = d0;
            let xa = X {
                z: x.z + 0.5 * hs * k1.z,
                v: x.v + 0.5 * hs * k1.v,
                i: x.i + 0.5 * hs * k1.i,
            };
            let k2 = deriv(&xa, i_cmd);
            let xb = X {
                z: x.z + 0.5 * hs * k2.z,
                v: x.v + 0.5 * hs * k2.v,
                i: x.i + 0.5 * hs * k2.i,
            };
            let k3 = deriv(&xb, i_cmd);
            let xc = X {
                z: x.z + hs * k3.z,
                v: x.v + hs * k3.v,
                i: x.i + hs * k3.i,
            };
            let k4 = deriv(&xc, i_cmd);
            let x1 = X {
                z: x.z + hs / 6.0 * (k1.z + 2.0 * k2.z + 2.0 * k3.z + k4.z),
                v: x.v + hs / 6.0 * (k1.v + 2.0 * k2.v + 2.0 * k3.v + k4.v),
                i: x.i + hs / 6.0 * (k1.i + 2.0 * k2.i + 2.0 * k3.i + k4.i),
            };
            // Derivative at the end with the i_cmd of this step (left limit).
            let d1 = deriv(&x1, i_cmd);
            let span = Span {
                t0,
                t1,
                x0: x,
                d0,
                x1,
                d1,
            };
            collector.take(&span, plant, profile, false);
            x = x1;
            a_prev = d1.v;
            stats.integration_steps += 1;
        }
        t = t_end;
        step += 1;
        stats.control_steps += 1;

        let cz = profile.kinematics(t).position_m;
        let err = (x.z - cz).abs();
        if !(x.z.is_finite() && x.v.is_finite() && x.i.is_finite()) || err > 0.1 {
            return Err(SimError::Diverged { time_s: t });
        }
        stats.max_following_error_m = stats.max_following_error_m.max(err);
        if step.is_multiple_of(report_every) {
            progress((t / duration_s).min(1.0));
        }
    }
    // Whatever is left (only for a zero duration) gets the final state.
    let d = deriv(&x, x.i);
    let span = Span {
        t0: t,
        t1: t,
        x0: x,
        d0: d,
        x1: x,
        d1: d,
    };
    collector.take(&span, plant, profile, true);
    progress(1.0);
    Ok((collector.out, stats))
}
