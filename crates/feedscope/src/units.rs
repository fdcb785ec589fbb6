//! Unit conversions between the SI inside the maths and the user units at the edges.
//!
//! Machine tools speak in millimetres and feeds in mm/min (the F word of a G-code program,
//! a controller's feed display); the equations here are in metres and m/s. Each conversion
//! has one name, so a reader sees *which* conversion a factor is and a search finds all of
//! them.
//!
//! # Exactness
//! The functions divide or multiply by the constant exactly as the formula reads
//! (`feed_mm_min / 60 000`), so replacing an inline `x / 60e3` with
//! [`feed_mm_min_to_m_s`]`(x)` gives the same bits. Multiplying by a rounded reciprocal is
//! *not* the same in the last bit: `x * M_S_PER_MM_MIN` can differ from `x / MM_MIN_PER_M_S`
//! by one ulp, so code whose output is compared as text keeps the operation it had.
//!
//! # Example
//! ```
//! use feedscope::units::{feed_m_s_to_mm_min, feed_mm_min_to_m_s, m_to_mm, MM_MIN_PER_M_S};
//! assert_eq!(feed_mm_min_to_m_s(600.0), 600.0 / MM_MIN_PER_M_S); // 0.01 m/s
//! assert!((feed_m_s_to_mm_min(0.01) - 600.0).abs() < 1e-9);
//! assert!((m_to_mm(0.25) - 250.0).abs() < 1e-12);
//! ```

/// Millimetres in one metre.
pub const MM_PER_M: f64 = 1e3;

/// Seconds in one minute.
pub const S_PER_MIN: f64 = 60.0;

/// mm/min in one m/s: 1 m/s = 60 000 mm/min.
pub const MM_MIN_PER_M_S: f64 = 60e3;

/// m/s in one mm/min (1/60 000, rounded to the nearest `f64`). Multiplying by it is not
/// bit-identical to dividing by [`MM_MIN_PER_M_S`]; see the module docs.
pub const M_S_PER_MM_MIN: f64 = 1.0 / 60_000.0;

/// A feed in mm/min as a speed in m/s: `feed_mm_min / 60 000`.
#[inline]
pub fn feed_mm_min_to_m_s(feed_mm_min: f64) -> f64 {
    feed_mm_min / MM_MIN_PER_M_S
}

/// A speed in m/s as a feed in mm/min: `speed_m_s · 60 000`.
#[inline]
pub fn feed_m_s_to_mm_min(speed_m_s: f64) -> f64 {
    speed_m_s * MM_MIN_PER_M_S
}

/// A feed in mm/min as a speed in mm/s: `feed_mm_min / 60`.
#[inline]
pub fn feed_mm_min_to_mm_s(feed_mm_min: f64) -> f64 {
    feed_mm_min / S_PER_MIN
}

/// A time in seconds as minutes: `t_s / 60`.
#[inline]
pub fn s_to_min(t_s: f64) -> f64 {
    t_s / S_PER_MIN
}

/// A length in metres as millimetres: `x_m · 1000`.
#[inline]
pub fn m_to_mm(x_m: f64) -> f64 {
    x_m * MM_PER_M
}

/// A length in millimetres as metres: `x_mm / 1000` (a division, correctly rounded; the
/// `x_mm * 1e-3` found in older code can differ from it in the last bit).
#[inline]
pub fn mm_to_m(x_mm: f64) -> f64 {
    x_mm / MM_PER_M
}

/// A number as a person reads it in a message: plain between 1e-4 and 1e9 in magnitude (and
/// 0, NaN, ±inf), in exponent form beyond (Rust's plain form of 1e300 is 301 digits, of
/// 1e-320 over 300).
///
/// ```
/// use feedscope::units::Shown;
/// assert_eq!(Shown(250.5).to_string(), "250.5");
/// assert_eq!(Shown(1e300).to_string(), "1e300");
/// assert_eq!(Shown(-1e-320).to_string(), "-1e-320");
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Shown(pub f64);

impl std::fmt::Display for Shown {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let a = self.0.abs();
        if a == 0.0 || !a.is_finite() || (1e-4..1e9).contains(&a) {
            write!(f, "{}", self.0)
        } else {
            write!(f, "{:e}", self.0)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shown_numbers_are_short() {
        for (v, text) in [
            (0.0, "0"),
            (1e-4, "0.0001"),
            (123456789.0, "123456789"),
            (1e9, "1e9"),
            (-1.797e308, "-1.797e308"),
            (5e-324, "5e-324"),
            (f64::NAN, "NaN"),
            (f64::NEG_INFINITY, "-inf"),
        ] {
            assert_eq!(Shown(v).to_string(), text);
        }
    }

    #[test]
    fn constants_are_the_literals_they_replace() {
        // Bit equality on purpose: these replace inline literals, and snapshot tests compare
        // the text printed from them.
        assert_eq!(MM_MIN_PER_M_S.to_bits(), 60_000.0f64.to_bits());
        assert_eq!(M_S_PER_MM_MIN.to_bits(), (1.0f64 / 60e3).to_bits());
        for x in [0.1, 1.0, 37.5, 1234.567, 8000.0] {
            assert_eq!(feed_mm_min_to_m_s(x).to_bits(), (x / 60e3).to_bits());
            assert_eq!(feed_m_s_to_mm_min(x).to_bits(), (x * 60e3).to_bits());
            assert_eq!(feed_mm_min_to_mm_s(x).to_bits(), (x / 60.0).to_bits());
        }
    }
}
