//! Steady-speed tables, the input of `feedscope fit-stribeck`: friction (or motor torque) at
//! constant feeds, read into per-direction points in SI units.
//!
//! # Format
//! A CSV with a header naming `feed_mm_min` and one of `torque_nm` (motor torque at steady
//! speed, converted by paper 001 Eq. 15: F = 2π·η·T/p) or `force_n` (friction force), and
//! optionally `direction` (`forward`/`backward`, or `+`/`-`; any case). Without a direction
//! column the sign of the feed gives the direction. |feed| must lie in
//! [[`MIN_FEED_MM_MIN`], [`MAX_FEED_MM_MIN`]] (1e-3 to 1e6 mm/min), |torque| at most
//! [`MAX_ABS_TORQUE_NM`], |force| at most [`MAX_ABS_FORCE_N`]. More columns are allowed; lines starting
//! with `#` and blank lines are skipped; fields are trimmed.
//!
//! ```text
//! feed_mm_min,torque_nm,direction
//! 100,1.52,forward
//! -100,1.49,backward
//! ```
//!
//! # Example
//! ```
//! use feedscope_io::stribeck_table::{parse, EffortColumn, TableOptions};
//!
//! let text = "feed_mm_min,force_n\n600,250\n-600,-245\n1200,262\n";
//! let t = parse(text, "t.csv", &TableOptions::default())?;
//! assert_eq!(t.effort, EffortColumn::ForceN);
//! assert_eq!(t.forward.friction_n, [250.0, 262.0]);
//! assert_eq!(t.backward.friction_n, [245.0]); // magnitudes
//! assert!((t.forward.speed_m_s[0] - 0.01).abs() < 1e-15); // 600 mm/min in m/s
//! # Ok::<(), feedscope_io::stribeck_table::TableError>(())
//! ```

use std::path::Path;

pub use crate::trace::limits::MAX_ABS_TORQUE_NM;

/// Smallest |feed| a row may hold (mm/min): 1e-3 mm/min is 17 nm/s, below the slowest
/// steady-speed test of any feed axis (the Stribeck region starts near 1 mm/min) and far
/// above the subnormal numbers that convert to 0 m/s.
pub const MIN_FEED_MM_MIN: f64 = 1e-3;
/// Largest |feed| a row may hold (mm/min): 1000 m/min, ten times the fastest ball-screw axis.
pub const MAX_FEED_MM_MIN: f64 = 1e6;
/// Largest |friction force| a `force_n` row may hold (N): 1e7 N, a thousand tonnes-force.
pub const MAX_ABS_FORCE_N: f64 = 1e7;

use feedscope::estimate::Direction;
use feedscope::stribeck::{friction_from_torque_n, StribeckError, M_S_PER_MM_MIN};
use serde::Serialize;

/// Which column carries the effort.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum EffortColumn {
    /// Motor torque (N·m), converted by Eq. 15.
    TorqueNm,
    /// Friction force (N).
    ForceN,
}

/// How a table is converted: the options of `feedscope fit-stribeck`, whose names the errors
/// use (`--lead-mm`, `--efficiency`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TableOptions {
    /// Screw lead p (mm), > 0; needed for a `torque_nm` table. Default none.
    pub lead_mm: Option<f64>,
    /// Transmission efficiency η in (0, 1] of Eq. 15. Default 1.
    pub efficiency: f64,
}

impl Default for TableOptions {
    fn default() -> Self {
        Self {
            lead_mm: None,
            efficiency: 1.0,
        }
    }
}

/// The points of one direction, in table order: speed magnitudes (m/s) and friction
/// magnitudes (N).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SpeedPoints {
    /// |feed| in m/s.
    pub speed_m_s: Vec<f64>,
    /// |friction| in N.
    pub friction_n: Vec<f64>,
}

/// A steady-speed table read and converted.
#[derive(Debug, Clone, PartialEq)]
pub struct SteadySpeedTable {
    /// The effort column the table had.
    pub effort: EffortColumn,
    /// Rows moving forward.
    pub forward: SpeedPoints,
    /// Rows moving backward.
    pub backward: SpeedPoints,
}

