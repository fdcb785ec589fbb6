//! `feedscope map`: friction over position and feed from a test set (issue 4).
use std::fmt::Write as _;
use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{anyhow, Context, Result};
use clap::ValueEnum;
use feedscope::compensation::{DriveConversion, FrictionCurve};
use feedscope::estimate::{Direction, EstimateParams};
use feedscope::map::{
    stribeck_profile, FeedScale, FrictionMap, MapParams, NonConventionalSpan, StribeckAtPosition,
    StribeckProfile, TestSet,
};
use feedscope::stribeck::{FitWarning, FrictionModel, ParamEstimate, Reduction, M_S_PER_MM_MIN};
use feedscope::study::{map_grid, map_study, MapStudy, MapStudyParams, StudyError};
use feedscope_io::compensation::CompensationTable;
use feedscope_io::test_set::{estimate_set, read_index};
use feedscope_io::trace::ReadOptions;
use serde::Serialize;

use super::estimate::Format;
use super::export::{ExportArgs, ExportConfig, ExportCurves, ExportFile};
use super::BadInput;
use crate::output::{bar, AtomicFile, OutputSet};
use crate::plot::{self, Heatmap, LineChart, Series, Style};

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
    #[arg(long, default_value_t = MapParams::default().feed_order)]
    pub feed_order: usize,
    /// Scaled feed variable of the feed polynomial.
    #[arg(long, value_enum, default_value_t = ScaleArg::from(MapParams::default().feed_scale))]
    pub feed_scale: ScaleArg,
    /// Position step of the map grid, the compensation table and the Stribeck profile (mm).
    #[arg(long, default_value_t = MapStudyParams::default().position_step_mm)]
    pub position_step_mm: f64,
    /// Feeds of the compensation table (mm/min) [default: the measured feeds].
    #[arg(long, value_delimiter = ',')]
    pub table_feeds: Option<Vec<f64>>,
    /// Allow table feeds outside the measured feeds (the feed polynomial extrapolates).
    #[arg(long)]
    pub extrapolate: bool,
    /// Trimmed from both ends of the strokes' common span (mm).
    #[arg(long, default_value_t = MapParams::default().margin_mm)]
    pub margin_mm: f64,
    /// Feed whose repeats are plotted with their mean (mm/min) [default: the slowest].
    #[arg(long)]
    pub plot_feed: Option<f64>,
    /// Exit with code 1 when any run failed.
    #[arg(long)]
    pub strict: bool,
    /// Resampling points per lead when estimating.
    #[arg(long, default_value_t = EstimateParams::default().samples_per_lead)]
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

/// Validated settings (before any I/O).
struct Config {
    params: MapStudyParams,
    export: Option<ExportConfig>,
}

fn validate(args: &Args) -> Result<Config> {
    let bad = |m: String| -> anyhow::Error { BadInput(m).into() };
    if let Some(p) = &args.positions {
        if let Some(x) = p.iter().find(|x| !x.is_finite()) {
            return Err(bad(format!("--positions: {x} is not a finite position")));
        }
    }
    if !(args.position_step_mm.is_finite() && args.position_step_mm > 0.0) {
        return Err(bad(format!(
            "--position-step-mm {} must be positive",
            args.position_step_mm
        )));
    }
    if let Some(f) = &args.table_feeds {
        if let Some(x) = f.iter().find(|x| !(x.is_finite() && **x > 0.0)) {
            return Err(bad(format!("--table-feeds: {x} is not a positive feed")));
        }
    }
    if args.samples_per_lead < 16 {
        return Err(bad("--samples-per-lead must be at least 16".into()));
    }
    let export = args.export.validate()?;
    if export.is_none() {
        if args.export_position_mm.is_some() {
            return Err(bad("--export-position-mm is used only with --export".into()));
        }
        if args.export_curve != ExportCurveArg::Stribeck {
            return Err(bad("--export-curve is used only with --export".into()));
        }
    }
    if let Some(z) = args.export_position_mm.filter(|z| !z.is_finite()) {
        return Err(bad(format!(
            "--export-position-mm: {z} is not a finite position"
        )));
    }
    let params = MapParams {
        breaks_mm: args.breaks.clone(),
        orders: args.orders.clone(),
        margin_mm: args.margin_mm,
        feed_order: args.feed_order,
        feed_scale: match args.feed_scale {
            ScaleArg::Log => FeedScale::Log,
            ScaleArg::Linear => FeedScale::Linear,
        },
        ..MapParams::default()
    };
    if let Some(o) = &args.orders {
        let n = args.breaks.as_ref().map_or(0, Vec::len) + 1;
        if o.len() != n {
            return Err(bad(format!(
                "--orders has {} values; {n} intervals need {n}",
                o.len()
            )));
        }
    }
    params.validate().map_err(|e| bad(e.to_string()))?;
    Ok(Config {
        params: MapStudyParams {
            map: params,
            positions_mm: args.positions.clone(),
            position_step_mm: args.position_step_mm,
            table_feeds_mm_min: args.table_feeds.clone(),
            extrapolate: args.extrapolate,
            ..MapStudyParams::default()
        },
        export,
    })
}

