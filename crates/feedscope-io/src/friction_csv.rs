//! The friction CSV of `feedscope estimate`, written and read back (by `feedscope analyze`),
//! and the friction CSV of `feedscope analyze` (with the IAFV and the fluctuation).
//!
//! # The estimate's friction CSV
//! One row per resampled point, strokes in order:
//!
//! ```text
//! stroke,direction,position_mm,time_s,velocity_mm_s,accel_mm_s2,current_a,friction_n
//! 0,forward,0.009766,0.501000,9.9987,0.012,1.234567,251.4321
//! ```
//!
//! (`torque_nm` instead of `current_a` for a torque trace). Position in mm to 1 nm, time in s
//! to 1 µs, velocity in mm/s to 0.1 µm/s, acceleration in mm/s² to 1 µm/s², effort to 6
//! decimals, friction in N to 0.1 mN, signed as paper 000 Eq. 5.
//!
//! A stroke whose data support only its mean level (its verdict, see `feedscope::verdict`) has
//! no rows along the travel: its one row leaves position, time, velocity, acceleration and
//! effort empty and carries its mean friction (N) ([`format_mean_level`]); its standard error,
//! span and reasons are in the summary:
//!
//! ```text
//! 3,backward,,,,,,-1113.2210
//! ```
//!
//! [`parse`] checks such rows and leaves them out of the strokes it returns. The JSON summary written
//! beside it (same name, extension `.json`) holds the per-stroke facts ([`StrokeSummary`]) and
//! the `samples_per_lead` of the grid; [`read`] uses both when it is there.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::Path;

use feedscope::estimate::{Direction, EstimateParams, MoveKind, StrokeFriction, StrokeSummary};
use feedscope::profile::StrokeAnalysis;
use feedscope::trace::EffortKind;

use crate::fixed::push_fixed;
use crate::trace::limits::MAX_ABS_POSITION_M;

/// The first bytes of every friction CSV of `feedscope estimate`: enough to tell it from a
/// trace file.
pub const HEADER_START: &[u8] = b"stroke,direction,position_mm,";

/// The header line of the estimate's friction CSV (without the line end).
pub fn header(effort: EffortKind) -> String {
    format!(
        "stroke,direction,position_mm,time_s,velocity_mm_s,accel_mm_s2,{},friction_n",
        effort.column()
    )
}

/// Write the header line of the estimate's friction CSV.
///
/// # Errors
/// I/O errors of the writer.
pub fn write_header<W: Write>(mut w: W, effort: EffortKind) -> std::io::Result<()> {
    writeln!(w, "{}", header(effort))
}

/// The CSV rows of one stroke, formatted in parallel chunks (formatting dominates writing); the
/// chunks go to the file in order without being joined first.
pub fn format_stroke(s: &StrokeFriction) -> Vec<Vec<u8>> {
    use rayon::prelude::*;
    let n = s.position_m.len();
    let dir = s.summary.direction.as_str().as_bytes();
    let stroke = s.summary.stroke.to_string();
    let chunk = 16_384;
    (0..n.div_ceil(chunk))
        .into_par_iter()
        .map(|c| {
            let mut b = Vec::with_capacity(chunk * 90);
            for j in c * chunk..((c + 1) * chunk).min(n) {
                b.extend_from_slice(stroke.as_bytes());
                b.push(b',');
                b.extend_from_slice(dir);
                b.push(b',');
                push_fixed(&mut b, s.position_m[j] * 1e3, 6);
                b.push(b',');
                push_fixed(&mut b, s.time_s[j], 6);
                b.push(b',');
                // Velocity to 0.1 µm/s and acceleration to 1 µm/s²: far below what a spline
                // of sampled positions resolves, so more digits would only carry noise.
                push_fixed(&mut b, s.velocity_m_s[j] * 1e3, 4);
                b.push(b',');
                push_fixed(&mut b, s.accel_m_s2[j] * 1e3, 3);
                b.push(b',');
                push_fixed(&mut b, s.effort[j], 6);
                b.push(b',');
                push_fixed(&mut b, s.friction_n[j], 4);
                b.push(b'\n');
            }
            b
        })
        .collect()
}

