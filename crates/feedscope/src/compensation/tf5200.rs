//! Beckhoff TwinCAT CNC (TF5200): the `frict_comp` block of the axis compensation list.
//!
//! # What the documentation states
//! Beckhoff Information System, TF5200 TwinCAT CNC, "Axis compensation parameters" and
//! "Friction compensation" (<https://infosys.beckhoff.com/content/1033/tf5200_axis_compensation_parameters/113454347.html>,
//! `.../113455883.html`, `.../113457419.html`, `.../113449739.html`, `.../654611851.html`,
//! `.../493246859.html`, `.../113451275.html`, `.../113452811.html`, `.../351557899.html`;
//! `https://infosys.beckhoff.com/content/1033/tf5200_friction_comp/352391819.html`,
//! `.../352406411.html`, `.../352383115.html`):
//!
//! | ID | key | type | unit | range, default |
//! |---|---|---|---|---|
//! | P-COMP-00041 | `frict_comp.mode` | UNS16 | – | 0 off, 3 "additive current taking into account the commanded speed" (the only value permitted besides 0); default 0 |
//! | P-COMP-00042 | `frict_comp.table_entries` | UNS16 | – | 0 ≤ entries ≤ P-COMP-00062 |
//! | P-COMP-00043 | `frict_comp.position_delay` | SGN32 | 0.1 µm | 0 ≤ value ≤ 10; default 0 (linear current build-up at start-up) |
//! | P-COMP-00044 | `frict_comp.reversal_lookahead` | UNS16 | cycles | 0 to 4; default 0 (current decays before a reversal) |
//! | P-COMP-00045 | `frict_comp.scaling_factor` | SGN16 | 0.1 % | default 1000 (= 100 %), scales every `out` |
//! | P-COMP-00046 | `frict_comp.table[i].in` | SGN32; REAL64 as of V3.1.3132.0 / V4.29.0 | µm/s (translatory axis) | ascending, ≥ 0 |
//! | P-COMP-00047 | `frict_comp.table[i].out` | SGN32; REAL64 as of V3.1.3132.0 / V4.29.0 | drive-dependent: for CANopen and SERCOS the unit of the CNC object `dig_drv.act_torque` | – |
//! | P-COMP-00058 | `frict_comp.delay_cycles` | SGN16 | cycles | 0 ≤ value < 249; default 0 |
//! | P-COMP-00062 | `frict_comp.max_points` | UNS32 | – | default 20 (as of CNC build V3.1.3079.06); may not change after start-up |
//!
//! Activation: the axis parameter P-AXIS-00522 `lr_param.frict_comp 1` and a mode ≠ 0; in
//! the NC program `X[COMP ON FRICT]` / `X[COMP OFF FRICT]`. The table must ascend in
//! velocity, checked when the list is loaded (error P-ERR-110591). Comment lines of the ASCII
//! lists start with `# ` (a hash and a blank).
//!
//! # What is not confirmed (and what this module does about it)
//! - **The unit of `out`** is the drive's (the unit of `dig_drv.act_torque`): the caller
//!   states it ([`Tf5200OutUnit`]: amperes or newton-metres per unit). Many drives report
//!   torque in 0.1 % of the rated torque or current, but nothing here assumes so.
//! - **Interpolation between entries** is not described; linear interpolation in velocity is
//!   assumed for the stated error. What the CNC outputs below the first and above the last
//!   entry is not described either; the table spans exactly the measured velocities and the
//!   documentation's example starts with `in 0, out 0`, which feedscope does not add (it
//!   would be an extrapolation below the slowest measured feed).
//! - **Directions**: the table has velocities ≥ 0 only, one table per axis; that the CNC
//!   applies it with the sign of the commanded velocity is assumed. With both directions
//!   measured the table holds their mean and the error against each direction is stated.
//! - P-COMP-00046's page gives the range `0 < in`, the parameterisation page `in ≥ 0` (and
//!   an example with `in 0`); P-COMP-00043's range is 0 to 10 but the example sets 30. Not
//!   used here: the table starts above 0 and the optional keys keep their defaults.
//! - A key prefix `kenngr.frict_comp` was not found in the documentation; the keys are
//!   `frict_comp.*` in the axis compensation list and `lr_param.frict_comp` in the axis list.
//!
//! Integers are written (SGN32 in older builds, exact in REAL64): velocities to 1 µm/s
//! (the first rounded up and the last down, so that no entry leaves the measured range),
//! `out` to one unit; the stated error is that of the rounded table.

use super::{
    interpolation_error, place_points, CompensationError, DriveConversion, FrictionCurve,
    InterpolationError, PlacedTable, PlacementParams,
};
use crate::stroke::Direction;