pub fn run(args: Args) -> Result<()> {
    let cfg = validate(&args)?;
    let axis = feedscope_io::axis::load(&args.axis)?;
    // A position outside the declared travel is wrong whatever the data say.
    if let (Some(lo), Some(hi)) = (axis.travel_min_mm, axis.travel_max_mm) {
        let outside = |flag: &str, xs: &[f64]| match xs.iter().find(|&&x| x < lo || x > hi) {
            Some(x) => Err(BadInput(format!(
                "{flag}: {x} mm is outside the axis travel [{lo}, {hi}] mm"
            ))),
            None => Ok(()),
        };
        outside("--positions", args.positions.as_deref().unwrap_or(&[]))?;
        outside("--export-position-mm", args.export_position_mm.as_slice())?;
    }
    let set = read_index(&args.index).map_err(|e| BadInput(e.to_string()))?;
    let est_params = EstimateParams {
        samples_per_lead: args.samples_per_lead,
        ..EstimateParams::default()
    };
    let pb = bar(set.runs.len() as u64, "estimate");
    let est = estimate_set(
        &set,
        &axis,
        &est_params,
        &ReadOptions::default(),
        cfg.params.map.stroke_feed_tolerance,
        &|_| pb.inc(1),
    );
    pb.finish_and_clear();
    for w in &est.read_warnings {
        eprintln!("warning: run {}: {}", w.run, w.message);
    }
    for f in &est.failed {
        eprintln!("run {} failed: {}", f.run.name, f.error);
    }
    if est.ok.is_empty() {
        return Err(anyhow!(
            "all {} runs of {} failed; nothing to map",
            set.runs.len(),
            set.source_name
        ));
    }
    // Everything is computed before the first file is written: a refusal leaves nothing behind.
    let study = map_study(&est.ok, axis.lead_m(), &cfg.params).map_err(|e| match e {
        StudyError::Position(e) => anyhow::Error::new(e).context("--positions"),
        StudyError::TableFeed(e) => {
            anyhow::Error::new(e).context("--table-feeds, without --extrapolate")
        }
        e => anyhow::Error::new(e).context(set.source_name.clone()),
    })?;
    let (map, at_positions, profiles, spans) = (
        &study.map,
        &study.at_positions,
        &study.profiles,
        &study.nonconventional,
    );
    let exports = match &cfg.export {
        Some(e) => export_files(e, &args, &axis, &study, &cfg.params.map, &set.source_name)?,
        None => Vec::new(),
    };

    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let out = &args.out;
    // All or nothing: the files replace the previous run's together at the end.
    let mut outputs = OutputSet::new();
    outputs.write(
        &out.join("stribeck.json"),
        serde_json::to_string_pretty(&stribeck_report(at_positions, spans))?.as_bytes(),
    )?;
    write_profile_csv(&mut outputs, &out.join("stribeck_profile.csv"), profiles)?;
    write_compensation(&mut outputs, out, &study, args.extrapolate)?;
    write_ppocm_csv(&mut outputs, &out.join("ppocm.csv"), map)?;
    write_repeatability_csv(&mut outputs, &out.join("repeatability.csv"), map)?;
    write_runs_csv(&mut outputs, &out.join("runs.csv"), &est)?;
    let summary = map_summary(&set, &est, map, spans);
    outputs.write(
        &out.join("map.json"),
        serde_json::to_string_pretty(&MapJson {
            summary: &summary,
            map,
        })?
        .as_bytes(),
    )?;
    write_plots(&mut outputs, out, &study, &args)?;
    for f in &exports {
        outputs.write(&out.join(f.name), &f.bytes)?;
    }
    outputs.commit()?;
    for f in &exports {
        eprintln!("wrote {}: {}", out.join(f.name).display(), f.summary);
    }

    print_models(at_positions);
    let stdout = std::io::stdout();
    let mut w = stdout.lock();
    match args.format {
        Format::Json => writeln!(w, "{}", serde_json::to_string_pretty(&summary)?)?,
        Format::Text => w.write_all(text_report(&summary, at_positions, spans).as_bytes())?,
    }
    w.flush()?;
    if args.strict && !est.failed.is_empty() {
        return Err(anyhow!(
            "{} of {} runs failed (--strict)",
            est.failed.len(),
            set.runs.len()
        ));
    }
    Ok(())
}