/// The one row of a stroke whose data support only its mean level: number, direction, five
/// empty fields and the mean friction (N, to 0.1 mN) (module docs).
pub fn format_mean_level(s: &StrokeSummary) -> Vec<u8> {
    let mut b = format!("{},{},,,,,,", s.stroke, s.direction.as_str()).into_bytes();
    push_fixed(&mut b, s.mean_friction_n, 4);
    b.push(b'\n');
    b
}

/// True when a stroke's verdict supports no more than its mean level: the friction CSV then
/// holds its mean level only ([`format_mean_level`]).
pub fn is_mean_level(s: &StrokeSummary) -> bool {
    s.verdict
        .as_ref()
        .is_some_and(|v| v.support < feedscope::verdict::Support::Profile)
}

/// Write a whole friction CSV: the header, then every stroke's rows
/// ([`format_stroke`]).
///
/// # Errors
/// I/O errors of the writer.
pub fn write<W: Write>(
    mut w: W,
    effort: EffortKind,
    strokes: &[StrokeFriction],
) -> std::io::Result<()> {
    write_header(&mut w, effort)?;
    for s in strokes {
        if is_mean_level(&s.summary) {
            w.write_all(&format_mean_level(&s.summary))?;
            continue;
        }
        for part in format_stroke(s) {
            w.write_all(&part)?;
        }
    }
    w.flush()
}

/// Write the friction CSV of `feedscope analyze`: per point of each stroke the friction, its
/// instantaneous average value (IAFV) and the fluctuating signal (FFS = friction − IAFV),
///
/// ```text
/// stroke,direction,position_mm,friction_n,iafv_n,ffs_n
/// ```
///
/// position in mm to 1 nm, forces in N to 0.1 mN. `analyses[k]` is the analysis of
/// `strokes[k]`.
///
/// # Errors
/// I/O errors of the writer.
///
/// # Panics
/// When an analysis has fewer points than its stroke.
pub fn write_analyzed<W: Write>(
    mut w: W,
    strokes: &[StrokeFriction],
    analyses: &[StrokeAnalysis],
) -> std::io::Result<()> {
    writeln!(w, "stroke,direction,position_mm,friction_n,iafv_n,ffs_n")?;
    let mut b = Vec::with_capacity(1 << 16);
    for (s, a) in strokes.iter().zip(analyses) {
        let dir = s.summary.direction.as_str();
        for j in 0..s.position_m.len() {
            b.clear();
            b.extend_from_slice(format!("{},{dir},", s.summary.stroke).as_bytes());
            push_fixed(&mut b, s.position_m[j] * 1e3, 6);
            b.push(b',');
            push_fixed(&mut b, s.friction_n[j], 4);
            b.push(b',');
            push_fixed(&mut b, a.iafv_n[j], 4);
            b.push(b',');
            push_fixed(&mut b, a.ffs_n[j], 4);
            b.push(b'\n');
            w.write_all(&b)?;
        }
    }
    w.flush()
}

