//! The plain-text view of an [`EstimateReport`], shared by the front ends (the CLI prints
//! it; Python's `str()` and a server's text/plain answer can return it): the stroke table,
//! the feeds that vary along a stroke, the data verdict, the moves left out
//! ([`Display`](std::fmt::Display)), and the remarks beside it
//! ([`EstimateReport::remarks`]): notes, verdict reasons and warnings, those repeated on many
//! strokes gathered into one line each. The JSON summary keeps every one.
use std::collections::BTreeMap;
use std::fmt;

use feedscope::diag::Code;
use feedscope::estimate::{Move, MoveKind, StrokeSummary};
use feedscope_io::friction_csv;

use super::EstimateReport;

impl fmt::Display for EstimateReport {
    /// The stroke table (feed mm/min, positions mm, mean friction and its standard error N,
    /// noise floor N RMS, cut-off Hz, samples per lead, highest resolved order), then the
    /// strokes whose feed varies by more than ±10 %, the data verdict's headline and the moves
    /// no friction was estimated for.
    fn fmt(&self, o: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            o,
            "{:>6}  {:<8}  {:>10}  {:>9}  {:>9}  {:>12}  {:>8}  {:>9}  {:>8}  {:>8}  {:>7}  supports",
            "stroke",
            "dir",
            "feed",
            "from",
            "to",
            "mean F_f",
            "±",
            "floor",
            "cut-off",
            "samples",
            "max"
        )?;
        writeln!(
            o,
            "{:>6}  {:<8}  {:>10}  {:>9}  {:>9}  {:>12}  {:>8}  {:>9}  {:>8}  {:>8}  {:>7}",
            "",
            "",
            "(mm/min)",
            "(mm)",
            "(mm)",
            "(N)",
            "(N, SE)",
            "(N RMS)",
            "(Hz)",
            "per lead",
            "order"
        )?;
        for s in &self.strokes {
            let kind = if s.kind == MoveKind::Measuring {
                String::new()
            } else {
                format!("  ({})", s.kind.as_str())
            };
            writeln!(
                o,
                "{:>6}  {:<8}  {:>10.1}  {:>9.2}  {:>9.2}  {:>12.2}  {:>8}  {:>9.2}  {:>8}  {:>8.1}  {:>7.1}  {}{kind}",
                s.stroke,
                s.direction.as_str(),
                s.feed_mm_min,
                s.start_mm,
                s.end_mm,
                s.mean_friction_n,
                s.mean_friction_se_n
                    .map_or_else(|| "-".to_string(), |e| format!("{e:.2}")),
                s.noise_floor.total_n,
                s.position_cutoff_hz
                    .map_or_else(|| "-".to_string(), |f| format!("{f:.1}")),
                s.raw_samples_per_lead,
                s.max_order,
                s.verdict.as_ref().map_or("-", |v| v.support.as_str())
            )?;
        }
        // A feed that varies along a stroke by more than ±10 % of its mean (a modulation, an
        // override changed mid-block) is named with its range.
        let varying: Vec<(&StrokeSummary, f64, f64)> = self
            .strokes
            .iter()
            .filter_map(|s| Some((s, s.feed_min_mm_min?, s.feed_max_mm_min?)))
            .filter(|&(s, lo, hi)| lo < 0.9 * s.feed_mm_min || hi > 1.1 * s.feed_mm_min)
            .collect();
        if !varying.is_empty() {
            writeln!(o)?;
            writeln!(
                o,
                "feed varies along strokes (5th-95th percentile of the chord speeds):"
            )?;
            for (s, lo, hi) in varying {
                writeln!(
                    o,
                    "  stroke {:>4}  {:>10.1} mm/min, from {:.1} to {:.1} mm/min ({:+.0} % / {:+.0} %)",
                    s.stroke,
                    s.feed_mm_min,
                    lo,
                    hi,
                    100.0 * (lo / s.feed_mm_min - 1.0),
                    100.0 * (hi / s.feed_mm_min - 1.0)
                )?;
            }
        }
        writeln!(o)?;
        writeln!(o, "{}", self.verdict.headline())?;
        let left_out: Vec<&Move> = self.moves.iter().filter(|m| m.strokes.is_empty()).collect();
        if !left_out.is_empty() {
            writeln!(o)?;
            writeln!(o, "moves left out (no friction estimated):")?;
            for m in left_out {
                let feed = match (m.feed_mm_min, m.gap_s) {
                    (Some(f), None) => format!("{} mm/min", feed_text(f)),
                    (Some(f), Some(g)) => {
                        format!("{} mm/min, spans a gap of {g:.1} s", feed_text(f))
                    }
                    (None, Some(g)) => format!("spans a gap of {g:.1} s: no feed"),
                    (None, None) => "feed unknown".to_string(),
                };
                writeln!(
                    o,
                    "  {:<11}  {:<8}  {:>17}  {:>9.2} → {:>9.2} mm  t = {:.3} s to {:.3} s{}",
                    m.kind.as_str(),
                    m.direction.as_str(),
                    feed,
                    m.start_mm,
                    m.end_mm,
                    m.start_time_s,
                    m.end_time_s,
                    m.program_line
                        .map(|l| format!("  (program line {l})"))
                        .unwrap_or_default()
                )?;
            }
        }
        Ok(())
    }
}

