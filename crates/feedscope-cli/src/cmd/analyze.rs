//! `feedscope analyze`: where along the travel friction changes, and which part does it.
use crate::output::outln;
use std::collections::BTreeMap;
use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use feedscope::estimate::{Direction, StrokeFriction};
use feedscope::order::{Cause, Segment};
use feedscope::profile::StrokeAnalysis;
use feedscope::study::AnalyzeStudyParams;
use feedscope_app::analyze::{AnalyzeOptions, AnalyzeRequest, Analyzed};
use feedscope_io::friction_csv;

use crate::front::Cli;
use crate::output::OutputSet;
use feedscope_app::plot::{self, Heatmap, LineChart, Series, Style};

/// Analyse friction along the travel (paper 000, section 4.1).
///
/// Estimates friction from a trace (or reads the CSV written by `feedscope estimate`), fits the
/// instantaneous average friction value (IAFV) as piecewise polynomials with value and slope
/// continuity (breakpoints and orders chosen by BIC unless given), separates the friction
/// fluctuating signal (FFS = friction − IAFV), computes its amplitude spectra in screw orders
/// (cycles per lead) for the whole stroke and for segments of the travel, finds the significant
/// components and names their likely cause from the axis geometry (shaft orders 1-4, ball
/// refeeding in the nut and the guides by Eq. 7, declared orders).
///
/// Writes into DIR: analysis.json, friction.csv (with iafv_n and ffs_n), components.csv,
/// order_scan.csv (Table 2) and SVG plots.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Trace file (CSV or Parquet, as for `estimate`), or the friction CSV written by
    /// `feedscope estimate` (its JSON summary beside it supplies the aliasing limits).
    pub input: PathBuf,
    /// Axis parameters (TOML or JSON); the geometry keys name the kinematic orders.
    #[arg(long)]
    pub axis: PathBuf,
    /// Output folder (created if missing).
    #[arg(long, default_value = "feedscope-analysis")]
    pub out: PathBuf,
    /// IAFV interior breakpoints (mm), e.g. `85,150`; automatic (BIC) when absent.
    #[arg(long, value_delimiter = ',', requires = "orders")]
    pub breaks: Option<Vec<f64>>,
    /// Polynomial order of each IAFV interval, e.g. `4,5,4` (one more than breakpoints).
    #[arg(long, value_delimiter = ',')]
    pub orders: Option<Vec<usize>>,
    /// Number of equal segments for the spectra [default: automatic, about 5 leads each
    /// within each IAFV interval, like the paper].
    #[arg(long, conflicts_with = "segment_length_mm")]
    pub segments: Option<usize>,
    /// Segment length for the spectra (mm).
    #[arg(long)]
    pub segment_length_mm: Option<f64>,
    /// Segment whose spectrum gets its own plot (1-based).
    #[arg(long, default_value_t = 1)]
    pub segment: usize,
    /// Resampling points per lead when estimating from a trace.
    #[arg(long, default_value_t = AnalyzeStudyParams::default().estimate.samples_per_lead)]
    pub samples_per_lead: u32,
    /// What to print on stdout.
    #[arg(long, value_enum, default_value_t = super::estimate::Format::Text)]
    pub format: super::estimate::Format,
}

pub fn run(args: Args) -> Result<()> {
    let request = AnalyzeRequest {
        input: args.input.clone(),
        axis: args.axis.clone(),
        options: AnalyzeOptions {
            samples_per_lead: args.samples_per_lead,
            breaks_mm: args.breaks.clone(),
            orders: args.orders.clone(),
            segments: args.segments,
            segment_length_mm: args.segment_length_mm,
        },
    };
    let Analyzed { report, study } = request.run(&Cli::default())?;

    // Render everything before anything is written.
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let json = serde_json::to_string_pretty(&report)?;
    let svgs = plots(
        &study.strokes,
        &study.analyses,
        &study.single_polynomials,
        args.segment,
    )?;

    // All or nothing: the files replace the previous run's together at the end.
    let mut outputs = OutputSet::new();
    let mut fcsv = outputs.create(&args.out.join("friction.csv"))?;
    friction_csv::write_analyzed(fcsv.writer(), &study.strokes, &study.analyses)?;
    outputs.add(fcsv)?;
    outputs.write(&args.out.join("analysis.json"), json.as_bytes())?;
    outputs.write(
        &args.out.join("components.csv"),
        report.components_csv().as_bytes(),
    )?;
    outputs.write(
        &args.out.join("order_scan.csv"),
        report.order_scan_csv().as_bytes(),
    )?;
    for (name, svg) in &svgs {
        outputs.write(&args.out.join(name), svg.as_bytes())?;
    }
    outputs.commit()?;

    match args.format {
        super::estimate::Format::Json => outln!("{json}"),
        super::estimate::Format::Text => {
            print_summary(&study.strokes, &study.analyses, &report.order_scan_table)?;
            if let Some(v) = &report.verdict {
                outln!();
                outln!("{}", v.headline());
            }
            for w in &report.withheld {
                eprintln!(
                    "verdict: stroke {} ({}) withheld, its data support {} only: {}",
                    w.stroke,
                    w.direction.as_str(),
                    w.support.as_str(),
                    w.reasons
                        .iter()
                        .map(|r| r.message.as_str())
                        .collect::<Vec<_>>()
                        .join("; ")
                );
            }
            eprintln!("wrote analysis.json, friction.csv, components.csv, order_scan.csv and");
            eprintln!("  {} plots to {}", svgs.len(), args.out.display());
        }
    }
    Ok(())
}