/// The `--export` files of the map at `--export-position-mm` (default: the middle of the span
/// both directions share): per direction the Stribeck fit there (Eq. 9, also what the
/// SINUMERIK values need) and, with `--export-curve map`, the map's section for the tables.
fn export_files(
    cfg: &ExportConfig,
    args: &Args,
    axis: &feedscope::axis::AxisParams,
    study: &MapStudy,
    params: &MapParams,
    index: &str,
) -> Result<Vec<ExportFile>> {
    let dirs = &study.map.directions;
    let lo = dirs
        .iter()
        .map(|d| d.start_mm)
        .fold(f64::NEG_INFINITY, f64::max);
    let hi = dirs.iter().map(|d| d.end_mm).fold(f64::INFINITY, f64::min);
    let z = match args.export_position_mm {
        Some(z) => z,
        None if hi >= lo => 0.5 * (lo + hi),
        None => {
            return Err(BadInput(format!(
                "--export: the directions' mapped spans do not overlap ({}); give \
                 --export-position-mm",
                dirs.iter()
                    .map(|d| format!(
                        "{} {:.3}-{:.3} mm",
                        dir_name(d.direction),
                        d.start_mm,
                        d.end_mm
                    ))
                    .collect::<Vec<_>>()
                    .join(", ")
            ))
            .into())
        }
    };
    let mut table = Vec::new();
    let mut stribeck = Vec::new();
    for d in dirs {
        let profile = stribeck_profile(d, &[z], params).context("--export-position-mm")?;
        let at = &profile.positions[0];
        let fit = at.fit.as_ref().ok_or_else(|| {
            BadInput(format!(
                "--export: the {} Stribeck fit at {z:.3} mm failed: {}",
                dir_name(d.direction),
                at.error.clone().unwrap_or_default()
            ))
        })?;
        let s = FrictionCurve::from_stribeck(d.direction, fit)
            .with_context(|| format!("--export: the {} fit at {z:.3} mm", dir_name(d.direction)))?;
        table.push(match args.export_curve {
            ExportCurveArg::Stribeck => s.clone(),
            ExportCurveArg::Map => {
                FrictionCurve::from_map_section(d, z).context("--export-position-mm")?
            }
        });
        stribeck.push(s);
    }
    let drive = DriveConversion::from_axis(axis, 1.0).context("--export: the axis file")?;
    let source = format!(
        "feedscope map {index} at {z:.3} mm, {}",
        match args.export_curve {
            ExportCurveArg::Stribeck => "Stribeck fit at the position",
            ExportCurveArg::Map => "map section at the position",
        }
    );
    super::export::build(
        cfg,
        &ExportCurves {
            table: &table,
            stribeck: &stribeck,
        },
        axis,
        drive,
        &feedscope_io::controller_compensation::ExportSource {
            source: &source,
            axis_name: axis.name.as_deref(),
        },
    )
}

/// On stderr, per direction: the model at the chosen positions (once when it is the same
/// everywhere), the refused models with their reasons and what to do, and every warning.
fn print_models(at: &[StribeckProfile]) {
    for p in at {
        let dir = dir_name(p.direction);
        let key = |q: &StribeckAtPosition| {
            q.fit.as_ref().map(|f| {
                let reasons: Vec<String> = f.reductions.iter().map(|r| r.to_string()).collect();
                (f.model, reasons)
            })
        };
        let first = p.positions.first().and_then(key);
        let same = p.positions.iter().all(|q| key(q) == first);
        let describe = |where_: &str, model: FrictionModel, reductions: &[Reduction]| {
            eprintln!("{dir}{where_}: model {model}");
            for r in reductions {
                eprintln!("  {r}");
            }
            if let Some(r) = reductions.last() {
                eprintln!("  {}", super::fit_stribeck::advice(r.code(), false));
            }
        };
        match (&first, same) {
            (Some(_), true) => {
                let f = p.positions[0].fit.as_ref().expect("a fit");
                describe(" (every position)", f.model, &f.reductions);
            }
            _ => {
                for q in &p.positions {
                    if let Some(f) = &q.fit {
                        describe(
                            &format!(" at {:.3} mm", q.position_mm),
                            f.model,
                            &f.reductions,
                        );
                    }
                }
            }
        }
        for q in &p.positions {
            for w in q.fit.iter().flat_map(|f| &f.warnings) {
                eprintln!("warning: {dir} at {:.3} mm: {w}", q.position_mm);
            }
        }
    }
}

fn dir_name(d: Direction) -> &'static str {
    match d {
        Direction::Forward => "forward",
        Direction::Backward => "backward",
    }
}

// ---------- stribeck.json ----------

#[derive(Serialize)]
struct Est {
    value: f64,
    std_error: Option<f64>,
    ci95_low: Option<f64>,
    ci95_high: Option<f64>,
}

fn est(value: f64, u: Option<&ParamEstimate>, scale: f64) -> Est {
    Est {
        value: value * scale,
        std_error: u.map(|u| u.std_error * scale),
        ci95_low: u.map(|u| u.ci95_low * scale),
        ci95_high: u.map(|u| u.ci95_high * scale),
    }
}

