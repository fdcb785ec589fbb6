//! UMich SMART CNC mill CSV (Kaggle "CNC Mill Tool Wear", CC0): one row per 100 ms, no
//! timestamp column, per axis `A_ActualPosition` (mm), `A_CurrentFeedback` and
//! `A_OutputCurrent` (A), among 48 columns.
//!
//! Time is the row index × 1 / `rate_hz` (10 Hz: row k at k × 0.1 s, the first data row at 0).
//! Lines may end in LF, CRLF or a bare CR (`experiment_12.csv` uses CR only).
//!
//! # Which current
//! `A_CurrentFeedback` is the default: it follows motion (about ±5-10 A during feeds, 0 at
//! rest), the motor's torque current. `A_OutputCurrent` in these files sits near 328 A whatever
//! the axis does, not a torque current; it can still be chosen ([`CurrentColumn::Output`]).
use std::path::Path;

use super::LineEndings;
use super::{read_text, shorten, split_lines, ChannelReport, ImportError, ImportReport, Imported};
use feedscope::diag::{Code, Diagnostic};
use feedscope::trace::{Channel, EffortKind, RecordingFacts, Trace, MIN_SAMPLES};

/// Which current column becomes `current_a` (serialised as `feedback`, `output`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CurrentColumn {
    /// `A_CurrentFeedback` (A).
    #[default]
    Feedback,
    /// `A_OutputCurrent` (A).
    Output,
}

impl CurrentColumn {
    /// Column suffix.
    pub fn suffix(self) -> &'static str {
        match self {
            Self::Feedback => "CurrentFeedback",
            Self::Output => "OutputCurrent",
        }
    }
}

/// Options of [`UmichTable::to_trace`].
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct UmichParams {
    /// Row rate (Hz); default 10 (the dataset's fixed 100 ms).
    pub rate_hz: f64,
    /// Current column; default [`CurrentColumn::Feedback`].
    pub current: CurrentColumn,
}

impl Default for UmichParams {
    fn default() -> Self {
        Self {
            rate_hz: 10.0,
            current: CurrentColumn::Feedback,
        }
    }
}

/// A UMich CSV held as text fields (numbers are parsed per converted column, so a bad cell in
/// a column not used does not stop a conversion).
#[derive(Debug, Clone)]
pub struct UmichTable {
    /// The file.
    pub source_name: String,
    /// Header names.
    pub columns: Vec<String>,
    /// Data rows: (1-based line number, fields).
    pub rows: Vec<(u64, Vec<String>)>,
    /// Line endings seen.
    pub endings: LineEndings,
}

/// Read a UMich CSV file.
///
/// # Errors
/// As [`parse_umich`], and [`ImportError::Io`].
pub fn read_umich(path: &Path) -> Result<UmichTable, ImportError> {
    let text = read_text(path)?;
    parse_umich(&text, &path.display().to_string())
}

/// Parse a UMich CSV held in memory.
///
/// # Errors
/// [`ImportError::Empty`] without a header; [`ImportError::FieldCount`] when a row's field
/// count differs from the header's.
pub fn parse_umich(text: &str, source_name: &str) -> Result<UmichTable, ImportError> {
    let mut endings = LineEndings::default();
    let mut columns: Option<Vec<String>> = None;
    let mut rows = Vec::new();
    for (line, l) in split_lines(text, &mut endings) {
        if l.trim().is_empty() {
            continue;
        }
        let fields: Vec<String> = l.split(',').map(|f| f.trim().to_string()).collect();
        match &columns {
            None => columns = Some(fields),
            Some(c) if c.len() != fields.len() => {
                return Err(ImportError::FieldCount {
                    source_name: source_name.to_string(),
                    line,
                    expected: c.len(),
                    found: fields.len(),
                })
            }
            Some(_) => rows.push((line, fields)),
        }
    }
    let Some(columns) = columns else {
        return Err(ImportError::Empty {
            source_name: source_name.to_string(),
        });
    };
    Ok(UmichTable {
        source_name: source_name.to_string(),
        columns,
        rows,
        endings,
    })
}

impl UmichTable {
    /// Feed axes that have an `A_ActualPosition` column, e.g. `X1`, `Y1`, `Z1`; the spindle
    /// (`S1`, position in degrees) is not one.
    pub fn axes(&self) -> Vec<String> {
        self.columns
            .iter()
            .filter_map(|c| c.strip_suffix("_ActualPosition"))
            .filter(|a| !a.starts_with('S'))
            .map(str::to_string)
            .collect()
    }

