//! `feedscope dynamics`: natural frequencies of the feed drive against feed rate and nut
//! position, bearing unloading and torque-ripple resonance risks.
//!
//! Files written under `--out DIR` (headers are part of the interface, see docs/dynamics.md):
//! `dynamics.json`, `frequency_vs_feed.csv` (`feed_mm_min,mode,frequency_hz`),
//! `frequency_vs_position.csv` (`feed_mm_min,position_mm,mode,frequency_hz`), `resonance.csv`
//! (`harmonic,feed_mm_min,frequency_hz,mode,margin_hz,order,feed_low_mm_min,feed_high_mm_min`),
//! `frequency_vs_feed.svg`, `frequency_vs_position.svg`.
//!
//! Exit codes (mapped in `cmd::run`): 0 ok; 2 bad input: an unreadable or invalid drive file,
//! reported as [`AppError::bad_input`] naming the key; 1 anything else (e.g. the output directory cannot
//! be written). The drive file is validated before any output is written.

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use feedscope::dynamics::{analyse, ripple_frequency_hz, DriveConfig, DriveModel, DynamicsReport};
use serde::Serialize;

use crate::output::write_atomic;
use feedscope_app::plot::{line_chart_svg, write_svg, LineChart, Series, Style};
use feedscope_app::AppError;

/// Output format of the summary on stdout.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    /// A few human-readable lines.
    Text,
    /// One JSON object.
    Json,
}

/// Natural frequency of the ball-screw feed system vs feed rate and table position, and
/// where the motor's torque ripple makes it resonate.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Drive file (TOML, units in the keys); see examples/drive.toml and docs/dynamics.md.
    #[arg(long, value_name = "FILE")]
    pub config: PathBuf,
    /// Directory for the JSON, CSV and SVG outputs (created if missing).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Summary format on stdout.
    #[arg(long, value_enum, default_value_t = Format::Text)]
    pub format: Format,
}

/// Read and validate the drive file before any output is written.
fn load(path: &Path) -> Result<DriveModel> {
    let text = feedscope_io::bounded::read_to_string(path, feedscope_io::bounded::MAX_CONFIG_BYTES)
        .map_err(|e| {
            AppError::bad_input(format!("cannot read drive file {}: {e}", path.display()))
        })?;
    let cfg = DriveConfig::from_toml_str(&text, &path.display().to_string())
        .map_err(|e| AppError::bad_input(format!("invalid drive file {}: {e}", path.display())))?;
    DriveModel::from_config(&cfg).map_err(|e| {
        AppError::bad_input(format!("invalid drive file {}: {e}", path.display())).into()
    })
}

/// Run the subcommand.
pub fn run(args: Args) -> Result<()> {
    let model = load(&args.config)?;
    let report = analyse(&model).context("modal analysis failed")?;

    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create output directory {}", args.out.display()))?;
    let files = write_outputs(&args.out, &report)?;
    for f in &files {
        eprintln!("wrote {}", f.display());
    }

    let summary = summary_text(&report);
    let text = match args.format {
        Format::Text => summary,
        Format::Json => {
            let mut s = serde_json::to_string_pretty(&Summary::from(&report))?;
            s.push('\n');
            s
        }
    };
    let mut stdout = std::io::stdout().lock();
    match stdout
        .write_all(text.as_bytes())
        .and_then(|()| stdout.flush())
    {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        other => other.context("cannot write to stdout"),
    }
}

/// The headline numbers, for `--format json`.
#[derive(Debug, Serialize)]
struct Summary<'a> {
    name: Option<&'a str>,
    position_mm: f64,
    static_first_hz: f64,
    breakaway_first_hz: f64,
    peak_first_hz: f64,
    peak_feed_mm_min: f64,
    bearing_unload: Option<&'a feedscope::dynamics::UnloadEvent>,
    resonances: &'a [feedscope::dynamics::Resonance],
}

impl<'a> From<&'a DynamicsReport> for Summary<'a> {
    fn from(r: &'a DynamicsReport) -> Self {
        Self {
            name: r.name.as_deref(),
            position_mm: r.position_mm,
            static_first_hz: r.static_first_hz,
            breakaway_first_hz: r.breakaway_first_hz,
            peak_first_hz: r.peak_first_hz,
            peak_feed_mm_min: r.peak_feed_mm_min,
            bearing_unload: r.bearing_unload.as_ref(),
            resonances: &r.resonances,
        }
    }
}

fn summary_text(r: &DynamicsReport) -> String {
    let mut s = String::new();
    let name = r.name.as_deref().unwrap_or("feed drive");
    let _ = writeln!(s, "dynamics of {name} (nut at {:.0} mm)", r.position_mm);
    let _ = writeln!(
        s,
        "  static first frequency     {:8.2} Hz",
        r.static_first_hz
    );
    let _ = writeln!(
        s,
        "  after breakaway (v = 0+)   {:8.2} Hz",
        r.breakaway_first_hz
    );
    let _ = writeln!(
        s,
        "  peak                       {:8.2} Hz at {:.2} m/min",
        r.peak_first_hz,
        r.peak_feed_mm_min / 1000.0
    );
    match &r.bearing_unload {
        Some(u) => {
            let _ = writeln!(
                s,
                "  {} bearing unloads at      {:8.2} m/min (first frequency {:.2} -> {:.2} Hz)",
                u.bearing,
                u.feed_mm_min / 1000.0,
                u.first_before_hz,
                u.first_after_hz
            );
        }
        None => {
            let _ = writeln!(s, "  no bearing unloads below 6000 m/min");
        }
    }
    if r.resonances.is_empty() {
        let _ = writeln!(
            s,
            "  no ripple harmonic meets a natural frequency in the sweep"
        );
    } else {
        let _ = writeln!(
            s,
            "  resonance risks (|f_T - f_n| <= {} Hz, pole pairs {}):",
            r.ripple.margin_hz, r.ripple.pole_pairs
        );
        for x in &r.resonances {
            let _ = writeln!(
                s,
                "    N_P = {} (order {}) meets mode {} at {:.2} m/min, {:.1} Hz (band {:.2}..{:.2} m/min)",
                x.harmonic,
                x.order,
                x.mode,
                x.feed_mm_min / 1000.0,
                x.frequency_hz,
                x.feed_low_mm_min / 1000.0,
                x.feed_high_mm_min / 1000.0
            );
        }
    }
    s
}