#[derive(Serialize)]
struct Fall {
    from_mm_min: f64,
    to_mm_min: f64,
    drop_n: f64,
    excess_drop_n: f64,
}

/// A warning or a refused model in the JSON: a stable code and the text printed on stderr.
#[derive(Serialize)]
struct Note {
    code: &'static str,
    message: String,
}

fn warning_note(w: &FitWarning) -> Note {
    Note {
        code: w.code(),
        message: w.to_string(),
    }
}

fn reduction_note(r: &Reduction) -> Note {
    Note {
        code: r.code(),
        message: r.to_string(),
    }
}

#[derive(Serialize)]
struct PositionFit {
    position_mm: f64,
    /// `stribeck`, `coulomb-viscous` or `coulomb`; `null` when the fit failed.
    model: Option<&'static str>,
    /// Richer models refused, in the order tried, and why.
    reductions: Vec<Note>,
    fc_n: Option<Est>,
    fs_n: Option<Est>,
    static_excess_n: Option<Est>,
    vs_mm_min: Option<Est>,
    sigma_n_s_per_m: Option<Est>,
    residual_rms_n: Option<f64>,
    friction_n: Vec<f64>,
    warnings: Vec<Note>,
    nonconventional: Vec<Fall>,
    error: Option<String>,
}

fn position_fit(p: &StribeckAtPosition) -> PositionFit {
    let f = p.fit.as_ref();
    let u = f.and_then(|f| f.uncertainty.as_ref());
    let mm = 1.0 / M_S_PER_MM_MIN;
    // Parameters the reported model does not have are null.
    let hump = f.filter(|f| f.model == FrictionModel::Stribeck);
    let viscous = f.filter(|f| f.model != FrictionModel::Coulomb);
    PositionFit {
        position_mm: p.position_mm,
        model: f.map(|f| f.model.code()),
        reductions: f
            .map(|f| f.reductions.iter().map(reduction_note).collect())
            .unwrap_or_default(),
        fc_n: f.map(|f| est(f.params.fc_n, u.map(|u| &u.fc_n), 1.0)),
        fs_n: hump.map(|f| est(f.params.fs_n, u.and_then(|u| u.fs_n.as_ref()), 1.0)),
        static_excess_n: hump.map(|f| {
            est(
                f.params.static_excess_n(),
                u.and_then(|u| u.static_excess_n.as_ref()),
                1.0,
            )
        }),
        vs_mm_min: hump.map(|f| est(f.params.vs_m_s, u.and_then(|u| u.vs_m_s.as_ref()), mm)),
        sigma_n_s_per_m: viscous.map(|f| {
            est(
                f.params.sigma_n_s_per_m,
                u.and_then(|u| u.sigma_n_s_per_m.as_ref()),
                1.0,
            )
        }),
        residual_rms_n: f.map(|f| f.residual_rms_n),
        friction_n: p.friction_n.clone(),
        warnings: f
            .map(|f| f.warnings.iter().map(warning_note).collect())
            .unwrap_or_default(),
        nonconventional: p
            .nonconventional
            .iter()
            .flat_map(|n| &n.ranges)
            .map(|r| Fall {
                from_mm_min: r.from_mm_min(),
                to_mm_min: r.to_mm_min(),
                drop_n: r.drop_n,
                excess_drop_n: r.excess_drop_n,
            })
            .collect(),
        error: p.error.clone(),
    }
}

#[derive(Serialize)]
struct DirectionStribeck {
    direction: Direction,
    feeds_mm_min: Vec<f64>,
    positions: Vec<PositionFit>,
}

#[derive(Serialize)]
struct StribeckReport<'a> {
    model: &'static str,
    conventions: &'static str,
    directions: Vec<DirectionStribeck>,
    nonconventional_spans: &'a [NonConventionalSpan],
}

fn stribeck_report<'a>(
    at: &[StribeckProfile],
    spans: &'a [NonConventionalSpan],
) -> StribeckReport<'a> {
    StribeckReport {
        model: "F(v) = Fc + (Fs - Fc)*exp(-(v/vs)^2) + sigma*v on friction magnitudes (paper 000 Eq. 9); \
                where the feeds do not determine it, the Coulomb + viscous line F = Fc + sigma*v \
                (positions[].model, the reasons in positions[].reductions)",
        conventions: "data points: |PPOCM(z)| of every measured feed at the position; forces in N, \
                      feeds and vs in mm/min, sigma in N*s/m; std_error and 95 % intervals null \
                      when the fit has no residual degrees of freedom; parameters the reported \
                      model does not have are null",
        directions: at
            .iter()
            .map(|p| DirectionStribeck {
                direction: p.direction,
                feeds_mm_min: p.feeds_mm_min.clone(),
                positions: p.positions.iter().map(position_fit).collect(),
            })
            .collect(),
        nonconventional_spans: spans,
    }
}

// ---------- CSV tables ----------

