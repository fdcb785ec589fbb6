//! Mechanism parameters of one ball-screw feed axis, read from a documented TOML (or JSON) file.
//!
//! User units live in the keys (`lead_mm`, `inertia_kgm2`, ...); the accessors give SI values
//! for the maths (`lead_m`, `equivalent_mass_kg`, ...).
//!
//! # Reference
//! Paper 000 (sensorless friction estimation), Eq. 1-5 for the drive model and Eq. 7 for the
//! ball-refeed order.

use std::f64::consts::PI;

use serde::{Deserialize, Serialize};

/// Largest `inertia_kgm2` accepted (kg·m²): ten times the largest feed drives' rotor, coupling
/// and screw.
pub const MAX_INERTIA_KGM2: f64 = 10.0;

/// Largest `damping_nms_per_rad` accepted (N·m·s/rad): a servo motor's viscous damping is
/// about 1e-4 to 1e-1 N·m·s/rad.
pub const MAX_DAMPING_NMS_PER_RAD: f64 = 10.0;

/// Largest `torque_constant_nm_per_a` accepted (N·m/A): feed-drive servo motors have 0.1 to
/// about 50 N·m/A.
pub const MAX_TORQUE_CONSTANT_NM_PER_A: f64 = 500.0;

/// Errors reading or validating an axis file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum AxisError {
    /// The file is not valid TOML/JSON or a key has the wrong type.
    #[error("{source_name}: {message}")]
    Parse {
        /// File name (or other label) of the input.
        source_name: String,
        /// What the parser reported.
        message: String,
    },
    /// A `[thresholds]` key is not a known condition indicator.
    #[error("{source_name}: [thresholds]: `{name}` is not a condition indicator (see `feedscope history show`)")]
    UnknownIndicator {
        /// File name (or other label) of the input.
        source_name: String,
        /// The unknown key.
        name: String,
    },
    /// A key holds a value outside its physical range.
    #[error("{source_name}: key `{key}` = {}: {reason}", crate::units::Shown(*.value))]
    InvalidValue {
        /// File name (or other label) of the input.
        source_name: String,
        /// The offending key.
        key: &'static str,
        /// The value found.
        value: f64,
        /// Why it is rejected.
        reason: &'static str,
    },
}

impl AxisError {
    /// What the error means to a caller: always [`BadInput`](crate::ErrorKind::BadInput): the axis file or a value in it is wrong.
    pub fn kind(&self) -> crate::ErrorKind {
        use crate::ErrorKind;
        ErrorKind::BadInput
    }
}

/// A kinematic order declared by the user (e.g. a rolling-tool mark at 0.56 cycles per lead).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DeclaredOrder {
    /// Cycles per screw revolution (= cycles per lead of table travel).
    pub order: f64,
    /// Human-readable cause, e.g. `"rolling-tool mark"`.
    pub cause: String,
}