/// The default of `frict_comp.max_points` (P-COMP-00062).
pub const DEFAULT_MAX_POINTS: usize = 20;

/// The default of `frict_comp.scaling_factor` (P-COMP-00045): 1000 × 0.1 % = 100 %.
pub const SCALING_FACTOR_100_PERCENT: i32 = 1000;

/// What one unit of `frict_comp.table[i].out` is: the drive's unit of `dig_drv.act_torque`,
/// which the documentation leaves to the drive.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Tf5200OutUnit {
    /// One unit is this many amperes of motor current (e.g. 0.001 for mA).
    Ampere(f64),
    /// One unit is this many newton-metres of motor torque.
    NewtonMetre(f64),
}

impl Tf5200OutUnit {
    /// The unit's size and symbol, e.g. (0.001, "A").
    pub fn size_and_symbol(&self) -> (f64, &'static str) {
        match *self {
            Self::Ampere(a) => (a, "A"),
            Self::NewtonMetre(t) => (t, "N*m"),
        }
    }

    /// A friction force (N) in units of `out` (not rounded).
    pub fn units_of_n(&self, drive: &DriveConversion, friction_n: f64) -> f64 {
        match *self {
            Self::Ampere(a) => drive.current_a(friction_n) / a,
            Self::NewtonMetre(t) => drive.torque_nm(friction_n) / t,
        }
    }

    /// The friction force (N) of `out` units.
    pub fn n_of_units(&self, drive: &DriveConversion, out: f64) -> f64 {
        match *self {
            Self::Ampere(a) => drive.friction_from_current_n(out * a),
            Self::NewtonMetre(t) => drive.friction_from_torque_n(out * t),
        }
    }
}

/// Settings of [`Tf5200Table::build`].
#[derive(Debug, Clone, PartialEq)]
pub struct Tf5200Params {
    /// Table entries (P-COMP-00042), 2 to `max_points`.
    pub points: usize,
    /// `frict_comp.max_points` configured on the CNC (P-COMP-00062). Default 20.
    pub max_points: usize,
    /// The unit of `out`.
    pub out_unit: Tf5200OutUnit,
}

impl Tf5200Params {
    /// `points` entries in `out_unit`, with the default `max_points` (20).
    pub fn new(points: usize, out_unit: Tf5200OutUnit) -> Self {
        Self {
            points,
            max_points: DEFAULT_MAX_POINTS,
            out_unit,
        }
    }
}

/// One table entry as written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Tf5200Entry {
    /// `frict_comp.table[i].in`: commanded velocity (µm/s).
    pub in_um_s: i64,
    /// `frict_comp.table[i].out`: additive motor current or torque, in units of
    /// [`Tf5200OutUnit`].
    pub out: i64,
}

/// The `frict_comp` block of one axis: mode 3, the table of commanded velocity against
/// additive motor current, scaling 100 % (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct Tf5200Table {
    /// The entries, ascending in velocity.
    pub entries: Vec<Tf5200Entry>,
    /// The settings it was built with.
    pub params: Tf5200Params,
    /// `frict_comp.scaling_factor` (0.1 %): [`SCALING_FACTOR_100_PERCENT`].
    pub scaling_factor: i32,
    /// The curve tabulated: one direction's, or the mean of both.
    pub curve: FrictionCurve,
    /// Force → torque → current.
    pub drive: DriveConversion,
    /// The placement before rounding to the controller's integers.
    pub placed: PlacedTable,
    /// Error of the written (rounded) table against `curve`, in N (divide by
    /// N per `out` unit for the unit of `out`).
    pub error: InterpolationError,
    /// For a table of both directions (their mean): the error of the written table against
    /// each direction's own curve, the interpolation and the asymmetry of the directions
    /// together. Empty for a table of one direction.
    pub direction_errors: Vec<(Direction, InterpolationError)>,
}

