//! Natural frequencies and mode shapes: K x = ω² M x (paper Eq. 1, undamped) at one nut
//! position and feed rate.
//!
//! nalgebra has no generalised symmetric eigensolver, so M = L·Lᵀ (Cholesky) and the standard
//! symmetric problem A z = ω² z with A = L⁻¹·K·L⁻ᵀ is solved with `SymmetricEigen`; x = L⁻ᵀ z
//! is then mass-normalised (xᵀ M x = 1). M depends on the nut position only, and the
//! feed-dependent joint springs are rank-one terms k·b·bᵀ, so a [`PositionPlan`] stores
//! A₀ = L⁻¹·K₀·L⁻ᵀ and w = L⁻¹·b for each joint, and a feed rate costs
//! A = A₀ + Σ k_j·w_j·w_jᵀ plus one eigenvalue problem.

use std::f64::consts::PI;

use nalgebra::{DMatrix, DVector, SymmetricEigen};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::assemble::{Layout, ScrewModel};
use super::config::DriveConfig;
use super::contact::{JointModel, JointState};
use super::DynamicsError;

/// A validated feed-drive model in SI units.
#[derive(Debug, Clone)]
pub struct DriveModel {
    pub(crate) screw: ScrewModel,
    pub(crate) joints: JointModel,
    pub(crate) config: DriveConfig,
}

impl DriveModel {
    /// Validate `cfg` and convert it to SI.
    ///
    /// # Errors
    /// [`DynamicsError::InvalidValue`] naming the first key out of range.
    pub fn from_config(cfg: &DriveConfig) -> Result<Self, DynamicsError> {
        cfg.validate()?;
        Ok(Self::from_config_unchecked(cfg))
    }

    /// The model without the range check, for test oracles that need a limit no real drive
    /// reaches (a rigid, massless screw).
    pub(crate) fn from_config_unchecked(cfg: &DriveConfig) -> Self {
        Self {
            screw: ScrewModel::from_config(cfg),
            joints: JointModel::from_config(cfg),
            config: cfg.clone(),
        }
    }

    /// The configuration this model was built from.
    pub fn config(&self) -> &DriveConfig {
        &self.config
    }

    /// Screw length L between the support bearings (m).
    pub fn length_m(&self) -> f64 {
        self.screw.length_m
    }

    /// Screw lead p (m).
    pub fn lead_m(&self) -> f64 {
        self.screw.lead_m
    }

    /// Joint loads and stiffnesses at feed rate v (m/s), paper Eq. 3-6.
    pub fn joints(&self, feed_m_s: f64) -> JointState {
        self.joints.state(feed_m_s)
    }

    /// Smallest positive feed rate (m/s) at which the rear bearing unit unloads (its stiffness
    /// reaches zero): f(v) = 2·Fas. `Some(0.0)` if it unloads as soon as the table moves,
    /// `None` if not below 100 m/s. By symmetry the front unit unloads at the same negative
    /// feed rate.
    pub fn bearing_unload_feed_m_s(&self) -> Option<f64> {
        self.joints.unload_feed_m_s()
    }

    /// The full stiffness and mass matrices K(f(v), y) and M(y) of paper Eq. 1 (reduced DOFs,
    /// layout as in the module docs of `assemble`), for export and checks; the solvers never
    /// form K this way.
    ///
    /// # Errors
    /// [`DynamicsError::PositionOutOfRange`] unless the nut is between the bearings, at least
    /// [`MIN_END_CLEARANCE`](super::MIN_END_CLEARANCE) of L from either.
    pub fn system_matrices(
        &self,
        y_m: f64,
        feed_m_s: f64,
    ) -> Result<(DMatrix<f64>, DMatrix<f64>), DynamicsError> {
        let length_m = self.screw.length_m;
        check_position(y_m, length_m)?;
        let layout = self.screw.layout();
        let (mut k, m) = self.screw.assemble(y_m, &layout);
        let j = self.joints.state(feed_m_s);
        let [b_rear, b_front, b_nut] = self.screw.joint_vectors(&layout);
        k.ger(j.k_rear_n_per_m, &b_rear, &b_rear, 1.0);
        k.ger(j.k_front_n_per_m, &b_front, &b_front, 1.0);
        k.ger(j.k_nut_n_per_m, &b_nut, &b_nut, 1.0);
        Ok((k, m))
    }