/// Parameters of one feed axis (user units in the key names).
///
/// Required: `lead_mm`, `table_mass_kg`, `inertia_kgm2`, `damping_nms_per_rad`,
/// `torque_constant_nm_per_a`. Geometry keys are optional and only needed for the kinematic
/// orders of the nut and the guides.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AxisParams {
    /// Free-text name, e.g. `"lathe Z"`.
    #[serde(default)]
    pub name: Option<String>,
    /// Screw lead p (mm of table travel per screw revolution).
    pub lead_mm: f64,
    /// Worktable (moving) mass m_t (kg).
    pub table_mass_kg: f64,
    /// Lumped inertia J of motor armature, coupling and screw on the motor shaft (kg·m²).
    pub inertia_kgm2: f64,
    /// Lumped viscous damping B of the bearings on the motor shaft (N·m·s/rad).
    pub damping_nms_per_rad: f64,
    /// Motor torque constant k_e (N·m/A). Ignored for traces that carry torque.
    pub torque_constant_nm_per_a: f64,
    /// Screw nominal (pitch-circle) diameter d (mm), for Eq. 7.
    #[serde(default)]
    pub screw_diameter_mm: Option<f64>,
    /// Ball diameter d_b in the nut (mm), for Eq. 7.
    #[serde(default)]
    pub screw_ball_diameter_mm: Option<f64>,
    /// Contact angle β between raceway and ball (degrees), for Eq. 7.
    #[serde(default)]
    pub contact_angle_deg: Option<f64>,
    /// Number of balls forming one circle (turn) in the nut raceway, z in Eq. 7.
    #[serde(default)]
    pub screw_balls_per_turn: Option<f64>,
    /// Ball diameter in the linear guides (mm); informative, Eq. 7 with d → ∞ does not use it.
    #[serde(default)]
    pub guide_ball_diameter_mm: Option<f64>,
    /// Number of balls in one loaded raceway of a guide carriage, z in Eq. 7 with d → ∞.
    #[serde(default)]
    pub guide_balls_per_raceway: Option<f64>,
    /// Lower end of the usable travel (mm), used by test planning.
    #[serde(default)]
    pub travel_min_mm: Option<f64>,
    /// Upper end of the usable travel (mm), used by test planning.
    #[serde(default)]
    pub travel_max_mm: Option<f64>,
    /// Rapid traverse rate of the axis (G00, mm/min). Optional: it sharpens the recognition
    /// of rapid moves in a trace and bounds the speed a position sample may imply.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rapid_rate_mm_min: Option<f64>,
    /// Extra orders with known causes (e.g. rolling-tool marks).
    #[serde(default, rename = "declared_order")]
    pub declared_orders: Vec<DeclaredOrder>,
    /// Alarm levels per condition indicator (`[thresholds]` table, e.g.
    /// `fs_n = { upper = 480 }`), used by `history trend` and `report`; keys are
    /// the indicator names of [`crate::history::Indicator`].
    #[serde(default, skip_serializing_if = "std::collections::BTreeMap::is_empty")]
    pub thresholds: std::collections::BTreeMap<String, crate::history::Threshold>,
}

/// Which file syntax an axis description is in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ConfigFormat {
    /// TOML (the documented default).
    Toml,
    /// JSON with the same keys.
    Json,
}

impl ConfigFormat {
    /// Guess from a file name: `.json` is JSON, anything else TOML.
    pub fn from_path(path: &std::path::Path) -> Self {
        match path.extension().and_then(|e| e.to_str()) {
            Some(e) if e.eq_ignore_ascii_case("json") => Self::Json,
            _ => Self::Toml,
        }
    }
}

impl AxisParams {
    /// Parse and validate an axis description.
    ///
    /// # Errors
    /// [`AxisError::Parse`] on syntax errors, unknown keys or missing required keys;
    /// [`AxisError::InvalidValue`] when a value is out of range (naming the key).
    pub fn parse(text: &str, format: ConfigFormat, source_name: &str) -> Result<Self, AxisError> {
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let parsed: Self = match format {
            ConfigFormat::Toml => toml::from_str(text).map_err(|e| AxisError::Parse {
                source_name: source_name.to_string(),
                message: with_identified_hint(e.to_string().trim_end()),
            })?,
            ConfigFormat::Json => serde_json::from_str(text).map_err(|e| AxisError::Parse {
                source_name: source_name.to_string(),
                message: with_identified_hint(&e.to_string()),
            })?,
        };
        parsed.validate(source_name)?;
        Ok(parsed)
    }

