//! The drive file: a documented TOML with the paper's Table 1 kind of parameters, user units in
//! the keys. Every key has a default; the defaults describe the paper's test drive (Table 1 and
//! Table 3), completed by the assumptions listed on each field and in `docs/dynamics.md`.

use serde::{Deserialize, Serialize};

use super::DynamicsError;

/// Which end of the screw the motor drives (and so is clamped in torsion).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum MotorEnd {
    /// The front bearing end (node at y = L); the paper's Eq. 8 puts the torsional stiffness
    /// on the front element, so this is the default.
    #[default]
    Front,
    /// The rear bearing end (node at y = 0), from which y is measured.
    Rear,
}

/// Screw shaft `[screw]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ScrewParams {
    /// Screw length between the two support bearings L (mm). Default 1400 (Table 1).
    pub length_mm: f64,
    /// Screw lead p (mm of table travel per revolution). Default 12 (Table 1).
    pub lead_mm: f64,
    /// Nominal (pitch-circle) diameter d0 (mm), used for the number of balls in the nut.
    /// Default 40 (Table 1).
    pub nominal_diameter_mm: f64,
    /// Cross-section of the root (bottom) diameter A0 (mm²), for the axial stiffness EA0.
    /// Default 930 (Table 1: 0.93e-3 m²).
    pub stiffness_area_mm2: f64,
    /// Equivalent cross-section Ae (mm²), for the mass ρAe. Default 1100 (Table 1: 1.1e-3 m²).
    pub mass_area_mm2: f64,
    /// Polar second moment of area Ir (mm⁴), for the torsional stiffness G·Ir and the torsional
    /// inertia ρ·Ir. Default 1.9e5 (Table 1: 1.9e-7 m⁴).
    pub polar_moment_mm4: f64,
    /// Young's modulus E (GPa). Default 210 (Table 1).
    pub youngs_modulus_gpa: f64,
    /// Shear modulus G (GPa). Default 80 (Table 1).
    pub shear_modulus_gpa: f64,
    /// Density ρ (kg/m³). Default 7850 (Table 1).
    pub density_kg_m3: f64,
    /// Motor end, `"front"` (default) or `"rear"`.
    pub motor_end: MotorEnd,
    /// Torsional stiffness holding the motor end (N·m/rad). Absent (default): rigid clamp,
    /// i.e. servo stiffness neglected as in the paper.
    pub motor_torsional_stiffness_nm_per_rad: Option<f64>,
}

impl Default for ScrewParams {
    fn default() -> Self {
        Self {
            length_mm: 1400.0,
            lead_mm: 12.0,
            nominal_diameter_mm: 40.0,
            stiffness_area_mm2: 930.0,
            mass_area_mm2: 1100.0,
            polar_moment_mm4: 1.9e5,
            youngs_modulus_gpa: 210.0,
            shear_modulus_gpa: 80.0,
            density_kg_m3: 7850.0,
            motor_end: MotorEnd::Front,
            motor_torsional_stiffness_nm_per_rad: None,
        }
    }
}

/// Calibrated Hertz constant of the default drive (N/m^1.5), Q = K_h·δ^{3/2} per ball.
///
/// Not in the paper's Table 1: chosen so that the default drive at rest, nut in the middle,
/// has the paper's static first frequency of 108 Hz (see `docs/dynamics.md`).
pub(crate) const DEFAULT_HERTZ_N_PER_M1_5: f64 = 2.98e9;

/// Screw-nut joint `[nut]` (paper Eq. 4).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NutParams {
    /// Contact angle α between ball and raceway (degrees). Default 60 (Table 1).
    pub contact_angle_deg: f64,
    /// Lead angle φ of the screw (degrees). Default 5.455 (Table 1).
    pub lead_angle_deg: f64,
    /// Ball diameter db (mm). Default 6.35 (Table 1).
    pub ball_diameter_mm: f64,
    /// Number of loaded turns (rings) i of one nut. Default 2 (Table 1).
    pub loaded_turns: f64,
    /// Rated dynamic load Pd (kN). Default 28.8 (Table 1).
    pub rated_dynamic_load_kn: f64,
    /// Preload as a fraction of Pd, Cp; P = Pd·Cp. Default 0.05 (the paper's text).
    pub preload_fraction: f64,
    /// Hertz constant K_h of one ball contact, Q = K_h·δ^{3/2} (N/m^1.5). Default 2.98e9:
    /// ASSUMED (calibrated to the 108 Hz static figure; the paper does not list it).
    pub hertz_constant_n_per_m1_5: f64,
    /// Weight c_wn for housing / bracket flexibility. Default 0.9 (the paper).
    pub stiffness_weight: f64,
}