    /// Assemble, factor and project the system with the nut at y (m from the rear bearing).
    ///
    /// # Errors
    /// [`DynamicsError::PositionOutOfRange`] unless the nut is between the bearings (as
    /// [`Self::system_matrices`]);
    /// [`DynamicsError::MassNotPositiveDefinite`] if the Cholesky factorisation of M fails.
    pub fn at_position(&self, y_m: f64) -> Result<PositionPlan, DynamicsError> {
        let length_m = self.screw.length_m;
        check_position(y_m, length_m)?;
        let layout = self.screw.layout();
        let (k0, m) = self.screw.assemble(y_m, &layout);
        let chol = m
            .cholesky()
            .ok_or(DynamicsError::MassNotPositiveDefinite { position_m: y_m })?;
        let l = chol.l();
        let diag = l.diagonal();
        let (pmin, pmax) = (diag.min(), diag.max());
        // A₀ = L⁻¹·K₀·L⁻ᵀ = L⁻¹·(L⁻¹·K₀)ᵀ since K₀ is symmetric.
        let x = solve_lower(&l, &k0, y_m)?;
        let mut a0 = solve_lower(&l, &x.transpose(), y_m)?;
        symmetrise(&mut a0);
        let [b_rear, b_front, b_nut] = self.screw.joint_vectors(&layout);
        let w = |b: &DVector<f64>| -> Result<DVector<f64>, DynamicsError> {
            l.solve_lower_triangular(b)
                .ok_or(DynamicsError::MassNotPositiveDefinite { position_m: y_m })
        };
        Ok(PositionPlan {
            y_m,
            node_positions_m: self.screw.node_positions_m(y_m),
            w_rear: w(&b_rear)?,
            w_front: w(&b_front)?,
            w_nut: w(&b_nut)?,
            a0,
            l,
            layout,
            joints: self.joints,
            table_mass_kg: self.screw.table_mass_kg,
            mass_pivot_min: pmin * pmin,
            mass_pivot_max: pmax * pmax,
        })
    }
}

impl DriveModel {
    /// The lowest `n_modes` frequencies (Hz) at one nut position for each feed rate (m/s),
    /// `[feed][mode]`. The position is planned once; feed rates run in parallel (rayon).
    ///
    /// # Errors
    /// As [`Self::at_position`].
    pub fn sweep_feed(
        &self,
        y_m: f64,
        feeds_m_s: &[f64],
        n_modes: usize,
    ) -> Result<Vec<Vec<f64>>, DynamicsError> {
        let plan = self.at_position(y_m)?;
        let n = n_modes.min(plan.dofs());
        Ok(feeds_m_s
            .par_iter()
            .map_init(
                || DMatrix::zeros(0, 0),
                |scratch, &v| {
                    let mut out = vec![0.0; n];
                    plan.frequencies_into(v, scratch, &mut out);
                    out
                },
            )
            .collect())
    }

    /// The lowest `n_modes` frequencies (Hz) over a grid, `[position][feed][mode]`: each
    /// position is planned once and its feed rates swept; positions run in parallel (rayon).
    ///
    /// # Errors
    /// As [`Self::at_position`], for the first failing position.
    pub fn sweep_grid(
        &self,
        positions_m: &[f64],
        feeds_m_s: &[f64],
        n_modes: usize,
    ) -> Result<Vec<Vec<Vec<f64>>>, DynamicsError> {
        positions_m
            .par_iter()
            .map(|&y| {
                let plan = self.at_position(y)?;
                let n = n_modes.min(plan.dofs());
                let mut scratch = DMatrix::zeros(0, 0);
                Ok(feeds_m_s
                    .iter()
                    .map(|&v| {
                        let mut out = vec![0.0; n];
                        plan.frequencies_into(v, &mut scratch, &mut out);
                        out
                    })
                    .collect())
            })
            .collect()
    }
}

fn solve_lower(
    l: &DMatrix<f64>,
    b: &DMatrix<f64>,
    y_m: f64,
) -> Result<DMatrix<f64>, DynamicsError> {
    l.solve_lower_triangular(b)
        .ok_or(DynamicsError::MassNotPositiveDefinite { position_m: y_m })
}

fn symmetrise(a: &mut DMatrix<f64>) {
    let n = a.nrows();
    for i in 0..n {
        for j in 0..i {
            let v = 0.5 * (a[(i, j)] + a[(j, i)]);
            a[(i, j)] = v;
            a[(j, i)] = v;
        }
    }
}

