//! Friction along the travel (paper 000, Section 4.1): the instantaneous average friction
//! value (IAFV) of every stroke, the friction fluctuating signal (FFS = friction − IAFV), its
//! amplitude spectra in screw orders and the likely cause of each significant component.
//!
//! [`AnalyzeRequest`] names the files (a trace, or the friction CSV `estimate` writes);
//! [`analyze_recording`] takes a trace already held (the Python module's path). Both give an
//! [`Analyzed`]: the [`AnalyzeReport`], which is `analysis.json`, with the study's strokes and
//! arrays for plots (`crate::plot::analysis_svgs`), `friction.csv` and Python's arrays. The
//! report's plain-text view is its `Display` and [`AnalyzeReport::remarks`].
use std::fmt;
use std::path::PathBuf;

use feedscope::axis::AxisParams;
use feedscope::estimate::Direction;
use feedscope::order::{FluctuationAnalysis, SegmentSpec};
use feedscope::profile::{AnalysisParams, IafvFit, OrderScan, OrderScanTable};
use feedscope::study::{
    analyze_strokes, analyze_trace, AnalyzeStudy, AnalyzeStudyParams, StudyError, WithheldStroke,
};
use feedscope::verdict::{DataVerdict, FrictionSign};
use feedscope_io::friction_csv;
use serde::{Deserialize, Serialize};

use crate::recording::read_recording;
use crate::{AppError, FrontEnd, Recording};

/// Analyse a file: a trace (CSV or Parquet) or the friction CSV written by `estimate`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AnalyzeRequest {
    /// The trace, or the friction CSV of `estimate` (its JSON summary beside it supplies the
    /// aliasing limits).
    pub input: PathBuf,
    /// Axis parameters (TOML or JSON); the geometry keys name the kinematic orders.
    pub axis: PathBuf,
    /// Settings of the analysis.
    #[serde(flatten)]
    pub options: AnalyzeOptions,
}

/// Settings of the analysis, as a user gives them; [`AnalyzeOptions::study_params`] turns them
/// into the study's [`AnalyzeStudyParams`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AnalyzeOptions {
    /// Resampling points per lead when estimating from a trace (1 to 1,000,000).
    pub samples_per_lead: u32,
    /// IAFV interior breakpoints (mm); automatic (BIC) when absent. Needs `orders`.
    pub breaks_mm: Option<Vec<f64>>,
    /// Polynomial order of each IAFV interval (one more than breakpoints; one order alone
    /// without breakpoints).
    pub orders: Option<Vec<usize>>,
    /// Number of equal segments for the spectra (default: about 5 leads each within each
    /// IAFV interval, like the paper).
    pub segments: Option<usize>,
    /// Segment length for the spectra (mm); not with `segments`.
    pub segment_length_mm: Option<f64>,
}

impl Default for AnalyzeOptions {
    fn default() -> Self {
        Self {
            samples_per_lead: AnalyzeStudyParams::default().estimate.samples_per_lead,
            breaks_mm: None,
            orders: None,
            segments: None,
            segment_length_mm: None,
        }
    }
}

impl AnalyzeOptions {
    /// Check the settings and give the study's parameters.
    ///
    /// # Errors
    /// [`AppError::invalid`] naming the field, in the front end's spelling: samples per lead
    /// out of range, breakpoints without orders or with the wrong number of orders, zero
    /// segments, a segment length that is not positive, segments given both ways.
    pub fn study_params(&self, front: &dyn FrontEnd) -> Result<AnalyzeStudyParams, AppError> {
        let mut params = AnalyzeStudyParams::default();
        if !(1..=1_000_000).contains(&self.samples_per_lead) {
            return Err(AppError::invalid(
                "samples_per_lead",
                format!(
                    "{} {} is not in 1..=1000000",
                    front.name("samples_per_lead"),
                    self.samples_per_lead
                ),
            ));
        }
        params.estimate.samples_per_lead = self.samples_per_lead;
        let p = &mut params.analysis;
        match (&self.breaks_mm, &self.orders) {
            (Some(b), Some(o)) => {
                if o.len() != b.len() + 1 {
                    return Err(AppError::invalid(
                        "orders",
                        format!(
                            "{} needs one order per interval: {} breakpoints make {} \
                             intervals, {} orders given",
                            front.name("orders"),
                            b.len(),
                            b.len() + 1,
                            o.len()
                        ),
                    ));
                }
                if let Some(x) = b.iter().find(|x| !x.is_finite()) {
                    return Err(AppError::invalid(
                        "breaks_mm",
                        format!("{} holds {x}, not a position", front.name("breaks_mm")),
                    ));
                }
                p.profile.breaks_mm = Some(b.clone());
                p.profile.orders = Some(o.clone());
            }
            (None, Some(o)) => {
                if o.len() != 1 {
                    return Err(AppError::invalid(
                        "orders",
                        format!(
                            "{} without {} takes one order",
                            front.name("orders"),
                            front.name("breaks_mm")
                        ),
                    ));
                }
                p.profile.breaks_mm = Some(Vec::new());
                p.profile.orders = Some(o.clone());
            }
            (Some(_), None) => {
                return Err(AppError::invalid(
                    "breaks_mm",
                    format!(
                        "{} needs {} (one per interval)",
                        front.name("breaks_mm"),
                        front.name("orders")
                    ),
                ))
            }
            (None, None) => {}
        }
        if self.segments.is_some() && self.segment_length_mm.is_some() {
            return Err(AppError::invalid(
                "segment_length_mm",
                format!(
                    "give {} or {}, not both",
                    front.name("segments"),
                    front.name("segment_length_mm")
                ),
            ));
        }
        if let Some(n) = self.segments {
            if n == 0 {
                return Err(AppError::invalid(
                    "segments",
                    format!("{} must be at least 1", front.name("segments")),
                ));
            }
            p.spectrum.segments = SegmentSpec::Count { count: n };
        }
        if let Some(l) = self.segment_length_mm {
            if !(l.is_finite() && l > 0.0) {
                return Err(AppError::invalid(
                    "segment_length_mm",
                    format!(
                        "{} must be a positive length",
                        front.name("segment_length_mm")
                    ),
                ));
            }
            p.spectrum.segments = SegmentSpec::LengthMm { length_mm: l };
        }
        Ok(params)
    }
}