impl Default for NutParams {
    fn default() -> Self {
        Self {
            contact_angle_deg: 60.0,
            lead_angle_deg: 5.455,
            ball_diameter_mm: 6.35,
            loaded_turns: 2.0,
            rated_dynamic_load_kn: 28.8,
            preload_fraction: 0.05,
            hertz_constant_n_per_m1_5: DEFAULT_HERTZ_N_PER_M1_5,
            stiffness_weight: 0.9,
        }
    }
}

/// Support bearings `[bearings]` (paper Eq. 5-6), the same unit at both ends.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BearingParams {
    /// Contact angle αb (degrees). Default 30 (Table 1).
    pub contact_angle_deg: f64,
    /// Loaded bearing rows per end carrying the axial load in one direction, N. Default 2:
    /// ASSUMED (a DT, i.e. tandem, pair of NSK 30TAC62B).
    pub loaded_rows: f64,
    /// Balls per row n. Default 17: ASSUMED (not in the paper; typical of a 30 mm bore
    /// 60° ball-screw support bearing).
    pub balls_per_row: f64,
    /// Screw pretension Fas (kN), the axial preload of each bearing unit at rest.
    /// Default 1.8 (Table 1, "Fa").
    pub screw_pretension_kn: f64,
    /// Hertz constant K_h of one ball contact (N/m^1.5). Default 2.98e9: ASSUMED, same as
    /// the nut.
    pub hertz_constant_n_per_m1_5: f64,
    /// Weight c_wb for housing flexibility. Default 0.9 (the paper).
    pub stiffness_weight: f64,
}

impl Default for BearingParams {
    fn default() -> Self {
        Self {
            contact_angle_deg: 30.0,
            loaded_rows: 2.0,
            balls_per_row: 17.0,
            screw_pretension_kn: 1.8,
            hertz_constant_n_per_m1_5: DEFAULT_HERTZ_N_PER_M1_5,
            stiffness_weight: 0.9,
        }
    }
}

/// Worktable `[table]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TableParams {
    /// Total moving mass m of worktable and nut (kg). Default 216 (Table 1).
    pub mass_kg: f64,
    /// Tangential stiffness of the guide carriages in the feed direction, kx (N/µm).
    /// Default 0 (the paper's Eq. 11 leaves it out).
    pub guide_stiffness_n_per_um: f64,
}

impl Default for TableParams {
    fn default() -> Self {
        Self {
            mass_kg: 216.0,
            guide_stiffness_n_per_um: 0.0,
        }
    }
}

/// Stribeck friction `[friction]` of the feed system, paper Eq. 3 with Table 3.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FrictionParams {
    /// Coulomb friction Fc (N). Default 658.89 (Table 3).
    pub coulomb_n: f64,
    /// Static friction Fs (N). Default 815.75 (Table 3).
    pub static_n: f64,
    /// Stribeck velocity vs (mm/min). Default 71 (Table 3: 0.071 m/min).
    pub stribeck_velocity_mm_min: f64,
    /// Viscous coefficient "delt" (N per mm/min). Default 0.04017 (Table 3: 40.17, read as
    /// N per m/min since the table gives vs in m/min).
    pub viscous_n_per_mm_min: f64,
    /// Stribeck shape exponent δ. Default 2 (Eq. 3).
    pub shape_exponent: f64,
}

impl Default for FrictionParams {
    fn default() -> Self {
        Self {
            coulomb_n: 658.89,
            static_n: 815.75,
            stribeck_velocity_mm_min: 71.0,
            viscous_n_per_mm_min: 0.04017,
            shape_exponent: 2.0,
        }
    }
}

/// Servo-motor torque ripple `[ripple]` (paper Eq. 16).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RippleParams {
    /// Pole pairs Pn of the motor. Default 4: ASSUMED (not in the paper).
    pub pole_pairs: f64,
    /// Harmonic coefficients N_P to check. Default [1, 2, 6]; N_P·Pn = 8 reproduces the paper's
    /// resonance near 10.8 m/min and 119 Hz.
    pub harmonics: Vec<f64>,
    /// A ripple line within this distance of a natural frequency is a resonance risk (Hz).
    /// Default 3.
    pub margin_hz: f64,
}