fn csv_file(path: &Path) -> Result<AtomicFile> {
    AtomicFile::create(path)
}

fn opt(x: Option<f64>) -> String {
    x.map_or_else(String::new, |v| format!("{v:.6}"))
}

fn write_profile_csv(set: &mut OutputSet, path: &Path, profiles: &[StribeckProfile]) -> Result<()> {
    let mut f = csv_file(path)?;
    let w = f.writer();
    writeln!(w, "# Stribeck fit (paper 000 Eq. 9, delta = 2) at every map grid position; forces in N, vs in mm/min, sigma in N*s/m; *_se = standard error")?;
    writeln!(w, "# model: stribeck, or coulomb-viscous (F = Fc + sigma*v; fs, vs empty) where the feeds do not determine a Stribeck curve (reasons in stribeck.json)")?;
    writeln!(w, "direction,position_mm,model,fc_n,fc_se_n,fs_n,fs_se_n,static_excess_n,static_excess_se_n,vs_mm_min,vs_ci95_low_mm_min,vs_ci95_high_mm_min,sigma_n_s_per_m,sigma_se_n_s_per_m,residual_rms_n,nonconventional,warnings")?;
    let mm = 1.0 / M_S_PER_MM_MIN;
    for p in profiles {
        for q in &p.positions {
            let Some(fit) = &q.fit else {
                writeln!(
                    w,
                    "{},{:.6},,,,,,,,,,,,,,,fit failed: {}",
                    dir_name(p.direction),
                    q.position_mm,
                    q.error.clone().unwrap_or_default().replace(',', ";")
                )?;
                continue;
            };
            let u = fit.uncertainty.as_ref();
            let nc = q.nonconventional.as_ref().map_or(0, |n| n.ranges.len());
            let warn: Vec<String> = fit
                .warnings
                .iter()
                .map(|w| w.to_string().replace(',', ";"))
                .collect();
            let hump = fit.model == FrictionModel::Stribeck;
            writeln!(
                w,
                "{},{:.6},{},{:.6},{},{},{},{},{},{},{},{},{},{},{:.6},{},{}",
                dir_name(p.direction),
                q.position_mm,
                fit.model.code(),
                fit.params.fc_n,
                opt(u.map(|u| u.fc_n.std_error)),
                opt(fit.fs_n()),
                opt(u.and_then(|u| u.fs_n).map(|e| e.std_error)),
                opt(hump.then(|| fit.params.static_excess_n())),
                opt(u.and_then(|u| u.static_excess_n).map(|e| e.std_error)),
                opt(fit.vs_m_s().map(|v| v * mm)),
                opt(u.and_then(|u| u.vs_m_s).map(|e| e.ci95_low * mm)),
                opt(u.and_then(|u| u.vs_m_s).map(|e| e.ci95_high * mm)),
                opt(fit.sigma_n_s_per_m()),
                opt(u.and_then(|u| u.sigma_n_s_per_m).map(|e| e.std_error)),
                fit.residual_rms_n,
                nc,
                warn.join(" | ")
            )?;
        }
    }
    set.add(f)
}

fn write_compensation(
    set: &mut OutputSet,
    out: &Path,
    study: &MapStudy,
    extrapolate: bool,
) -> Result<()> {
    let map = &study.map;
    let table = CompensationTable::new(map, extrapolate, |d| {
        let (grid, feeds) = study
            .table_axes(d.direction)
            .expect("a direction of the study's map");
        (feeds.to_vec(), grid.to_vec())
    })?;
    let mut long = csv_file(&out.join("compensation.csv"))?;
    table.write_long(long.writer())?;
    for d in &map.directions {
        let mut wide = csv_file(&out.join(format!("compensation_{}.csv", dir_name(d.direction))))?;
        table.write_matrix(wide.writer(), d.direction)?;
        set.add(wide)?;
    }
    set.add(long)
}

fn write_ppocm_csv(set: &mut OutputSet, path: &Path, map: &FrictionMap) -> Result<()> {
    let mut f = csv_file(path)?;
    let w = f.writer();
    writeln!(w, "# PPOCM: mean Legendre coefficients (N) of the repeats' IAFV per feed; in interval [start_mm, end_mm], F = sum_k coefficient_n * P_k(t), t = 2*(z - start_mm)/(end_mm - start_mm) - 1")?;
    writeln!(
        w,
        "direction,feed_mm_min,repeats,interval,start_mm,end_mm,k,coefficient_n"
    )?;
    for d in &map.directions {
        for g in &d.feeds {
            for (j, c) in g.ppocm.coeffs_n.iter().enumerate() {
                for (k, v) in c.iter().enumerate() {
                    writeln!(
                        w,
                        "{},{:.6},{},{},{:.6},{:.6},{},{:.9}",
                        dir_name(d.direction),
                        g.feed_mm_min,
                        g.repeats.len(),
                        j + 1,
                        d.breaks_mm[j],
                        d.breaks_mm[j + 1],
                        k,
                        v
                    )?;
                }
            }
        }
    }
    set.add(f)
}

