//! Friction compensation for the controller: from an identified friction curve to the table
//! or the parameters a CNC loads.
//!
//! A control compensates friction by feeding forward, at every commanded velocity, the motor
//! current (or torque, or a velocity-setpoint pulse) that the friction will take. This module
//! turns what feedscope identified into that, with the numbers a control engineer needs to
//! trust it: where the table is valid, how far its straight lines stray from the curve, and in
//! which units and signs its values are.
//!
//! # Operations
//! - [`FrictionCurve`]: a friction magnitude curve of one direction on the velocity range
//!   where it was measured, from a Stribeck fit ([`FrictionCurve::from_stribeck`], paper 000
//!   Eq. 9) or from the friction map's section at one position
//!   ([`FrictionCurve::from_map_section`], Eq. 6 with the feed polynomial of Eq. 8). Nothing
//!   is ever evaluated outside that range: a table point outside it is refused.
//! - [`place_points`]: N table points (commanded velocity → friction) placed where the curve
//!   bends, by minimising the largest error of the piecewise-linear interpolation between them
//!   (module [`placement`]), and [`interpolation_error`], the error of any table against the
//!   continuous curve (largest and RMS, in N and %).
//! - [`DriveConversion`]: friction force at the table to motor torque and motor current.
//! - [`VelocityTable`]: the generic table, per direction, for any control.
//! - [`Tf5200Table`]: the `frict_comp` block of the Beckhoff TwinCAT CNC (TF5200) axis
//!   compensation list.
//! - [`SinumerikStartValues`]: starting values of the SINUMERIK conventional friction
//!   compensation (quadrant-error compensation), to be tuned with the circularity test.
//!
//! Files are written by `feedscope_io::controller_compensation`.
//!
//! # Conventions
//! - SI inside: velocities in m/s, forces in N, torques in N·m, currents in A. The tables of a
//!   curve hold **magnitudes**, one table per direction (or one for both, TF5200).
//! - Sign: friction is signed as in paper 000 Eq. 5 (positive while the table moves forward,
//!   position increasing). The compensation adds the friction's torque/current **with the
//!   sign of the commanded velocity**: +|i| moving forward, −|i| moving backward, where a
//!   positive current is one that pushes the table forward (the convention of the traces
//!   feedscope reads; a drive whose current sign is inverted against the axis direction needs
//!   the opposite sign).
//! - Conversion (paper 000 Eq. 3/5 at steady speed, paper 001 Eq. 15 inverted): motor torque
//!   T = F·p/(2π·η), motor current i = T/k_e, p the lead, η the screw's forward efficiency
//!   used when the friction was computed from a torque (η = 1 for `feedscope map`, whose
//!   Eq. 5 already attributes every loss of the drive to F), k_e the torque constant.
//!
//! # Example
//! ```
//! use feedscope::compensation::{place_points, DriveConversion, FrictionCurve, PlacementParams};
//! use feedscope::stribeck::{fit_stribeck, StribeckFitParams, StribeckParams};
//! use feedscope::stroke::Direction;
//! use feedscope::units::feed_mm_min_to_m_s;
//!
//! // A Stribeck fit of 12 log-spaced feeds 9-900 mm/min (exact data).
//! let truth = StribeckParams { fc_n: 260.0, fs_n: 345.0, vs_m_s: feed_mm_min_to_m_s(45.0),
//!                              sigma_n_s_per_m: 7000.0, delta: 2.0 };
//! let v: Vec<f64> = (0..12).map(|k| feed_mm_min_to_m_s(9.0 * 100f64.powf(k as f64 / 11.0)))
//!     .collect();
//! let f: Vec<f64> = v.iter().map(|&v| truth.magnitude_n(v)).collect();
//! let fit = fit_stribeck(&v, &f, &StribeckFitParams::default())?;
//! let curve = FrictionCurve::from_stribeck(Direction::Forward, &fit)?;
//!
//! // 20 points where the curve bends, and what linear interpolation between them costs.
//! let table = place_points(&curve, 20, &PlacementParams::default())?;
//! assert_eq!(table.velocity_m_s.len(), 20);
//! assert!(table.error.max_n < 0.5 && table.error.max_pct < 0.2);
//!
//! // The motor current of the first point: 10 mm lead, k_e 1.82 N·m/A, η = 1.
//! let drive = DriveConversion::new(0.010, 1.82, 1.0)?;
//! let i = drive.current_a(table.friction_n[0]);
//! assert!((i - table.friction_n[0] * 0.010 / (2.0 * std::f64::consts::PI) / 1.82).abs() < 1e-12);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! # Reference
//! Paper 000 Eq. 3, 5, 6, 8, 9; paper 001 Eq. 15. Beckhoff TF5200 TwinCAT CNC, axis
//! compensation parameters P-COMP-00041 to P-COMP-00047, P-COMP-00058, P-COMP-00062
//! (<https://infosys.beckhoff.com/content/1033/tf5200_axis_compensation_parameters/113454347.html>
//! and the neighbouring pages); SINUMERIK 840D sl Function Manual Extended Functions K3,
//! Section 4.6 "Friction compensation (quadrant error compensation)", 03/2013,
//! 6FC5397-1BP40-3BA1. See [`tf5200`] and [`sinumerik`] for what was confirmed there and
//! what was not.

mod curve;
mod drive;
pub mod placement;
pub mod sinumerik;
mod table;
#[cfg(test)]
mod tests;
pub mod tf5200;