fn print_summary(
    strokes: &[StrokeFriction],
    analyses: &[StrokeAnalysis],
    table: &feedscope::profile::OrderScanTable,
) -> Result<()> {
    outln!("Residual standard deviation of single polynomials (N), paper 000 Table 2:");
    outln!("{:>6}  {:>10}  {:>10}", "order", "forward", "backward");
    for r in &table.rows {
        let f = |v: Option<f64>| v.map(|x| format!("{x:.2}")).unwrap_or("-".into());
        outln!(
            "{:>6}  {:>10}  {:>10}",
            r.order,
            f(r.forward_std_n),
            f(r.backward_std_n)
        );
    }
    for (s, a) in strokes.iter().zip(analyses) {
        let p = &a.iafv.poly;
        outln!(
            "\nstroke {} ({}, {:.0} mm/min): IAFV intervals {} with orders {:?}; linear trend \
             {:+.3} N/mm",
            s.summary.stroke,
            s.summary.direction.as_str(),
            s.summary.feed_mm_min,
            p.breaks_mm
                .windows(2)
                .map(|w| format!("{:.0}-{:.0}", w[0], w[1]))
                .collect::<Vec<_>>()
                .join(", "),
            p.orders,
            a.iafv.linear.slope_n_per_mm
        );
        outln!("  significant components over the whole stroke:");
        outln!("  {:>8}  {:>12}  cause", "order", "amplitude (N)");
        for c in a
            .fluctuation
            .components
            .iter()
            .filter(|c| c.segment.is_whole())
        {
            outln!(
                "  {:>8.3}  {:>12.2}  {}{}",
                c.order,
                c.amplitude_n,
                c.cause,
                if c.trusted {
                    ""
                } else {
                    " (beyond the aliasing limit)"
                }
            );
        }
        for w in &a.fluctuation.warnings {
            eprintln!("warning: stroke {}: {w}", s.summary.stroke);
        }
    }
    Ok(())
}

/// All SVG plots: (file name, content).
fn plots(
    strokes: &[StrokeFriction],
    analyses: &[StrokeAnalysis],
    singles: &[feedscope::profile::PiecewiseFit],
    segment: usize,
) -> Result<Vec<(String, String)>> {
    let mut out = Vec::new();
    // First stroke of each direction.
    let pick = |d: Direction| strokes.iter().position(|s| s.summary.direction == d);
    let chosen: Vec<usize> = [Direction::Forward, Direction::Backward]
        .into_iter()
        .filter_map(pick)
        .collect();
    if chosen.is_empty() {
        bail!("no stroke to plot");
    }
    let decim = |n: usize| n.div_ceil(3000).max(1);
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
    out.push(("friction_iafv.svg".to_string(), plot::stacked_svg(&charts)?));

    for &k in &chosen {
        let s = &strokes[k];
        let a = &analyses[k];
        let dir = s.summary.direction.as_str();
        let fl = &a.fluctuation;
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
            let svg = plot::heatmap_svg(&Heatmap {
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
            plot::line_chart_svg(&LineChart {
                title: &title,
                x_label: "order (cycles per lead)",
                y_label: "amplitude (N)",
                series,
            })?,
        ));
        // 4. Amplitude of each significant component along the travel (paper Fig. 9d).
        let mut by_cause: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
        for c in fl.components.iter().filter(|c| !c.segment.is_whole()) {
            let label = if c.cause == Cause::Unexplained {
                continue;
            } else {
                format!("{} ({:.2})", c.cause, c.kinematic_order.unwrap_or(c.order))
            };
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
                plot::line_chart_svg(&LineChart {
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
