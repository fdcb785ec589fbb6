//! Units of controller signals and the plausibility limits of the controller imports
//! ([`super::sinumerik`], [`super::twincat`]).
//!
//! A controller file states a signal's unit as text (`mm (Length)`, `A`), as a quantity
//! (SINUMERIK `unitsType="posn"`) or not at all; the user can always say it with a flag.
//! [`PositionUnit`] and [`EffortUnit`] are the units feedscope converts from, each with its
//! factor to SI. The limits ([`MAX_POSITION_MM`], [`MAX_CURRENT_A`], [`MAX_TORQUE_NM`]) are far
//! beyond any feed drive: a value past them is a wrong signal, a wrong unit or a damaged file,
//! never a measurement, and the imports refuse it naming the record.
use feedscope::trace::EffortKind;

/// Largest |position| accepted (mm): 100 m, longer than any machine axis.
pub const MAX_POSITION_MM: f64 = 1e5;
/// Largest |current| accepted (A): 10 kA, above the largest servo drives.
pub const MAX_CURRENT_A: f64 = 1e4;
/// Largest |torque| accepted (N·m): 1 MN·m, above any feed or spindle motor.
pub const MAX_TORQUE_NM: f64 = 1e6;

/// Unit of a position signal (serialised as its flag value: `mm`, `um`, `m`, `inch`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum PositionUnit {
    /// Millimetre (SINUMERIK and TwinCAT NC default for linear axes).
    #[serde(rename = "mm")]
    Millimetre,
    /// Micrometre.
    #[serde(rename = "um")]
    Micrometre,
    /// Metre.
    #[serde(rename = "m")]
    Metre,
    /// Inch (a control with an inch basic system).
    #[serde(rename = "inch")]
    Inch,
}

impl PositionUnit {
    /// Metres per unit.
    pub fn metres(self) -> f64 {
        match self {
            Self::Millimetre => 1e-3,
            Self::Micrometre => 1e-6,
            Self::Metre => 1.0,
            Self::Inch => 25.4e-3,
        }
    }

    /// The symbol written in reports.
    pub fn symbol(self) -> &'static str {
        match self {
            Self::Millimetre => "mm",
            Self::Micrometre => "µm",
            Self::Metre => "m",
            Self::Inch => "inch",
        }
    }

    /// The unit a symbol names (`mm`, `µm`/`um`, `m`, `inch`/`in`), any case; `None` for any
    /// other text (degrees included: a rotary axis is not a feed drive's table).
    pub fn from_symbol(text: &str) -> Option<Self> {
        match text.trim().to_ascii_lowercase().as_str() {
            "mm" | "millimeter" | "millimetre" => Some(Self::Millimetre),
            "µm" | "um" | "micrometer" | "micrometre" | "micron" => Some(Self::Micrometre),
            "m" | "meter" | "metre" => Some(Self::Metre),
            "in" | "inch" => Some(Self::Inch),
            _ => None,
        }
    }
}

/// Unit of an effort signal (motor current or torque; serialised as its flag value: `a`,
/// `ma`, `nm`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum EffortUnit {
    /// Ampere: `current_a`.
    #[serde(rename = "a")]
    Ampere,
    /// Milliampere: `current_a` after ÷ 1000.
    #[serde(rename = "ma")]
    Milliampere,
    /// Newton-metre: `torque_nm`.
    #[serde(rename = "nm")]
    NewtonMetre,
}

impl EffortUnit {
    /// SI units (A or N·m) per unit.
    pub fn si(self) -> f64 {
        match self {
            Self::Ampere | Self::NewtonMetre => 1.0,
            Self::Milliampere => 1e-3,
        }
    }

    /// Current or torque.
    pub fn kind(self) -> EffortKind {
        match self {
            Self::Ampere | Self::Milliampere => EffortKind::CurrentA,
            Self::NewtonMetre => EffortKind::TorqueNm,
        }
    }

