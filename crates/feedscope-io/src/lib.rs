//! feedscope-io: the files of feedscope, read and written, so that the maths crate `feedscope`
//! opens none and depends on no file format.
//!
//! # The layers
//! ```text
//!   feedscope           maths: estimation, fits, identification, the twin
//!       ↑
//!   feedscope-io        files       feedscope-store   the condition history     ← this crate: files
//!   feedscope-live      live sources (MTConnect, OPC UA)
//!       ↑
//!   feedscope-app       use cases: Request → run → Report
//!       ↑
//!   feedscope-cli (`feedscope`), feedscope-py (`import feedscope`), a server
//! ```
//!
//! # Example
//! ```
//! use feedscope::axis::{AxisParams, ConfigFormat};
//! use feedscope::estimate::{estimate, EstimateParams};
//! use feedscope::sim::{simulate, DynamicsMode, SimConfig};
//! use feedscope_io::trace::{parse_trace, write_csv, Layout, ReadOptions};
//!
//! // A simulated controller trace, written as a CSV file would hold it and read back.
//! let mut cfg = SimConfig::from_toml_str(
//!     "[motion]\nlead_in_s = 0.2\nlead_out_s = 0.2\n\
//!      [[motion.stroke]]\nto_mm = 20\nfeed_mm_min = 600\n\
//!      [[motion.stroke]]\nto_mm = 0\nfeed_mm_min = 600\n",
//! )?;
//! cfg.dynamics.mode = DynamicsMode::Ideal;
//! let sim = simulate(&cfg, &mut |_| {})?;
//! let mut csv = Vec::new();
//! write_csv(&sim.trace, &mut csv, Layout::Long)?;
//! let (trace, report) = parse_trace(&csv, "trace.csv", &ReadOptions::default())?;
//! assert_eq!(report.layout, Some(Layout::Long));
//! assert!(report.dropped_position.is_empty());
//!
//! // The maths takes it from here.
//! let est = estimate(&trace, &sim.truth.axis, &EstimateParams::default())?;
//! assert_eq!(est.strokes.len(), 2);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! # Modules
//! - [`trace`]: trace files, CSV and Parquet in the long and wide layouts, read into a
//!   [`feedscope::trace::Trace`] (strictly, errors naming file and line or row, glitches
//!   screened) and written from one; a corrupt Parquet file is an error, not a crash.
//! - [`import`]: real controller exports: MTConnect SHDR logs with their `Devices.xml`, the
//!   UMich CNC mill CSV, SINUMERIK Operate servo traces, TwinCAT 3 Scope exports.
//! - [`friction_csv`], [`compensation`], [`stribeck_table`]: the tables feedscope writes
//!   (friction along the travel, friction-compensation tables) and reads (its own friction
//!   CSV, steady-speed tables).
//! - [`controller_compensation`]: friction compensation in the controllers' own files (the
//!   Beckhoff TF5200 `frict_comp` block, SINUMERIK starting values) and a generic velocity
//!   table.
//! - [`axis`], [`nc`], [`sim`], [`test_set`]: files named on the command line: axis
//!   descriptions, NC programs, simulator configs (with their program file), the index of a
//!   test set and its traces.
//! - [`fixed`]: fast fixed-decimal formatting for large CSV outputs.
//! - [`bounded`]: whole-file reads with a size bound (`/dev/zero` named as a file is an error).
//!
//! Errors are one enum per file kind, naming the file and, where there is one, the 1-based
//! line (or Parquet row). The errors of [`axis`], [`friction_csv`] and [`stribeck_table`] tell
//! a file that cannot be read (the operating system's error is the source) from one whose
//! content is wrong by `is_io()`.
#![warn(missing_docs)]
#![deny(clippy::float_cmp)]

pub mod axis;
pub mod bounded;
pub mod compensation;
pub mod controller_compensation;
pub mod fixed;
pub mod friction_csv;
pub mod import;
pub mod nc;
pub mod sim;
pub mod stribeck_table;
pub mod test_set;
pub mod thresholds;
pub mod trace;

/// The kind of one error of a chain when it is this crate's (each error enum says its own) or
/// one that [`feedscope::error::kind_of`] knows; `None` otherwise.
pub fn error_kind(e: &(dyn std::error::Error + 'static)) -> Option<feedscope::ErrorKind> {
    macro_rules! kind_if {
        ($($t:ty),* $(,)?) => {
            $(if let Some(x) = e.downcast_ref::<$t>() {
                return Some(x.kind());
            })*
        };
    }
    kind_if!(
        axis::AxisFileError,
        friction_csv::FrictionCsvError,
        import::ImportError,
        stribeck_table::TableError,
        thresholds::ThresholdsError,
        trace::TraceError,
    );
    feedscope::error::kind_of(e)
}