/// Why a friction CSV (or the summary beside it) could not be read. Every variant names the
/// file and, where it applies, the 1-based line.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FrictionCsvError {
    /// The file could not be opened; the operating system's error is the source.
    #[error("opening {source_name}")]
    Open {
        /// The file.
        source_name: String,
        /// The operating system's error.
        #[source]
        error: std::io::Error,
    },
    /// The first bytes of an opened file could not be read (the operating system's error is
    /// the message, e.g. a directory).
    #[error(transparent)]
    Head(std::io::Error),
    /// The file could not be read; the operating system's error is the source.
    #[error("reading {source_name}")]
    Read {
        /// The file.
        source_name: String,
        /// The operating system's error.
        #[source]
        error: std::io::Error,
    },
    /// The summary beside the CSV is not JSON; the parser's error is the source.
    #[error("reading {source_name}")]
    SummaryJson {
        /// The summary file.
        source_name: String,
        /// What the JSON parser reported.
        #[source]
        error: serde_json::Error,
    },
    /// The summary has no list of strokes of the right shape; the parser's error is the source.
    #[error("{source_name}: no `strokes` list")]
    SummaryStrokes {
        /// The summary file.
        source_name: String,
        /// What the JSON parser reported.
        #[source]
        error: serde_json::Error,
    },
    /// A row has the wrong number of fields.
    #[error("{source_name}:{line}: expected {expected} fields, found {found}")]
    FieldCount {
        /// The file.
        source_name: String,
        /// 1-based line number.
        line: usize,
        /// Fields of a row.
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
        column: &'static str,
        /// The text found.
        text: String,
    },
    /// A number is NaN or infinite.
    #[error("{source_name}:{line}: column `{column}` is not finite")]
    NonFinite {
        /// The file.
        source_name: String,
        /// 1-based line number.
        line: usize,
        /// Column name.
        column: &'static str,
    },
    /// The stroke number is not a non-negative integer.
    #[error("{source_name}:{line}: bad stroke number `{text}`")]
    BadStroke {
        /// The file.
        source_name: String,
        /// 1-based line number.
        line: usize,
        /// The text found.
        text: String,
    },
    /// The direction is neither `forward` nor `backward`.
    #[error("{source_name}:{line}: bad direction `{text}`")]
    BadDirection {
        /// The file.
        source_name: String,
        /// 1-based line number.
        line: usize,
        /// The text found (trimmed).
        text: String,
    },
    /// A position beyond any feed axis' travel ([`MAX_ABS_POSITION_M`]).
    #[error("{source_name}:{line}: position {} mm is beyond ±{} mm, which no feed axis reaches", feedscope::units::Shown(*.value_mm), feedscope::units::Shown(*.limit_mm))]
    PositionOutOfRange {
        /// The file.
        source_name: String,
        /// 1-based line number.
        line: usize,
        /// The position read (mm).
        value_mm: f64,
        /// The bound (mm).
        limit_mm: f64,
    },
    /// The summary's `params.samples_per_lead` is not a grid a friction CSV was written on.
    #[error("{source_name}: params.samples_per_lead = {}: must lie in [1, {max}]", feedscope::units::Shown(*.value), max = MAX_SAMPLES_PER_LEAD)]
    BadSamplesPerLead {
        /// The summary file.
        source_name: String,
        /// The value found.
        value: f64,
    },
    /// The file holds no row of friction.
    #[error("{source_name}: no friction rows")]
    NoRows {
        /// The file.
        source_name: String,
    },
    /// The file holds only mean levels: strokes whose data support no friction profile.
    #[error(
        "{source_name}: only mean levels ({strokes} stroke(s) whose data support no friction \
         profile), no friction along the travel"
    )]
    MeanLevelsOnly {
        /// The file.
        source_name: String,
        /// Mean-level rows found.
        strokes: usize,
    },
}

impl FrictionCsvError {
    /// What the error means to a caller: a file that cannot be opened or
    /// read is [`ErrorKind::of_io`](feedscope::ErrorKind::of_io) of the operating system's error (bad input when missing);
    /// what it holds is [`BadInput`](feedscope::ErrorKind::BadInput).
    pub fn kind(&self) -> feedscope::ErrorKind {
        use feedscope::ErrorKind;
        match self {
            FrictionCsvError::Open { error, .. }
            | FrictionCsvError::Head(error)
            | FrictionCsvError::Read { error, .. } => ErrorKind::of_io(error),
            _ => ErrorKind::BadInput,
        }
    }
}

impl FrictionCsvError {
    /// True when a file could not be opened or read (the operating system's error is the
    /// source or the message), false when what it holds is wrong.
    pub fn is_io(&self) -> bool {
        matches!(self, Self::Open { .. } | Self::Head(_) | Self::Read { .. })
    }
}

