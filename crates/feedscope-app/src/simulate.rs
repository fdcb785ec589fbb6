//! A simulated feed drive whose friction is known (the twin, [`feedscope::sim`]): the trace a
//! controller would record, and the truth to compare an estimate with.
//!
//! [`SimulateRequest::run`] builds the twin's config (the config file or the default lathe Z
//! axis, with the request's seed), checks it and the request before anything is written,
//! simulates, and writes the outputs of [`write_outputs`] under the folder `out`:
//!
//! | file | content |
//! |---|---|
//! | `trace.csv` (the request's `trace` name) | the controller's view: `time_s,channel,value` (long) or `time_s,position_mm,current_a` / `torque_nm` (wide); Parquet when the name ends in `.parquet` |
//! | `axis.toml` | the axis, for estimating from the trace |
//! | `truth.json` | the friction model and the commanded strokes |
//! | `truth.csv` | `time_s,position_mm,velocity_mm_s,accel_mm_s2,friction_n` of the true state |
//!
//! The four appear together or not at all: each is written under a temporary name and all are
//! renamed at the end.
use std::io::Write as _;
use std::path::{Path, PathBuf};

use feedscope::sim::{simulate, SamplingMode, SimConfig, SimOutput};
use feedscope::ErrorKind;
use feedscope_io::trace::{write_csv, write_parquet, Layout};
use serde::{Deserialize, Serialize};

use crate::{AppError, FrontEnd};

/// The outputs besides the trace, whose names the trace may not take.
const OTHER_OUTPUTS: [&str; 3] = ["axis.toml", "truth.json", "truth.csv"];

/// Layout of the simulated trace file.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TraceLayout {
    /// `time_s,channel,value`, one sample per row: each channel on its own clock.
    #[default]
    Long,
    /// `time_s,position_mm,current_a` (or `torque_nm`): needs both channels on the same
    /// timestamps (`sampling.mode = "synchronous"`).
    Wide,
}

impl From<TraceLayout> for Layout {
    fn from(l: TraceLayout) -> Self {
        match l {
            TraceLayout::Long => Layout::Long,
            TraceLayout::Wide => Layout::Wide,
        }
    }
}

/// Simulate the twin and write its trace and truth.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SimulateRequest {
    /// The simulator's config (TOML, units in the keys); none: the default lathe Z axis,
    /// 0 → 410 → 0 mm at 100 mm/min. A relative `motion.program_file` is read relative to it.
    pub config: Option<PathBuf>,
    /// Output folder (made when missing).
    pub out: PathBuf,
    /// File name of the trace under `out`; a name ending in `.parquet` writes Parquet (the
    /// same layouts, SI units at full precision). Default `trace.csv`.
    pub trace: String,
    /// Layout of the trace file.
    pub layout: TraceLayout,
    /// Seed of the random draws (jitter, dropouts, noise); overrides the config's `seed`.
    pub seed: Option<u64>,
}

impl Default for SimulateRequest {
    fn default() -> Self {
        Self {
            config: None,
            out: PathBuf::new(),
            trace: "trace.csv".to_string(),
            layout: TraceLayout::Long,
            seed: None,
        }
    }
}

/// A simulation done and written.
#[derive(Debug, Clone)]
pub struct Simulated {
    /// The trace, the truth and the run's statistics.
    pub output: SimOutput,
    /// The folder written.
    pub dir: PathBuf,
}

impl SimulateRequest {
    /// Check the output names (no file is read).
    ///
    /// # Errors
    /// [`AppError::invalid`] naming the field as the front end spells it: a `trace` that is
    /// not a plain file name or is the name of another output; an empty `out`, or one that
    /// exists and is not a folder.
    pub fn validate(&self, front: &dyn FrontEnd) -> Result<(), AppError> {
        let name = |f: &str| front.name(f);
        let plain = Path::new(&self.trace)
            .file_name()
            .is_some_and(|n| n == self.trace.as_str());
        if !plain || self.trace.starts_with('.') {
            return Err(AppError::invalid(
                "trace",
                format!(
                    "{} {}: expected a plain file name (written under {} DIR)",
                    name("trace"),
                    self.trace,
                    name("out")
                ),
            ));
        }
        if OTHER_OUTPUTS.contains(&self.trace.as_str()) {
            return Err(AppError::invalid(
                "trace",
                format!(
                    "{} {}: that name is taken by another output",
                    name("trace"),
                    self.trace
                ),
            ));
        }
        if self.out.as_os_str().is_empty() {
            return Err(AppError::invalid(
                "out",
                format!("{} DIR is required", name("out")),
            ));
        }
        if self.out.exists() && !self.out.is_dir() {
            return Err(AppError::invalid(
                "out",
                format!(
                    "{} {} exists and is not a directory",
                    name("out"),
                    self.out.display()
                ),
            ));
        }
        Ok(())
    }

