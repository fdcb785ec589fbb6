//! LuGre dynamic friction (paper 001 Eq. 2): simulation with an unconditionally stable step,
//! and identification of the bristle stiffness σ0 from pre-sliding data after a reversal.
//!
//! # Model
//! dz/dt = v − σ0·|v|·z / g(v),
//! F = σ0·z + σ1·dz/dt + σ2·v,
//! g(v) = F_c + (F_s − F_c)·exp(−(|v|/v_s)^δ)
//!
//! z (m) is the mean bristle deflection, σ0 (N/m) the bristle stiffness, σ1 (N·s/m) the
//! bristle damping, σ2 (N·s/m) the viscous coefficient; g is the Stribeck curve without its
//! viscous part (δ = 2 in paper 001; [`StribeckParams::delta`] here). F is signed with v as
//! in paper 000 Eq. 5. At constant v the state settles to z_ss = sgn(v)·g(v)/σ0 and
//! F = sgn(v)·g(v) + σ2·v (paper 001 Eq. 3); from rest (z = 0) a tiny displacement x gives
//! F ≈ σ0·x: the pre-sliding spring.
//!
//! # Integration
//! With σ0 of 1e7-1e8 N/m the time constant g/(σ0·|v|) is micro- to milliseconds, so explicit
//! schemes need tiny steps (an adaptive Dormand–Prince stops with "stiffness detected"). For a
//! velocity frozen at v over a step h the ODE is linear in z, with the exact solution
//!
//! z(t + h) = z_ss + (z(t) − z_ss)·exp(−σ0·|v|·h/g(v)),  z_ss = sgn(v)·g(v)/σ0
//!
//! [`LuGre::simulate`] uses it with v frozen at the mean of the step's end velocities (so the
//! displacement of each step is exact for piecewise-linear velocity). It is exact for constant
//! velocity, stable and monotone for any step, and keeps |z| ≤ max g/σ0 when it starts there.
//!
//! # Identification
//! The static part (F_c, F_s, v_s, δ, σ2) comes from a Stribeck fit of steady-speed data
//! ([`crate::stribeck::fit_stribeck`]). σ0 needs pre-sliding data: friction against the
//! displacement x ≥ 0 travelled since a velocity reversal, slow enough that g stays at its
//! value g at the reversal speed and σ1·ż and σ2·v are negligible. Then z obeys dz/dx =
//! 1 − σ0·z/g, so
//!
//! F(x) = g − (g − F_0)·exp(−x/x_c),  x_c = g/σ0,
//!
//! with F_0 the friction at the reversal (≈ −g when the axis slid steadily the other way).
//! [`identify_presliding`] fits (g, F_0, x_c) or, when g is known from the Stribeck fit,
//! (F_0, x_c). The data must cover the transition: samples inside the first x_c of travel
//! and travel up to at least 2·x_c (0.5·x_c when g is known); otherwise the answer is
//! [`LuGreError::NotIdentifiable`].
//!
//! σ1 is not identified. At a constant speed v after the reversal its term is
//! σ1·ż = σ1·v·(1 − σ0·z/g), which decays as exp(−x/x_c) exactly like the elastic term: it only
//! changes the apparent amplitude g − F_0 by σ1·v·(1 − F_0/g) and is absorbed by the fitted
//! F_0. Even with F_0 measured just before the reversal it would show as ≈ 2·σ1·v, a fraction
//! of a newton at the slow speeds this method needs. σ1 needs dynamic pre-sliding tests (e.g.
//! the decay of a stick-phase oscillation).
//!
//! # Reference
//! Paper 001 Eq. 2-3; Canudas de Wit, Olsson, Åström, Lischinsky, IEEE TAC 40 (1995) 419-425.
//!
//! # Example
//! ```
//! use feedscope::lugre::{LuGre, LuGreParams};
//! use feedscope::stribeck::StribeckParams;
//!
//! let model = LuGre::new(LuGreParams {
//!     stribeck: StribeckParams { fc_n: 150.0, fs_n: 210.0, vs_m_s: 3e-4,
//!                                sigma_n_s_per_m: 3000.0, delta: 2.0 },
//!     sigma0_n_per_m: 1e8,
//!     sigma1_n_s_per_m: 2e4,
//! }).unwrap();
//! // 10 ms steps at σ0 = 1e8 N/m: the exact step stays stable.
//! let t: Vec<f64> = (0..100).map(|k| k as f64 * 0.01).collect();
//! let v = vec![0.01; 100];
//! let r = model.simulate(&t, &v, 0.0).unwrap();
//! let f_ss = model.params().steady_state_force_n(0.01);
//! assert!((r.friction_n[99] - f_ss).abs() < 1e-9 * f_ss);
//! ```