/// True when the file starts like a friction CSV of `feedscope estimate` ([`HEADER_START`])
/// rather than a trace.
///
/// # Errors
/// [`FrictionCsvError::Open`] or [`FrictionCsvError::Head`] when the file cannot be opened or
/// read.
pub fn is_friction_csv(path: &Path) -> Result<bool, FrictionCsvError> {
    let mut f = std::fs::File::open(path).map_err(|error| FrictionCsvError::Open {
        source_name: path.display().to_string(),
        error,
    })?;
    let mut head = vec![0u8; 256];
    let n = std::io::Read::read(&mut f, &mut head).map_err(FrictionCsvError::Head)?;
    head.truncate(n);
    Ok(head.starts_with(HEADER_START))
}

/// What the JSON summary beside a friction CSV tells its reader.
#[derive(Debug, Clone, PartialEq)]
pub struct EstimateSummary {
    /// The per-stroke facts (`strokes`).
    pub strokes: Vec<StrokeSummary>,
    /// Resampling points per lead of the grid (`params.samples_per_lead`).
    pub samples_per_lead: f64,
}

/// Read the JSON summary written by `feedscope estimate`; `None` when the file cannot be read
/// (a friction CSV without its summary is still read, with the aliasing limit unknown).
///
/// # Errors
/// [`FrictionCsvError::SummaryJson`] when the file is not JSON,
/// [`FrictionCsvError::SummaryStrokes`] when its `strokes` list does not hold stroke summaries.
pub fn read_summary(path: &Path) -> Result<Option<EstimateSummary>, FrictionCsvError> {
    let Ok(text) = crate::bounded::read_to_string(path, crate::bounded::MAX_DATA_BYTES) else {
        return Ok(None);
    };
    let source_name = || path.display().to_string();
    let v: serde_json::Value =
        serde_json::from_str(&text).map_err(|error| FrictionCsvError::SummaryJson {
            source_name: source_name(),
            error,
        })?;
    let strokes = serde_json::from_value(v["strokes"].clone()).map_err(|error| {
        FrictionCsvError::SummaryStrokes {
            source_name: source_name(),
            error,
        }
    })?;
    let samples_per_lead = v["params"]["samples_per_lead"]
        .as_f64()
        .unwrap_or_else(default_samples_per_lead);
    // The grid step is lead / samples_per_lead: a value of 1e-320 made it infinite.
    if !(1.0..=MAX_SAMPLES_PER_LEAD).contains(&samples_per_lead) {
        return Err(FrictionCsvError::BadSamplesPerLead {
            source_name: source_name(),
            value: samples_per_lead,
        });
    }
    Ok(Some(EstimateSummary {
        strokes,
        samples_per_lead,
    }))
}

/// Finest grid a summary may declare (samples per lead): 2^24, far finer than any estimate.
const MAX_SAMPLES_PER_LEAD: f64 = 16_777_216.0;

/// The grid of `feedscope estimate` when no summary says otherwise.
fn default_samples_per_lead() -> f64 {
    f64::from(EstimateParams::default().samples_per_lead)
}

/// Read a friction CSV of `feedscope estimate` back into strokes, with the summary beside it
/// (same name, extension `.json`) when there is one ([`parse`]).
///
/// # Errors
/// [`FrictionCsvError::Read`] when the CSV cannot be read, the errors of [`read_summary`] and
/// of [`parse`].
pub fn read(path: &Path, lead_m: f64) -> Result<Vec<StrokeFriction>, FrictionCsvError> {
    let source_name = path.display().to_string();
    let text =
        crate::bounded::read_to_string(path, crate::bounded::MAX_DATA_BYTES).map_err(|error| {
            FrictionCsvError::Read {
                source_name: source_name.clone(),
                error,
            }
        })?;
    let summary_path = path.with_extension("json");
    let summary = read_summary(&summary_path)?;
    parse(
        &text,
        &source_name,
        lead_m,
        summary.as_ref(),
        &summary_path.display().to_string(),
    )
}