/// Everything about one nut position that does not depend on the feed rate.
#[derive(Debug, Clone)]
pub struct PositionPlan {
    y_m: f64,
    node_positions_m: Vec<f64>,
    a0: DMatrix<f64>,
    l: DMatrix<f64>,
    w_rear: DVector<f64>,
    w_front: DVector<f64>,
    w_nut: DVector<f64>,
    layout: Layout,
    joints: JointModel,
    table_mass_kg: f64,
    mass_pivot_min: f64,
    mass_pivot_max: f64,
}

/// Numerical health of one solve.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ModalDiagnostics {
    /// Size of the reduced system (degrees of freedom).
    pub dofs: usize,
    /// Smallest Cholesky pivot of M, min (L_ii)² (kg or kg·m²).
    pub mass_pivot_min: f64,
    /// Largest Cholesky pivot of M, max (L_ii)².
    pub mass_pivot_max: f64,
    /// Pivot ratio max/min, a cheap lower bound on the condition number of M.
    pub mass_pivot_ratio: f64,
    /// Smallest eigenvalue of L⁻¹KL⁻ᵀ before clipping at 0 (rad²/s²); a negative value is
    /// round-off (or a mechanism, if large).
    pub smallest_eigenvalue_rad2_s2: f64,
}

/// One mode shape, mass-normalised (xᵀ M x = 1).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModeShape {
    /// Natural frequency (Hz).
    pub frequency_hz: f64,
    /// Axial displacement of each screw node (m·kg^-½), nodes as in
    /// [`ModalResult::node_positions_m`].
    pub axial: Vec<f64>,
    /// Torsional rotation of each screw node (rad·kg^-½); 0 at a clamped motor end.
    pub torsion: Vec<f64>,
    /// Table displacement (m·kg^-½).
    pub table: f64,
    /// Share of the modal mass in the table, m·x_t² (0..1): near 1 for the transmission mode
    /// the paper reports, small for screw modes.
    pub table_mass_fraction: f64,
}

/// Natural frequencies and mode shapes at one (position, feed rate).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModalResult {
    /// Nut position y from the rear bearing (m).
    pub position_m: f64,
    /// Joint loads and stiffnesses used.
    pub joints: JointState,
    /// Screw node coordinates from the rear bearing (m).
    pub node_positions_m: Vec<f64>,
    /// Lowest modes, ascending in frequency.
    pub modes: Vec<ModeShape>,
    /// Numerical diagnostics.
    pub diagnostics: ModalDiagnostics,
}

impl PositionPlan {
    /// Nut position y (m from the rear bearing).
    pub fn position_m(&self) -> f64 {
        self.y_m
    }

    /// Size of the reduced system.
    pub fn dofs(&self) -> usize {
        self.layout.dofs
    }

    /// A = A₀ + Σ k_j·w_j·w_jᵀ into `a` (resized if needed).
    fn projected(&self, joints: &JointState, a: &mut DMatrix<f64>) {
        a.clone_from(&self.a0);
        for (k, w) in [
            (joints.k_rear_n_per_m, &self.w_rear),
            (joints.k_front_n_per_m, &self.w_front),
            (joints.k_nut_n_per_m, &self.w_nut),
        ] {
            if k > 0.0 {
                a.ger(k, w, w, 1.0);
            }
        }
    }

    /// The lowest `n_modes` natural frequencies (Hz) at feed rate v (m/s).
    pub fn frequencies_hz(&self, feed_m_s: f64, n_modes: usize) -> Vec<f64> {
        let mut out = vec![0.0; n_modes.min(self.layout.dofs)];
        let mut scratch = DMatrix::zeros(0, 0);
        self.frequencies_into(feed_m_s, &mut scratch, &mut out);
        out
    }

    /// Hot-path form of [`Self::frequencies_hz`]: fills `out` with the lowest `out.len()`
    /// frequencies (Hz) using `scratch` as the work matrix (reused across calls).
    ///
    /// # Panics
    /// If `out` is longer than [`Self::dofs`].
    pub fn frequencies_into(&self, feed_m_s: f64, scratch: &mut DMatrix<f64>, out: &mut [f64]) {
        assert!(
            out.len() <= self.layout.dofs,
            "more modes than degrees of freedom"
        );
        let joints = self.joints.state(feed_m_s);
        self.projected(&joints, scratch);
        let mut ev: Vec<f64> = scratch.symmetric_eigenvalues().iter().copied().collect();
        ev.sort_by(f64::total_cmp);
        for (o, lam) in out.iter_mut().zip(ev) {
            *o = omega_to_hz(lam);
        }
    }

