//! A real controller export made a feedscope trace CSV (docs/import.md): an MTConnect SHDR log
//! with its device model, the UMich mill CSV, a SINUMERIK Operate servo trace, a TwinCAT Scope
//! export. One axis per request, in the long layout (`time_s,channel,value`) with `#` lines
//! that say where the data came from and what time 0 is.
//!
//! [`ImportRequest::run`] converts and writes the file (whole or not at all) and returns an
//! [`ImportReport`]; [`ImportSource::list`] says what a file holds, for choosing the axis.
use std::path::PathBuf;

use feedscope_io::import::devices::DeviceModel;
use feedscope_io::import::shdr::{read_shdr, ShdrConvertParams, ShdrLog};
use feedscope_io::import::sinumerik::{
    list_sinumerik, read_sinumerik, SinumerikListing, SinumerikParams,
};
use feedscope_io::import::twincat::{list_twincat, read_twincat, TwincatListing, TwincatParams};
use feedscope_io::import::umich::{read_umich, UmichParams, UmichTable};
use feedscope_io::import::{check_informative, write_trace_csv, Imported};
use serde::{Deserialize, Serialize};

use crate::output::{io_error, AtomicFile};
use crate::{AppError, FrontEnd};

/// Where the trace comes from, with the options of its format (serialised with the format as
/// its key: `{"shdr": {"log": ..., "devices": ..., "axis": "Z1", ...}}`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum ImportSource {
    /// An MTConnect SHDR adapter log and its device model (Devices.xml).
    Shdr {
        /// The SHDR log.
        log: PathBuf,
        /// The device model.
        devices: PathBuf,
        /// Device of the model (name, id or uuid); default: the one whose data items match the
        /// most keys of the log.
        #[serde(default)]
        device: Option<String>,
        /// Axis: its component name, id or nativeName (required to convert).
        #[serde(default)]
        axis: Option<String>,
        /// Keys, load scale and time origin.
        #[serde(default)]
        params: ShdrConvertParams,
    },
    /// The UMich SMART CNC mill CSV (10 Hz rows, no timestamps).
    Umich {
        /// The experiment CSV.
        file: PathBuf,
        /// Axis `X`, `Y` or `Z` (required to convert).
        #[serde(default)]
        axis: Option<String>,
        /// Row rate and current column.
        #[serde(default)]
        params: UmichParams,
    },
    /// A SINUMERIK Operate servo trace (XML).
    Sinumerik {
        /// The trace file.
        file: PathBuf,
        /// Axis, signals and units.
        #[serde(default)]
        params: SinumerikParams,
    },
    /// A TwinCAT 3 Scope export (CSV or TXT).
    Twincat {
        /// The export.
        file: PathBuf,
        /// Channels and units.
        #[serde(default)]
        params: TwincatParams,
    },
}

/// What a file holds, as [`ImportSource::list`] read it.
#[derive(Debug)]
pub enum Listing {
    /// The log's devices, axes and data items with their counts and spans.
    Shdr {
        /// The log.
        log: ShdrLog,
        /// Its device model.
        model: DeviceModel,
    },
    /// The table's axes and columns.
    Umich {
        /// The table.
        table: UmichTable,
        /// The row rate the spans are given at (Hz).
        rate_hz: f64,
    },
    /// The trace's frames, axes and signals.
    Sinumerik(SinumerikListing),
    /// The export's channels.
    Twincat(TwincatListing),
}

impl ImportSource {
    /// The options that do not need a file read, naming the field.
    ///
    /// # Errors
    /// An invalid-parameter error: a load scale (`torque_per_load_nm`) or a row rate
    /// (`rate_hz`) that is not a positive finite number.
    pub fn validate(&self, front: &dyn FrontEnd) -> Result<(), AppError> {
        match self {
            ImportSource::Shdr { params, .. } => {
                if let Some(x) = params.torque_per_load_nm {
                    if !(x.is_finite() && x > 0.0) {
                        return Err(AppError::invalid(
                            "torque_per_load_nm",
                            format!(
                                "{} {x} must be a positive torque",
                                front.name("torque_per_load_nm")
                            ),
                        ));
                    }
                }
            }
            ImportSource::Umich { params, .. } => {
                if !(params.rate_hz.is_finite() && params.rate_hz > 0.0) {
                    return Err(AppError::invalid(
                        "rate_hz",
                        format!(
                            "{} {} must be a positive rate",
                            front.name("rate_hz"),
                            params.rate_hz
                        ),
                    ));
                }
            }
            ImportSource::Sinumerik { .. } | ImportSource::Twincat { .. } => {}
        }
        Ok(())
    }