pub use curve::{CurveSource, FrictionCurve};
pub use drive::DriveConversion;
pub use placement::{
    interpolation_error, place_points, InterpolationError, PlacedTable, PlacementParams,
};
pub use sinumerik::{SinumerikParams, SinumerikStartValues};
pub use table::{DirectionVelocityTable, VelocityTable, VELOCITY_TABLE_MAX_POINTS};
pub use tf5200::{Tf5200Entry, Tf5200OutUnit, Tf5200Params, Tf5200Table};

use crate::stroke::Direction;

/// Why a compensation table or a set of controller parameters cannot be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum CompensationError {
    /// Fewer table points than a piecewise-linear table needs.
    #[error("{points} table points: a table needs at least 2")]
    TooFewPoints {
        /// Points asked for.
        points: usize,
    },
    /// More table points than the controller (or the placement grid) holds.
    #[error("{points} table points: {what} holds at most {max}")]
    TooManyPoints {
        /// Points asked for.
        points: usize,
        /// The limit.
        max: usize,
        /// Whose limit, for people (e.g. `frict_comp.max_points (P-COMP-00062)`).
        what: &'static str,
    },
    /// The measured velocity range of a curve is empty, not positive or not finite.
    #[error(
        "{curve}: the measured velocities [{lo_mm_min}, {hi_mm_min}] mm/min are not a range \
         a table can span (it needs two distinct positive feeds)"
    )]
    NoRange {
        /// Which curve.
        curve: String,
        /// Slowest measured feed (mm/min).
        lo_mm_min: f64,
        /// Fastest measured feed (mm/min).
        hi_mm_min: f64,
    },
    /// The two directions' measured velocities do not overlap (one table for both
    /// directions needs a common range).
    #[error(
        "the forward feeds [{forward_lo_mm_min}, {forward_hi_mm_min}] mm/min and the backward \
         feeds [{backward_lo_mm_min}, {backward_hi_mm_min}] mm/min do not overlap"
    )]
    NoCommonRange {
        /// Forward slowest feed (mm/min).
        forward_lo_mm_min: f64,
        /// Forward fastest feed (mm/min).
        forward_hi_mm_min: f64,
        /// Backward slowest feed (mm/min).
        backward_lo_mm_min: f64,
        /// Backward fastest feed (mm/min).
        backward_hi_mm_min: f64,
    },
    /// A table velocity lies outside the curve's measured range: an extrapolation.
    #[error(
        "{curve}: table velocity {velocity_mm_min} mm/min is outside the measured feeds \
         [{lo_mm_min}, {hi_mm_min}] mm/min (no extrapolation)"
    )]
    OutsideRange {
        /// Which curve.
        curve: String,
        /// The velocity (mm/min).
        velocity_mm_min: f64,
        /// Slowest measured feed (mm/min).
        lo_mm_min: f64,
        /// Fastest measured feed (mm/min).
        hi_mm_min: f64,
    },
    /// A table is malformed (velocities not strictly increasing, lengths that disagree, a
    /// value that is not finite).
    #[error("malformed table: {reason}")]
    BadTable {
        /// What is wrong.
        reason: String,
    },
    /// The curve gives a value that is not a positive finite force.
    #[error(
        "{curve}: friction {value_n} N at {velocity_mm_min} mm/min is not a positive finite force"
    )]
    BadValue {
        /// Which curve.
        curve: String,
        /// Where (mm/min).
        velocity_mm_min: f64,
        /// The value (N).
        value_n: f64,
    },
    /// The fit a curve would come from did not converge.
    #[error(
        "the {direction} Stribeck fit did not converge ({iterations} iterations): its curve \
         is not a result to load into a control"
    )]
    NotConverged {
        /// Direction (`forward`, `backward`).
        direction: &'static str,
        /// Iterations used.
        iterations: usize,
    },
    /// An operation needs a Stribeck curve (breakaway friction F_s, Stribeck velocity v_s)
    /// and the curve is not one.
    #[error(
        "{what} need the breakaway friction Fs and the Stribeck velocity vs of a Stribeck \
         curve; the {direction} curve is {model}: measure at least 4 distinct feeds per \
         direction, several below the Stribeck velocity"
    )]
    NeedsStribeck {
        /// Which output, plural (e.g. `the SINUMERIK starting values`).
        what: &'static str,
        /// Direction (`forward`, `backward`).
        direction: &'static str,
        /// What the curve is instead (e.g. `a coulomb-viscous fit`).
        model: String,
    },
    /// A parameter is out of its range.
    #[error("{name} = {value} is out of range: {expected}")]
    BadParameter {
        /// Parameter name (as the user gives it where possible).
        name: &'static str,
        /// Its value.
        value: f64,
        /// The allowed range, for people.
        expected: &'static str,
    },
    /// A value does not fit the controller's data type.
    #[error("{name} = {value} does not fit the controller's {data_type} ({reason})")]
    DoesNotFit {
        /// Parameter name.
        name: &'static str,
        /// The value.
        value: f64,
        /// The controller's data type (e.g. `SGN32`).
        data_type: &'static str,
        /// What to change.
        reason: &'static str,
    },
}

impl CompensationError {
    /// What the error means to a caller: always [`BadInput`](crate::ErrorKind::BadInput): the
    /// curve, the table or a parameter the user gave does not allow the output.
    pub fn kind(&self) -> crate::ErrorKind {
        crate::ErrorKind::BadInput
    }
}

/// The name of a direction, or `both` for a curve of both directions.
pub(crate) fn direction_name(direction: Option<Direction>) -> &'static str {
    direction.map_or("both", Direction::as_str)
}
