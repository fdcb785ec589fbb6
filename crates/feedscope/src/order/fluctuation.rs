//! Analysis of the friction fluctuating signal of one stroke: the travel split into segments,
//! the amplitude spectrum of each, and its significant components classified by kinematic
//! order, with aliasing warnings (paper 000, section 4.1.2, Figs 9-10).

use serde::{Deserialize, Serialize};

use super::kinematic::{classify, KinematicOrder};
use super::peaks::{find_peaks, PeakParams};
use super::spectrum::{SpectrumAnalyzer, Window};
use super::OrderError;
use super::{Cause, Segment};
use crate::diag::{Code, Diagnostic};
use crate::stroke::StrokeView;

/// How the travel is split into segments for the spectra.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum SegmentSpec {
    /// Like the paper: each IAFV interval is split into equal segments, n =
    /// max(round(len / target), 2 if len ≥ 2·min else 1), capped so no segment is shorter than
    /// `min_leads` (an interval shorter than that stays whole).
    Auto {
        /// Target segment length in leads (default 5).
        target_leads: f64,
        /// Minimum segment length in leads (default 3).
        min_leads: f64,
    },
    /// `count` equal segments of the whole stroke.
    Count {
        /// Number of segments (≥ 1).
        count: usize,
    },
    /// Equal segments of about `length_mm` over the whole stroke.
    LengthMm {
        /// Segment length (mm).
        length_mm: f64,
    },
}

impl Default for SegmentSpec {
    fn default() -> Self {
        Self::Auto {
            target_leads: 5.0,
            min_leads: 3.0,
        }
    }
}

/// Fewest leads a segment must span for its components to be given a cause: its spectrum's
/// resolution 1/L must be 0.5 orders or finer to tell 1x from 2x (the stroke-level rule of
/// [`crate::verdict`] asks for more).
pub const SEGMENT_CAUSE_MIN_LEADS: f64 = 2.0;

/// Most segments [`segment_bounds`] returns per interval (and for `count`).
pub const MAX_SEGMENTS: usize = 1000;

/// Segment bounds (mm) for `spec` over [start_mm, end_mm] with IAFV interval ends `breaks_mm`
/// (including both stroke ends).
///
/// # Errors
/// [`OrderError::InvalidParameter`] for a non-positive count, length or target.
pub fn segment_bounds(
    breaks_mm: &[f64],
    lead_mm: f64,
    spec: &SegmentSpec,
) -> Result<Vec<(f64, f64)>, OrderError> {
    let (Some(&start), Some(&end)) = (breaks_mm.first(), breaks_mm.last()) else {
        return Ok(Vec::new());
    };
    let split = |a: f64, b: f64, n: usize| -> Vec<(f64, f64)> {
        (0..n)
            .map(|i| {
                let h = (b - a) / n as f64;
                (a + i as f64 * h, a + (i + 1) as f64 * h)
            })
            .collect()
    };
    match spec {
        SegmentSpec::Count { count } => {
            if *count == 0 || *count > MAX_SEGMENTS {
                return Err(OrderError::InvalidParameter {
                    name: "segments.count",
                    value: *count as f64,
                    reason: "must be in 1..=1000",
                });
            }
            Ok(split(start, end, *count))
        }
        SegmentSpec::LengthMm { length_mm } => {
            if !(length_mm.is_finite() && *length_mm > 0.0) {
                return Err(OrderError::InvalidParameter {
                    name: "segments.length_mm",
                    value: *length_mm,
                    reason: "must be > 0",
                });
            }
            let n = (((end - start) / length_mm).round().max(1.0) as usize).min(MAX_SEGMENTS);
            Ok(split(start, end, n))
        }
        SegmentSpec::Auto {
            target_leads,
            min_leads,
        } => {
            if !(target_leads.is_finite()
                && *target_leads > 0.0
                && min_leads.is_finite()
                && *min_leads > 0.0)
            {
                return Err(OrderError::InvalidParameter {
                    name: "segments.target_leads",
                    value: *target_leads,
                    reason: "target_leads and min_leads must be > 0",
                });
            }
            let mut out = Vec::new();
            for w in breaks_mm.windows(2) {
                let len = (w[1] - w[0]) / lead_mm;
                let mut n = (len / target_leads).round().max(1.0) as usize;
                if len >= 2.0 * min_leads {
                    n = n.max(2);
                }
                n = n
                    .min((len / min_leads).floor().max(1.0) as usize)
                    .min(MAX_SEGMENTS);
                out.extend(split(w[0], w[1], n));
            }
            Ok(out)
        }
    }
}

