//! `feedscope analyze`: where along the travel friction changes, and which part does it.
use std::path::PathBuf;

use anyhow::{Context, Result};
use feedscope::study::AnalyzeStudyParams;
use feedscope_app::analyze::{AnalyzeOptions, AnalyzeRequest, Analyzed};
use feedscope_app::plot;
use feedscope_io::friction_csv;

use super::estimate::Format;
use crate::front::Cli;
use crate::output::{out, outln, OutputSet};

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
    #[arg(long, value_enum, default_value_t = Format::Text)]
    pub format: Format,
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
    let svgs = plot::analysis_svgs(&study, args.segment)?;

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
        Format::Json => outln!("{json}"),
        Format::Text => {
            out!("{report}");
            for line in report.remarks() {
                eprintln!("{line}");
            }
            eprintln!("wrote analysis.json, friction.csv, components.csv, order_scan.csv and");
            eprintln!("  {} plots to {}", svgs.len(), args.out.display());
        }
    }
    Ok(())
}