use serde::{Deserialize, Serialize};

use crate::stribeck::StribeckParams;

/// Parameters of the LuGre model, SI units.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LuGreParams {
    /// Static part: F_c, F_s, v_s, δ of g(v) and the viscous σ2 = `sigma_n_s_per_m`.
    pub stribeck: StribeckParams,
    /// Bristle stiffness σ0 (N/m), > 0.
    pub sigma0_n_per_m: f64,
    /// Bristle damping σ1 (N·s/m), ≥ 0.
    pub sigma1_n_s_per_m: f64,
}

impl LuGreParams {
    /// g(v) = F_c + (F_s − F_c)·exp(−(|v|/v_s)^δ) (N), the Stribeck curve without viscous part.
    pub fn g_n(&self, velocity_m_s: f64) -> f64 {
        let s = &self.stribeck;
        s.fc_n + (s.fs_n - s.fc_n) * (-(velocity_m_s.abs() / s.vs_m_s).powf(s.delta)).exp()
    }

    /// Steady-state deflection z_ss = sgn(v)·g(v)/σ0 (m); 0 at v = 0.
    pub fn steady_state_z_m(&self, velocity_m_s: f64) -> f64 {
        sign(velocity_m_s) * self.g_n(velocity_m_s) / self.sigma0_n_per_m
    }

    /// Steady-state friction sgn(v)·g(v) + σ2·v (N), paper 001 Eq. 3.
    pub fn steady_state_force_n(&self, velocity_m_s: f64) -> f64 {
        sign(velocity_m_s) * self.g_n(velocity_m_s) + self.stribeck.sigma_n_s_per_m * velocity_m_s
    }

    /// dz/dt = v − σ0·|v|·z/g(v) (m/s).
    pub fn z_rate_m_s(&self, z_m: f64, velocity_m_s: f64) -> f64 {
        velocity_m_s - self.sigma0_n_per_m * velocity_m_s.abs() * z_m / self.g_n(velocity_m_s)
    }

    /// F = σ0·z + σ1·dz/dt + σ2·v (N).
    pub fn force_n(&self, z_m: f64, velocity_m_s: f64) -> f64 {
        self.sigma0_n_per_m * z_m
            + self.sigma1_n_s_per_m * self.z_rate_m_s(z_m, velocity_m_s)
            + self.stribeck.sigma_n_s_per_m * velocity_m_s
    }

    /// The exact step of z over `step_s` at a frozen velocity (see the module docs).
    pub fn step_z_m(&self, z_m: f64, velocity_m_s: f64, step_s: f64) -> f64 {
        if velocity_m_s == 0.0 {
            return z_m;
        }
        let g = self.g_n(velocity_m_s);
        let z_ss = sign(velocity_m_s) * g / self.sigma0_n_per_m;
        let decay = (-self.sigma0_n_per_m * velocity_m_s.abs() * step_s / g).exp();
        z_ss + (z_m - z_ss) * decay
    }
}

/// −1, 0 or +1 by the sign of `v` (0 at rest, unlike `f64::signum`): the sgn of the friction
/// models.
pub(crate) fn sign(v: f64) -> f64 {
    if v > 0.0 {
        1.0
    } else if v < 0.0 {
        -1.0
    } else {
        0.0
    }
}

/// Why a LuGre operation failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum LuGreError {
    /// A parameter is out of range.
    #[error("{name} = {value} is out of range: {expected}")]
    BadParameter {
        /// Parameter name.
        name: &'static str,
        /// Its value.
        value: f64,
        /// The allowed range.
        expected: &'static str,
    },
    /// Slices of different lengths.
    #[error("{what}: {left} and {right} values")]
    LengthMismatch {
        /// Which inputs.
        what: &'static str,
        /// Length of the first.
        left: usize,
        /// Length of the second.
        right: usize,
    },
    /// An input is NaN or infinite.
    #[error("{quantity} number {index} is not finite ({value})")]
    NonFinite {
        /// Which input.
        quantity: &'static str,
        /// Index (0-based).
        index: usize,
        /// The value.
        value: f64,
    },
    /// Time does not increase.
    #[error("time does not increase at sample {index} ({time_s} s)")]
    TimeNotIncreasing {
        /// Index (0-based).
        index: usize,
        /// Its time (s).
        time_s: f64,
    },
    /// Fewer samples than needed.
    #[error("{points} samples; at least {needed} are needed")]
    TooFewPoints {
        /// Samples given.
        points: usize,
        /// Samples needed.
        needed: usize,
    },
    /// The data cannot determine σ0.
    #[error("σ0 is not identifiable from these data: {0}")]
    NotIdentifiable(NotIdentifiable),
}