fn write_repeatability_csv(set: &mut OutputSet, path: &Path, map: &FrictionMap) -> Result<()> {
    let mut f = csv_file(path)?;
    let w = f.writer();
    writeln!(w, "# repeatability per interval: std_n = RMS over the interval of the pointwise sample std of the repeats' IAFV (N); max_spread_n = largest pointwise max - min (N); mean_n = mean of the PPOCM (N, signed)")?;
    writeln!(
        w,
        "direction,feed_mm_min,repeats,interval,start_mm,end_mm,mean_n,std_n,max_spread_n"
    )?;
    for d in &map.directions {
        for g in &d.feeds {
            for (j, r) in g.repeatability.iter().enumerate() {
                writeln!(
                    w,
                    "{},{:.6},{},{},{:.6},{:.6},{:.6},{},{:.6}",
                    dir_name(d.direction),
                    g.feed_mm_min,
                    g.repeats.len(),
                    j + 1,
                    r.start_mm,
                    r.end_mm,
                    r.mean_n,
                    opt(r.std_n),
                    r.max_spread_n
                )?;
            }
        }
    }
    set.add(f)
}

fn write_runs_csv(
    set: &mut OutputSet,
    path: &Path,
    est: &feedscope::map::SetEstimate,
) -> Result<()> {
    let mut f = csv_file(path)?;
    let w = f.writer();
    writeln!(w, "file,feed_mm_min,repeat,status,strokes,message")?;
    let clean = |s: &str| s.replace([',', '\n'], ";");
    for r in &est.ok {
        writeln!(
            w,
            "{},{},{},ok,{},{}",
            r.run.name,
            r.run.feed_mm_min,
            r.run.repeat,
            r.strokes.len(),
            clean(&r.warnings.join(" | "))
        )?;
    }
    for r in &est.failed {
        writeln!(
            w,
            "{},{},{},failed,0,{}",
            r.run.name,
            r.run.feed_mm_min,
            r.run.repeat,
            clean(&r.error)
        )?;
    }
    set.add(f)
}

// ---------- summary ----------

#[derive(Serialize)]
struct DirSummary {
    direction: Direction,
    start_mm: f64,
    end_mm: f64,
    breaks_mm: Vec<f64>,
    orders: Vec<usize>,
    feeds_mm_min: Vec<f64>,
    repeats: Vec<usize>,
    feed_order: usize,
    feed_scale: FeedScale,
    feed_misfit_rms_n: f64,
    feed_misfit_max_n: f64,
    worst_repeatability_std_n: Option<f64>,
}

#[derive(Serialize)]
struct Summary {
    index: String,
    runs: usize,
    runs_ok: usize,
    failed: Vec<FailedRun>,
    directions: Vec<DirSummary>,
    nonconventional_spans: usize,
}

#[derive(Serialize)]
struct FailedRun {
    file: String,
    error: String,
}

#[derive(Serialize)]
struct MapJson<'a> {
    summary: &'a Summary,
    map: &'a FrictionMap,
}

fn map_summary(
    set: &TestSet,
    est: &feedscope::map::SetEstimate,
    map: &FrictionMap,
    spans: &[NonConventionalSpan],
) -> Summary {
    Summary {
        index: set.source_name.clone(),
        runs: set.runs.len(),
        runs_ok: est.ok.len(),
        failed: est
            .failed
            .iter()
            .map(|f| FailedRun {
                file: f.run.name.clone(),
                error: f.error.clone(),
            })
            .collect(),
        directions: map
            .directions
            .iter()
            .map(|d| DirSummary {
                direction: d.direction,
                start_mm: d.start_mm,
                end_mm: d.end_mm,
                breaks_mm: d.breaks_mm.clone(),
                orders: d.orders.clone(),
                feeds_mm_min: d.feeds_mm_min(),
                repeats: d.feeds.iter().map(|g| g.repeats.len()).collect(),
                feed_order: d.feed_model.order,
                feed_scale: d.feed_model.scale,
                feed_misfit_rms_n: d.feed_model.rms_misfit_n,
                feed_misfit_max_n: d.feed_model.max_misfit_n,
                worst_repeatability_std_n: d
                    .feeds
                    .iter()
                    .flat_map(|g| g.repeatability.iter().filter_map(|r| r.std_n))
                    .reduce(f64::max),
            })
            .collect(),
        nonconventional_spans: spans.len(),
    }
}