/// Why a steady-speed table could not be read. Every variant about the file names it and,
/// where it applies, the 1-based line.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TableError {
    /// The file could not be read; the operating system's error is the source.
    #[error("reading {source_name}")]
    Read {
        /// The file.
        source_name: String,
        /// The operating system's error.
        #[source]
        error: std::io::Error,
    },
    /// No header line (the file is empty or holds only comments).
    #[error("{source_name}: empty file, expected a header line")]
    Empty {
        /// The file.
        source_name: String,
    },
    /// The header has no `feed_mm_min` column.
    #[error("{source_name}:{line}: no `feed_mm_min` column (header: {header})")]
    NoFeedColumn {
        /// The file.
        source_name: String,
        /// 1-based line of the header.
        line: usize,
        /// The header as read (trimmed).
        header: String,
    },
    /// The header has both effort columns.
    #[error("{source_name}:{line}: both `torque_nm` and `force_n` columns; keep one")]
    BothEfforts {
        /// The file.
        source_name: String,
        /// 1-based line of the header.
        line: usize,
    },
    /// The header has no effort column.
    #[error("{source_name}:{line}: no `torque_nm` or `force_n` column (header: {header})")]
    NoEffortColumn {
        /// The file.
        source_name: String,
        /// 1-based line of the header.
        line: usize,
        /// The header as read (trimmed).
        header: String,
    },
    /// A torque table without a lead.
    #[error("{source_name}: a `torque_nm` table needs --lead-mm (Eq. 15: F = 2π·η·T/p)")]
    NeedsLead {
        /// The file.
        source_name: String,
    },
    /// The lead is not positive ([`TableOptions::lead_mm`]).
    #[error("--lead-mm must be positive, got {lead_mm}")]
    BadLead {
        /// The lead given (mm).
        lead_mm: f64,
    },
    /// The efficiency is not in (0, 1] ([`TableOptions::efficiency`]).
    #[error("--efficiency must be in (0, 1], got {efficiency}")]
    BadEfficiency {
        /// The efficiency given.
        efficiency: f64,
    },
    /// A row has another number of fields than the header.
    #[error("{source_name}:{line}: {found} fields, the header has {expected}")]
    FieldCount {
        /// The file.
        source_name: String,
        /// 1-based line number.
        line: usize,
        /// Fields in the header.
        expected: usize,
        /// Fields in this row.
        found: usize,
    },
    /// A field that must be a number is not.
    #[error("{source_name}:{line}: column `{column}`: `{text}` is not a number")]
    NotANumber {
        /// The file.
        source_name: String,
        /// 1-based line number.
        line: usize,
        /// Column name.
        column: String,
        /// The text found (trimmed).
        text: String,
    },
    /// A number is NaN or infinite.
    #[error("{source_name}:{line}: column `{column}`: {value} is not finite")]
    NonFinite {
        /// The file.
        source_name: String,
        /// 1-based line number.
        line: usize,
        /// Column name.
        column: String,
        /// The value read.
        value: f64,
    },
    /// A row at feed 0 (it has no direction).
    #[error("{source_name}:{line}: feed 0 has no direction; a steady-speed table needs motion")]
    ZeroFeed {
        /// The file.
        source_name: String,
        /// 1-based line number.
        line: usize,
    },
    /// A row whose |feed| lies outside [[`MIN_FEED_MM_MIN`], [`MAX_FEED_MM_MIN`]] (but is not
    /// 0): no steady-speed test runs that slowly or fast, and a subnormal feed such as 1e-320
    /// mm/min becomes 0 m/s.
    #[error(
        "{source_name}:{line}: feed {} mm/min: |feed| must lie in [{min}, {max}] mm/min",
        feedscope::units::Shown(*.feed_mm_min),
        min = MIN_FEED_MM_MIN,
        max = MAX_FEED_MM_MIN
    )]
    FeedOutOfRange {
        /// The file.
        source_name: String,
        /// 1-based line number.
        line: usize,
        /// The feed read (mm/min).
        feed_mm_min: f64,
    },
    /// A torque or force beyond any feed drive's ([`MAX_ABS_TORQUE_NM`], [`MAX_ABS_FORCE_N`]).
    #[error("{source_name}:{line}: column `{column}`: {} is beyond ±{}, which no feed drive reaches", feedscope::units::Shown(*.value), feedscope::units::Shown(*.limit))]
    EffortOutOfRange {
        /// The file.
        source_name: String,
        /// 1-based line number.
        line: usize,
        /// Column name.
        column: String,
        /// The value read.
        value: f64,
        /// The bound of the column.
        limit: f64,
    },
    /// The direction is not one of `forward`, `backward`, `+`, `-`.
    #[error("{source_name}:{line}: direction `{text}`: expected forward or backward")]
    BadDirection {
        /// The file.
        source_name: String,
        /// 1-based line number.
        line: usize,
        /// The text found (lower case).
        text: String,
    },
    /// A negative feed marked forward.
    #[error("{source_name}:{line}: negative feed {feed_mm_min} marked forward")]
    NegativeForward {
        /// The file.
        source_name: String,
        /// 1-based line number.
        line: usize,
        /// The feed (mm/min).
        feed_mm_min: f64,
    },
    /// The torque of a row could not be converted to a force (Eq. 15).
    #[error("{source_name}:{line}: {error}")]
    Conversion {
        /// The file.
        source_name: String,
        /// 1-based line number.
        line: usize,
        /// Why (the message, not a source: it is part of this one).
        error: StribeckError,
    },
}