    /// Parse and validate an axis description for the one-test identification
    /// ([`crate::ident::identify`], [`crate::study::triangle_test`]), which identifies the
    /// inertia and the damping: `inertia_kgm2` and `damping_nms_per_rad` may be absent.
    ///
    /// An absent key is held as NaN ("not given"): such an axis must not reach estimation or
    /// simulation, which need the values. Before storing or reusing it, fill the keys with
    /// [`AxisParams::resolve_identified`]. Given keys are validated as by
    /// [`AxisParams::parse`].
    ///
    /// # Errors
    /// As [`AxisParams::parse`], except that the two keys may be missing.
    pub fn parse_for_identification(
        text: &str,
        format: ConfigFormat,
        source_name: &str,
    ) -> Result<Self, AxisError> {
        const IDENTIFIED: [&str; 2] = ["inertia_kgm2", "damping_nms_per_rad"];
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let parse_err = |message: String| AxisError::Parse {
            source_name: source_name.to_string(),
            message,
        };
        // Fill the absent keys with 0 (valid), deserialize, then mark them NaN.
        let mut missing = [false; 2];
        let mut parsed: Self = match format {
            ConfigFormat::Toml => {
                let mut t: toml::Table = toml::from_str(text)
                    .map_err(|e| parse_err(e.to_string().trim_end().to_string()))?;
                for (k, key) in IDENTIFIED.iter().enumerate() {
                    if !t.contains_key(*key) {
                        missing[k] = true;
                        t.insert((*key).to_string(), toml::Value::Float(0.0));
                    }
                }
                toml::Value::Table(t)
                    .try_into()
                    .map_err(|e| parse_err(e.to_string().trim_end().to_string()))?
            }
            ConfigFormat::Json => {
                let mut v: serde_json::Value =
                    serde_json::from_str(text).map_err(|e| parse_err(e.to_string()))?;
                if let Some(o) = v.as_object_mut() {
                    for (k, key) in IDENTIFIED.iter().enumerate() {
                        if !o.contains_key(*key) {
                            missing[k] = true;
                            o.insert((*key).to_string(), serde_json::json!(0.0));
                        }
                    }
                }
                serde_json::from_value(v).map_err(|e| parse_err(e.to_string()))?
            }
        };
        parsed.validate(source_name)?;
        if missing[0] {
            parsed.inertia_kgm2 = f64::NAN;
        }
        if missing[1] {
            parsed.damping_nms_per_rad = f64::NAN;
        }
        Ok(parsed)
    }

    /// True when `inertia_kgm2` and `damping_nms_per_rad` hold values (always, except for an
    /// axis from [`AxisParams::parse_for_identification`] whose file left them out).
    pub fn has_dynamics(&self) -> bool {
        self.inertia_kgm2.is_finite() && self.damping_nms_per_rad.is_finite()
    }

    /// Fill the keys that [`AxisParams::parse_for_identification`] left as NaN with what the
    /// identification found for the total inertia J_total (kg·m²): `inertia_kgm2` =
    /// J_total − m_t·(p/2π)² (not below 0), `damping_nms_per_rad` = 0 (the identification
    /// lumps the bearing damping into its σ). Given values are kept.
    pub fn resolve_identified(&mut self, j_total_kgm2: f64) {
        if !self.inertia_kgm2.is_finite() {
            let k = self.lead_m() / (2.0 * PI);
            self.inertia_kgm2 = (j_total_kgm2 - self.table_mass_kg * k * k).max(0.0);
        }
        if !self.damping_nms_per_rad.is_finite() {
            self.damping_nms_per_rad = 0.0;
        }
    }