impl Default for RippleParams {
    fn default() -> Self {
        Self {
            pole_pairs: 4.0,
            harmonics: vec![1.0, 2.0, 6.0],
            margin_hz: 3.0,
        }
    }
}

/// What to sweep `[sweep]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SweepParams {
    /// Highest feed rate of the feed sweep (mm/min); the sweep runs from 0 (rest). Default 80000.
    pub feed_max_mm_min: f64,
    /// Number of feed rates, rest included. Default 200.
    pub feed_points: usize,
    /// Nut position y (from the rear bearing) of the feed sweep (mm). Default 700 (middle).
    pub position_mm: f64,
    /// First nut position of the position sweep (mm). Default 100.
    pub position_min_mm: f64,
    /// Last nut position of the position sweep (mm). Default 1300.
    pub position_max_mm: f64,
    /// Number of positions. Default 50.
    pub position_points: usize,
    /// Feed rates at which the position sweep is run (mm/min). Default [0, 10000, 30000, 60000].
    pub position_feeds_mm_min: Vec<f64>,
    /// Number of modes reported (lowest first). Default 3.
    pub modes: usize,
}

impl Default for SweepParams {
    fn default() -> Self {
        Self {
            feed_max_mm_min: 80_000.0,
            feed_points: 200,
            position_mm: 700.0,
            position_min_mm: 100.0,
            position_max_mm: 1300.0,
            position_points: 50,
            position_feeds_mm_min: vec![0.0, 10_000.0, 30_000.0, 60_000.0],
            modes: 3,
        }
    }
}

/// Finite-element mesh `[mesh]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MeshParams {
    /// Shaft elements on each side of the nut. Default 8 (the first frequency is converged to
    /// better than 0.01 %, see the test `mesh_convergence_of_first_frequency`).
    pub elements_per_side: usize,
}

impl Default for MeshParams {
    fn default() -> Self {
        Self {
            elements_per_side: 8,
        }
    }
}

/// A whole drive file. Every table and key is optional; missing ones take the defaults above
/// (the paper's drive).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct DriveConfig {
    /// Free-text name.
    pub name: Option<String>,
    /// `[screw]`
    pub screw: ScrewParams,
    /// `[nut]`
    pub nut: NutParams,
    /// `[bearings]`
    pub bearings: BearingParams,
    /// `[table]`
    pub table: TableParams,
    /// `[friction]`
    pub friction: FrictionParams,
    /// `[ripple]`
    pub ripple: RippleParams,
    /// `[sweep]`
    pub sweep: SweepParams,
    /// `[mesh]`
    pub mesh: MeshParams,
}

/// Highest feed rate a drive file may name (mm/min): 1000 m/min, several times the fastest
/// linear-motor axis and ten times the fastest ball-screw axis.
const MAX_FEED_MM_MIN: f64 = 1e6;

/// A value within the physical range `[lo, hi]` of its key. Every float key has one: the
/// ranges are wide (far beyond any ball-screw drive) but finite, because the model multiplies
/// and factors these numbers, and a product that overflows (a Hertz constant of 1e308
/// N/m^1.5, a preload fraction or loaded turns of 1e300, a stiffness weight of 1.8e308, a
/// feed of 1e308 mm/min) puts an infinity into the stiffness matrix, whose eigenvalues are
/// then NaN and were reported as natural frequencies of 0.0 Hz.
fn ranged(
    key: &'static str,
    value: f64,
    lo: f64,
    hi: f64,
    reason: &'static str,
) -> Result<(), DynamicsError> {
    if value.is_finite() && value >= lo && value <= hi {
        Ok(())
    } else {
        Err(DynamicsError::InvalidValue { key, value, reason })
    }
}

fn angle(key: &'static str, value: f64) -> Result<(), DynamicsError> {
    if value.is_finite() && value > 0.0 && value < 90.0 {
        Ok(())
    } else {
        Err(DynamicsError::InvalidValue {
            key,
            value,
            reason: "must be an angle in (0, 90) degrees",
        })
    }
}

