//! `feedscope map`: friction over position and feed from a test set (issue 4).
use std::path::PathBuf;

use anyhow::{anyhow, Context, Result};
use clap::ValueEnum;
use feedscope::map::FeedScale;
use feedscope_app::map::{ExportCurve, MapOptions, MapRequest};

use super::estimate::Format;
use super::export::ExportArgs;
use crate::front::Cli;
use crate::output::{out, outln, OutputSet};
use feedscope_app::plot;

/// Friction map over position and feed from a test set (paper 000 Section 4.2).
///
/// INDEX is a CSV listing the runs of one axis: a header with at least `file,feed_mm_min,repeat`
/// (more columns allowed, `#` comment lines skipped), one run per line; `file` is relative to
/// the index's folder. Every run is estimated in parallel; a run that fails (missing or
/// malformed file, no stroke at its feed) is reported by name on stderr and the others are
/// mapped.
///
/// Per direction: every stroke is fitted with common breakpoints (given, or 1-3 equal intervals
/// of at least 4 leads, quartic), the repeats of each feed are averaged coefficient by
/// coefficient (PPOCM, the mean friction curve of the feed) with a repeatability figure per
/// interval, and each mean coefficient becomes a polynomial of the feed (Eq. 8; order
/// min(--feed-order, feeds − 2) in log-feed scaled to [−1, 1]): the friction map F(z, v).
/// The Stribeck curve (Eq. 9, δ = 2) is fitted to the PPOCM values of every feed at the
/// chosen positions and at every position of the map grid; falls of friction with feed where
/// the Stribeck curve rises are reported as non-conventional. Where the feeds do not
/// determine a Stribeck curve (fewer than 4 distinct feeds per direction, a singular or
/// ill-conditioned fit, non-physical values) the Coulomb + viscous line F = Fc + σ·v is
/// reported instead; the model and the reason are printed on stderr with every fit warning.
///
/// Writes into OUT: stribeck.json, stribeck_profile.csv, compensation.csv (long) and
/// compensation_forward.csv / compensation_backward.csv (matrix: rows positions, columns
/// feeds), map.json, ppocm.csv, repeatability.csv, runs.csv and SVG plots (friction vs feed
/// at the positions, map heat maps, repeats and their mean at one feed, mean curves of
/// several feeds). Friction is signed: positive forward, negative backward.
///
/// With --export, the friction compensation at one position (--export-position-mm) goes
/// into the controllers' own files as well: a Beckhoff TF5200 frict_comp block, SINUMERIK
/// starting values, a generic velocity table (docs/friction-map.md says how to load them).
///
/// Exit codes: 0 success, also when some runs failed (they are listed); 1 when every run
/// failed, or when any run failed with --strict (the outputs are still written); 2 bad input
/// (unreadable index or axis, a position outside the mapped travel, a table feed outside the
/// measured feeds without --extrapolate, an export the fits do not allow, bad options).
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Index CSV of the test set (`file,feed_mm_min,repeat`).
    pub index: PathBuf,
    /// Axis parameters (TOML or JSON).
    #[arg(long)]
    pub axis: PathBuf,
    /// Output folder (created if missing).
    #[arg(long, default_value = "feedscope-map")]
    pub out: PathBuf,
    /// Positions for the Stribeck fits (mm), e.g. `40,55`; default: 5 evenly spaced inside
    /// each direction's mapped span.
    #[arg(long, value_delimiter = ',', allow_negative_numbers = true)]
    pub positions: Option<Vec<f64>>,
    /// Interior breakpoints common to every feed (mm), e.g. `30,45`; default: equal intervals.
    #[arg(long, value_delimiter = ',', requires = "orders")]
    pub breaks: Option<Vec<f64>>,
    /// Polynomial order of each interval, one more than breakpoints [default: 4 each].
    #[arg(long, value_delimiter = ',')]
    pub orders: Option<Vec<usize>>,
    /// Highest order of the feed polynomial (Eq. 8); lowered to feeds − 2 when fewer feeds.
    #[arg(long, default_value_t = MapOptions::default().feed_order)]
    pub feed_order: usize,
    /// Scaled feed variable of the feed polynomial.
    #[arg(long, value_enum, default_value_t = ScaleArg::from(MapOptions::default().feed_scale))]
    pub feed_scale: ScaleArg,
    /// Position step of the map grid, the compensation table and the Stribeck profile (mm).
    #[arg(long, default_value_t = MapOptions::default().position_step_mm)]
    pub position_step_mm: f64,
    /// Feeds of the compensation table (mm/min) [default: the measured feeds].
    #[arg(long, value_delimiter = ',')]
    pub table_feeds: Option<Vec<f64>>,
    /// Allow table feeds outside the measured feeds (the feed polynomial extrapolates).
    #[arg(long)]
    pub extrapolate: bool,
    /// Trimmed from both ends of the strokes' common span (mm).
    #[arg(long, default_value_t = MapOptions::default().margin_mm)]
    pub margin_mm: f64,
    /// Feed whose repeats are plotted with their mean (mm/min) [default: the slowest].
    #[arg(long)]
    pub plot_feed: Option<f64>,
    /// Exit with code 1 when any run failed.
    #[arg(long)]
    pub strict: bool,
    /// Resampling points per lead when estimating.
    #[arg(long, default_value_t = MapOptions::default().samples_per_lead)]
    pub samples_per_lead: u32,
    /// What to print on stdout.
    #[arg(long, value_enum, default_value_t = Format::Text)]
    pub format: Format,
    #[command(flatten)]
    pub export: ExportArgs,
    /// Position (mm) whose friction the exports tabulate [default: the middle of the span
    /// both directions share].
    #[arg(
        long,
        allow_negative_numbers = true,
        help_heading = "Controller export"
    )]
    pub export_position_mm: Option<f64>,
    /// Curve the exported tables follow at that position: the Stribeck fit (Eq. 9, smooth)
    /// or the map's section (Eq. 6 and 8, the measured means' feed polynomial).
    #[arg(long, value_enum, default_value_t = ExportCurveArg::Stribeck, help_heading = "Controller export")]
    pub export_curve: ExportCurveArg,
}