impl LuGreError {
    /// What the error means to a caller: always [`BadInput`](crate::ErrorKind::BadInput): the data or a parameter do not allow the fit.
    pub fn kind(&self) -> crate::ErrorKind {
        use crate::ErrorKind;
        ErrorKind::BadInput
    }
}

/// Why pre-sliding data cannot determine σ0.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
#[non_exhaustive]
pub enum NotIdentifiable {
    /// The travel stops inside the linear pre-sliding range: only the initial slope
    /// σ0·(1 − F_0/g) is seen, not σ0 and g apart.
    TooShort {
        /// Longest travel since the reversal (m).
        max_displacement_m: f64,
        /// Pre-sliding length x_c = g/σ0 of the best fit (m).
        presliding_length_m: f64,
    },
    /// Too few samples inside the first x_c of travel: the data show only gross sliding.
    TransitionNotSampled {
        /// Samples with x < x_c.
        samples_inside: usize,
        /// Pre-sliding length x_c of the best fit (m).
        presliding_length_m: f64,
    },
    /// Friction hardly changes over the data (|g − F_0| below 3 residual RMS): there is no
    /// reversal transition to fit.
    NoTransition {
        /// |g − F_0| (N).
        change_n: f64,
        /// Residual RMS (N).
        residual_rms_n: f64,
    },
}

impl std::fmt::Display for NotIdentifiable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::TooShort {
                max_displacement_m,
                presliding_length_m,
            } => write!(
                f,
                "the travel since the reversal ({:.3} µm) stays inside the linear pre-sliding \
                 range (x_c ≈ {:.3} µm); record at least 2·x_c",
                max_displacement_m * 1e6,
                presliding_length_m * 1e6
            ),
            Self::TransitionNotSampled {
                samples_inside,
                presliding_length_m,
            } => write!(
                f,
                "only {samples_inside} samples within the first {:.3} µm after the reversal; \
                 sample the transition more densely",
                presliding_length_m * 1e6
            ),
            Self::NoTransition {
                change_n,
                residual_rms_n,
            } => write!(
                f,
                "friction changes by only {change_n:.3} N (residual RMS {residual_rms_n:.3} N); \
                 the data hold no reversal"
            ),
        }
    }
}

/// A validated LuGre model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LuGre {
    params: LuGreParams,
}

/// Response of [`LuGre::simulate`], one value per input sample.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LuGreResponse {
    /// Bristle deflection z (m).
    pub z_m: Vec<f64>,
    /// Friction F (N), signed with v.
    pub friction_n: Vec<f64>,
    /// Displacement ∫v dt from the first sample (m), trapezoidal.
    pub displacement_m: Vec<f64>,
}

impl LuGre {
    /// Check the parameters: F_c > 0, F_s > 0 (so g > 0), v_s > 0, δ > 0, σ0 > 0, σ1 ≥ 0,
    /// σ2 ≥ 0, all finite.
    ///
    /// # Errors
    /// [`LuGreError::BadParameter`] naming the first bad one.
    pub fn new(params: LuGreParams) -> Result<Self, LuGreError> {
        let s = &params.stribeck;
        let checks: [(&'static str, f64, bool, &'static str); 7] = [
            (
                "fc_n",
                s.fc_n,
                s.fc_n > 0.0,
                "> 0 (g(v) must stay positive)",
            ),
            (
                "fs_n",
                s.fs_n,
                s.fs_n > 0.0,
                "> 0 (g(v) must stay positive)",
            ),
            ("vs_m_s", s.vs_m_s, s.vs_m_s > 0.0, "> 0"),
            ("delta", s.delta, s.delta > 0.0, "> 0"),
            (
                "sigma_n_s_per_m",
                s.sigma_n_s_per_m,
                s.sigma_n_s_per_m >= 0.0,
                ">= 0",
            ),
            (
                "sigma0_n_per_m",
                params.sigma0_n_per_m,
                params.sigma0_n_per_m > 0.0,
                "> 0",
            ),
            (
                "sigma1_n_s_per_m",
                params.sigma1_n_s_per_m,
                params.sigma1_n_s_per_m >= 0.0,
                ">= 0",
            ),
        ];
        for (name, value, ok, expected) in checks {
            if !(ok && value.is_finite()) {
                return Err(LuGreError::BadParameter {
                    name,
                    value,
                    expected,
                });
            }
        }
        Ok(Self { params })
    }

