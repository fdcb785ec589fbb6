//! `feedscope map`: friction over position and feed from a test set (issue 4).
use std::fmt::Write as _;
use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{anyhow, Context, Result};
use clap::ValueEnum;
use feedscope::estimate::Direction;
use feedscope::map::{FeedScale, NonConventionalSpan, StribeckAtPosition, StribeckProfile};
use feedscope::stribeck::{FrictionModel, Reduction, M_S_PER_MM_MIN};
use feedscope::study::{map_grid, MapStudy};
use feedscope_app::map::{ExportCurve, MapOptions, MapRequest, MapSummary};

use super::estimate::Format;
use super::export::{ExportArgs, ExportCurves};
use crate::front::Cli;
use crate::output::OutputSet;
use feedscope_app::plot::{self, Heatmap, LineChart, Series, Style};
use feedscope_app::AppError;

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
    let export = args.export.validate()?;
    if export.is_none() {
        if args.export_position_mm.is_some() {
            return Err(
                AppError::bad_input("--export-position-mm is used only with --export").into(),
            );
        }
        if args.export_curve != ExportCurveArg::Stribeck {
            return Err(AppError::bad_input("--export-curve is used only with --export").into());
        }
    }
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
    };
    let front = Cli::default();
    let mapped = request.run(&front)?;
    let est = &mapped.estimate;
    // Everything is computed before the first file is written: a refusal leaves nothing behind.
    let exports = match &export {
        Some(cfg) => {
            let at = mapped.export_at(args.export_position_mm, args.export_curve.into(), &front)?;
            super::export::build(
                cfg,
                &ExportCurves {
                    table: &at.table,
                    stribeck: &at.stribeck,
                },
                &mapped.axis,
                at.drive,
                &feedscope_io::controller_compensation::ExportSource {
                    source: &at.source,
                    axis_name: mapped.axis.name.as_deref(),
                },
            )?
        }
        None => Vec::new(),
    };
    let files = mapped.files()?;

    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let out = &args.out;
    // All or nothing: the files replace the previous run's together at the end.
    let mut outputs = OutputSet::new();
    for (name, text) in &files {
        outputs.write(&out.join(name), text.as_bytes())?;
    }
    write_plots(&mut outputs, out, &mapped.study, &args)?;
    for f in &exports {
        outputs.write(&out.join(f.name), &f.bytes)?;
    }
    outputs.commit()?;
    for f in &exports {
        eprintln!("wrote {}: {}", out.join(f.name).display(), f.summary);
    }

    let (at_positions, spans) = (&mapped.study.at_positions, &mapped.study.nonconventional);
    print_models(at_positions);
    let summary = &mapped.report.summary;
    let stdout = std::io::stdout();
    let mut w = stdout.lock();
    match args.format {
        Format::Json => writeln!(w, "{}", serde_json::to_string_pretty(summary)?)?,
        Format::Text => w.write_all(text_report(summary, at_positions, spans).as_bytes())?,
    }
    w.flush()?;
    if args.strict && !est.failed.is_empty() {
        return Err(anyhow!(
            "{} of {} runs failed (--strict)",
            est.failed.len(),
            summary.runs
        ));
    }
    Ok(())
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

fn text_report(s: &MapSummary, at: &[StribeckProfile], spans: &[NonConventionalSpan]) -> String {
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