fn text_report(s: &Summary, at: &[StribeckProfile], spans: &[NonConventionalSpan]) -> String {
    let mut o = String::new();
    let _ = writeln!(o, "{}: {} of {} runs mapped", s.index, s.runs_ok, s.runs);
    for f in &s.failed {
        let _ = writeln!(o, "  failed: {} ({})", f.file, f.error);
    }
    for d in &s.directions {
        let _ = writeln!(
            o,
            "{:?}: {:.3}-{:.3} mm, {} intervals, {} feeds {:.4}-{:.4} mm/min, feed polynomial order {} (misfit RMS {:.3} N, max {:.3} N), worst repeatability std {}",
            d.direction,
            d.start_mm,
            d.end_mm,
            d.orders.len(),
            d.feeds_mm_min.len(),
            d.feeds_mm_min.first().copied().unwrap_or(f64::NAN),
            d.feeds_mm_min.last().copied().unwrap_or(f64::NAN),
            d.feed_order,
            d.feed_misfit_rms_n,
            d.feed_misfit_max_n,
            d.worst_repeatability_std_n
                .map_or("n/a (one repeat)".to_string(), |v| format!("{v:.3} N"))
        );
    }
    let _ = writeln!(
        o,
        "Stribeck fits (Eq. 9; coulomb-viscous where the feeds do not determine one, see stderr):"
    );
    let _ = writeln!(
        o,
        "  direction  position_mm  model                 Fc_N    Fs-Fc_N   vs_mm_min   sigma_Ns/m  rms_N  warnings"
    );
    let cell = |x: Option<f64>, w: usize, prec: usize| {
        x.map_or_else(|| format!("{:>w$}", "-"), |v| format!("{v:w$.prec$}"))
    };
    for p in at {
        for q in &p.positions {
            match &q.fit {
                Some(f) => {
                    let hump = f.model == FrictionModel::Stribeck;
                    let _ = writeln!(
                        o,
                        "  {:9}  {:11.3}  {:15}  {:9.2}  {}  {}  {}  {:5.2}  {}",
                        dir_name(p.direction),
                        q.position_mm,
                        f.model.code(),
                        f.params.fc_n,
                        cell(hump.then(|| f.params.static_excess_n()), 9, 2),
                        cell(f.vs_m_s().map(|v| v / M_S_PER_MM_MIN), 10, 2),
                        cell(f.sigma_n_s_per_m(), 11, 1),
                        f.residual_rms_n,
                        f.warnings.len()
                    );
                }
                None => {
                    let _ = writeln!(
                        o,
                        "  {:9}  {:11.3}  fit failed: {}",
                        dir_name(p.direction),
                        q.position_mm,
                        q.error.clone().unwrap_or_default()
                    );
                }
            }
        }
    }
    if spans.is_empty() {
        let _ = writeln!(
            o,
            "no non-conventional behaviour (friction falling with feed where Stribeck rises)"
        );
    }
    for s in spans {
        let _ = writeln!(
            o,
            "non-conventional {}: positions {:.3}-{:.3} mm, friction falls between {:.3} and {:.3} mm/min (excess drop up to {:.2} N)",
            dir_name(s.direction),
            s.from_position_mm,
            s.to_position_mm,
            s.from_feed_mm_min,
            s.to_feed_mm_min,
            s.max_excess_drop_n
        );
    }
    o
}

// ---------- plots ----------

fn log_feeds(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| lo * (hi / lo).powf(i as f64 / (n - 1) as f64))
        .collect()
}