/// Options of the fluctuation spectra.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SpectrumParams {
    /// Window (default Hann).
    pub window: Window,
    /// Segmentation (default [`SegmentSpec::Auto`]).
    pub segments: SegmentSpec,
    /// Significance rule.
    pub peaks: PeakParams,
    /// Relative tolerance for matching a kinematic order (default 0.03); the tolerance used is
    /// max(order resolution, this × order).
    pub tolerance_fraction: f64,
    /// Spectra are reported up to this order (detection uses the full spectrum; default 64).
    pub report_max_order: f64,
}

impl Default for SpectrumParams {
    fn default() -> Self {
        Self {
            window: Window::Hann,
            segments: SegmentSpec::default(),
            peaks: PeakParams::default(),
            tolerance_fraction: 0.03,
            report_max_order: 64.0,
        }
    }
}

/// Amplitude spectrum of one segment of the FFS.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Spectrum {
    /// Segment: the whole stroke (`all`), else `1`, `2`, ... along increasing position.
    pub segment: Segment,
    /// Segment start (mm).
    pub start_mm: f64,
    /// Segment end (mm).
    pub end_mm: f64,
    /// Number of samples.
    pub samples: usize,
    /// Segment length N·Δu in leads.
    pub length_leads: f64,
    /// Bin spacing = order resolution = 1 / `length_leads` (orders).
    pub order_resolution: f64,
    /// Window used.
    pub window: Window,
    /// Amplitude correction applied to |X_k|: 2/Σw (halved at DC and Nyquist).
    pub amplitude_correction: f64,
    /// Segment mean (N) removed before windowing.
    pub mean_removed_n: f64,
    /// Amplitude (N) at orders k · `order_resolution`, k = 0, 1, ...
    pub amplitude_n: Vec<f64>,
}

impl Spectrum {
    /// The order of bin k (cycles per lead).
    pub fn order(&self, k: usize) -> f64 {
        k as f64 * self.order_resolution
    }
}

/// A significant component of a segment's FFS spectrum.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SignificantComponent {
    /// Segment (`all` or `1`, `2`, ...).
    pub segment: Segment,
    /// Centre of the segment (mm).
    pub position_mm: f64,
    /// Refined order (cycles per lead).
    pub order: f64,
    /// Refined amplitude (N).
    pub amplitude_n: f64,
    /// Local median noise floor (N).
    pub floor_n: f64,
    /// Cause: a kinematic cause (`shaft 1x`, `nut ball refeed 1x`, ...), `unexplained`, or
    /// `unresolved` when the order is not resolved well enough to name one.
    pub cause: Cause,
    /// The kinematic order matched, if any.
    pub kinematic_order: Option<f64>,
    /// `false` when the order is above the stroke's highest trusted order (possible alias).
    pub trusted: bool,
}

