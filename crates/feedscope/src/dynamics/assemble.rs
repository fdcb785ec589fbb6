//! Mesh and assembly of the screw's shaft elements, the table mass and the joint incidence
//! vectors at one nut position y.
//!
//! # Element (rebuilt from the paper's Eq. 7-10)
//!
//! The paper's Timoshenko beam element carries, in the transmission direction, an axial
//! displacement and a torsional rotation at each of its two nodes. Shear deformation and
//! rotary inertia of a Timoshenko beam act on the bending degrees of freedom only, which do not
//! enter the transmission direction at linear order, so in these degrees of freedom the element
//! is exactly a two-node rod plus a two-node shaft with linear shape functions:
//!
//! K_e = EA0/ℓ·[1 −1; −1 1] (axial, Eq. 7) and G·Ir/ℓ·[1 −1; −1 1] (torsion, Eq. 8),
//! M_e = ρAe·ℓ/6·[2 1; 1 2] (axial) and ρIr·ℓ/6·[2 1; 1 2] (torsion), Eq. 9-10 (consistent
//! mass; the garbled entries 1/3, 1/6 and Ir/(3Ae), Ir/(6Ae) read as these).
//!
//! Note the paper's two areas: the root area A0 for stiffness, the equivalent area Ae for mass.
//!
//! The paper's Eq. 8 folds the screw's torsion on the motor side into one axial compliance
//! ℓ/(EA0) + (p/2π)²·ℓ/(G·Ir); here the torsion is kept as its own degree of freedom and the
//! nut couples the two through its kinematics (below), which gives the same series stiffness
//! statically and keeps the torsional inertia of the screw in the dynamics.
//!
//! # Degrees of freedom
//!
//! Nodes 0..=2n along the screw (node 0 at the rear bearing, node n at the nut, node 2n at the
//! front bearing), each with (u_i, θ_i), then the table displacement x_t last. The motor-end θ
//! is removed when the motor end is rigidly clamped (Dirichlet condition).
//!
//! # Joints (rank-one springs, Eq. 11-12)
//!
//! Rear bearing: spring k1 on u_0; front bearing: spring k2 on u_2n. Nut: the table moves by
//! u_n + (p/2π)·θ_n when the nut joint is rigid, so the joint deformation is
//! d = x_t − u_n − (p/2π)·θ_n with energy ½·k_nut·d², i.e. k_nut·b·bᵀ with
//! b = e_xt − e_un − (p/2π)·e_θn.

use std::f64::consts::PI;

use nalgebra::{DMatrix, DVector};

use super::config::{DriveConfig, MotorEnd};

/// The screw, table and mesh in SI.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct ScrewModel {
    pub length_m: f64,
    pub lead_m: f64,
    /// EA0 (N).
    pub ea_n: f64,
    /// G·Ir (N·m²).
    pub gj_nm2: f64,
    /// ρ·Ae (kg/m).
    pub rho_a_kg_m: f64,
    /// ρ·Ir (kg·m).
    pub rho_j_kg_m: f64,
    pub motor_end: MotorEnd,
    /// None: rigid torsional clamp at the motor end.
    pub motor_k_nm_per_rad: Option<f64>,
    pub table_mass_kg: f64,
    pub guide_k_n_per_m: f64,
    pub elements_per_side: usize,
}

impl ScrewModel {
    pub fn from_config(cfg: &DriveConfig) -> Self {
        let s = &cfg.screw;
        Self {
            length_m: s.length_mm / 1000.0,
            lead_m: s.lead_mm / 1000.0,
            ea_n: s.youngs_modulus_gpa * 1e9 * s.stiffness_area_mm2 * 1e-6,
            gj_nm2: s.shear_modulus_gpa * 1e9 * s.polar_moment_mm4 * 1e-12,
            rho_a_kg_m: s.density_kg_m3 * s.mass_area_mm2 * 1e-6,
            rho_j_kg_m: s.density_kg_m3 * s.polar_moment_mm4 * 1e-12,
            motor_end: s.motor_end,
            motor_k_nm_per_rad: s.motor_torsional_stiffness_nm_per_rad,
            table_mass_kg: cfg.table.mass_kg,
            guide_k_n_per_m: cfg.table.guide_stiffness_n_per_um * 1e6,
            elements_per_side: cfg.mesh.elements_per_side,
        }
    }