    /// The lowest `n_modes` modes with shapes and diagnostics at feed rate v (m/s).
    pub fn modes(&self, feed_m_s: f64, n_modes: usize) -> ModalResult {
        let joints = self.joints.state(feed_m_s);
        let mut a = DMatrix::zeros(0, 0);
        self.projected(&joints, &mut a);
        let eig = SymmetricEigen::new(a);
        let mut order: Vec<usize> = (0..eig.eigenvalues.len()).collect();
        order.sort_by(|&i, &j| eig.eigenvalues[i].total_cmp(&eig.eigenvalues[j]));
        let smallest = order.first().map_or(0.0, |&i| eig.eigenvalues[i]);
        let lt = self.l.transpose();
        let modes = order
            .iter()
            .take(n_modes)
            .map(|&i| {
                let z = eig.eigenvectors.column(i).into_owned();
                // x = L⁻ᵀ z; ‖z‖ = 1 gives xᵀ M x = 1.
                let mut x = lt
                    .solve_upper_triangular(&z)
                    .expect("L has a nonzero diagonal after a successful Cholesky");
                // Sign convention: table displacement ≥ 0.
                if x[self.layout.table] < 0.0 {
                    x.neg_mut();
                }
                let table = x[self.layout.table];
                ModeShape {
                    frequency_hz: omega_to_hz(eig.eigenvalues[i]),
                    axial: self.layout.u.iter().map(|&d| x[d]).collect(),
                    torsion: self
                        .layout
                        .theta
                        .iter()
                        .map(|d| d.map_or(0.0, |d| x[d]))
                        .collect(),
                    table,
                    table_mass_fraction: self.table_mass_kg * table * table,
                }
            })
            .collect();
        ModalResult {
            position_m: self.y_m,
            joints,
            node_positions_m: self.node_positions_m.clone(),
            modes,
            diagnostics: ModalDiagnostics {
                dofs: self.layout.dofs,
                mass_pivot_min: self.mass_pivot_min,
                mass_pivot_max: self.mass_pivot_max,
                mass_pivot_ratio: self.mass_pivot_max / self.mass_pivot_min,
                smallest_eigenvalue_rad2_s2: smallest,
            },
        }
    }
}

/// f = √max(λ, 0) / 2π; a slightly negative λ is round-off on a (near) mechanism. A NaN λ
/// (a matrix that overflowed) stays NaN: `f64::max` would turn it into a plausible-looking
/// 0.0 Hz.
fn omega_to_hz(lambda: f64) -> f64 {
    if lambda.is_nan() {
        return f64::NAN;
    }
    lambda.max(0.0).sqrt() / (2.0 * PI)
}

/// Generalised eigenvalues ω² of K x = ω² M x, ascending, by Cholesky of M (a slow obvious
/// reference for tests and small problems).
#[cfg(test)]
pub(crate) fn generalized_eigenvalues(k: &DMatrix<f64>, m: &DMatrix<f64>) -> Option<Vec<f64>> {
    let l = m.clone().cholesky()?.l();
    let x = l.solve_lower_triangular(k)?;
    let mut a = l.solve_lower_triangular(&x.transpose())?;
    symmetrise(&mut a);
    let mut ev: Vec<f64> = a.symmetric_eigenvalues().iter().copied().collect();
    ev.sort_by(f64::total_cmp);
    Some(ev)
}

/// [`DynamicsError::PositionOutOfRange`] unless `y_m` lies at least
/// [`MIN_END_CLEARANCE`](super::MIN_END_CLEARANCE)·L from either bearing: the mesh
/// puts elements on both sides of the nut, and a side of no length gives modes of NaN.
fn check_position(y_m: f64, length_m: f64) -> Result<(), DynamicsError> {
    let c = super::config::MIN_END_CLEARANCE * length_m;
    if y_m.is_finite() && y_m >= c && y_m <= length_m - c {
        Ok(())
    } else {
        Err(DynamicsError::PositionOutOfRange {
            position_m: y_m,
            length_m,
        })
    }
}