/// Spectra and significant components of one stroke's FFS.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FluctuationAnalysis {
    /// Whole stroke (`all`) first, then the segments.
    pub spectra: Vec<Spectrum>,
    /// Significant components of every spectrum.
    pub components: Vec<SignificantComponent>,
    /// Kinematic orders used for the classification.
    pub kinematic_orders: Vec<KinematicOrder>,
    /// Highest order resolvable without aliasing (raw samples per lead / 2).
    pub max_trusted_order: f64,
    /// The significance rule in words.
    pub noise_floor_rule: String,
    /// Aliasing and other warnings, each with a stable code (`segments-skipped`,
    /// `kinematic-order-above-trusted`, `components-above-trusted`, `components-unresolved`,
    /// and from a study `components-withheld`, `causes-withheld`).
    pub warnings: Vec<Diagnostic>,
}

/// Segment spectra on one order grid, for a heat map of amplitude over order and position.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SpectrumGrid {
    /// Orders of the columns (cycles per lead), from 0 in equal steps.
    pub orders: Vec<f64>,
    /// Segment centre of each row (mm), increasing.
    pub position_mm: Vec<f64>,
    /// Amplitude (N), one row per segment; NaN where a segment's spectrum ends.
    pub amplitude_n: Vec<Vec<f64>>,
}

impl FluctuationAnalysis {
    /// The segment spectra (not `all`) on a common order grid from 0 to `max_order`: the
    /// finest segment resolution, but at most `max_columns` columns; each cell takes its
    /// segment's nearest bin. `None` without segments.
    pub fn segment_grid(&self, max_order: f64, max_columns: usize) -> Option<SpectrumGrid> {
        let segs: Vec<&Spectrum> = self
            .spectra
            .iter()
            .filter(|sp| !sp.segment.is_whole())
            .collect();
        if segs.is_empty() || max_order.is_nan() || max_order <= 0.0 {
            return None;
        }
        let step = segs
            .iter()
            .map(|sp| sp.order_resolution)
            .fold(f64::INFINITY, f64::min)
            .max(max_order / max_columns.max(1) as f64);
        let nx = (max_order / step).floor() as usize + 1;
        let orders: Vec<f64> = (0..nx).map(|i| i as f64 * step).collect();
        let mut rows: Vec<(f64, Vec<f64>)> = segs
            .iter()
            .map(|sp| {
                let row = orders
                    .iter()
                    .map(|&o| {
                        let b = (o / sp.order_resolution).round() as usize;
                        sp.amplitude_n.get(b).copied().unwrap_or(f64::NAN)
                    })
                    .collect();
                (0.5 * (sp.start_mm + sp.end_mm), row)
            })
            .collect();
        rows.sort_by(|a, b| a.0.total_cmp(&b.0));
        Some(SpectrumGrid {
            orders,
            position_mm: rows.iter().map(|r| r.0).collect(),
            amplitude_n: rows.into_iter().map(|r| r.1).collect(),
        })
    }
}