/// Sizes are bounded above as well: they set how much is allocated and solved (a sweep of
/// 2^63 points or a mesh of 10^9 elements would abort the process instead of failing cleanly).
fn count(
    key: &'static str,
    value: usize,
    min: usize,
    max: usize,
    too_many: &'static str,
) -> Result<(), DynamicsError> {
    if value < min {
        return Err(DynamicsError::InvalidValue {
            key,
            value: value as f64,
            reason: if min <= 1 {
                "must be at least 1"
            } else {
                "must be at least 2"
            },
        });
    }
    if value > max {
        return Err(DynamicsError::InvalidValue {
            key,
            value: value as f64,
            reason: too_many,
        });
    }
    Ok(())
}

impl DriveConfig {
    /// Parse a TOML drive file. `source_name` labels errors (usually the file name).
    ///
    /// # Errors
    /// [`DynamicsError::Parse`] for bad TOML, unknown keys or wrong types (the message names the
    /// key), [`DynamicsError::InvalidValue`] for values out of range.
    pub fn from_toml_str(text: &str, source_name: &str) -> Result<Self, DynamicsError> {
        let cfg: DriveConfig = toml::from_str(text).map_err(|e| DynamicsError::Parse {
            source_name: source_name.to_owned(),
            message: e.to_string(),
        })?;
        cfg.validate()?;
        Ok(cfg)
    }