impl AnalyzeRequest {
    /// Check the request without reading anything.
    ///
    /// # Errors
    /// [`AppError::invalid`] naming the field: an empty path, a setting out of range.
    pub fn validate(&self, front: &dyn FrontEnd) -> Result<(), AppError> {
        for (field, p) in [("input", &self.input), ("axis", &self.axis)] {
            if p.as_os_str().is_empty() {
                return Err(AppError::invalid(
                    field,
                    format!("{} names no file", front.name(field)),
                ));
            }
        }
        self.options.study_params(front).map(|_| ())
    }

    /// Read the files and analyse.
    ///
    /// # Errors
    /// As [`AnalyzeRequest::validate`]; the readers' errors (naming the file and line); the
    /// study's refusal of a stroke, with the stroke named.
    pub fn run(&self, front: &dyn FrontEnd) -> Result<Analyzed, AppError> {
        self.validate(front)?;
        let params = self.options.study_params(front)?;
        let axis = feedscope_io::axis::load(&self.axis).map_err(AppError::from_error)?;
        let is_friction =
            friction_csv::is_friction_csv(&self.input).map_err(AppError::from_error)?;
        if is_friction {
            let source = self.input.display().to_string();
            front.stage(&format!("reading {source}"));
            let strokes =
                friction_csv::read(&self.input, axis.lead_m()).map_err(AppError::from_error)?;
            front.stage("analysing");
            let study =
                analyze_strokes(strokes, &axis, &params, &progress(front)).map_err(study_error)?;
            Ok(Analyzed::new(study, source, axis, &params))
        } else {
            let recording = read_recording(&self.input, None, &axis, front)?;
            analyze_with(&recording, &axis, &params, front)
        }
    }
}

/// What an analysis gives: the report and the study behind it.
#[derive(Debug, Clone)]
pub struct Analyzed {
    /// `analysis.json`.
    pub report: AnalyzeReport,
    /// The strokes, their analyses (with the IAFV and FFS on the stroke's grid) and single
    /// polynomials, for plots, `friction.csv` and arrays.
    pub study: AnalyzeStudy,
}

/// Analyse a trace already held.
///
/// # Errors
/// As [`AnalyzeOptions::study_params`]; the study's refusal of a stroke, with the stroke named.
pub fn analyze_recording(
    recording: &Recording<'_>,
    axis: &AxisParams,
    options: &AnalyzeOptions,
    front: &dyn FrontEnd,
) -> Result<Analyzed, AppError> {
    let params = options.study_params(front)?;
    analyze_with(recording, axis, &params, front)
}

fn analyze_with(
    recording: &Recording<'_>,
    axis: &AxisParams,
    params: &AnalyzeStudyParams,
    front: &dyn FrontEnd,
) -> Result<Analyzed, AppError> {
    front.stage("analysing");
    let study =
        analyze_trace(&recording.trace, axis, params, &progress(front)).map_err(study_error)?;
    Ok(Analyzed::new(
        study,
        recording.source.clone(),
        axis.clone(),
        params,
    ))
}

fn progress(front: &dyn FrontEnd) -> impl Fn(usize, usize) + '_ {
    move |done, total| front.progress("analyse", done, total)
}