fn write_file(path: &Path, text: &str) -> Result<()> {
    Ok(write_atomic(path, text.as_bytes())?)
}

fn write_outputs(dir: &Path, r: &DynamicsReport) -> Result<Vec<PathBuf>> {
    let mut files = Vec::new();

    let path = dir.join("dynamics.json");
    let mut json = serde_json::to_string_pretty(r)?;
    json.push('\n');
    write_file(&path, &json)?;
    files.push(path);

    let mut csv = String::from("feed_mm_min,mode,frequency_hz\n");
    for p in &r.feed_sweep.points {
        for (m, f) in p.frequencies_hz.iter().enumerate() {
            let _ = writeln!(csv, "{},{},{}", p.feed_mm_min, m + 1, f);
        }
    }
    let path = dir.join("frequency_vs_feed.csv");
    write_file(&path, &csv)?;
    files.push(path);

    let mut csv = String::from("feed_mm_min,position_mm,mode,frequency_hz\n");
    for sweep in &r.position_sweeps {
        for p in &sweep.points {
            for (m, f) in p.frequencies_hz.iter().enumerate() {
                let _ = writeln!(
                    csv,
                    "{},{},{},{}",
                    sweep.feed_mm_min,
                    p.position_mm,
                    m + 1,
                    f
                );
            }
        }
    }
    let path = dir.join("frequency_vs_position.csv");
    write_file(&path, &csv)?;
    files.push(path);

    let mut csv = String::from(
        "harmonic,feed_mm_min,frequency_hz,mode,margin_hz,order,feed_low_mm_min,feed_high_mm_min\n",
    );
    for x in &r.resonances {
        let _ = writeln!(
            csv,
            "{},{},{},{},{},{},{},{}",
            x.harmonic,
            x.feed_mm_min,
            x.frequency_hz,
            x.mode,
            x.margin_hz,
            x.order,
            x.feed_low_mm_min,
            x.feed_high_mm_min
        );
    }
    let path = dir.join("resonance.csv");
    write_file(&path, &csv)?;
    files.push(path);

    let path = dir.join("frequency_vs_feed.svg");
    write_svg(&path, &line_chart_svg(&feed_chart(r))?)?;
    files.push(path);

    let path = dir.join("frequency_vs_position.svg");
    write_svg(&path, &line_chart_svg(&position_chart(r))?)?;
    files.push(path);

    Ok(files)
}

/// The paper's Fig. 7: the first (transmission) mode against feed rate with the ripple lines
/// f_T = N_P·P_n·v/(60·p), each drawn only inside the band of the first mode (±15 %) so the
/// curve stays readable; higher modes are in the CSV and JSON.
fn feed_chart(r: &DynamicsReport) -> LineChart<'static> {
    let first: Vec<(f64, f64)> = r
        .feed_sweep
        .points
        .iter()
        .map(|p| (p.feed_mm_min / 1000.0, p.frequencies_hz[0]))
        .collect();
    let (lo, hi) = first
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(p.1), b.max(p.1))
        });
    let (ylo, yhi) = (0.85 * lo, 1.15 * hi);
    let vmax = r.feed_sweep.points.last().map_or(0.0, |p| p.feed_mm_min);
    let mut series = vec![Series {
        name: "mode 1".to_owned(),
        points: first,
        style: Style::Line,
    }];
    for &h in &r.ripple.harmonics {
        let slope = ripple_frequency_hz(h, r.ripple.pole_pairs, 1.0, r.lead_mm);
        let v0 = (ylo / slope).max(0.0);
        let v1 = (yhi / slope).min(vmax);
        if v1 > v0 {
            series.push(Series {
                name: format!("ripple N_P = {h} (order {})", h * r.ripple.pole_pairs),
                points: vec![(v0 / 1000.0, slope * v0), (v1 / 1000.0, slope * v1)],
                style: Style::Dashed,
            });
        }
    }
    let risks: Vec<(f64, f64)> = r
        .resonances
        .iter()
        .filter(|x| x.mode == 1)
        .map(|x| (x.feed_mm_min / 1000.0, x.frequency_hz))
        .collect();
    if !risks.is_empty() {
        series.push(Series {
            name: "resonance risk".to_owned(),
            points: risks,
            style: Style::Points,
        });
    }
    LineChart {
        title: "First natural frequency and torque-ripple harmonics vs feed rate",
        x_label: "feed rate (m/min)",
        y_label: "frequency (Hz)",
        series,
    }
}

fn position_chart(r: &DynamicsReport) -> LineChart<'static> {
    let series = r
        .position_sweeps
        .iter()
        .map(|s| Series {
            name: format!("mode 1, v = {} m/min", s.feed_mm_min / 1000.0),
            points: s
                .points
                .iter()
                .map(|p| (p.position_mm, p.frequencies_hz[0]))
                .collect(),
            style: Style::Line,
        })
        .collect();
    LineChart {
        title: "First natural frequency vs nut position",
        x_label: "nut position from rear bearing (mm)",
        y_label: "frequency (Hz)",
        series,
    }
}