    fn column(&self, name: &str) -> Option<usize> {
        self.columns.iter().position(|c| c == name)
    }

    /// Resolve `X`, `x` or `X1` to an axis prefix.
    fn resolve_axis(&self, wanted: &str) -> Option<String> {
        let axes = self.axes();
        axes.iter()
            .find(|a| a.eq_ignore_ascii_case(wanted))
            .or_else(|| {
                axes.iter()
                    .find(|a| a.eq_ignore_ascii_case(&format!("{wanted}1")))
            })
            .cloned()
    }

    /// Parse one column as numbers.
    ///
    /// # Errors
    /// [`ImportError::NotANumber`] naming the line.
    pub fn numbers(&self, col: usize) -> Result<Vec<f64>, ImportError> {
        self.rows
            .iter()
            .map(|(line, f)| {
                f[col]
                    .parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| ImportError::NotANumber {
                        source_name: self.source_name.clone(),
                        line: *line,
                        column: self.columns[col].clone(),
                        text: shorten(&f[col]),
                    })
            })
            .collect()
    }

    /// Convert one axis: position (mm → m) and current (A), time = row × 1 / `rate_hz`.
    ///
    /// # Errors
    /// [`ImportError::MissingColumns`] listing the axes that have both columns;
    /// [`ImportError::NotANumber`]; [`ImportError::TooFewSamples`]; [`ImportError::BadParam`]
    /// for a rate that is not positive.
    pub fn to_trace(&self, axis: &str, params: &UmichParams) -> Result<Imported, ImportError> {
        if !(params.rate_hz.is_finite() && params.rate_hz > 0.0) {
            return Err(ImportError::BadParam(format!(
                "--rate-hz {} must be a positive rate",
                params.rate_hz
            )));
        }
        let suffix = params.current.suffix();
        let usable: Vec<String> = self
            .axes()
            .into_iter()
            .filter(|a| self.column(&format!("{a}_{suffix}")).is_some())
            .collect();
        // An axis not in the file is named as the dataset would (`Y` → `Y1`) in the message.
        let prefix = self.resolve_axis(axis).unwrap_or_else(|| {
            let a = axis.to_ascii_uppercase();
            if a.ends_with(|c: char| c.is_ascii_digit()) {
                a
            } else {
                format!("{a}1")
            }
        });
        let pos_name = format!("{prefix}_ActualPosition");
        let cur_name = format!("{prefix}_{suffix}");
        let (pc, cc) = (self.column(&pos_name), self.column(&cur_name));
        let (Some(pc), Some(cc)) = (pc, cc) else {
            let missing: Vec<&str> = [(pc, &pos_name), (cc, &cur_name)]
                .into_iter()
                .filter(|(c, _)| c.is_none())
                .map(|(_, n)| n.as_str())
                .collect();
            return Err(ImportError::MissingColumns {
                source_name: self.source_name.clone(),
                axis: axis.to_string(),
                missing: missing.join(", "),
                found: if usable.is_empty() {
                    "none".into()
                } else {
                    usable.join(", ")
                },
            });
        };
        let pos = self.numbers(pc)?;
        let cur = self.numbers(cc)?;
        if pos.len() < MIN_SAMPLES {
            return Err(ImportError::TooFewSamples {
                source_name: self.source_name.clone(),
                channel: pos_name,
                found: pos.len(),
                needed: MIN_SAMPLES,
            });
        }
        let dt = 1.0 / params.rate_hz;
        let time_s: Vec<f64> = (0..pos.len()).map(|k| k as f64 * dt).collect();
        let position_m = Channel {
            time_s: time_s.clone(),
            value: pos.iter().map(|p| p * 1e-3).collect(),
        };
        let effort = Channel { time_s, value: cur };
        let mut prep = ChannelReport {
            source_key: format!("{pos_name} (mm)"),
            ..Default::default()
        };
        prep.finish(&position_m);
        let mut crep = ChannelReport {
            source_key: format!("{cur_name} (A)"),
            ..Default::default()
        };
        crep.finish(&effort);
        let mut warnings = vec![Diagnostic::new(
            Code::ThreeSignificantFigures,
            "values carry 3 significant figures: positions of 100-999 mm are quantised to 1 mm",
        )];
        if params.current == CurrentColumn::Output {
            warnings.push(Diagnostic::new(
                Code::OutputCurrentNotTorque,
                "OutputCurrent in the UMich files stays near 328 A whatever the axis does; \
                 CurrentFeedback is the torque current",
            ));
        }
        let trace = Trace {
            position_m,
            effort,
            effort_kind: EffortKind::CurrentA,
            // Every run of this data set mills a wax block: the current holds cutting load.
            facts: RecordingFacts {
                process_load: Some(true),
                recordings: Some(1),
                ..RecordingFacts::default()
            },
        };
        let mut report = ImportReport {
            source_name: self.source_name.clone(),
            time_zero: None,
            time_zero_rule: format!(
                "first data row; no timestamps in the file, row k at k / {} Hz",
                params.rate_hz
            ),
            position: prep,
            effort: crep,
            effort_rule: format!("current_a = {cur_name} (A)"),
            warnings,
        };
        super::sampling_warnings(&mut report, &trace);
        let imported = Imported { trace, report };
        super::check_limits(&imported)?;
        Ok(imported)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn csv(ending: &str) -> String {
        let rows = [
            "X1_ActualPosition,X1_CurrentFeedback,Y1_ActualPosition,Machining_Process",
            "1.98E+02,1.80E-01,1.58E+02,Starting",
            "1.97E+02,-1.09E+01,1.58E+02,Prep",
            "1.96E+02,-8.59E+00,1.54E+02,Prep",
            "1.95E+02,-8.00E+00,1.50E+02,Layer 1 Up",
            "1.94E+02,-7.50E+00,1.46E+02,Layer 1 Up",
        ];
        rows.join(ending) + ending
    }

    #[test]
    fn lf_crlf_and_bare_cr_give_the_same_table() {
        let a = parse_umich(&csv("\n"), "a.csv").unwrap();
        let b = parse_umich(&csv("\r\n"), "b.csv").unwrap();
        let c = parse_umich(&csv("\r"), "c.csv").unwrap();
        assert_eq!(a.rows.len(), 5);
        assert_eq!(a.rows, b.rows);
        assert_eq!(a.rows, c.rows);
        assert_eq!(c.endings.describe(), "CR");
        assert_eq!(b.endings.describe(), "CRLF");
        assert_eq!(a.axes(), ["X1", "Y1"]);
    }

    #[test]
    fn conversion_times_rows_at_the_rate_and_scales_to_metres() {
        let t = parse_umich(&csv("\r"), "c.csv").unwrap();
        let imp = t.to_trace("x", &UmichParams::default()).unwrap();
        assert_eq!(imp.trace.position_m.len(), 5);
        // Row 3 at 0.3 s (3 × 0.1 s, one rounding of 3 × 0.1).
        assert!((imp.trace.position_m.time_s[3] - 0.3).abs() < 1e-15);
        assert!((imp.trace.position_m.value[0] - 0.198).abs() < 1e-15);
        assert!((imp.trace.effort.value[1] + 10.9).abs() < 1e-12);
        assert_eq!(imp.trace.effort_kind, EffortKind::CurrentA);
        let five = UmichParams {
            rate_hz: 5.0,
            ..Default::default()
        };
        let imp = t.to_trace("X1", &five).unwrap();
        assert!((imp.trace.effort.time_s[4] - 0.8).abs() < 1e-15);
    }

    #[test]
    fn missing_axis_columns_list_the_usable_axes() {
        let t = parse_umich(&csv("\n"), "a.csv").unwrap();
        let e = t.to_trace("Y", &UmichParams::default()).unwrap_err();
        let s = e.to_string();
        assert!(s.contains("missing column(s) Y1_CurrentFeedback"), "{s}");
        assert!(s.contains("axes found: X1"), "{s}");
        let e = t.to_trace("Z", &UmichParams::default()).unwrap_err();
        assert!(
            e.to_string()
                .contains("Z1_ActualPosition, Z1_CurrentFeedback"),
            "{e}"
        );
    }

    #[test]
    fn bad_rows_name_their_line() {
        let e = parse_umich("a,b\n1,2\n3\n", "f.csv").unwrap_err();
        assert!(e.to_string().starts_with("f.csv:3: expected 2"), "{e}");
        let t = parse_umich(
            "X1_ActualPosition,X1_CurrentFeedback\n1,2\nnan,3\n1,1\n2,2\n",
            "f.csv",
        )
        .unwrap();
        let e = t.to_trace("X", &UmichParams::default()).unwrap_err();
        assert!(
            e.to_string()
                .starts_with("f.csv:3: column `X1_ActualPosition`"),
            "{e}"
        );
        assert!(matches!(
            parse_umich("", "e.csv").unwrap_err(),
            ImportError::Empty { .. }
        ));
    }
}