impl Tf5200Table {
    /// Build the block from the forward and/or backward curve (both: their mean, on the
    /// common velocity range).
    ///
    /// # Errors
    /// [`CompensationError::TooFewPoints`], [`CompensationError::TooManyPoints`] (above
    /// `max_points`), [`CompensationError::BadParameter`] for no curve, a `max_points` below
    /// 2 or above the placement limit, or a unit that is not positive and finite;
    /// [`CompensationError::NoCommonRange`]; [`CompensationError::DoesNotFit`] for a value
    /// beyond SGN32 or a unit so coarse that the largest entry is below 10 units;
    /// [`CompensationError::BadTable`] when the velocities collapse at 1 µm/s; else as
    /// [`place_points`].
    pub fn build(
        forward: Option<&FrictionCurve>,
        backward: Option<&FrictionCurve>,
        drive: DriveConversion,
        params: &Tf5200Params,
        placement: &PlacementParams,
    ) -> Result<Self, CompensationError> {
        if params.max_points < 2 || params.max_points > placement.max_points() {
            return Err(CompensationError::BadParameter {
                name: "frict_comp.max_points",
                value: params.max_points as f64,
                expected: "2 to the placement limit (512)",
            });
        }
        if params.points < 2 {
            return Err(CompensationError::TooFewPoints {
                points: params.points,
            });
        }
        if params.points > params.max_points {
            return Err(CompensationError::TooManyPoints {
                points: params.points,
                max: params.max_points,
                what: "frict_comp.max_points (P-COMP-00062)",
            });
        }
        let (size, _) = params.out_unit.size_and_symbol();
        if !(size.is_finite() && size > 0.0) {
            return Err(CompensationError::BadParameter {
                name: "out unit",
                value: size,
                expected: "a positive finite size of one unit of frict_comp.table[i].out",
            });
        }
        let curve = match (forward, backward) {
            (Some(f), Some(b)) => FrictionCurve::direction_mean(f, b)?,
            (Some(c), None) | (None, Some(c)) => c.clone(),
            (None, None) => {
                return Err(CompensationError::BadParameter {
                    name: "direction",
                    value: f64::NAN,
                    expected: "a forward or a backward curve",
                })
            }
        };
        let placed = place_points(&curve, params.points, placement)?;
        let (lo, hi) = curve.range_m_s();
        // Velocities in whole µm/s, inside the measured range.
        let last = placed.velocity_m_s.len() - 1;
        let mut in_um_s: Vec<i64> = placed
            .velocity_m_s
            .iter()
            .enumerate()
            .map(|(i, &v)| {
                let x = v * 1e6;
                match i {
                    0 => x.ceil(),
                    i if i == last => x.floor(),
                    _ => x.round(),
                }
            })
            .map(|x| x as i64)
            .collect();
        in_um_s[0] = in_um_s[0].max((lo * 1e6).ceil() as i64);
        for i in 1..in_um_s.len() {
            if in_um_s[i] <= in_um_s[i - 1] {
                in_um_s[i] = in_um_s[i - 1] + 1;
            }
        }
        if in_um_s[last] as f64 > (hi * 1e6).floor() {
            return Err(CompensationError::BadTable {
                reason: format!(
                    "{} entries do not fit between {} and {} µm/s at the 1 µm/s resolution of \
                     frict_comp.table[i].in: use fewer points",
                    params.points,
                    (lo * 1e6).ceil(),
                    (hi * 1e6).floor()
                ),
            });
        }
        let velocity_m_s: Vec<f64> = in_um_s.iter().map(|&x| x as f64 * 1e-6).collect();
        let mut entries = Vec::with_capacity(in_um_s.len());
        for (&v, &inn) in velocity_m_s.iter().zip(&in_um_s) {
            let units = params
                .out_unit
                .units_of_n(&drive, curve.checked_n(v)?)
                .round();
            if units.abs() > i32::MAX as f64 {
                return Err(CompensationError::DoesNotFit {
                    name: "frict_comp.table[i].out",
                    value: units,
                    data_type: "SGN32",
                    reason: "choose a larger unit of out",
                });
            }
            entries.push(Tf5200Entry {
                in_um_s: inn,
                out: units as i64,
            });
        }
        let largest = entries.iter().map(|e| e.out.abs()).max().unwrap_or(0);
        if largest < 10 {
            return Err(CompensationError::DoesNotFit {
                name: "frict_comp.table[i].out",
                value: largest as f64,
                data_type: "integer units",
                reason: "the largest entry is below 10 units: the unit given for out is too \
                         coarse (or given inverted: it is the size of ONE unit, e.g. 0.001 A)",
            });
        }
        let written_n: Vec<f64> = entries
            .iter()
            .map(|e| params.out_unit.n_of_units(&drive, e.out as f64))
            .collect();
        let error = interpolation_error(&curve, &velocity_m_s, &written_n, placement)?;
        // A mean table: its error against each direction's own curve too.
        let mut direction_errors = Vec::new();
        if let (Some(f), Some(b)) = (forward, backward) {
            for c in [f, b] {
                if let Some(d) = c.direction() {
                    direction_errors.push((
                        d,
                        interpolation_error(c, &velocity_m_s, &written_n, placement)?,
                    ));
                }
            }
        }
        Ok(Self {
            entries,
            params: params.clone(),
            scaling_factor: SCALING_FACTOR_100_PERCENT,
            curve,
            drive,
            placed,
            error,
            direction_errors,
        })
    }

    /// Newtons of friction per unit of `out`.
    pub fn n_per_unit(&self) -> f64 {
        self.params.out_unit.n_of_units(&self.drive, 1.0)
    }
}