/// The curve `--export` tabulates.
#[derive(Debug, Clone, Copy, ValueEnum, PartialEq, Eq)]
pub enum ExportCurveArg {
    /// The Stribeck fit at the position (Eq. 9; the reduced model where the feeds do not
    /// determine one).
    Stribeck,
    /// The map's section at the position (Eq. 6 with the feed polynomial of Eq. 8).
    Map,
}

#[derive(Debug, Clone, Copy, ValueEnum, PartialEq, Eq)]
pub enum ScaleArg {
    /// u from ln(feed) (log-spaced feeds).
    Log,
    /// u from the feed itself (paper 000 Eq. 8).
    Linear,
}

impl From<FeedScale> for ScaleArg {
    fn from(s: FeedScale) -> Self {
        match s {
            FeedScale::Log => ScaleArg::Log,
            FeedScale::Linear => ScaleArg::Linear,
        }
    }
}

impl From<ScaleArg> for FeedScale {
    fn from(s: ScaleArg) -> Self {
        match s {
            ScaleArg::Log => FeedScale::Log,
            ScaleArg::Linear => FeedScale::Linear,
        }
    }
}

impl From<ExportCurveArg> for ExportCurve {
    fn from(c: ExportCurveArg) -> Self {
        match c {
            ExportCurveArg::Stribeck => ExportCurve::Stribeck,
            ExportCurveArg::Map => ExportCurve::Map,
        }
    }
}

pub fn run(args: Args) -> Result<()> {
    let request = MapRequest {
        index: args.index.clone(),
        axis: args.axis.clone(),
        options: MapOptions {
            positions_mm: args.positions.clone(),
            breaks_mm: args.breaks.clone(),
            orders: args.orders.clone(),
            feed_order: args.feed_order,
            feed_scale: args.feed_scale.into(),
            position_step_mm: args.position_step_mm,
            table_feeds_mm_min: args.table_feeds.clone(),
            extrapolate: args.extrapolate,
            margin_mm: args.margin_mm,
            samples_per_lead: args.samples_per_lead,
        },
        export: args.export.options(),
        export_position_mm: args.export_position_mm,
        export_curve: args.export_curve.into(),
    };
    // Everything is computed before the first file is written: a refusal leaves nothing behind.
    let mapped = request.run(&Cli::default())?;
    let files = mapped.files()?;
    let svgs = plot::map_svgs(&mapped.study, args.plot_feed)?;

    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let out = &args.out;
    // All or nothing: the files replace the previous run's together at the end.
    let mut outputs = OutputSet::new();
    for (name, text) in files.iter().chain(&svgs) {
        outputs.write(&out.join(name), text.as_bytes())?;
    }
    for f in &mapped.exports {
        outputs.write(&out.join(f.name), &f.bytes)?;
    }
    outputs.commit()?;
    for f in &mapped.exports {
        eprintln!("wrote {}: {}", out.join(f.name).display(), f.summary);
    }

    for line in mapped.remarks() {
        eprintln!("{line}");
    }
    let summary = &mapped.report.summary;
    match args.format {
        Format::Json => outln!("{}", serde_json::to_string_pretty(summary)?),
        Format::Text => out!("{mapped}"),
    }
    let failed = mapped.estimate.failed.len();
    if args.strict && failed > 0 {
        return Err(anyhow!(
            "{failed} of {} runs failed (--strict)",
            summary.runs
        ));
    }
    Ok(())
}