    /// The symbol written in reports.
    pub fn symbol(self) -> &'static str {
        match self {
            Self::Ampere => "A",
            Self::Milliampere => "mA",
            Self::NewtonMetre => "N·m",
        }
    }

    /// The unit a symbol names (`A`, `mA`, `Nm`, `N m`, `N·m`, `N*m`); `None` for any other text
    /// (a percentage of the rated torque included: it needs the drive's rating).
    pub fn from_symbol(text: &str) -> Option<Self> {
        match text.trim() {
            "A" | "a" | "Arms" | "A rms" => Some(Self::Ampere),
            "mA" => Some(Self::Milliampere),
            // Not `nm`: that is a nanometre.
            "Nm" | "N m" | "N·m" | "N*m" | "N.m" | "NM" => Some(Self::NewtonMetre),
            _ => None,
        }
    }
}

/// Check one converted value against the limits.
///
/// # Errors
/// A sentence naming the value in its file unit and the limit.
pub(crate) fn check_position(value_m: f64, unit: PositionUnit) -> Result<(), String> {
    if value_m.abs() * 1e3 > MAX_POSITION_MM {
        return Err(format!(
            "position {} {} is beyond ±{MAX_POSITION_MM:e} mm: not a linear axis position \
             (wrong signal or unit?)",
            value_m / unit.metres(),
            unit.symbol()
        ));
    }
    Ok(())
}

/// Check one effort value (SI) against the limits of its kind.
///
/// # Errors
/// A sentence naming the value and the limit.
pub(crate) fn check_effort(value_si: f64, unit: EffortUnit) -> Result<(), String> {
    let (limit, what, si) = match unit.kind() {
        EffortKind::CurrentA => (MAX_CURRENT_A, "current", "A"),
        EffortKind::TorqueNm => (MAX_TORQUE_NM, "torque", "N·m"),
    };
    if value_si.abs() > limit {
        return Err(format!(
            "{what} {} {} is beyond ±{limit:e} {si}: not a feed drive's {what} (wrong signal \
             or unit?)",
            value_si / unit.si(),
            unit.symbol()
        ));
    }
    Ok(())
}

/// The unit symbol in a unit text such as TwinCAT's `mm (Length)` or `(None)`: the text before
/// a parenthesised quantity, `None` when that is empty.
pub(crate) fn unit_symbol(text: &str) -> Option<&str> {
    let t = text.trim();
    let sym = match t.find('(') {
        Some(k) => t[..k].trim(),
        None => t,
    };
    (!sym.is_empty()).then_some(sym)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn symbols_and_factors() {
        assert_eq!(
            PositionUnit::from_symbol("MM"),
            Some(PositionUnit::Millimetre)
        );
        assert_eq!(
            PositionUnit::from_symbol("um"),
            Some(PositionUnit::Micrometre)
        );
        assert_eq!(PositionUnit::from_symbol("deg"), None);
        assert!((PositionUnit::Inch.metres() - 0.0254).abs() < 1e-15);
        assert_eq!(
            EffortUnit::from_symbol("N·m"),
            Some(EffortUnit::NewtonMetre)
        );
        assert_eq!(EffortUnit::from_symbol("%"), None);
        assert_eq!(EffortUnit::Milliampere.kind(), EffortKind::CurrentA);
        assert_eq!(unit_symbol("mm (Length)"), Some("mm"));
        assert_eq!(unit_symbol("(None)"), None);
        assert_eq!(unit_symbol(" A "), Some("A"));
    }

    #[test]
    fn limits_name_the_value_in_the_file_unit() {
        assert!(check_position(99.9, PositionUnit::Metre).is_ok());
        let e = check_position(0.2 * 1e3, PositionUnit::Millimetre).unwrap_err();
        assert!(e.starts_with("position 200000 mm is beyond"), "{e}");
        assert!(check_effort(-9_999.0, EffortUnit::Ampere).is_ok());
        let e = check_effort(2e4, EffortUnit::Ampere).unwrap_err();
        assert!(e.starts_with("current 20000 A is beyond ±1e4 A"), "{e}");
        assert!(check_effort(2e5, EffortUnit::NewtonMetre).is_ok());
        assert!(check_effort(2e6, EffortUnit::NewtonMetre).is_err());
    }
}