    /// Check every value against its physical range.
    ///
    /// # Errors
    /// [`AxisError::InvalidValue`] naming the first offending key.
    pub fn validate(&self, source_name: &str) -> Result<(), AxisError> {
        let bad = |key: &'static str, value: f64, reason: &'static str| AxisError::InvalidValue {
            source_name: source_name.to_string(),
            key,
            value,
            reason,
        };
        let positive = |key: &'static str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(bad(key, v, "must be a finite number greater than zero"))
            }
        };
        let non_negative = |key: &'static str, v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(bad(key, v, "must be a finite number, zero or greater"))
            }
        };
        // Upper (and for the lead, lower) bounds far beyond any ball-screw axis but finite:
        // the maths divides by the lead and multiplies by the rest, and 1e308 would
        // overflow into infinities that no later check names.
        let at_most = |key: &'static str, v: f64, max: f64, reason: &'static str| {
            if v <= max {
                Ok(())
            } else {
                Err(bad(key, v, reason))
            }
        };
        positive("lead_mm", self.lead_mm)?;
        if !(0.1..=500.0).contains(&self.lead_mm) {
            return Err(bad("lead_mm", self.lead_mm, "must lie in [0.1, 500] mm"));
        }
        non_negative("table_mass_kg", self.table_mass_kg)?;
        at_most(
            "table_mass_kg",
            self.table_mass_kg,
            1e6,
            "must be at most 1e6 kg",
        )?;
        // The upper bounds are physical, ten times and more beyond the largest feed drives:
        // a value past them is a unit slip (g·cm² for kg·m², N·m·s/rev for /rad, mN·m/A)
        // that would turn every friction value into nonsense (damping 1000 gave −7.9e6 N).
        non_negative("inertia_kgm2", self.inertia_kgm2)?;
        at_most(
            "inertia_kgm2",
            self.inertia_kgm2,
            MAX_INERTIA_KGM2,
            "must be at most 10 kg·m² (motor rotor, coupling and screw: the largest feed \
             drives have about 1 kg·m²)",
        )?;
        non_negative("damping_nms_per_rad", self.damping_nms_per_rad)?;
        at_most(
            "damping_nms_per_rad",
            self.damping_nms_per_rad,
            MAX_DAMPING_NMS_PER_RAD,
            "must be at most 10 N·m·s/rad (a servo motor's viscous damping is about 1e-4 to \
             1e-1 N·m·s/rad; 10 would take 3 kN·m at 3000 rpm)",
        )?;
        positive("torque_constant_nm_per_a", self.torque_constant_nm_per_a)?;
        at_most(
            "torque_constant_nm_per_a",
            self.torque_constant_nm_per_a,
            MAX_TORQUE_CONSTANT_NM_PER_A,
            "must be at most 500 N·m/A (feed-drive servo motors have 0.1 to about 50 N·m/A)",
        )?;
        for (key, v) in [
            ("travel_min_mm", self.travel_min_mm),
            ("travel_max_mm", self.travel_max_mm),
        ] {
            // NaN is refused too: a lone travel bound let it through.
            if let Some(v) = v.filter(|v| !v.is_finite() || v.abs() > 1e5) {
                return Err(bad(key, v, "must lie within ±100000 mm (100 m)"));
            }
        }
        if let Some(v) = self.rapid_rate_mm_min {
            at_most("rapid_rate_mm_min", v, 1e6, "must be at most 1e6 mm/min")?;
        }
        // The geometry of Eq. 7 is bounded too: a ball count of 1e308 made the nut's refeed
        // order infinite.
        if let Some(v) = self.screw_diameter_mm {
            positive("screw_diameter_mm", v)?;
            at_most("screw_diameter_mm", v, 1000.0, "must be at most 1000 mm")?;
        }
        if let Some(v) = self.screw_ball_diameter_mm {
            positive("screw_ball_diameter_mm", v)?;
            at_most("screw_ball_diameter_mm", v, 200.0, "must be at most 200 mm")?;
            if let Some(d) = self.screw_diameter_mm {
                if v >= d {
                    return Err(bad(
                        "screw_ball_diameter_mm",
                        v,
                        "must be smaller than screw_diameter_mm",
                    ));
                }
            }
        }
        if let Some(v) = self.contact_angle_deg {
            if !(v.is_finite() && (0.0..90.0).contains(&v)) {
                return Err(bad("contact_angle_deg", v, "must lie in [0, 90) degrees"));
            }
        }
        if let Some(v) = self.screw_balls_per_turn {
            positive("screw_balls_per_turn", v)?;
            at_most("screw_balls_per_turn", v, 1000.0, "must be at most 1000")?;
        }
        if let Some(v) = self.guide_ball_diameter_mm {
            positive("guide_ball_diameter_mm", v)?;
            at_most("guide_ball_diameter_mm", v, 200.0, "must be at most 200 mm")?;
        }
        if let Some(v) = self.guide_balls_per_raceway {
            positive("guide_balls_per_raceway", v)?;
            at_most(
                "guide_balls_per_raceway",
                v,
                10_000.0,
                "must be at most 10000",
            )?;
        }
        if let (Some(lo), Some(hi)) = (self.travel_min_mm, self.travel_max_mm) {
            if !(lo.is_finite() && hi.is_finite() && hi > lo) {
                return Err(bad(
                    "travel_max_mm",
                    hi,
                    "must be finite and greater than travel_min_mm",
                ));
            }
        }
        if let Some(v) = self.rapid_rate_mm_min {
            positive("rapid_rate_mm_min", v)?;
        }
        for d in &self.declared_orders {
            positive("declared_order.order", d.order)?;
            at_most(
                "declared_order.order",
                d.order,
                1e4,
                "must be at most 1e4 cycles per lead",
            )?;
        }
        for (name, t) in &self.thresholds {
            if crate::history::Indicator::parse(name).is_none() {
                return Err(AxisError::UnknownIndicator {
                    source_name: source_name.to_string(),
                    name: name.clone(),
                });
            }
            for v in [t.upper, t.lower].into_iter().flatten() {
                if !v.is_finite() {
                    return Err(bad("thresholds", v, "must be a finite number"));
                }
                if v.abs() > crate::history::MAX_ABS_THRESHOLD {
                    return Err(bad(
                        "thresholds",
                        v,
                        "must lie within ±1e9 (no condition indicator comes near)",
                    ));
                }
            }
        }
        Ok(())
    }

    /// Screw lead p in metres.
    pub fn lead_m(&self) -> f64 {
        self.lead_mm * 1e-3
    }

    /// Equivalent translational mass m_t + 4π²J/p² (kg), the left factor of Eq. 5.
    pub fn equivalent_mass_kg(&self) -> f64 {
        let p = self.lead_m();
        self.table_mass_kg + 4.0 * PI * PI * self.inertia_kgm2 / (p * p)
    }

    /// Equivalent translational damping 4π²B/p² (N·s/m), Eq. 5.
    pub fn equivalent_damping_n_s_per_m(&self) -> f64 {
        let p = self.lead_m();
        4.0 * PI * PI * self.damping_nms_per_rad / (p * p)
    }

    /// Force on the table per newton-metre of motor torque, 2π/p (N per N·m), Eq. 3.
    pub fn force_per_torque_n_per_nm(&self) -> f64 {
        2.0 * PI / self.lead_m()
    }

    /// Ball-refeed order of the nut (cycles per screw revolution), Eq. 7:
    /// f = ½·z·(d − d_b·cos β)/d. `None` when the geometry keys are missing.
    pub fn nut_refeed_order(&self) -> Option<f64> {
        let d = self.screw_diameter_mm?;
        let db = self.screw_ball_diameter_mm?;
        let beta = self.contact_angle_deg?.to_radians();
        let z = self.screw_balls_per_turn?;
        Some(0.5 * z * (d - db * beta.cos()) / d)
    }

    /// Ball-refeed order of the linear guides (cycles per lead), Eq. 7 with d → ∞: f = z/2.
    pub fn guide_refeed_order(&self) -> Option<f64> {
        self.guide_balls_per_raceway.map(|z| 0.5 * z)
    }
}