/// Spectra of the FFS of a stroke: whole stroke and segments, significant components and
/// their causes, aliasing guard.
///
/// `ffs_n` is aligned with `stroke.position_m` (any direction); `breaks_mm` are the IAFV
/// interval ends (both stroke ends included) used by [`SegmentSpec::Auto`]. The grid must be
/// uniform (as validated by [`crate::profile::fit_iafv`]).
///
/// # Reference
/// Paper 000, section 4.1.2, Figs 9-10, Eq. 7.
///
/// # Errors
/// [`OrderError::LengthMismatch`], [`OrderError::NonFinite`], [`OrderError::TooFewSamples`],
/// [`OrderError::InvalidParameter`].
pub fn analyze_fluctuation(
    analyzer: &mut SpectrumAnalyzer,
    stroke: &StrokeView<'_>,
    ffs_n: &[f64],
    breaks_mm: &[f64],
    kinematic: &[KinematicOrder],
    params: &SpectrumParams,
) -> Result<FluctuationAnalysis, OrderError> {
    let n = stroke.position_m.len();
    if ffs_n.len() != n {
        return Err(OrderError::LengthMismatch {
            what: "ffs_n",
            got: ffs_n.len(),
            expected: n,
        });
    }
    if n < 16 {
        return Err(OrderError::TooFewSamples { needed: 16, got: n });
    }
    if let Some(index) = ffs_n.iter().position(|v| !v.is_finite()) {
        return Err(OrderError::NonFinite { index });
    }
    params.peaks.validate()?;
    if !(params.tolerance_fraction.is_finite() && params.tolerance_fraction >= 0.0) {
        return Err(OrderError::InvalidParameter {
            name: "tolerance_fraction",
            value: params.tolerance_fraction,
            reason: "must be >= 0",
        });
    }
    let lead_mm = stroke.lead_m * 1e3;
    if !(lead_mm.is_finite() && lead_mm > 0.0) {
        return Err(OrderError::InvalidParameter {
            name: "lead_m",
            value: stroke.lead_m,
            reason: "must be > 0",
        });
    }
    let reversed = stroke.position_m[n - 1] < stroke.position_m[0];
    let (x0_mm, x1_mm) = if reversed {
        (stroke.position_m[n - 1] * 1e3, stroke.position_m[0] * 1e3)
    } else {
        (stroke.position_m[0] * 1e3, stroke.position_m[n - 1] * 1e3)
    };
    let mut y = ffs_n.to_vec();
    if reversed {
        y.reverse();
    }
    let dx_mm = (x1_mm - x0_mm) / (n - 1) as f64;
    let du = dx_mm / lead_mm;
    let bounds = if breaks_mm.len() >= 2 {
        segment_bounds(breaks_mm, lead_mm, &params.segments)?
    } else {
        segment_bounds(&[x0_mm, x1_mm], lead_mm, &params.segments)?
    };
    let mut segs: Vec<(Segment, usize, usize)> = vec![(Segment::Whole, 0, n)];
    let mut warnings = Vec::new();
    let mut skipped = Vec::new();
    for (i, (a, b)) in bounds.iter().enumerate() {
        let lo = (((a - x0_mm) / dx_mm).round().max(0.0) as usize).min(n);
        let hi = (((b - x0_mm) / dx_mm).round().max(0.0) as usize + 1).min(n);
        if hi.saturating_sub(lo) < 16 {
            skipped.push((i + 1).to_string());
            continue;
        }
        // Adjacent segments share their boundary sample at most.
        segs.push((Segment::Part(i + 1), lo, hi));
    }
    if !skipped.is_empty() {
        warnings.push(Diagnostic::new(
            Code::SegmentsSkipped,
            format!(
                "{} segment(s) with fewer than 16 samples skipped (first: {})",
                skipped.len(),
                skipped[0]
            ),
        ));
    }
    let mut spectra = Vec::new();
    let mut components = Vec::new();
    let mut unresolved = 0usize;
    let mut amp = Vec::new();
    let mut buf = Vec::new();
    for (label, lo, hi) in segs {
        let seg = &y[lo..hi];
        let m = seg.len();
        let mean = seg.iter().sum::<f64>() / m as f64;
        buf.clear();
        buf.extend(seg.iter().map(|v| v - mean));
        let corr = analyzer.amplitude_spectrum(&buf, params.window, &mut amp)?;
        let res = 1.0 / (m as f64 * du);
        let centre = x0_mm + 0.5 * (lo + hi - 1) as f64 * dx_mm;
        // A cause needs the order resolved: the segment long enough for its resolution to
        // tell neighbouring kinematic orders apart, and the order below the trusted one.
        let long_enough = m as f64 * du >= SEGMENT_CAUSE_MIN_LEADS;
        for p in find_peaks(analyzer, params.window, &buf, &amp, du, &params.peaks) {
            let trusted = p.order <= stroke.max_trusted_order || stroke.max_trusted_order.is_nan();
            let k = if long_enough && trusted {
                classify(p.order, res, params.tolerance_fraction, kinematic)
            } else {
                unresolved += 1;
                None
            };
            let cause = match k {
                Some(k) => k.cause.clone(),
                None if long_enough && trusted => Cause::Unexplained,
                None => Cause::Unresolved,
            };
            components.push(SignificantComponent {
                segment: label,
                position_mm: centre,
                order: p.order,
                amplitude_n: p.amplitude_n,
                floor_n: p.floor_n,
                cause,
                kinematic_order: k.map(|k| k.order),
                trusted,
            });
        }
        let keep = ((params.report_max_order / res).floor() as usize + 1).min(amp.len());
        spectra.push(Spectrum {
            segment: label,
            start_mm: x0_mm + lo as f64 * dx_mm,
            end_mm: x0_mm + (hi - 1) as f64 * dx_mm,
            samples: m,
            length_leads: m as f64 * du,
            order_resolution: res,
            window: params.window,
            amplitude_correction: corr,
            mean_removed_n: mean,
            amplitude_n: amp[..keep].to_vec(),
        });
    }
    warnings.extend(aliasing_warnings(stroke, kinematic, &components));
    if unresolved > 0 {
        warnings.push(Diagnostic::new(
            Code::ComponentsUnresolved,
            format!(
                "{unresolved} significant component(s) left `{}`: their segment \
                 spans fewer than {SEGMENT_CAUSE_MIN_LEADS} leads (order resolution coarser \
                 than 0.5) or their order is above the trusted order {:.2}",
                Cause::Unresolved,
                stroke.max_trusted_order
            ),
        ));
    }
    Ok(FluctuationAnalysis {
        spectra,
        components,
        kinematic_orders: kinematic.to_vec(),
        max_trusted_order: stroke.max_trusted_order,
        noise_floor_rule: format!(
            "local maximum at order >= {} with refined amplitude >= {} x floor (1.55 x lower \
             quartile of the amplitudes over +-max({} bins, {} orders), the median for pure \
             noise) and >= {} N; window sidelobes of stronger peaks rejected",
            params.peaks.min_order,
            params.peaks.noise_floor_factor,
            params.peaks.floor_min_bins,
            params.peaks.floor_half_width_orders,
            params.peaks.min_amplitude_n
        ),
        warnings,
    })
}