/// Parse a friction CSV of `feedscope estimate` (the first line is the header; blank lines and
/// lines starting with `#` are skipped) into strokes, in stroke order.
///
/// The CSV rounds positions to 1 nm; they are put back on the exact grid k·p/m of the lead
/// `lead_m` and the summary's `samples_per_lead` (1024 without a summary). A stroke takes its
/// [`StrokeSummary`] from `summary`; without one it gets a summary of what the rows hold, with
/// an unknown feed and aliasing limit and a warning naming `summary_name`.
///
/// # Errors
/// [`FrictionCsvError`] naming `source_name` and the line: a wrong field count, a field that is
/// not a (finite) number, a bad stroke number or direction; no rows at all, or only the mean
/// levels of strokes without a profile (module docs), which are checked and left out.
pub fn parse(
    text: &str,
    source_name: &str,
    lead_m: f64,
    summary: Option<&EstimateSummary>,
    summary_name: &str,
) -> Result<Vec<StrokeFriction>, FrictionCsvError> {
    let summaries = summary.map_or(&[][..], |s| &s.strokes[..]);
    let m = summary.map_or_else(default_samples_per_lead, |s| s.samples_per_lead);
    let step = lead_m / m;
    let mut by_stroke: BTreeMap<usize, StrokeFriction> = BTreeMap::new();
    let name = || source_name.to_string();
    let mut levels = 0usize;
    for (k, row) in text.lines().enumerate().skip(1) {
        let line = k + 1;
        if row.trim().is_empty() || row.starts_with('#') {
            continue;
        }
        let f: Vec<&str> = row.split(',').collect();
        if f.len() != 8 {
            return Err(FrictionCsvError::FieldCount {
                source_name: name(),
                line,
                expected: 8,
                found: f.len(),
            });
        }
        let num = |i: usize, column: &'static str| -> Result<f64, FrictionCsvError> {
            let v: f64 = f[i]
                .trim()
                .parse()
                .map_err(|_| FrictionCsvError::NotANumber {
                    source_name: name(),
                    line,
                    column,
                    text: f[i].to_string(),
                })?;
            if !v.is_finite() {
                return Err(FrictionCsvError::NonFinite {
                    source_name: name(),
                    line,
                    column,
                });
            }
            Ok(v)
        };
        let stroke: usize = f[0]
            .trim()
            .parse()
            .map_err(|_| FrictionCsvError::BadStroke {
                source_name: name(),
                line,
                text: f[0].to_string(),
            })?;
        let direction = match f[1].trim() {
            "forward" => Direction::Forward,
            "backward" => Direction::Backward,
            other => {
                return Err(FrictionCsvError::BadDirection {
                    source_name: name(),
                    line,
                    text: other.to_string(),
                })
            }
        };
        // A stroke's mean level (module docs): no row along the travel.
        if f[2..7].iter().all(|x| x.trim().is_empty()) {
            num(7, "friction_n")?;
            levels += 1;
            continue;
        }
        let s = by_stroke.entry(stroke).or_insert_with(|| StrokeFriction {
            summary: summaries
                .iter()
                .find(|x| x.stroke == stroke)
                .cloned()
                .unwrap_or_else(|| unknown_summary(stroke, direction, summary_name)),
            position_m: Vec::new(),
            time_s: Vec::new(),
            velocity_m_s: Vec::new(),
            accel_m_s2: Vec::new(),
            effort: Vec::new(),
            friction_n: Vec::new(),
        });
        let position_mm = num(2, "position_mm")?;
        // Bounded before the grid snap, whose division by a small step overflowed to inf.
        if position_mm.abs() > MAX_ABS_POSITION_M * 1e3 {
            return Err(FrictionCsvError::PositionOutOfRange {
                source_name: name(),
                line,
                value_mm: position_mm,
                limit_mm: MAX_ABS_POSITION_M * 1e3,
            });
        }
        s.position_m
            .push((position_mm * 1e-3 / step).round() * step);
        s.time_s.push(num(3, "time_s")?);
        s.velocity_m_s.push(num(4, "velocity_mm_s")? * 1e-3);
        s.accel_m_s2.push(num(5, "accel_mm_s2")? * 1e-3);
        s.effort.push(num(6, "effort")?);
        s.friction_n.push(num(7, "friction_n")?);
    }
    if by_stroke.is_empty() && levels > 0 {
        return Err(FrictionCsvError::MeanLevelsOnly {
            source_name: name(),
            strokes: levels,
        });
    }
    if by_stroke.is_empty() {
        return Err(FrictionCsvError::NoRows {
            source_name: name(),
        });
    }
    Ok(by_stroke.into_values().collect())
}

