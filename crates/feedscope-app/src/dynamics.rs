//! The dynamics of a ball-screw feed drive (paper 001; docs/dynamics.md): its natural
//! frequencies against feed rate and nut position, where a support bearing unloads, and the
//! feed rates where a torque-ripple harmonic of the motor meets a natural frequency.
//!
//! [`DynamicsRequest`] names the drive file and the output folder; [`DynamicsRequest::run`]
//! reads and validates the file before anything is written, analyses it
//! ([`feedscope::dynamics::analyse`]) and writes the outputs of [`Dynamics::files`] together
//! (an [`OutputSet`]: all of them or none). The headers are part of the interface:
//!
//! | file | content |
//! |---|---|
//! | `dynamics.json` | the whole [`DynamicsReport`] |
//! | `frequency_vs_feed.csv` | `feed_mm_min,mode,frequency_hz` |
//! | `frequency_vs_position.csv` | `feed_mm_min,position_mm,mode,frequency_hz` |
//! | `resonance.csv` | `harmonic,feed_mm_min,frequency_hz,mode,margin_hz,order,feed_low_mm_min,feed_high_mm_min` |
//! | `frequency_vs_feed.svg` | paper 001 Fig. 7: the first mode against feed rate with the ripple lines |
//! | `frequency_vs_position.svg` | the first mode against nut position, one line per feed |
//!
//! The headline numbers are a [`DynamicsSummary`] (what `feedscope dynamics --format json`
//! prints) and [`Dynamics::summary_text`] their plain-text view.
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use feedscope::dynamics::{
    analyse, ripple_frequency_hz, DriveConfig, DriveModel, DynamicsReport, Resonance, UnloadEvent,
};
use serde::{Deserialize, Serialize};

use crate::output::{io_error, OutputSet};
use crate::plot::{line_chart_svg, LineChart, Series, Style};
use crate::{AppError, FrontEnd};

/// Analyse a drive file and write its outputs.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DynamicsRequest {
    /// The drive file (TOML, units in the keys; see examples/drive.toml and docs/dynamics.md).
    pub config: PathBuf,
    /// Folder for the JSON, CSV and SVG outputs (made when missing).
    pub out: PathBuf,
}

impl DynamicsRequest {
    /// Check the request before any file is read.
    ///
    /// # Errors
    /// [`AppError::invalid`] naming `config` or `out` (as the front end spells them) when it
    /// names no file or folder.
    pub fn validate(&self, front: &dyn FrontEnd) -> Result<(), AppError> {
        if self.config.as_os_str().is_empty() {
            return Err(AppError::invalid(
                "config",
                format!("{} names no drive file", front.name("config")),
            ));
        }
        if self.out.as_os_str().is_empty() {
            return Err(AppError::invalid(
                "out",
                format!("{} names no folder", front.name("out")),
            ));
        }
        Ok(())
    }

    /// Read and validate the drive file, analyse it and write the outputs under `out`.
    ///
    /// # Errors
    /// As [`validate`](Self::validate); bad input naming the file and the key for a drive file
    /// that cannot be read or is invalid (nothing is written then); the analysis's errors;
    /// I/O errors making `out` or writing the outputs (then none of them is replaced).
    pub fn run(&self, front: &dyn FrontEnd) -> Result<Dynamics, AppError> {
        self.validate(front)?;
        let model = read_drive(&self.config)?;
        front.stage("modal analysis");
        let report = analyse(&model).map_err(|e| AppError::within("modal analysis failed", e))?;
        std::fs::create_dir_all(&self.out).map_err(|e| {
            io_error(
                format!("cannot create output directory {}", self.out.display()),
                e,
            )
        })?;
        let done = Dynamics {
            report,
            files: Vec::new(),
        };
        let mut set = OutputSet::new();
        let mut files = Vec::new();
        for (name, text) in done.outputs()? {
            let path = self.out.join(name);
            set.write(&path, text.as_bytes())?;
            files.push(path);
        }
        set.commit()?;
        Ok(Dynamics { files, ..done })
    }
}

/// Read and validate the drive file at `path`, before any output is written.
///
/// # Errors
/// Bad input naming the file: it cannot be read (missing, too large, not UTF-8), or it is not
/// a valid drive file (the message names the key).
pub fn read_drive(path: &Path) -> Result<DriveModel, AppError> {
    let text = feedscope_io::bounded::read_to_string(path, feedscope_io::bounded::MAX_CONFIG_BYTES)
        .map_err(|e| {
            AppError::bad_input(format!("cannot read drive file {}: {e}", path.display()))
        })?;
    let source = path.display().to_string();
    drive_from_toml(&text, &source, &format!("drive file {source}"))
}