    /// The twin's config: the file's (or the default), with the request's seed, checked, and
    /// fit for the layout.
    ///
    /// # Errors
    /// Bad input: the file cannot be read, a key is unknown or its value invalid (the message
    /// names the key), the program file cannot be read; a wide layout without
    /// synchronous sampling, naming `layout`.
    pub fn sim_config(&self, front: &dyn FrontEnd) -> Result<SimConfig, AppError> {
        let bad = ErrorKind::BadInput;
        let mut cfg = match &self.config {
            Some(path) => {
                let text = feedscope_io::bounded::read_to_string(
                    path,
                    feedscope_io::bounded::MAX_CONFIG_BYTES,
                )
                .map_err(|e| {
                    AppError::caused(bad, format!("reading config {}", path.display()), e)
                })?;
                let dir = path.parent().unwrap_or(Path::new("."));
                feedscope_io::sim::config_from_toml_str_in_dir(&text, dir)
                    .map_err(|e| AppError::caused(bad, format!("config {}", path.display()), e))?
            }
            None => SimConfig::default(),
        };
        if let Some(seed) = self.seed {
            cfg.seed = seed;
        }
        cfg.validate()
            .map_err(|e| AppError::caused(bad, "config", e))?;
        if self.layout == TraceLayout::Wide && cfg.sampling.mode != SamplingMode::Synchronous {
            return Err(AppError::invalid(
                "layout",
                format!(
                    "{} needs both channels on the same timestamps: set sampling.mode = \
                     \"synchronous\" in the config, or use {}",
                    front.spell("layout", "wide"),
                    front.spell("layout", "long")
                ),
            ));
        }
        Ok(cfg)
    }

    /// Build the config, simulate (progress as `simulate`, in thousandths) and write the
    /// outputs.
    ///
    /// # Errors
    /// Bad input ([`ErrorKind::BadInput`]) for everything found before the first output is
    /// written: as [`sim_config`](Self::sim_config), and a simulation that fails (a servo that
    /// diverges), whatever the error below says; after that, the errors of
    /// [`write_outputs`], never bad input.
    pub fn run(&self, front: &dyn FrontEnd) -> Result<Simulated, AppError> {
        // The config's errors first: the order in which the command line has reported them.
        let cfg = self.sim_config(front)?;
        self.validate(front)?;
        const STEPS: usize = 1000;
        let output = simulate(&cfg, &mut |f| {
            front.progress("simulate", (f * STEPS as f64) as usize, STEPS);
        })
        .map_err(|e| AppError::caused(ErrorKind::BadInput, "simulation failed", e))?;
        front.progress("simulate", STEPS, STEPS);
        write_outputs(&self.out, &output, self.layout.into(), &self.trace)?;
        Ok(Simulated {
            output,
            dir: self.out.clone(),
        })
    }
}

/// The temporary name of the output `name` under `dir`, for this process.
fn tmp_name(dir: &Path, name: &str) -> PathBuf {
    dir.join(format!(".{name}.{}.tmp", std::process::id()))
}

/// An output that could not be written: never the input's fault (the request was checked), so
/// [`ErrorKind::Io`] whatever the error below says.
fn write_error(
    context: impl Into<String>,
    e: impl std::error::Error + Send + Sync + 'static,
) -> AppError {
    AppError::caused(ErrorKind::Io, context, e)
}

/// Write the four outputs of a simulation under `dir` (made when missing), the trace as
/// `trace_name` in `layout` (Parquet when the name ends in `.parquet`): each under a temporary
/// name (removed by an interrupt, [`crate::output::remove_unfinished`]), all renamed at the
/// end. On an error what was written is removed, and `dir` too when this call made it.
///
/// # Errors
/// [`ErrorKind::Io`] naming the file (or [`ErrorKind::Internal`] for an output that does not
/// serialise); the causes below say more.
pub fn write_outputs(
    dir: &Path,
    out: &SimOutput,
    layout: Layout,
    trace_name: &str,
) -> Result<(), AppError> {
    let files = [
        trace_name,
        OTHER_OUTPUTS[0],
        OTHER_OUTPUTS[1],
        OTHER_OUTPUTS[2],
    ];
    let parquet = Path::new(trace_name)
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("parquet"));
    let created = !dir.exists();
    std::fs::create_dir_all(dir)
        .map_err(|e| write_error(format!("creating {}", dir.display()), e))?;
    let result = (|| -> Result<(), AppError> {
        let create = |name: &str| {
            let p = tmp_name(dir, name);
            crate::output::register(&p);
            std::fs::File::create(&p)
                .map_err(|e| write_error(format!("creating {}", p.display()), e))
        };
        if parquet {
            write_parquet(&out.trace, create(trace_name)?, layout)
        } else {
            write_csv(&out.trace, create(trace_name)?, layout)
        }
        .map_err(|e| write_error(format!("writing {trace_name}"), e))?;
        let axis = toml::to_string_pretty(&out.truth.axis)
            .map_err(|e| AppError::caused(ErrorKind::Internal, "serializing the axis", e))?;
        create("axis.toml")?
            .write_all(axis.as_bytes())
            .map_err(|e| write_error("writing axis.toml", e))?;
        let json = serde_json::to_string_pretty(&out.truth)
            .map_err(|e| AppError::caused(ErrorKind::Internal, "serializing the truth", e))?;
        create("truth.json")?
            .write_all(json.as_bytes())
            .map_err(|e| write_error("writing truth.json", e))?;
        out.truth
            .write_states_csv(create("truth.csv")?)
            .map_err(|e| write_error("writing truth.csv", e))?;
        for name in files {
            std::fs::rename(tmp_name(dir, name), dir.join(name))
                .map_err(|e| write_error(format!("renaming to {}", dir.join(name).display()), e))?;
        }
        Ok(())
    })();
    for name in files {
        if result.is_err() {
            let _ = std::fs::remove_file(tmp_name(dir, name));
        }
        crate::output::unregister(&tmp_name(dir, name));
    }
    if result.is_err() && created {
        let _ = std::fs::remove_dir(dir);
    }
    result
}