/// The summary of a stroke that has none: its number and direction, an unknown feed and
/// aliasing limit, and a warning saying which summary was missing.
fn unknown_summary(stroke: usize, direction: Direction, summary_name: &str) -> StrokeSummary {
    StrokeSummary {
        stroke,
        direction,
        feed_mm_min: f64::NAN,
        feed_min_mm_min: None,
        feed_max_mm_min: None,
        start_mm: 0.0,
        end_mm: 0.0,
        length_mm: 0.0,
        start_time_s: 0.0,
        end_time_s: 0.0,
        mean_friction_n: 0.0,
        friction_std_n: 0.0,
        position_samples: 0,
        effort_samples: 0,
        points: 0,
        raw_samples_per_lead: f64::INFINITY,
        max_order: f64::INFINITY,
        kind: MoveKind::Measuring,
        position_cutoff_order: None,
        position_cutoff_hz: None,
        settle_margin_s: 0.0,
        noise_floor: Default::default(),
        mean_friction_se_n: None,
        effort_quantum_n: 0.0,
        verdict: None,
        program_line: None,
        programmed_feed_mm_min: None,
        warnings: vec![feedscope::diag::Diagnostic::new(
            feedscope::diag::Code::NoSummary,
            format!("no summary {summary_name} found: the aliasing limit is unknown"),
        )],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use feedscope::diag::Code;

    /// Two short strokes on the grid of a 10 mm lead at 1024 points per lead.
    fn strokes() -> Vec<StrokeFriction> {
        let step = 0.010 / 1024.0;
        (0..2)
            .map(|k| {
                let direction = if k == 0 {
                    Direction::Forward
                } else {
                    Direction::Backward
                };
                let n = 50;
                let mut s = StrokeFriction {
                    summary: unknown_summary(k, direction, "x.json"),
                    position_m: (0..n).map(|j| (100 + j) as f64 * step).collect(),
                    time_s: (0..n).map(|j| 0.5 + j as f64 * 1e-3).collect(),
                    velocity_m_s: vec![0.01; n],
                    accel_m_s2: vec![0.0; n],
                    effort: (0..n).map(|j| 1.0 + 0.001 * j as f64).collect(),
                    friction_n: (0..n).map(|j| 250.0 + 0.1 * j as f64).collect(),
                };
                if k == 1 {
                    s.velocity_m_s.iter_mut().for_each(|v| *v = -*v);
                    s.friction_n.iter_mut().for_each(|f| *f = -*f);
                }
                s
            })
            .collect()
    }

    #[test]
    fn round_trip_puts_positions_back_on_the_grid() {
        let want = strokes();
        let mut csv = Vec::new();
        write(&mut csv, EffortKind::CurrentA, &want).unwrap();
        let text = String::from_utf8(csv).unwrap();
        assert!(text.starts_with(
            "stroke,direction,position_mm,time_s,velocity_mm_s,accel_mm_s2,current_a,friction_n\n"
        ));
        assert!(text.as_bytes().starts_with(HEADER_START));
        let got = parse(&text, "f.csv", 0.010, None, "f.json").unwrap();
        assert_eq!(got.len(), 2);
        for (g, w) in got.iter().zip(&want) {
            // Positions: back on the grid exactly; the rest to the decimals written.
            assert_eq!(g.position_m, w.position_m);
            assert_eq!(g.summary.direction, w.summary.direction);
            assert!(g.summary.feed_mm_min.is_nan());
            assert_eq!(g.summary.warnings.len(), 1);
            assert_eq!(g.summary.warnings[0].code, Code::NoSummary);
            assert_eq!(
                g.summary.warnings[0].message,
                "no summary f.json found: the aliasing limit is unknown"
            );
            for (a, b) in g.friction_n.iter().zip(&w.friction_n) {
                assert!((a - b).abs() <= 0.5e-4 + 1e-12, "{a} {b}");
            }
        }
    }

    /// A mean-level stroke is one row without a position, read back as no profile; a file of
    /// mean levels only is refused saying so.
    #[test]
    fn mean_level_strokes_are_one_row_and_read_back_as_no_profile() {
        let mut want = strokes();
        want[1].summary.mean_friction_n = -250.123456;
        want[1].summary.verdict = Some(feedscope::verdict::judge_stroke(
            &feedscope::verdict::StrokeEvidence {
                length_leads: 0.1,
                max_order: 1.0,
                floor_n: 1.0,
                mean_n: -250.0,
                process_load: true,
            },
        ));
        assert!(is_mean_level(&want[1].summary) && !is_mean_level(&want[0].summary));
        let mut csv = Vec::new();
        write(&mut csv, EffortKind::CurrentA, &want).unwrap();
        let text = String::from_utf8(csv).unwrap();
        let rows: Vec<&str> = text.lines().filter(|l| l.starts_with("1,")).collect();
        assert_eq!(rows, ["1,backward,,,,,,-250.1235"], "{text}");
        assert_eq!(text.lines().count(), 1 + 50 + 1);
        let got = parse(&text, "f.csv", 0.010, None, "f.json").unwrap();
        assert_eq!(got.len(), 1);
        assert_eq!(got[0].position_m, want[0].position_m);
        let head = text.lines().next().unwrap();
        let only = format!("{head}\n1,backward,,,,,,-250.1235\n");
        let e = parse(&only, "f.csv", 0.010, None, "f.json").unwrap_err();
        assert_eq!(
            e.to_string(),
            "f.csv: only mean levels (1 stroke(s) whose data support no friction profile), \
             no friction along the travel"
        );
        let bad = format!("{head}\n1,backward,,,,,,x\n");
        let e = parse(&bad, "f.csv", 0.010, None, "f.json").unwrap_err();
        assert_eq!(
            e.to_string(),
            "f.csv:2: column `friction_n`: `x` is not a number"
        );
    }

    #[test]
    fn errors_name_file_and_line() {
        let head =
            "stroke,direction,position_mm,time_s,velocity_mm_s,accel_mm_s2,current_a,friction_n\n";
        for (row, want) in [
            ("0,forward,1,2,3\n", "f.csv:2: expected 8 fields, found 5"),
            (
                "0,forward,x,2,3,4,5,6\n",
                "f.csv:2: column `position_mm`: `x` is not a number",
            ),
            (
                "0,forward,1,2,3,4,5,inf\n",
                "f.csv:2: column `friction_n` is not finite",
            ),
            (
                "-1,forward,1,2,3,4,5,6\n",
                "f.csv:2: bad stroke number `-1`",
            ),
            ("0,up,1,2,3,4,5,6\n", "f.csv:2: bad direction `up`"),
            ("# only a comment\n", "f.csv: no friction rows"),
        ] {
            let e = parse(&format!("{head}{row}"), "f.csv", 0.01, None, "f.json").unwrap_err();
            assert_eq!(e.to_string(), want);
            assert!(!e.is_io());
        }
    }
}