/// The drive of a TOML text. `source` names it inside the config's own messages (the file's
/// path), `what` in the message around them (`drive file d.toml`, or `drive config` for keys
/// given in memory, as Python's dict).
///
/// # Errors
/// Bad input `invalid {what}: ...` naming the key.
pub fn drive_from_toml(text: &str, source: &str, what: &str) -> Result<DriveModel, AppError> {
    let invalid = |e: &dyn std::fmt::Display| AppError::bad_input(format!("invalid {what}: {e}"));
    let cfg = DriveConfig::from_toml_str(text, source).map_err(|e| invalid(&e))?;
    DriveModel::from_config(&cfg).map_err(|e| invalid(&e))
}

/// What an analysis gives: the report (`dynamics.json`) and the files written.
#[derive(Debug, Clone)]
pub struct Dynamics {
    /// The sweeps, the modes and the resonance risks.
    pub report: DynamicsReport,
    /// The outputs written, in the order of the module's table.
    pub files: Vec<PathBuf>,
}

/// The headline numbers of an analysis: what `feedscope dynamics --format json` prints.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DynamicsSummary {
    /// The drive's name from the file.
    pub name: Option<String>,
    /// Nut position of the feed sweep (mm).
    pub position_mm: f64,
    /// Lowest natural frequency at rest (Hz).
    pub static_first_hz: f64,
    /// Lowest natural frequency just after breakaway, v = 0⁺ (Hz).
    pub breakaway_first_hz: f64,
    /// Highest lowest-frequency over the feed sweep (Hz).
    pub peak_first_hz: f64,
    /// Feed rate of that peak (mm/min).
    pub peak_feed_mm_min: f64,
    /// Where a support bearing unloads, if it does in the sweep.
    pub bearing_unload: Option<UnloadEvent>,
    /// Resonance risks on the feed sweep, ascending in feed rate.
    pub resonances: Vec<Resonance>,
}

impl Dynamics {
    /// The headline numbers.
    pub fn summary(&self) -> DynamicsSummary {
        let r = &self.report;
        DynamicsSummary {
            name: r.name.clone(),
            position_mm: r.position_mm,
            static_first_hz: r.static_first_hz,
            breakaway_first_hz: r.breakaway_first_hz,
            peak_first_hz: r.peak_first_hz,
            peak_feed_mm_min: r.peak_feed_mm_min,
            bearing_unload: r.bearing_unload.clone(),
            resonances: r.resonances.clone(),
        }
    }

    /// The headline numbers in plain text (feeds in m/min), one line each, and one line per
    /// resonance risk: what `feedscope dynamics` prints.
    pub fn summary_text(&self) -> String {
        let r = &self.report;
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

    /// Every output's file name and text, in the order of the module's table.
    ///
    /// # Errors
    /// When the report does not serialise or a chart has no finite point.
    pub fn outputs(&self) -> Result<Vec<(&'static str, String)>, AppError> {
        let r = &self.report;
        let mut json = serde_json::to_string_pretty(r)
            .map_err(|e| AppError::within("serialising dynamics.json", e))?;
        json.push('\n');

        let mut by_feed = String::from("feed_mm_min,mode,frequency_hz\n");
        for p in &r.feed_sweep.points {
            for (m, f) in p.frequencies_hz.iter().enumerate() {
                let _ = writeln!(by_feed, "{},{},{}", p.feed_mm_min, m + 1, f);
            }
        }

        let mut by_position = String::from("feed_mm_min,position_mm,mode,frequency_hz\n");
        for sweep in &r.position_sweeps {
            for p in &sweep.points {
                for (m, f) in p.frequencies_hz.iter().enumerate() {
                    let _ = writeln!(
                        by_position,
                        "{},{},{},{}",
                        sweep.feed_mm_min,
                        p.position_mm,
                        m + 1,
                        f
                    );
                }
            }
        }

        let mut resonance = String::from(
            "harmonic,feed_mm_min,frequency_hz,mode,margin_hz,order,feed_low_mm_min,feed_high_mm_min\n",
        );
        for x in &r.resonances {
            let _ = writeln!(
                resonance,
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

        Ok(vec![
            ("dynamics.json", json),
            ("frequency_vs_feed.csv", by_feed),
            ("frequency_vs_position.csv", by_position),
            ("resonance.csv", resonance),
            ("frequency_vs_feed.svg", line_chart_svg(&feed_chart(r))?),
            (
                "frequency_vs_position.svg",
                line_chart_svg(&position_chart(r))?,
            ),
        ])
    }
}

/// Paper 001 Fig. 7: the first (transmission) mode against feed rate with the ripple lines
/// f_T = N_P·P_n·v/(60·p) (paper 001 Eq. 16), each drawn only inside the band of the first
/// mode (±15 %) so the curve stays readable; higher modes are in the CSV and JSON.
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
        // Hz per mm/min of feed: the line is straight through the origin.
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

/// The first mode against nut position, one line per feed of the position sweeps.
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