/// The study's error with the context `analyze` has always given the failing step.
fn study_error(e: StudyError) -> AppError {
    match e {
        StudyError::Stroke {
            stroke,
            direction,
            start_mm,
            end_mm,
            source,
        } => AppError::within(
            format!("stroke {stroke} ({direction}, {start_mm:.1} to {end_mm:.1} mm)"),
            source,
        ),
        StudyError::SinglePolynomial { source, .. } => {
            AppError::within("single-polynomial fit", source)
        }
        StudyError::OrderScanTable(e) => AppError::from_error(e),
        StudyError::Estimate(e) => AppError::from_error(e),
        e => AppError::from_error(e),
    }
}

/// `analysis.json`: the settings, Table 2, and every stroke's IAFV, order scan and fluctuation
/// (the per-point arrays are in `friction.csv`).
#[derive(Debug, Clone, Serialize)]
pub struct AnalyzeReport {
    /// The file analysed (or what the caller named the trace).
    pub source: String,
    /// The axis parameters used.
    pub axis: AxisParams,
    /// The analysis settings used.
    pub params: AnalysisParams,
    /// Paper 000 Table 2: residual standard deviation of single polynomials per order and
    /// direction.
    pub order_scan_table: OrderScanTable,
    /// The analysed strokes.
    pub strokes: Vec<AnalyzedStroke>,
    /// Strokes left out: their data support no profile.
    pub withheld: Vec<WithheldStroke>,
    /// The recording's data verdict (absent when a friction CSV was read).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub verdict: Option<DataVerdict>,
    /// How to read the numbers.
    pub conventions: Conventions,
}

/// One stroke of `analysis.json`.
#[derive(Debug, Clone, Serialize)]
pub struct AnalyzedStroke {
    /// Stroke number (as the estimate numbers them).
    pub stroke: usize,
    /// Direction of motion.
    pub direction: Direction,
    /// Feed of the stroke (mm/min).
    pub feed_mm_min: f64,
    /// Where the stroke starts (mm).
    pub start_mm: f64,
    /// Where it ends (mm).
    pub end_mm: f64,
    /// Highest order the sampling resolves without aliasing (cycles per lead).
    pub max_trusted_order: f64,
    /// The order scan of single polynomials over the stroke.
    pub order_scan: OrderScan,
    /// The piecewise IAFV fit and its linear trend.
    pub iafv: IafvFit,
    /// The best single polynomial's order (the paper's dotted line).
    pub single_polynomial_order: usize,
    /// Its residual standard deviation (N).
    pub single_polynomial_std_n: f64,
    /// Spectra of the FFS and its significant components.
    pub fluctuation: FluctuationAnalysis,
}

/// The conventions block of `analysis.json`.
#[derive(Debug, Clone, Serialize)]
pub struct Conventions {
    /// What an order is.
    pub order: &'static str,
    /// The sign of friction.
    pub friction_sign: &'static str,
    /// What an amplitude is.
    pub amplitude: &'static str,
}

impl Analyzed {
    fn new(study: AnalyzeStudy, source: String, axis: AxisParams, p: &AnalyzeStudyParams) -> Self {
        let strokes = study
            .strokes
            .iter()
            .zip(&study.analyses)
            .zip(&study.single_polynomials)
            .map(|((s, a), single)| AnalyzedStroke {
                stroke: s.summary.stroke,
                direction: s.summary.direction,
                feed_mm_min: s.summary.feed_mm_min,
                start_mm: s.summary.start_mm,
                end_mm: s.summary.end_mm,
                max_trusted_order: s.summary.max_order,
                order_scan: a.order_scan.clone(),
                iafv: a.iafv.clone(),
                single_polynomial_order: a.order_scan.best_order,
                single_polynomial_std_n: single.residual_std_n,
                fluctuation: a.fluctuation.clone(),
            })
            .collect();
        let friction_sign = match study.verdict.as_ref().map(|v| v.friction_sign) {
            Some(FrictionSign::FromDirection) => {
                "from the direction of motion (the effort is a magnitude): positive moving \
                 forward, negative backward"
            }
            _ => "as paper 000 Eq. 5: positive moving forward, negative backward",
        };
        let report = AnalyzeReport {
            source,
            axis,
            params: p.analysis.clone(),
            order_scan_table: study.order_scan_table.clone(),
            strokes,
            withheld: study.withheld.clone(),
            verdict: study.verdict.clone(),
            conventions: Conventions {
                order: "cycles per screw revolution = cycles per lead of table travel",
                friction_sign,
                amplitude: "single-sided amplitude spectrum in newtons; the window's coherent \
                            gain is corrected (factor amplitude_correction = 2/sum(w)), so a \
                            sinusoid of amplitude A reads A on its bin",
            },
        };
        Self { report, study }
    }
}

