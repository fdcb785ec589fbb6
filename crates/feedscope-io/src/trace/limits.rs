//! Bounds of a feed axis that every trace reader enforces where a value is read: a sample
//! beyond them is not a measurement of a ball-screw feed drive but a corrupt or mis-scaled
//! file, and it is refused naming the line (CSV) or row (Parquet), the column and the value
//! ([`super::TraceError::Implausible`]).
//!
//! The bounds are generous on purpose; they only keep numbers that cannot come from a drive
//! out of the maths (one current sample of 1e300 A made a mean friction of 1.9e300 N):
//! - position: |x| ≤ 100 m. Ball screws are at most about 15 m long; a position beyond
//!   100 m is a unit error (µm read as mm) or a logger glitch. The imports refuse it; the
//!   trace readers leave position samples to the glitch screen of `feedscope::trace::glitch`
//!   (issue #10), which drops an excursion of 1-3 samples that comes back, with a warning
//!   naming its line, and refuses a jump that does not come back; a position it keeps
//!   beyond the bound (a stretch mis-scaled as a whole, or times so far apart that every jump
//!   is slow) is refused after it, naming its line or row.
//! - motor current: |i| ≤ 10 kA. The largest servo drives of machine tools deliver a few
//!   hundred amperes.
//! - motor torque: |T| ≤ 1 MN·m. The largest feed-axis motors deliver a few thousand N·m.

/// Largest |position| accepted (m).
pub const MAX_ABS_POSITION_M: f64 = 100.0;
/// Largest |motor current| accepted (A).
pub const MAX_ABS_CURRENT_A: f64 = 1e4;
/// Largest |motor torque| accepted (N·m).
pub const MAX_ABS_TORQUE_NM: f64 = 1e6;

/// The bound of a channel by its column name (SI values after the unit scale), with the
/// unit a message states it in; `None` for the time column.
pub(crate) fn bound(channel: &str) -> Option<(f64, &'static str)> {
    match channel {
        "position" | "position_mm" | "position_m" => Some((MAX_ABS_POSITION_M, "m")),
        "current_a" => Some((MAX_ABS_CURRENT_A, "A")),
        "torque_nm" => Some((MAX_ABS_TORQUE_NM, "N·m")),
        _ => None,
    }
}

/// The error for a sample `v` (SI) of `channel` beyond its bound, `None` when within.
pub(crate) fn check(
    source_name: &str,
    channel: &str,
    v: f64,
    line: Option<u64>,
    row: Option<u64>,
) -> Option<super::TraceError> {
    let (limit, unit) = bound(channel)?;
    // Positions: the glitch screen decides (module docs).
    if unit == "m" {
        return None;
    }
    (v.abs() > limit).then(|| super::TraceError::Implausible {
        source_name: source_name.to_string(),
        line,
        row,
        channel: channel.to_string(),
        value: v,
        limit,
        unit,
    })
}
