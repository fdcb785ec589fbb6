//! Feed-drive dynamics: natural frequencies of a ball-screw feed system against feed rate and
//! table position, and the feed rates where a torque-ripple harmonic of the servo motor meets
//! one of them.
//!
//! # Model (hybrid elements, transmission direction only)
//!
//! * The screw between the two support bearings (length `L`) is split at the nut (distance `y`
//!   from the rear bearing) into a rear part of length `y` and a front part of length `L − y`;
//!   each part is meshed with `n` two-node shaft elements. Each node carries an axial
//!   displacement `u` (m) and a torsional rotation `θ` (rad).
//! * Support bearings are axial springs to ground at the two screw ends, the screw-nut joint is a
//!   spring between the table and the nut point of the screw, and the worktable is a point mass.
//! * The motor end of the screw is clamped in torsion (servo stiffness neglected, as in the paper)
//!   or held by a torsional spring if one is given.
//! * Joint stiffnesses come from Hertz point contact (paper Eq. 4-6) and change with feed rate
//!   through the Stribeck friction force f(v) (paper Eq. 3).
//!
//! The generalised eigenproblem `K x = ω² M x` (paper Eq. 1 without damping) is solved by
//! factoring `M = L Lᵀ` and taking the symmetric eigenvalues of `L⁻¹ K L⁻ᵀ` (nalgebra has no
//! generalised solver). See `docs/dynamics.md` for the derivation and the reconstruction of the
//! paper's matrices, which are garbled in the available text.
//!
//! # Plan once, run many
//!
//! [`DriveModel`] holds the validated SI parameters. [`DriveModel::at_position`] assembles `M`
//! and the feed-independent part of `K` at one nut position, factors `M` and projects everything
//! into a [`PositionPlan`]; the joint springs are rank-one updates, so each call of
//! [`PositionPlan::frequencies_hz`] for another feed rate costs one small symmetric eigenvalue
//! problem.
//!
//! ```
//! use feedscope::dynamics::{DriveConfig, DriveModel};
//!
//! let model = DriveModel::from_config(&DriveConfig::default()).unwrap();
//! let plan = model.at_position(0.7).unwrap(); // nut in the middle of the 1.4 m screw
//! let at_rest = plan.frequencies_hz(0.0, 1)[0];
//! let moving = plan.frequencies_hz(1.0 / 60.0, 1)[0]; // 1 m/min
//! assert!((at_rest - 108.0).abs() < 1.0); // the paper's static figure (calibrated, see docs)
//! assert!(moving > at_rest); // the jump from rest to motion
//! ```
//!
//! # Reference
//! H. Zhang, J. Zhang, H. Liu, T. Liang, W. Zhao, "Dynamic modeling and analysis of the
//! high-speed ball screw feed system", Proc. IMechE Part B 229(5) 870-877, 2015
//! (paper 001 in `shared/seeds`).

mod assemble;
mod config;
mod contact;
mod modal;
mod report;
mod ripple;

pub use config::{
    BearingParams, DriveConfig, FrictionParams, MeshParams, MotorEnd, NutParams, RippleParams,
    ScrewParams, SweepParams, TableParams, MIN_END_CLEARANCE,
};
pub use contact::{hertz_axial_stiffness_n_per_m, JointState};
pub use modal::{DriveModel, ModalDiagnostics, ModalResult, ModeShape, PositionPlan};
pub use report::{
    analyse, DynamicsReport, FeedPoint, FeedSweep, PositionPoint, PositionSweep, Resonance,
    UnloadEvent,
};
pub use ripple::{find_resonances, ripple_frequency_hz};

/// Errors reading, validating or solving a feed-drive model.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DynamicsError {
    /// The configuration is not valid TOML or a key is unknown or has the wrong type.
    #[error("{source_name}: {message}")]
    Parse {
        /// File name (or other label) of the input.
        source_name: String,
        /// What the parser reported (names the key).
        message: String,
    },
    /// A key holds a value outside its physical range.
    #[error("key `{key}` = {}: {reason}", crate::units::Shown(*.value))]
    InvalidValue {
        /// The offending key, with its table, e.g. `screw.length_mm`.
        key: &'static str,
        /// The value found.
        value: f64,
        /// Why it is rejected.
        reason: &'static str,
    },
    /// The nut position must lie strictly between the two support bearings.
    #[error(
        "nut position {position_m} m is not between the bearings (0 and {length_m} m, at \
         least 0.1 % of the length from either)"
    )]
    PositionOutOfRange {
        /// Requested nut position y from the rear bearing (m).
        position_m: f64,
        /// Screw length L between the bearings (m).
        length_m: f64,
    },
    /// The mass matrix failed its Cholesky factorisation (not positive definite).
    #[error("mass matrix is not positive definite at nut position {position_m} m")]
    MassNotPositiveDefinite {
        /// Nut position y from the rear bearing (m).
        position_m: f64,
    },
}

impl DynamicsError {
    /// What the error means to a caller: always [`BadInput`](crate::ErrorKind::BadInput): the drive file, a value in it or a nut position is wrong
    /// (a mass matrix that is not positive definite comes from its masses and inertias).
    pub fn kind(&self) -> crate::ErrorKind {
        use crate::ErrorKind;
        ErrorKind::BadInput
    }
}

#[cfg(test)]
mod tests;