impl TableError {
    /// What the error means to a caller: a file that cannot be read is
    /// [`ErrorKind::of_io`](feedscope::ErrorKind::of_io) of the operating system's error (bad input when missing); what it
    /// holds, or an option, is [`BadInput`](feedscope::ErrorKind::BadInput).
    pub fn kind(&self) -> feedscope::ErrorKind {
        use feedscope::ErrorKind;
        match self {
            TableError::Read { error, .. } => ErrorKind::of_io(error),
            TableError::Conversion { error, .. } => error.kind(),
            _ => ErrorKind::BadInput,
        }
    }
}

impl TableError {
    /// True when the file could not be read (the operating system's error is the source),
    /// false when what it holds, or an option, is wrong.
    pub fn is_io(&self) -> bool {
        matches!(self, Self::Read { .. })
    }
}

/// Read a steady-speed table file ([`parse`]); errors name the file.
///
/// # Errors
/// [`TableError::Read`] when the file cannot be read; as [`parse`].
pub fn read(path: &Path, opts: &TableOptions) -> Result<SteadySpeedTable, TableError> {
    let source_name = path.display().to_string();
    let text = crate::bounded::read_to_string(path, crate::bounded::MAX_CONFIG_BYTES).map_err(
        |error| TableError::Read {
            source_name: source_name.clone(),
            error,
        },
    )?;
    parse(&text, &source_name, opts)
}