    /// The parameters.
    pub fn params(&self) -> &LuGreParams {
        &self.params
    }

    /// Friction for a velocity profile v(t_k) (m/s) sampled at increasing times t_k (s),
    /// starting from deflection `z0_m` (0: at rest, unloaded). Between samples v is taken as
    /// linear; z advances by the exact frozen-velocity step at the step's mean velocity.
    ///
    /// # Errors
    /// [`LuGreError::LengthMismatch`], [`LuGreError::NonFinite`],
    /// [`LuGreError::TimeNotIncreasing`], [`LuGreError::TooFewPoints`] (none given).
    pub fn simulate(
        &self,
        time_s: &[f64],
        velocity_m_s: &[f64],
        z0_m: f64,
    ) -> Result<LuGreResponse, LuGreError> {
        if time_s.len() != velocity_m_s.len() {
            return Err(LuGreError::LengthMismatch {
                what: "time and velocity",
                left: time_s.len(),
                right: velocity_m_s.len(),
            });
        }
        if time_s.is_empty() {
            return Err(LuGreError::TooFewPoints {
                points: 0,
                needed: 1,
            });
        }
        finite("time", time_s)?;
        finite("velocity", velocity_m_s)?;
        finite("z0", &[z0_m])?;
        if let Some(k) = (1..time_s.len()).find(|&k| time_s[k] <= time_s[k - 1]) {
            return Err(LuGreError::TimeNotIncreasing {
                index: k,
                time_s: time_s[k],
            });
        }
        let p = &self.params;
        let n = time_s.len();
        let mut z = Vec::with_capacity(n);
        let mut x = Vec::with_capacity(n);
        let (mut zk, mut xk) = (z0_m, 0.0);
        z.push(zk);
        x.push(xk);
        for k in 1..n {
            let h = time_s[k] - time_s[k - 1];
            let vm = 0.5 * (velocity_m_s[k - 1] + velocity_m_s[k]);
            zk = p.step_z_m(zk, vm, h);
            xk += vm * h;
            z.push(zk);
            x.push(xk);
        }
        let friction_n = z
            .iter()
            .zip(velocity_m_s)
            .map(|(&zk, &v)| p.force_n(zk, v))
            .collect();
        Ok(LuGreResponse {
            z_m: z,
            friction_n,
            displacement_m: x,
        })
    }
}

fn finite(quantity: &'static str, v: &[f64]) -> Result<(), LuGreError> {
    match v.iter().position(|x| !x.is_finite()) {
        Some(index) => Err(LuGreError::NonFinite {
            quantity,
            index,
            value: v[index],
        }),
        None => Ok(()),
    }
}

/// Settings of [`identify_presliding`].
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct PreSlidingParams {
    /// The sliding level g (N, > 0) at the speed after the reversal, e.g. the Stribeck fit's
    /// magnitude there minus σ2·|v|; `None` (default) fits it.
    pub level_n: Option<f64>,
}

/// σ0 identified from a reversal, with the fitted transition.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PreSlidingFit {
    /// Bristle stiffness σ0 = g/x_c (N/m).
    pub sigma0_n_per_m: f64,
    /// Its standard error (N/m), `None` without residual degrees of freedom.
    pub sigma0_std_error_n_per_m: Option<f64>,
    /// Sliding level g (N), fitted or as given.
    pub level_n: f64,
    /// Friction at the reversal F_0 (N).
    pub start_force_n: f64,
    /// Pre-sliding length x_c = g/σ0 (m).
    pub presliding_length_m: f64,
    /// RMS of the residuals (N).
    pub residual_rms_n: f64,
    /// Samples used.
    pub points: usize,
}