    /// Check every key against its physical range.
    ///
    /// # Errors
    /// [`DynamicsError::InvalidValue`] naming the first offending key.
    pub fn validate(&self) -> Result<(), DynamicsError> {
        let s = &self.screw;
        ranged(
            "screw.length_mm",
            s.length_mm,
            1.0,
            50_000.0,
            "must lie in [1, 50000] mm",
        )?;
        ranged(
            "screw.lead_mm",
            s.lead_mm,
            0.1,
            500.0,
            "must lie in [0.1, 500] mm",
        )?;
        ranged(
            "screw.nominal_diameter_mm",
            s.nominal_diameter_mm,
            1.0,
            1000.0,
            "must lie in [1, 1000] mm",
        )?;
        ranged(
            "screw.stiffness_area_mm2",
            s.stiffness_area_mm2,
            0.1,
            1e6,
            "must lie in [0.1, 1e6] mm²",
        )?;
        ranged(
            "screw.mass_area_mm2",
            s.mass_area_mm2,
            0.1,
            1e6,
            "must lie in [0.1, 1e6] mm²",
        )?;
        ranged(
            "screw.polar_moment_mm4",
            s.polar_moment_mm4,
            1e-3,
            1e12,
            "must lie in [1e-3, 1e12] mm⁴",
        )?;
        ranged(
            "screw.youngs_modulus_gpa",
            s.youngs_modulus_gpa,
            1.0,
            1500.0,
            "must lie in [1, 1500] GPa (steel: 210)",
        )?;
        ranged(
            "screw.shear_modulus_gpa",
            s.shear_modulus_gpa,
            0.5,
            1000.0,
            "must lie in [0.5, 1000] GPa (steel: 80)",
        )?;
        ranged(
            "screw.density_kg_m3",
            s.density_kg_m3,
            100.0,
            25_000.0,
            "must lie in [100, 25000] kg/m³ (steel: 7850)",
        )?;
        if let Some(k) = s.motor_torsional_stiffness_nm_per_rad {
            ranged(
                "screw.motor_torsional_stiffness_nm_per_rad",
                k,
                1e-3,
                1e10,
                "must lie in [1e-3, 1e10] N·m/rad",
            )?;
        }
        let n = &self.nut;
        angle("nut.contact_angle_deg", n.contact_angle_deg)?;
        angle("nut.lead_angle_deg", n.lead_angle_deg)?;
        ranged(
            "nut.ball_diameter_mm",
            n.ball_diameter_mm,
            0.1,
            200.0,
            "must lie in [0.1, 200] mm",
        )?;
        ranged(
            "nut.loaded_turns",
            n.loaded_turns,
            0.1,
            100.0,
            "must lie in [0.1, 100]",
        )?;
        ranged(
            "nut.rated_dynamic_load_kn",
            n.rated_dynamic_load_kn,
            1e-3,
            1e5,
            "must lie in [0.001, 1e5] kN",
        )?;
        ranged(
            "nut.preload_fraction",
            n.preload_fraction,
            0.0,
            1.0,
            "must lie in [0, 1] (a fraction of the rated dynamic load; typical 0.02-0.1)",
        )?;
        ranged(
            "nut.hertz_constant_n_per_m1_5",
            n.hertz_constant_n_per_m1_5,
            1e6,
            1e13,
            "must lie in [1e6, 1e13] N/m^1.5 (steel balls: about 3e9)",
        )?;
        ranged(
            "nut.stiffness_weight",
            n.stiffness_weight,
            1e-3,
            10.0,
            "must lie in [0.001, 10] (the paper: 0.9)",
        )?;
        if n.ball_diameter_mm >= s.nominal_diameter_mm {
            return Err(DynamicsError::InvalidValue {
                key: "nut.ball_diameter_mm",
                value: n.ball_diameter_mm,
                reason: "must be smaller than screw.nominal_diameter_mm",
            });
        }
        let b = &self.bearings;
        angle("bearings.contact_angle_deg", b.contact_angle_deg)?;
        ranged(
            "bearings.loaded_rows",
            b.loaded_rows,
            0.1,
            100.0,
            "must lie in [0.1, 100]",
        )?;
        ranged(
            "bearings.balls_per_row",
            b.balls_per_row,
            1.0,
            1000.0,
            "must lie in [1, 1000]",
        )?;
        ranged(
            "bearings.screw_pretension_kn",
            b.screw_pretension_kn,
            0.0,
            1e4,
            "must lie in [0, 1e4] kN",
        )?;
        ranged(
            "bearings.hertz_constant_n_per_m1_5",
            b.hertz_constant_n_per_m1_5,
            1e6,
            1e13,
            "must lie in [1e6, 1e13] N/m^1.5 (steel balls: about 3e9)",
        )?;
        ranged(
            "bearings.stiffness_weight",
            b.stiffness_weight,
            1e-3,
            10.0,
            "must lie in [0.001, 10] (the paper: 0.9)",
        )?;
        ranged(
            "table.mass_kg",
            self.table.mass_kg,
            1e-3,
            1e6,
            "must lie in [0.001, 1e6] kg",
        )?;
        ranged(
            "table.guide_stiffness_n_per_um",
            self.table.guide_stiffness_n_per_um,
            0.0,
            1e6,
            "must lie in [0, 1e6] N/µm",
        )?;
        let f = &self.friction;
        ranged(
            "friction.coulomb_n",
            f.coulomb_n,
            0.0,
            1e6,
            "must lie in [0, 1e6] N",
        )?;
        ranged(
            "friction.static_n",
            f.static_n,
            0.0,
            1e6,
            "must lie in [0, 1e6] N",
        )?;
        ranged(
            "friction.stribeck_velocity_mm_min",
            f.stribeck_velocity_mm_min,
            0.0,
            MAX_FEED_MM_MIN,
            "must lie in [0, 1e6] mm/min",
        )?;
        ranged(
            "friction.viscous_n_per_mm_min",
            f.viscous_n_per_mm_min,
            0.0,
            1e3,
            "must lie in [0, 1000] N per mm/min",
        )?;
        ranged(
            "friction.shape_exponent",
            f.shape_exponent,
            0.1,
            10.0,
            "must lie in [0.1, 10] (Eq. 3: 2)",
        )?;
        let r = &self.ripple;
        ranged(
            "ripple.pole_pairs",
            r.pole_pairs,
            1.0,
            1000.0,
            "must lie in [1, 1000]",
        )?;
        for &h in &r.harmonics {
            ranged(
                "ripple.harmonics",
                h,
                1e-3,
                1000.0,
                "must lie in [0.001, 1000]",
            )?;
        }
        ranged(
            "ripple.margin_hz",
            r.margin_hz,
            0.0,
            1e5,
            "must lie in [0, 1e5] Hz",
        )?;
        let w = &self.sweep;
        ranged(
            "sweep.feed_max_mm_min",
            w.feed_max_mm_min,
            1e-3,
            MAX_FEED_MM_MIN,
            "must lie in [0.001, 1e6] mm/min",
        )?;
        count(
            "sweep.feed_points",
            w.feed_points,
            2,
            100_000,
            "must be at most 100000",
        )?;
        count(
            "sweep.position_points",
            w.position_points,
            2,
            10_000,
            "must be at most 10000",
        )?;
        count("sweep.modes", w.modes, 1, 100, "must be at most 100")?;
        inside("sweep.position_mm", w.position_mm, s.length_mm)?;
        inside("sweep.position_min_mm", w.position_min_mm, s.length_mm)?;
        inside("sweep.position_max_mm", w.position_max_mm, s.length_mm)?;
        if w.position_max_mm <= w.position_min_mm {
            return Err(DynamicsError::InvalidValue {
                key: "sweep.position_max_mm",
                value: w.position_max_mm,
                reason: "must be greater than sweep.position_min_mm",
            });
        }
        if w.position_feeds_mm_min.is_empty() {
            return Err(DynamicsError::InvalidValue {
                key: "sweep.position_feeds_mm_min",
                value: 0.0,
                reason: "must list at least one feed rate",
            });
        }
        for &v in &w.position_feeds_mm_min {
            if !(v.is_finite() && v.abs() <= MAX_FEED_MM_MIN) {
                return Err(DynamicsError::InvalidValue {
                    key: "sweep.position_feeds_mm_min",
                    value: v,
                    reason: "must lie in [-1e6, 1e6] mm/min",
                });
            }
        }
        // 500 per side is a 1001-node model, far finer than the modes need (tests converge by 20).
        count(
            "mesh.elements_per_side",
            self.mesh.elements_per_side,
            1,
            500,
            "must be at most 500",
        )?;
        // Each sweep point solves an eigenproblem of about 4·elements_per_side + 2 DOFs
        // (axial and torsional nodes): O(n³) each. 500 elements and 10,000 positions at four
        // feeds ran for minutes; the bound keeps a run within about ten seconds.
        let solves = (w.feed_points + w.position_points * w.position_feeds_mm_min.len()) as f64;
        let n = (4 * self.mesh.elements_per_side + 2) as f64;
        if solves * n.powi(3) > MAX_SWEEP_WORK {
            return Err(DynamicsError::InvalidValue {
                key: "mesh.elements_per_side",
                value: self.mesh.elements_per_side as f64,
                reason: "too fine for the sweep: (sweep.feed_points + sweep.position_points × \
                         the number of sweep.position_feeds_mm_min) × (4·elements_per_side + \
                         2)³ must be at most 1e10 (about ten seconds of eigen solves); use \
                         fewer elements or fewer sweep points",
            });
        }
        Ok(())
    }
}