/// A parser's message, with a hint when it is about a missing key that the one-test
/// identification could supply.
fn with_identified_hint(message: &str) -> String {
    let key = ["inertia_kgm2", "damping_nms_per_rad"]
        .into_iter()
        .find(|k| message.contains(&format!("missing field `{k}`")));
    match key {
        Some(k) => format!(
            "{message}\n(`{k}` is required here; `feedscope identify` and `feedscope history \
             add --kind triangle` identify it from a triangular-wave test and accept an axis \
             file without it)"
        ),
        None => message.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MINIMAL: &str = "lead_mm = 10\ntable_mass_kg = 425\ninertia_kgm2 = 0.004\n\
        damping_nms_per_rad = 0.002\ntorque_constant_nm_per_a = 1.82\n";

    #[test]
    fn minimal_toml_parses_and_gives_si() {
        let a = AxisParams::parse(MINIMAL, ConfigFormat::Toml, "a.toml").unwrap();
        assert!((a.lead_m() - 0.01).abs() < 1e-15);
        // 425 + 4π²·0.004/1e-4 = 425 + 1579.14
        assert!((a.equivalent_mass_kg() - (425.0 + 1579.1367)).abs() < 1e-3);
    }

    #[test]
    fn identification_accepts_an_axis_without_inertia_and_damping() {
        let text = "lead_mm = 16\ntable_mass_kg = 400\ntorque_constant_nm_per_a = 1.2\n\
                    [thresholds]\nfs_n = { upper = 480 }\n";
        // estimation needs the keys: the error names the first and says who identifies it
        let e = AxisParams::parse(text, ConfigFormat::Toml, "a.toml").unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.contains("inertia_kgm2") && msg.contains("identify"),
            "{msg}"
        );
        let mut a =
            AxisParams::parse_for_identification(text, ConfigFormat::Toml, "a.toml").unwrap();
        assert!(a.inertia_kgm2.is_nan() && a.damping_nms_per_rad.is_nan());
        assert!(!a.has_dynamics());
        assert_eq!(a.thresholds["fs_n"].upper, Some(480.0));
        // J_total 0.0056 with 400 kg at 16 mm: J_m = 0.0056 − 400·(0.016/2π)² = 0.0030061
        a.resolve_identified(0.0056);
        assert!((a.inertia_kgm2 - (0.0056 - 400.0 * (0.016 / (2.0 * PI)).powi(2))).abs() < 1e-15);
        assert!(a.has_dynamics());
        assert!(a.validate("a.toml").is_ok());
        // given keys are kept and still validated; JSON works the same
        let full = AxisParams::parse_for_identification(MINIMAL, ConfigFormat::Toml, "a").unwrap();
        assert!((full.inertia_kgm2 - 0.004).abs() < 1e-15);
        let bad = MINIMAL.replace("inertia_kgm2 = 0.004", "inertia_kgm2 = -1");
        let e = AxisParams::parse_for_identification(&bad, ConfigFormat::Toml, "a").unwrap_err();
        assert!(e.to_string().contains("inertia_kgm2"), "{e}");
        let json = r#"{"lead_mm": 5, "table_mass_kg": 100, "torque_constant_nm_per_a": 0.9,
            "damping_nms_per_rad": 0.001}"#;
        let j = AxisParams::parse_for_identification(json, ConfigFormat::Json, "a.json").unwrap();
        assert!(j.inertia_kgm2.is_nan() && (j.damping_nms_per_rad - 0.001).abs() < 1e-15);
        // other missing keys are still refused
        let e = AxisParams::parse_for_identification("lead_mm = 5\n", ConfigFormat::Toml, "a")
            .unwrap_err();
        assert!(e.to_string().contains("table_mass_kg"), "{e}");
    }

    #[test]
    fn negative_lead_names_key() {
        let text = MINIMAL.replace("lead_mm = 10", "lead_mm = -10");
        let e = AxisParams::parse(&text, ConfigFormat::Toml, "a.toml").unwrap_err();
        assert!(e.to_string().contains("lead_mm"), "{e}");
    }

    #[test]
    fn zero_torque_constant_rejected() {
        let text = MINIMAL.replace("= 1.82", "= 0");
        let e = AxisParams::parse(&text, ConfigFormat::Toml, "a.toml").unwrap_err();
        assert!(e.to_string().contains("torque_constant_nm_per_a"), "{e}");
    }

    #[test]
    fn unknown_key_rejected() {
        let text = format!("{MINIMAL}leadd_mm = 3\n");
        let e = AxisParams::parse(&text, ConfigFormat::Toml, "a.toml").unwrap_err();
        assert!(e.to_string().contains("leadd_mm"), "{e}");
    }

    #[test]
    fn json_with_same_keys() {
        let json = r#"{"lead_mm": 5, "table_mass_kg": 100, "inertia_kgm2": 0.001,
            "damping_nms_per_rad": 0, "torque_constant_nm_per_a": 0.9}"#;
        let a = AxisParams::parse(json, ConfigFormat::Json, "a.json").unwrap();
        assert!((a.lead_mm - 5.0).abs() < 1e-15);
    }

    #[test]
    fn thresholds_table_is_checked() {
        let ok = format!("{MINIMAL}[thresholds]\nfs_n = {{ upper = 480 }}\n");
        let a = AxisParams::parse(&ok, ConfigFormat::Toml, "a.toml").unwrap();
        assert_eq!(a.thresholds["fs_n"].upper, Some(480.0));
        let bad = format!("{MINIMAL}[thresholds]\nfs_nn = {{ upper = 480 }}\n");
        let e = AxisParams::parse(&bad, ConfigFormat::Toml, "a.toml").unwrap_err();
        assert!(e.to_string().contains("fs_nn"), "{e}");
    }

    #[test]
    fn refeed_orders_eq7() {
        let mut a = AxisParams::parse(MINIMAL, ConfigFormat::Toml, "a").unwrap();
        a.guide_balls_per_raceway = Some(19.0);
        assert!((a.guide_refeed_order().unwrap() - 9.5).abs() < 1e-12);
        a.screw_diameter_mm = Some(40.0);
        a.screw_ball_diameter_mm = Some(5.556);
        a.contact_angle_deg = Some(0.0);
        a.screw_balls_per_turn = Some(20.0);
        // ½·20·(40 − 5.556)/40
        assert!((a.nut_refeed_order().unwrap() - 8.611).abs() < 1e-9);
    }
}