impl PreSlidingFit {
    /// The fitted transition F(x) = g − (g − F_0)·exp(−x/x_c) (N).
    pub fn friction_n(&self, displacement_m: f64) -> f64 {
        self.level_n
            - (self.level_n - self.start_force_n)
                * (-displacement_m / self.presliding_length_m).exp()
    }
}

/// Identify σ0 from friction against displacement since a reversal (see the module docs for
/// the data this needs). `displacement_m` is the travel since the reversal, ≥ 0, measured in
/// the new direction of motion; `friction_n` is signed positive in that direction (so the
/// friction at the reversal is negative).
///
/// Method: for x_c on a log grid (60 points from a tenth of the smallest non-zero
/// displacement to ten times the largest) the model is linear in (g, F_0) (or in F_0 when g is
/// given) and is solved by least squares; golden-section search on ln x_c refines the best
/// grid point; the standard error of σ0 follows from the Jacobian in (g, F_0, ln x_c).
///
/// # Errors
/// [`LuGreError::LengthMismatch`], [`LuGreError::NonFinite`], [`LuGreError::BadParameter`]
/// (negative displacement, non-positive level), [`LuGreError::TooFewPoints`] (fewer than 4
/// samples), [`LuGreError::NotIdentifiable`].
pub fn identify_presliding(
    displacement_m: &[f64],
    friction_n: &[f64],
    params: &PreSlidingParams,
) -> Result<PreSlidingFit, LuGreError> {
    if displacement_m.len() != friction_n.len() {
        return Err(LuGreError::LengthMismatch {
            what: "displacement and friction",
            left: displacement_m.len(),
            right: friction_n.len(),
        });
    }
    let n = displacement_m.len();
    if n < 4 {
        return Err(LuGreError::TooFewPoints {
            points: n,
            needed: 4,
        });
    }
    finite("displacement", displacement_m)?;
    finite("friction", friction_n)?;
    if let Some(i) = displacement_m.iter().position(|&x| x < 0.0) {
        return Err(LuGreError::BadParameter {
            name: "displacement_m",
            value: displacement_m[i],
            expected: ">= 0 (travel since the reversal)",
        });
    }
    if let Some(g) = params.level_n {
        if !(g.is_finite() && g > 0.0) {
            return Err(LuGreError::BadParameter {
                name: "level_n",
                value: g,
                expected: "> 0",
            });
        }
    }
    let x_max = displacement_m.iter().fold(0.0f64, |m, &x| m.max(x));
    let x_min_pos = displacement_m
        .iter()
        .copied()
        .filter(|&x| x > 0.0)
        .fold(f64::INFINITY, f64::min);
    if x_max <= 0.0 {
        return Err(LuGreError::NotIdentifiable(NotIdentifiable::TooShort {
            max_displacement_m: 0.0,
            presliding_length_m: 0.0,
        }));
    }
    // Linear least squares for a given x_c: returns (g, F0, SSR).
    let solve = |xc: f64| -> (f64, f64, f64) {
        let e: Vec<f64> = displacement_m.iter().map(|&x| (-x / xc).exp()).collect();
        match params.level_n {
            Some(g) => {
                // F − g = (F0 − g)·e
                let (mut se, mut ee) = (0.0, 0.0);
                for (ei, fi) in e.iter().zip(friction_n) {
                    se += ei * (fi - g);
                    ee += ei * ei;
                }
                let c = if ee > 0.0 { se / ee } else { 0.0 };
                let ssr = e
                    .iter()
                    .zip(friction_n)
                    .map(|(ei, fi)| (fi - g - c * ei).powi(2))
                    .sum();
                (g, g + c, ssr)
            }
            None => {
                // F = g·(1 − e) + F0·e, 2×2 normal equations
                let (mut a11, mut a12, mut a22, mut b1, mut b2) = (0.0, 0.0, 0.0, 0.0, 0.0);
                for (ei, fi) in e.iter().zip(friction_n) {
                    let u = 1.0 - ei;
                    a11 += u * u;
                    a12 += u * ei;
                    a22 += ei * ei;
                    b1 += u * fi;
                    b2 += ei * fi;
                }
                let det = a11 * a22 - a12 * a12;
                if det.is_nan() || det <= 1e-12 * a11 * a22 {
                    return (0.0, 0.0, f64::INFINITY);
                }
                let g = (b1 * a22 - b2 * a12) / det;
                let f0 = (a11 * b2 - a12 * b1) / det;
                let ssr = e
                    .iter()
                    .zip(friction_n)
                    .map(|(ei, fi)| (fi - g * (1.0 - ei) - f0 * ei).powi(2))
                    .sum();
                (g, f0, ssr)
            }
        }
    };
    let (l_lo, l_hi) = ((0.1 * x_min_pos.min(x_max)).ln(), (10.0 * x_max).ln());
    let m = 60;
    let grid: Vec<f64> = (0..m)
        .map(|k| l_lo + (l_hi - l_lo) * k as f64 / (m - 1) as f64)
        .collect();
    let ssr_at: Vec<f64> = grid.iter().map(|&l| solve(l.exp()).2).collect();
    let kbest = (0..m)
        .min_by(|&a, &b| ssr_at[a].total_cmp(&ssr_at[b]))
        .expect("grid is not empty");
    // Golden-section refinement between the neighbours of the best grid point.
    let (mut a, mut b) = (grid[kbest.saturating_sub(1)], grid[(kbest + 1).min(m - 1)]);
    let phi = 0.5 * (5f64.sqrt() - 1.0);
    let (mut c, mut d) = (b - phi * (b - a), a + phi * (b - a));
    let (mut fc, mut fd) = (solve(c.exp()).2, solve(d.exp()).2);
    for _ in 0..80 {
        if fc < fd {
            b = d;
            d = c;
            fd = fc;
            c = b - phi * (b - a);
            fc = solve(c.exp()).2;
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + phi * (b - a);
            fd = solve(d.exp()).2;
        }
    }
    let l = 0.5 * (a + b);
    let xc = l.exp();
    let (g, f0, ssr) = solve(xc);
    let residual_rms_n = (ssr / n as f64).sqrt();

    // Identifiability (module docs).
    let change_n = (g - f0).abs();
    if g.is_nan() || g <= 0.0 || change_n <= 3.0 * residual_rms_n {
        return Err(LuGreError::NotIdentifiable(NotIdentifiable::NoTransition {
            change_n,
            residual_rms_n,
        }));
    }
    let needed_travel = if params.level_n.is_some() { 0.5 } else { 2.0 };
    if x_max < needed_travel * xc || kbest + 1 == m {
        return Err(LuGreError::NotIdentifiable(NotIdentifiable::TooShort {
            max_displacement_m: x_max,
            presliding_length_m: xc,
        }));
    }
    let inside = displacement_m.iter().filter(|&&x| x < xc).count();
    if inside < 3 || kbest == 0 {
        return Err(LuGreError::NotIdentifiable(
            NotIdentifiable::TransitionNotSampled {
                samples_inside: inside,
                presliding_length_m: xc,
            },
        ));
    }
    let sigma0 = g / xc;

    // Standard error of σ0 through ln σ0 = ln g − ln x_c.
    let free_g = params.level_n.is_none();
    let p = if free_g { 3 } else { 2 };
    let mut jtj = nalgebra::DMatrix::<f64>::zeros(p, p);
    for &x in displacement_m {
        let e = (-x / xc).exp();
        let dl = -(g - f0) * e * (x / xc); // ∂F/∂ln x_c
        let row: Vec<f64> = if free_g {
            vec![1.0 - e, e, dl]
        } else {
            vec![e, dl]
        };
        for i in 0..p {
            for j in 0..p {
                jtj[(i, j)] += row[i] * row[j];
            }
        }
    }
    let sigma0_std_error_n_per_m = if n > p {
        jtj.try_inverse().and_then(|inv| {
            let s2 = ssr / (n - p) as f64;
            let var_ln = if free_g {
                inv[(0, 0)] / (g * g) + inv[(2, 2)] - 2.0 * inv[(0, 2)] / g
            } else {
                inv[(1, 1)]
            };
            let se = sigma0 * (s2 * var_ln).max(0.0).sqrt();
            se.is_finite().then_some(se)
        })
    } else {
        None
    };
    Ok(PreSlidingFit {
        sigma0_n_per_m: sigma0,
        sigma0_std_error_n_per_m,
        level_n: g,
        start_force_n: f0,
        presliding_length_m: xc,
        residual_rms_n,
        points: n,
    })
}

#[cfg(test)]
mod tests;