/// Bound of the sweep's eigen-solve work, solves × DOFs³ (the default drive: 1.6e7).
const MAX_SWEEP_WORK: f64 = 1e10;

/// Nearest a nut position may come to a bearing, as a fraction of the screw's length: 0.1 %.
/// The mesh puts `elements_per_side` elements on either side of the nut, and a side of
/// 2.2e-308 mm made elements of no length and modes of NaN.
pub const MIN_END_CLEARANCE: f64 = 1e-3;

fn inside(key: &'static str, value: f64, length_mm: f64) -> Result<(), DynamicsError> {
    let margin = MIN_END_CLEARANCE * length_mm;
    if value.is_finite() && value >= margin && value <= length_mm - margin {
        Ok(())
    } else {
        Err(DynamicsError::InvalidValue {
            key,
            value,
            reason: "must lie between 0 and screw.length_mm, at least 0.1 % of the length \
                     from either end (the nut between the bearings)",
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_validate_and_round_trip() {
        let cfg = DriveConfig::default();
        cfg.validate().unwrap();
        let text = toml::to_string(&cfg).unwrap();
        let back = DriveConfig::from_toml_str(&text, "x").unwrap();
        assert_eq!(back, cfg);
    }

    #[test]
    fn unknown_key_is_named() {
        let err = DriveConfig::from_toml_str("[screw]\nlenght_mm = 3\n", "d.toml").unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains("lenght_mm"), "{msg}");
        assert!(msg.contains("d.toml"), "{msg}");
    }

    #[test]
    fn bad_value_is_named() {
        let err = DriveConfig::from_toml_str("[table]\nmass_kg = -1\n", "d.toml").unwrap_err();
        assert!(matches!(
            err,
            DynamicsError::InvalidValue {
                key: "table.mass_kg",
                ..
            }
        ));
        let err = DriveConfig::from_toml_str("[sweep]\nposition_mm = 1400\n", "d").unwrap_err();
        assert!(err.to_string().contains("sweep.position_mm"));
    }
}