impl EstimateReport {
    /// The remarks beside the text view (the CLI's stderr), one line each, each starting with
    /// its kind: `note:` (the estimation's notes, rows of other channels ignored), `verdict:`
    /// (the recording's reasons, then the strokes' by code: [`verdict_reasons`]) and
    /// `warning:` (the strokes' warnings, [`stroke_warnings`]; the segments skipped).
    pub fn remarks(&self) -> Vec<String> {
        let mut lines: Vec<String> = self.notes.iter().map(|n| format!("note: {n}")).collect();
        lines.extend(self.verdict.reasons.iter().map(|r| format!("verdict: {r}")));
        for (code, (count, first)) in verdict_reasons(&self.strokes) {
            lines.push(format!(
                "verdict: {count} stroke(s) limited by {code}; e.g. {first}"
            ));
        }
        lines.extend(
            stroke_warnings(&self.strokes)
                .into_iter()
                .map(|l| format!("warning: {l}")),
        );
        lines.extend(self.skipped.iter().map(|w| format!("warning: skipped {w}")));
        if self.ignored_rows > 0 {
            lines.push(format!(
                "note: ignored {} rows of other channels ({})",
                self.ignored_rows,
                self.ignored_channels.join(", ")
            ));
        }
        lines
    }
}

/// A feed for people (mm/min): to 0.1 mm/min from 10 mm/min up, else to 3 significant
/// digits, so that a slow move never reads "0.0".
fn feed_text(f: f64) -> String {
    let a = f.abs();
    if a >= 10.0 || a == 0.0 || !a.is_finite() {
        format!("{f:.1}")
    } else if a >= 1e-6 {
        let decimals = (2.0 - a.log10().floor()) as usize;
        format!("{f:.decimals$}")
    } else {
        format!("{f:.2e}")
    }
}

/// Warnings of a stroke about its friction profile (its spectrum, its noise against the
/// variation along it): moot for a stroke whose data support only its mean level, where the
/// profile is withheld anyway.
pub const PROFILE_WARNINGS: [Code; 5] = [
    Code::FewSamplesPerLead,
    Code::PositionSmoothedBelowOrder,
    Code::NoiseFloorHigh,
    Code::FeedChangeUnresolved,
    Code::PositionNotMonotone,
];

/// Warnings repeated on more strokes than this are one line ([`stroke_warnings`]).
pub const WARNING_REPEATS_SHOWN: usize = 3;

/// The strokes' warnings as lines for people: one per stroke and warning (`stroke 3: ...`),
/// except that a warning about the profile ([`PROFILE_WARNINGS`]) on strokes whose profile
/// is withheld (mean level only), and any warning repeated on more than
/// [`WARNING_REPEATS_SHOWN`] strokes, is one line that counts the strokes, lists them
/// ([`number_list`]) and quotes the first. The lines that bear on what is reported come
/// first, the moot ones last.
pub fn stroke_warnings(strokes: &[StrokeSummary]) -> Vec<String> {
    let key =
        |s: &StrokeSummary, code: Code| (mean_only(s) && PROFILE_WARNINGS.contains(&code), code);
    let mut by_code: BTreeMap<(bool, Code), Vec<&StrokeSummary>> = BTreeMap::new();
    for s in strokes {
        for w in &s.warnings {
            by_code.entry(key(s, w.code)).or_default().push(s);
        }
    }
    let mut lines = Vec::new();
    let mut collapsed = Vec::new();
    for s in strokes {
        for w in &s.warnings {
            let k = key(s, w.code);
            let moot = k.0;
            let group = &by_code[&k];
            if !moot && group.len() <= WARNING_REPEATS_SHOWN {
                lines.push(format!("stroke {}: {w}", s.stroke));
            } else if std::ptr::eq(group[0], s) {
                let numbers: Vec<usize> = group.iter().map(|g| g.stroke).collect();
                let first = group[0]
                    .warnings
                    .iter()
                    .find(|x| x.code == w.code)
                    .map_or_else(String::new, |x| x.message.clone());
                collapsed.push(format!(
                    "{} stroke(s) ({}){}: {}; e.g. stroke {}: {first} (each in the JSON summary)",
                    numbers.len(),
                    number_list(&numbers),
                    if moot {
                        ", whose profile is withheld anyway (mean level only)"
                    } else {
                        ""
                    },
                    w.code,
                    numbers[0],
                ));
            }
        }
    }
    lines.extend(collapsed);
    lines
}

/// Stroke numbers as ranges: `0-3, 5, 7-8` (the numbers ascending).
pub fn number_list(n: &[usize]) -> String {
    let mut parts: Vec<String> = Vec::new();
    let mut k = 0;
    while k < n.len() {
        let mut j = k;
        while j + 1 < n.len() && n[j + 1] == n[j] + 1 {
            j += 1;
        }
        parts.push(if j > k {
            format!("{}-{}", n[k], n[j])
        } else {
            n[k].to_string()
        });
        k = j + 1;
    }
    parts.join(", ")
}

/// True when a stroke's data verdict supports no more than its mean level.
fn mean_only(s: &StrokeSummary) -> bool {
    friction_csv::is_mean_level(s)
}

/// The binding reasons of the strokes' verdicts, by code: how many strokes and the first
/// stroke's message (`stroke 2: ...`).
pub fn verdict_reasons(strokes: &[StrokeSummary]) -> BTreeMap<Code, (usize, String)> {
    let mut by_code = BTreeMap::new();
    for s in strokes {
        for r in s.verdict.iter().flat_map(|v| &v.reasons) {
            by_code
                .entry(r.code)
                .or_insert((0, format!("stroke {}: {}", s.stroke, r.message)))
                .0 += 1;
        }
    }
    by_code
}