/// The aliasing guard: warn when a kinematic order or a detected component lies above the
/// stroke's highest trusted order, and say which feed would resolve the highest kinematic order.
fn aliasing_warnings(
    stroke: &StrokeView<'_>,
    kinematic: &[KinematicOrder],
    components: &[SignificantComponent],
) -> Vec<Diagnostic> {
    let mut out = Vec::new();
    let limit = stroke.max_trusted_order;
    let highest = kinematic.iter().max_by(|a, b| a.order.total_cmp(&b.order));
    if let Some(h) = highest.filter(|h| h.order > limit) {
        // Samples per lead = sample rate × lead / feed; resolving order f needs 2f per lead.
        let factor = h.order / limit;
        let feed = match stroke.feed_mm_min {
            Some(f) if f.is_finite() && f > 0.0 => {
                format!("feed at most {:.1} mm/min (now {f:.1} mm/min)", f / factor)
            }
            _ => format!("feed at most {:.3} x the present feed", 1.0 / factor),
        };
        out.push(Diagnostic::new(
            Code::KinematicOrderAboveTrusted,
            format!(
                "highest kinematic order {:.2} ({}) exceeds the highest trusted order \
                 {limit:.2} (raw samples per lead / 2): sample at least {factor:.2} x faster \
                 or {feed} so that it is resolved without aliasing",
                h.order, h.cause
            ),
        ));
    }
    let untrusted = components.iter().filter(|c| !c.trusted).count();
    if untrusted > 0 {
        out.push(Diagnostic::new(
            Code::ComponentsAboveTrusted,
            format!(
                "{untrusted} significant component(s) above the trusted order {limit:.2} are \
                 flagged trusted = false: they may be aliases of higher orders"
            ),
        ));
    }
    out
}