impl AnalyzeReport {
    /// `components.csv`: every significant component of every stroke and segment.
    pub fn components_csv(&self) -> String {
        let mut out = String::from(
            "stroke,direction,segment,start_mm,end_mm,order,amplitude_n,floor_n,cause,trusted\n",
        );
        for s in &self.strokes {
            let fl = &s.fluctuation;
            for c in &fl.components {
                let sp = fl.spectra.iter().find(|x| x.segment == c.segment);
                let (lo, hi) = sp.map_or((f64::NAN, f64::NAN), |x| (x.start_mm, x.end_mm));
                out.push_str(&format!(
                    "{},{},{},{:.3},{:.3},{:.4},{:.4},{:.4},{},{}\n",
                    s.stroke,
                    s.direction.as_str(),
                    c.segment,
                    lo,
                    hi,
                    c.order,
                    c.amplitude_n,
                    c.floor_n,
                    c.cause,
                    c.trusted
                ));
            }
        }
        out
    }

    /// `order_scan.csv`: Table 2 (empty cells where a direction has no stroke).
    pub fn order_scan_csv(&self) -> String {
        let mut out = String::from("order,forward_std_n,backward_std_n\n");
        let f = |v: Option<f64>| v.map(|x| format!("{x:.4}")).unwrap_or_default();
        for r in &self.order_scan_table.rows {
            out.push_str(&format!(
                "{},{},{}\n",
                r.order,
                f(r.forward_std_n),
                f(r.backward_std_n)
            ));
        }
        out
    }
}

impl fmt::Display for AnalyzeReport {
    /// The report's plain-text view shared by the front ends: Table 2 (residual standard
    /// deviation of single polynomials, N), then per stroke its IAFV intervals (mm), orders
    /// and linear trend (N/mm) and its significant components over the whole stroke (order
    /// in cycles per lead, amplitude in N, cause), and the data verdict's headline.
    fn fmt(&self, o: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            o,
            "Residual standard deviation of single polynomials (N), paper 000 Table 2:"
        )?;
        writeln!(o, "{:>6}  {:>10}  {:>10}", "order", "forward", "backward")?;
        for r in &self.order_scan_table.rows {
            let f = |v: Option<f64>| v.map(|x| format!("{x:.2}")).unwrap_or("-".into());
            writeln!(
                o,
                "{:>6}  {:>10}  {:>10}",
                r.order,
                f(r.forward_std_n),
                f(r.backward_std_n)
            )?;
        }
        for s in &self.strokes {
            let p = &s.iafv.poly;
            writeln!(
                o,
                "\nstroke {} ({}, {:.0} mm/min): IAFV intervals {} with orders {:?}; linear trend \
                 {:+.3} N/mm",
                s.stroke,
                s.direction.as_str(),
                s.feed_mm_min,
                p.breaks_mm
                    .windows(2)
                    .map(|w| format!("{:.0}-{:.0}", w[0], w[1]))
                    .collect::<Vec<_>>()
                    .join(", "),
                p.orders,
                s.iafv.linear.slope_n_per_mm
            )?;
            writeln!(o, "  significant components over the whole stroke:")?;
            writeln!(o, "  {:>8}  {:>12}  cause", "order", "amplitude (N)")?;
            for c in s
                .fluctuation
                .components
                .iter()
                .filter(|c| c.segment.is_whole())
            {
                writeln!(
                    o,
                    "  {:>8.3}  {:>12.2}  {}{}",
                    c.order,
                    c.amplitude_n,
                    c.cause,
                    if c.trusted {
                        ""
                    } else {
                        " (beyond the aliasing limit)"
                    }
                )?;
            }
        }
        if let Some(v) = &self.verdict {
            writeln!(o)?;
            writeln!(o, "{}", v.headline())?;
        }
        Ok(())
    }
}

impl AnalyzeReport {
    /// The remarks beside the text view (the CLI's stderr), one line each: every stroke's
    /// fluctuation warnings (`warning: stroke 2: ...`), then the strokes withheld because
    /// their data support no profile, with the reasons (`verdict: stroke 3 ...`).
    pub fn remarks(&self) -> Vec<String> {
        let mut lines = Vec::new();
        for s in &self.strokes {
            for w in &s.fluctuation.warnings {
                lines.push(format!("warning: stroke {}: {w}", s.stroke));
            }
        }
        for w in &self.withheld {
            lines.push(format!(
                "verdict: stroke {} ({}) withheld, its data support {} only: {}",
                w.stroke,
                w.direction.as_str(),
                w.support.as_str(),
                w.reasons
                    .iter()
                    .map(|r| r.message.as_str())
                    .collect::<Vec<_>>()
                    .join("; ")
            ));
        }
        lines
    }
}