/// Parse a steady-speed table (see the [module docs](self)) and convert it: speeds to m/s,
/// torque to friction by Eq. 15 with the options' lead and efficiency, both as magnitudes, rows
/// sorted into forward and backward.
///
/// # Errors
/// [`TableError`] naming `source_name` and the line: the header (no feed or effort column, or
/// both efforts), a torque table without a lead, a lead or efficiency out of range, a row's
/// field count, a field that is not a finite number, a zero feed, a bad direction or one that
/// contradicts the feed's sign.
pub fn parse(
    text: &str,
    source_name: &str,
    opts: &TableOptions,
) -> Result<SteadySpeedTable, TableError> {
    let name = || source_name.to_string();
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'));
    let (hline, header) = lines.next().ok_or_else(|| TableError::Empty {
        source_name: name(),
    })?;
    let cols: Vec<&str> = header.split(',').map(str::trim).collect();
    let find = |c: &str| cols.iter().position(|h| *h == c);
    let feed_col = find("feed_mm_min").ok_or_else(|| TableError::NoFeedColumn {
        source_name: name(),
        line: hline,
        header: header.to_string(),
    })?;
    let (effort, eff_col) = match (find("torque_nm"), find("force_n")) {
        (Some(c), None) => (EffortColumn::TorqueNm, c),
        (None, Some(c)) => (EffortColumn::ForceN, c),
        (Some(_), Some(_)) => {
            return Err(TableError::BothEfforts {
                source_name: name(),
                line: hline,
            })
        }
        (None, None) => {
            return Err(TableError::NoEffortColumn {
                source_name: name(),
                line: hline,
                header: header.to_string(),
            })
        }
    };
    let dir_col = find("direction");
    let lead_m = match (effort, opts.lead_mm) {
        (EffortColumn::TorqueNm, None) => {
            return Err(TableError::NeedsLead {
                source_name: name(),
            })
        }
        (_, Some(p)) if !(p.is_finite() && p > 0.0) => {
            return Err(TableError::BadLead { lead_mm: p })
        }
        (_, p) => p.map(|p| p * 1e-3),
    };
    let efficiency = opts.efficiency;
    if !(efficiency > 0.0 && efficiency <= 1.0) {
        return Err(TableError::BadEfficiency { efficiency });
    }
    let (mut forward, mut backward) = (SpeedPoints::default(), SpeedPoints::default());
    for (line, l) in lines {
        let fields: Vec<&str> = l.split(',').map(str::trim).collect();
        if fields.len() != cols.len() {
            return Err(TableError::FieldCount {
                source_name: name(),
                line,
                expected: cols.len(),
                found: fields.len(),
            });
        }
        let num = |c: usize| -> Result<f64, TableError> {
            let v: f64 = fields[c].parse().map_err(|_| TableError::NotANumber {
                source_name: name(),
                line,
                column: cols[c].to_string(),
                text: fields[c].to_string(),
            })?;
            if !v.is_finite() {
                return Err(TableError::NonFinite {
                    source_name: name(),
                    line,
                    column: cols[c].to_string(),
                    value: v,
                });
            }
            Ok(v)
        };
        let feed = num(feed_col)?;
        let effort_value = num(eff_col)?;
        let limit = match effort {
            EffortColumn::TorqueNm => MAX_ABS_TORQUE_NM,
            EffortColumn::ForceN => MAX_ABS_FORCE_N,
        };
        if effort_value.abs() > limit {
            return Err(TableError::EffortOutOfRange {
                source_name: name(),
                line,
                column: cols[eff_col].to_string(),
                value: effort_value,
                limit,
            });
        }
        if feed == 0.0 {
            return Err(TableError::ZeroFeed {
                source_name: name(),
                line,
            });
        }
        if !(MIN_FEED_MM_MIN..=MAX_FEED_MM_MIN).contains(&feed.abs()) {
            return Err(TableError::FeedOutOfRange {
                source_name: name(),
                line,
                feed_mm_min: feed,
            });
        }
        let direction = match dir_col {
            None => Direction::of_velocity(feed),
            Some(c) => {
                let d = match fields[c].to_ascii_lowercase().as_str() {
                    "forward" | "+" => Direction::Forward,
                    "backward" | "-" => Direction::Backward,
                    other => {
                        return Err(TableError::BadDirection {
                            source_name: name(),
                            line,
                            text: other.to_string(),
                        })
                    }
                };
                if feed < 0.0 && d == Direction::Forward {
                    return Err(TableError::NegativeForward {
                        source_name: name(),
                        line,
                        feed_mm_min: feed,
                    });
                }
                d
            }
        };
        let friction = match (effort, lead_m) {
            (EffortColumn::TorqueNm, Some(p)) => {
                friction_from_torque_n(effort_value, p, efficiency).map_err(|error| {
                    TableError::Conversion {
                        source_name: name(),
                        line,
                        error,
                    }
                })?
            }
            _ => effort_value,
        };
        let dst = match direction {
            Direction::Forward => &mut forward,
            Direction::Backward => &mut backward,
        };
        dst.speed_m_s.push(feed.abs() * M_S_PER_MM_MIN);
        dst.friction_n.push(friction.abs());
    }
    Ok(SteadySpeedTable {
        effort,
        forward,
        backward,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err(text: &str, opts: &TableOptions) -> String {
        parse(text, "t.csv", opts).unwrap_err().to_string()
    }

    #[test]
    fn torque_is_converted_by_eq_15() {
        let opts = TableOptions {
            lead_mm: Some(10.0),
            efficiency: 0.9,
        };
        let t = parse(
            "# steady\nfeed_mm_min, torque_nm, direction\n600, 1.5, +\n600, -1.4, BACKWARD\n",
            "t.csv",
            &opts,
        )
        .unwrap();
        assert_eq!(t.effort, EffortColumn::TorqueNm);
        let want = friction_from_torque_n(1.5, 0.010, 0.9).unwrap();
        assert_eq!(t.forward.friction_n, [want]);
        assert_eq!(t.backward.speed_m_s, [600.0 * M_S_PER_MM_MIN]);
    }

    #[test]
    fn errors_name_file_and_line() {
        let no = TableOptions::default();
        assert_eq!(
            err("# x\n", &no),
            "t.csv: empty file, expected a header line"
        );
        assert_eq!(
            err("\nfeed,force_n\n", &no),
            "t.csv:2: no `feed_mm_min` column (header: feed,force_n)"
        );
        assert_eq!(
            err("feed_mm_min,torque_nm\n1,1\n", &no),
            "t.csv: a `torque_nm` table needs --lead-mm (Eq. 15: F = 2π·η·T/p)"
        );
        let bad_lead = TableOptions {
            lead_mm: Some(-1.0),
            efficiency: 1.0,
        };
        assert_eq!(
            err("feed_mm_min,force_n\n1,1\n", &bad_lead),
            "--lead-mm must be positive, got -1"
        );
        assert_eq!(
            err("feed_mm_min,force_n\n1,1\n2\n", &no),
            "t.csv:3: 1 fields, the header has 2"
        );
        assert_eq!(
            err("feed_mm_min,force_n\n1,x\n", &no),
            "t.csv:2: column `force_n`: `x` is not a number"
        );
        assert_eq!(
            err("feed_mm_min,force_n\n0,1\n", &no),
            "t.csv:2: feed 0 has no direction; a steady-speed table needs motion"
        );
        // A subnormal feed would become 0 m/s: refused below 1e-3 mm/min, naming the line.
        assert_eq!(
            err("feed_mm_min,force_n\n600,1\n1e-320,1\n", &no),
            "t.csv:3: feed 1e-320 mm/min: |feed| must lie in [0.001, 1000000] mm/min"
        );
        assert_eq!(
            err("feed_mm_min,force_n\n-0.0009,1\n", &no),
            "t.csv:2: feed -0.0009 mm/min: |feed| must lie in [0.001, 1000000] mm/min"
        );
        assert!(parse("feed_mm_min,force_n\n0.001,1\n", "t.csv", &no).is_ok());
        assert_eq!(
            err("feed_mm_min,force_n\n1e308,1\n", &no),
            "t.csv:2: feed 1e308 mm/min: |feed| must lie in [0.001, 1000000] mm/min"
        );
        // A torque of 1e308 N·m made an infinite friction force (Eq. 15).
        let lead = TableOptions {
            lead_mm: Some(10.0),
            efficiency: 0.9,
        };
        assert_eq!(
            err("feed_mm_min,torque_nm\n600,1e308\n", &lead),
            "t.csv:2: column `torque_nm`: 1e308 is beyond ±1000000, which no feed drive reaches"
        );
        assert_eq!(
            err("feed_mm_min,force_n,direction\n-5,1,forward\n", &no),
            "t.csv:2: negative feed -5 marked forward"
        );
        let e = parse("feed_mm_min,force_n\n1,nan\n", "t.csv", &no).unwrap_err();
        assert_eq!(
            e.to_string(),
            "t.csv:2: column `force_n`: NaN is not finite"
        );
        assert!(!e.is_io());
    }
}
