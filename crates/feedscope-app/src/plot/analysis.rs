//! The pictures of an analysis along the travel (paper 000, Section 4.1): per direction
//! (its first stroke) the friction with its IAFV, the spectra of the FFS along the travel as
//! a heat map, the spectrum of the whole stroke and of one segment, and the amplitude of each
//! explained component along the travel (paper 000 Fig. 9d).
use std::collections::BTreeMap;

use feedscope::estimate::Direction;
use feedscope::order::{Cause, Segment};
use feedscope::study::AnalyzeStudy;

use super::{heatmap_svg, line_chart_svg, stacked_svg, Heatmap, LineChart, Result, Series, Style};
use crate::AppError;

/// Points of one series at most: longer ones are decimated.
const MAX_POINTS: usize = 3000;

/// Every SVG of an analysis as (file name, content): `friction_iafv.svg` (the first stroke
/// of each direction, stacked), and per direction `spectra_heatmap_<dir>.svg`,
/// `spectrum_<dir>.svg` (the whole stroke and segment `segment`, 1-based) and, when a
/// component has a cause, `components_<dir>.svg`. Orders in cycles per lead, positions in mm,
/// friction and amplitudes in N.
///
/// # Errors
/// No stroke to plot; a chart that cannot be drawn (no finite value).
pub fn analysis_svgs(study: &AnalyzeStudy, segment: usize) -> Result<Vec<(String, String)>> {
    let (strokes, analyses, singles) = (&study.strokes, &study.analyses, &study.single_polynomials);
    let mut out = Vec::new();
    // First stroke of each direction.
    let pick = |d: Direction| strokes.iter().position(|s| s.summary.direction == d);
    let chosen: Vec<usize> = [Direction::Forward, Direction::Backward]
        .into_iter()
        .filter_map(pick)
        .collect();
    if chosen.is_empty() {
        return Err(AppError::failed("no stroke to plot"));
    }
    let decim = |n: usize| n.div_ceil(MAX_POINTS).max(1);
    // 1. Friction with IAFV (piecewise and single polynomial) and the linear trend.
    let titles: Vec<String> = chosen
        .iter()
        .map(|&k| {
            format!(
                "Friction and IAFV, {} at {:.0} mm/min",
                strokes[k].summary.direction.as_str(),
                strokes[k].summary.feed_mm_min
            )
        })
        .collect();
    let charts: Vec<LineChart> = chosen
        .iter()
        .zip(&titles)
        .map(|(&k, title)| {
            let s = &strokes[k];
            let a = &analyses[k];
            let st = decim(s.position_m.len());
            let zmm: Vec<f64> = s.position_m.iter().map(|z| z * 1e3).collect();
            let pts = |v: &[f64]| -> Vec<(f64, f64)> {
                zmm.iter()
                    .zip(v)
                    .step_by(st)
                    .map(|(a, b)| (*a, *b))
                    .collect()
            };
            let single: Vec<f64> = s
                .position_m
                .iter()
                .map(|&z| singles[k].poly.value_n(z))
                .collect();
            let lin = &a.iafv.linear;
            LineChart {
                title,
                x_label: "position (mm)",
                y_label: "friction F_f (N)",
                series: vec![
                    Series {
                        name: "estimated friction".into(),
                        points: pts(&s.friction_n),
                        style: Style::Line,
                    },
                    Series {
                        name: format!("IAFV, piecewise orders {:?}", a.iafv.poly.orders),
                        points: pts(&a.iafv_n),
                        style: Style::Line,
                    },
                    Series {
                        name: format!("single polynomial, order {}", a.order_scan.best_order),
                        points: pts(&single),
                        style: Style::Dashed,
                    },
                    Series {
                        name: format!("linear trend {:+.3} N/mm", lin.slope_n_per_mm),
                        points: vec![
                            (lin.start_mm, lin.value_at_start_n),
                            (lin.end_mm, lin.value_at_end_n),
                        ],
                        style: Style::Dashed,
                    },
                ],
            }
        })
        .collect();
    out.push(("friction_iafv.svg".to_string(), stacked_svg(&charts)?));

    for &k in &chosen {
        let s = &strokes[k];
        let a = &analyses[k];
        let dir = s.summary.direction.as_str();
        let fl = &a.fluctuation;
        // Up to the aliasing limit (at least order 4, the shaft's), at most order 40.
        let max_order = fl
            .spectra
            .iter()
            .map(|sp| sp.order(sp.amplitude_n.len().saturating_sub(1)))
            .fold(0.0f64, f64::max)
            .min(fl.max_trusted_order.max(4.0))
            .min(40.0);
        // 2. Heat map of segment spectra: amplitude over order and position.
        if let Some(g) = fl.segment_grid(max_order, 800) {
            let title = format!("FFS spectra along the travel, {dir}");
            let svg = heatmap_svg(&Heatmap {
                title: &title,
                x_label: "order (cycles per lead)",
                y_label: "segment centre position (mm)",
                z_label: "amplitude (N)",
                x: g.orders,
                y: g.position_mm,
                z: g.amplitude_n,
            })?;
            out.push((format!("spectra_heatmap_{dir}.svg"), svg));
        }
        // 3. Spectrum of the whole stroke and of the chosen segment.
        let mut series = Vec::new();
        for sp in fl
            .spectra
            .iter()
            .filter(|sp| sp.segment.is_whole() || sp.segment == Segment::Part(segment))
        {
            series.push(Series {
                name: if sp.segment.is_whole() {
                    "whole stroke".into()
                } else {
                    format!(
                        "segment {} ({:.0}-{:.0} mm)",
                        sp.segment, sp.start_mm, sp.end_mm
                    )
                },
                points: (0..sp.amplitude_n.len())
                    .map(|b| (sp.order(b), sp.amplitude_n[b]))
                    .filter(|p| p.0 <= max_order)
                    .collect(),
                style: Style::Line,
            });
        }
        let title = format!("Amplitude spectrum of the FFS, {dir}");
        out.push((
            format!("spectrum_{dir}.svg"),
            line_chart_svg(&LineChart {
                title: &title,
                x_label: "order (cycles per lead)",
                y_label: "amplitude (N)",
                series,
            })?,
        ));
        // 4. Amplitude of each significant component along the travel (paper Fig. 9d).
        let mut by_cause: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
        for c in fl.components.iter().filter(|c| !c.segment.is_whole()) {
            if c.cause == Cause::Unexplained {
                continue;
            }
            let label = format!("{} ({:.2})", c.cause, c.kinematic_order.unwrap_or(c.order));
            by_cause
                .entry(label)
                .or_default()
                .push((c.position_mm, c.amplitude_n));
        }
        if !by_cause.is_empty() {
            let series = by_cause
                .into_iter()
                .map(|(name, mut pts)| {
                    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
                    Series {
                        name,
                        points: pts,
                        style: Style::Line,
                    }
                })
                .collect();
            let title = format!("Significant components along the travel, {dir}");
            out.push((
                format!("components_{dir}.svg"),
                line_chart_svg(&LineChart {
                    title: &title,
                    x_label: "segment centre position (mm)",
                    y_label: "amplitude (N)",
                    series,
                })?,
            ));
        }
    }
    Ok(out)
}