    /// Where each physical degree of freedom sits in the reduced system.
    pub fn layout(&self) -> Layout {
        let n_nodes = 2 * self.elements_per_side + 1;
        let clamped_node = match (self.motor_k_nm_per_rad, self.motor_end) {
            (Some(_), _) => None,
            (None, MotorEnd::Rear) => Some(0),
            (None, MotorEnd::Front) => Some(n_nodes - 1),
        };
        let mut u = Vec::with_capacity(n_nodes);
        let mut theta = Vec::with_capacity(n_nodes);
        let mut next = 0;
        for i in 0..n_nodes {
            u.push(next);
            next += 1;
            if clamped_node == Some(i) {
                theta.push(None);
            } else {
                theta.push(Some(next));
                next += 1;
            }
        }
        Layout {
            u,
            theta,
            table: next,
            dofs: next + 1,
            nut_node: self.elements_per_side,
        }
    }

    /// Node coordinates from the rear bearing (m) with the nut at y.
    pub fn node_positions_m(&self, y_m: f64) -> Vec<f64> {
        let n = self.elements_per_side;
        let l1 = y_m / n as f64;
        let l2 = (self.length_m - y_m) / n as f64;
        (0..=2 * n)
            .map(|i| {
                if i <= n {
                    i as f64 * l1
                } else {
                    y_m + (i - n) as f64 * l2
                }
            })
            .collect()
    }

    /// Stiffness (without the feed-dependent joints) and mass matrices at nut position y.
    pub fn assemble(&self, y_m: f64, layout: &Layout) -> (DMatrix<f64>, DMatrix<f64>) {
        let nd = layout.dofs;
        let mut k = DMatrix::zeros(nd, nd);
        let mut m = DMatrix::zeros(nd, nd);
        let x = self.node_positions_m(y_m);
        for e in 0..x.len() - 1 {
            let l = x[e + 1] - x[e];
            let (a, b) = (layout.u[e], layout.u[e + 1]);
            add_rod(
                &mut k,
                &mut m,
                Some(a),
                Some(b),
                self.ea_n / l,
                self.rho_a_kg_m * l,
            );
            add_rod(
                &mut k,
                &mut m,
                layout.theta[e],
                layout.theta[e + 1],
                self.gj_nm2 / l,
                self.rho_j_kg_m * l,
            );
        }
        if let Some(kt) = self.motor_k_nm_per_rad {
            let node = match self.motor_end {
                MotorEnd::Rear => 0,
                MotorEnd::Front => x.len() - 1,
            };
            if let Some(i) = layout.theta[node] {
                k[(i, i)] += kt;
            }
        }
        let t = layout.table;
        m[(t, t)] += self.table_mass_kg;
        k[(t, t)] += self.guide_k_n_per_m;
        (k, m)
    }

    /// Incidence vectors b of the rear bearing, front bearing and nut joint (k·b·bᵀ each).
    pub fn joint_vectors(&self, layout: &Layout) -> [DVector<f64>; 3] {
        let nd = layout.dofs;
        let mut rear = DVector::zeros(nd);
        rear[layout.u[0]] = 1.0;
        let mut front = DVector::zeros(nd);
        front[layout.u[layout.u.len() - 1]] = 1.0;
        let mut nut = DVector::zeros(nd);
        nut[layout.table] = 1.0;
        nut[layout.u[layout.nut_node]] = -1.0;
        if let Some(i) = layout.theta[layout.nut_node] {
            nut[i] = -self.lead_m / (2.0 * PI);
        }
        [rear, front, nut]
    }
}

/// Degree-of-freedom numbering of the reduced system.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Layout {
    /// Index of u_i for node i.
    pub u: Vec<usize>,
    /// Index of θ_i for node i; None where clamped.
    pub theta: Vec<Option<usize>>,
    /// Index of the table displacement.
    pub table: usize,
    /// Size of the reduced system.
    pub dofs: usize,
    /// Node at the nut.
    pub nut_node: usize,
}

/// Add one two-node linear element (stiffness `k_el` = EA/ℓ or GJ/ℓ, total mass or inertia
/// `m_el` = ρAℓ or ρJℓ, consistent mass m_el/6·[2 1; 1 2]) between DOFs a and b; a `None` DOF
/// is clamped and its rows/columns are dropped.
pub(crate) fn add_rod(
    k: &mut DMatrix<f64>,
    m: &mut DMatrix<f64>,
    a: Option<usize>,
    b: Option<usize>,
    k_el: f64,
    m_el: f64,
) {
    let dofs = [a, b];
    let ke = [[k_el, -k_el], [-k_el, k_el]];
    let me = [[m_el / 3.0, m_el / 6.0], [m_el / 6.0, m_el / 3.0]];
    for (r, dr) in dofs.iter().enumerate() {
        let Some(i) = *dr else { continue };
        for (c, dc) in dofs.iter().enumerate() {
            let Some(j) = *dc else { continue };
            k[(i, j)] += ke[r][c];
            m[(i, j)] += me[r][c];
        }
    }
}