    /// What the file holds (axes, data items or signals, counts, spans).
    ///
    /// # Errors
    /// As [`validate`](Self::validate); the file's errors, with its line.
    pub fn list(&self, front: &dyn FrontEnd) -> Result<Listing, AppError> {
        self.validate(front)?;
        let e = AppError::from_error;
        Ok(match self {
            ImportSource::Shdr {
                log,
                devices,
                device,
                ..
            } => {
                let model = DeviceModel::read(devices).map_err(e)?;
                let log = read_shdr(log, &model, device.as_deref()).map_err(e)?;
                Listing::Shdr { log, model }
            }
            ImportSource::Umich { file, params, .. } => Listing::Umich {
                table: read_umich(file).map_err(e)?,
                rate_hz: params.rate_hz,
            },
            ImportSource::Sinumerik { file, .. } => {
                Listing::Sinumerik(list_sinumerik(file).map_err(e)?)
            }
            ImportSource::Twincat { file, .. } => Listing::Twincat(list_twincat(file).map_err(e)?),
        })
    }

    /// The converted trace with its report, and notes of the format (TwinCAT's header).
    fn convert(&self, front: &dyn FrontEnd) -> Result<(Imported, Vec<String>), AppError> {
        self.validate(front)?;
        let e = AppError::from_error;
        let axis_needed = |axis: &Option<String>| {
            axis.clone().ok_or_else(|| {
                AppError::invalid(
                    "axis",
                    format!(
                        "{} is required to convert (list the file to see its axes)",
                        front.name("axis")
                    ),
                )
            })
        };
        Ok(match self {
            ImportSource::Shdr {
                log,
                devices,
                device,
                axis,
                params,
            } => {
                let axis = axis_needed(axis)?;
                let model = DeviceModel::read(devices).map_err(e)?;
                let log = read_shdr(log, &model, device.as_deref()).map_err(e)?;
                (log.to_trace(&model, &axis, params).map_err(e)?, vec![])
            }
            ImportSource::Umich { file, axis, params } => {
                let axis = axis_needed(axis)?;
                let table = read_umich(file).map_err(e)?;
                (table.to_trace(&axis, params).map_err(e)?, vec![])
            }
            ImportSource::Sinumerik { file, params } => {
                (read_sinumerik(file, params).map_err(e)?.imported, vec![])
            }
            ImportSource::Twincat { file, params } => {
                let imp = read_twincat(file, params).map_err(e)?;
                (imp.imported, imp.listing.header.notes)
            }
        })
    }
}

/// Convert one axis of a controller export into a trace CSV.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImportRequest {
    /// The export and its format's options.
    pub source: ImportSource,
    /// The trace CSV to write (whole or not at all).
    pub output: PathBuf,
    /// Write the trace even when its effort is constant (zero in every row: a control that
    /// does not report the axis's current) or its position never moves.
    #[serde(default)]
    pub keep_empty_channels: bool,
}

/// What an import wrote (`feedscope import` prints it; a server returns it).
#[derive(Debug, Clone, Serialize)]
pub struct ImportReport {
    /// The trace CSV written.
    pub output: PathBuf,
    /// Its effort column (`current_a` or `torque_nm`).
    pub effort_column: &'static str,
    /// Sources, counts, time zero and the warnings (each with its code).
    pub import: feedscope_io::import::ImportReport,
    /// What the format's header says that a user should know (TwinCAT).
    pub notes: Vec<String>,
}

impl ImportRequest {
    /// Read, convert, check and write.
    ///
    /// # Errors
    /// As [`ImportSource::validate`]; the file's errors (with its line; an unknown axis or
    /// channel listing those that exist); a channel without information unless
    /// `keep_empty_channels`; I/O errors writing `output` (nothing is left there).
    pub fn run(&self, front: &dyn FrontEnd) -> Result<ImportReport, AppError> {
        let (imported, notes) = self.source.convert(front)?;
        if !self.keep_empty_channels {
            check_informative(&imported).map_err(AppError::from_error)?;
        }
        let mut f = AtomicFile::create(&self.output)?;
        write_trace_csv(&imported, &mut *f.writer())
            .map_err(|e| io_error(format!("writing {}", self.output.display()), e))?;
        f.commit()?;
        Ok(ImportReport {
            output: self.output.clone(),
            effort_column: imported.trace.effort_kind.column(),
            import: imported.report,
            notes,
        })
    }
}