fn write_plots(set: &mut OutputSet, out: &Path, study: &MapStudy, args: &Args) -> Result<()> {
    let (map, at) = (&study.map, &study.at_positions);
    // Friction vs feed at the chosen positions: PPOCM points, Stribeck fit, map section (Fig. 14).
    let mut titles = Vec::new();
    for p in at {
        for q in &p.positions {
            titles.push(format!(
                "{} at {:.3} mm: friction vs feed",
                dir_name(p.direction),
                q.position_mm
            ));
        }
    }
    let mut charts = Vec::new();
    let mut t = titles.iter();
    for p in at {
        let d = map.direction(p.direction).expect("direction");
        let fine = log_feeds(
            d.feed_model.feed_min_mm_min,
            d.feed_model.feed_max_mm_min,
            120,
        );
        for q in &p.positions {
            let mut series = vec![Series {
                name: "PPOCM at the measured feeds (joined)".into(),
                points: p
                    .feeds_mm_min
                    .iter()
                    .map(|f| f.log10())
                    .zip(q.friction_n.iter().copied())
                    .collect(),
                // Joined: the chart draws points as 1 px dots, invisible for a few feeds.
                style: Style::Dashed,
            }];
            if let Some(f) = &q.fit {
                series.push(Series {
                    name: match f.model {
                        FrictionModel::Stribeck => "Stribeck fit (Eq. 9)".into(),
                        m => format!("{m} fit"),
                    },
                    points: fine
                        .iter()
                        .map(|&x| (x.log10(), f.magnitude_n(x * M_S_PER_MM_MIN)))
                        .collect(),
                    style: Style::Line,
                });
            }
            series.push(Series {
                name: "map section (Eq. 8)".into(),
                points: fine
                    .iter()
                    .filter_map(|&x| {
                        d.friction_n(q.position_mm, x, false)
                            .ok()
                            .map(|v| (x.log10(), v.abs()))
                    })
                    .collect(),
                style: Style::Line,
            });
            charts.push(LineChart {
                title: t.next().expect("title"),
                // Feeds are log-spaced and the chart axes linear: plot log10 of the feed.
                x_label: "log10 of feed (feed in mm/min)",
                y_label: "friction magnitude (N)",
                series,
            });
        }
    }
    set.write(
        &out.join("friction_vs_feed.svg"),
        plot::stacked_svg(&charts)?.as_bytes(),
    )?;

    for (d, zs) in map.directions.iter().zip(&study.grids_mm) {
        let feeds = log_feeds(
            d.feed_model.feed_min_mm_min,
            d.feed_model
                .feed_max_mm_min
                .max(d.feed_model.feed_min_mm_min * 1.0001),
            40,
        );
        // Two feeds at least (the study refuses one), so the log-spaced feeds lie inside the
        // measured ones; an error here is a bug, reported rather than a panic.
        let z: Vec<Vec<f64>> = feeds
            .iter()
            .map(|&f| {
                let p = d.poly_at(f, false)?;
                Ok(zs.iter().map(|&x| p.value_n(x * 1e-3)).collect())
            })
            .collect::<Result<_>>()?;
        let title = format!("friction map F(z, v), {} (signed)", dir_name(d.direction));
        set.write(
            &out.join(format!("map_{}.svg", dir_name(d.direction))),
            plot::heatmap_svg(&Heatmap {
                title: &title,
                x_label: "position (mm)",
                y_label: "log10 of feed (feed in mm/min)",
                z_label: "friction (N)",
                x: zs.clone(),
                y: feeds.iter().map(|f| f.log10()).collect(),
                z,
            })?
            .as_bytes(),
        )?;
    }

    // Repeats and their mean at one feed (Fig. 11); mean curves of several feeds (Fig. 12).
    let mut t11 = Vec::new();
    let mut t12 = Vec::new();
    for d in &map.directions {
        let target = args.plot_feed.unwrap_or(d.feeds[0].feed_mm_min);
        let g = d
            .feeds
            .iter()
            .min_by(|a, b| {
                (a.feed_mm_min - target)
                    .abs()
                    .total_cmp(&(b.feed_mm_min - target).abs())
            })
            .expect("a feed group");
        t11.push(format!(
            "{} at {} mm/min: IAFV of the repeats and their PPOCM",
            dir_name(d.direction),
            g.feed_mm_min
        ));
        t12.push(format!(
            "{}: mean friction (PPOCM) along the travel per feed",
            dir_name(d.direction)
        ));
    }
    let mut c11 = Vec::new();
    let mut c12 = Vec::new();
    for (k, d) in map.directions.iter().enumerate() {
        let zs = map_grid(d, (d.end_mm - d.start_mm) / 200.0);
        let curve = |p: &feedscope::profile::PiecewisePoly| -> Vec<(f64, f64)> {
            zs.iter().map(|&x| (x, p.value_n(x * 1e-3))).collect()
        };
        let target = args.plot_feed.unwrap_or(d.feeds[0].feed_mm_min);
        let g = d
            .feeds
            .iter()
            .min_by(|a, b| {
                (a.feed_mm_min - target)
                    .abs()
                    .total_cmp(&(b.feed_mm_min - target).abs())
            })
            .expect("a feed group");
        let mut s: Vec<Series> = g
            .repeats
            .iter()
            .map(|r| Series {
                name: format!("{} (repeat {})", r.run, r.repeat),
                points: curve(&r.poly),
                style: Style::Line,
            })
            .collect();
        s.push(Series {
            name: "PPOCM (mean)".into(),
            points: curve(&g.ppocm),
            style: Style::Dashed,
        });
        c11.push(LineChart {
            title: &t11[k],
            x_label: "position (mm)",
            y_label: "friction (N)",
            series: s,
        });
        let n = d.feeds.len();
        let pick: Vec<usize> = if n <= 8 {
            (0..n).collect()
        } else {
            (0..8).map(|i| (i * (n - 1) + 3) / 7).collect()
        };
        c12.push(LineChart {
            title: &t12[k],
            x_label: "position (mm)",
            y_label: "friction (N)",
            series: pick
                .iter()
                .map(|&i| Series {
                    name: format!("{} mm/min", d.feeds[i].feed_mm_min),
                    points: curve(&d.feeds[i].ppocm),
                    style: Style::Line,
                })
                .collect(),
        });
    }
    set.write(
        &out.join("iafv_repeats.svg"),
        plot::stacked_svg(&c11)?.as_bytes(),
    )?;
    set.write(&out.join("mvoiaf.svg"), plot::stacked_svg(&c12)?.as_bytes())?;
    Ok(())
}
