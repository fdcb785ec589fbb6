//! The use cases of feedscope as requests and reports: the layer that the command-line tool,
//! the Python module and a server share, so that each is a thin front end.
//!
//! # The layers
//! ```text
//!   feedscope (maths: estimation, fits, identification, the twin)
//!       ↑
//!   feedscope-io (file formats)   feedscope-store (the history)   feedscope-live (controls)
//!       ↑                               ↑                              ↑
//!   feedscope-app (use cases: Request → run → Report)        ← this crate
//!       ↑
//!   feedscope-cli (`feedscope`), feedscope-py (`import feedscope`), a server
//! ```
//! A use case takes a request (serde, `Default`, with `validate()` naming a bad field), runs
//! against a [`FrontEnd`] (progress, and how the user spells a field: `--effort torque` on the
//! command line, `effort="torque"` in Python) and returns a report that derives `Serialize`
//! and *is* the JSON layout the front ends write or return. Errors are one type,
//! [`AppError`], whose [`kind`](AppError::kind) a front end maps to an exit code or a status;
//! a finding the user asked to be alerted to is an [`Outcome`], not an error. Every warning
//! carries a code of the catalogue in [`feedscope::diag`].
//!
//! The use cases: [`estimate`] (friction along the travel, paper 000 Eq. 5, streamed while the
//! file is read), [`analyze`] (the friction profile along the travel and its fluctuation in
//! screw orders, paper 000 Section 4.1), [`map`] (the friction map F(z, v) of a test set, paper
//! 000 Section 4.2), [`stribeck`] (Stribeck curves from a steady-speed table, paper 000 Eq. 9
//! and paper 001 Eq. 15), [`identify`] (paper 002, with the comparison against constant-speed
//! groups), [`compensation`] (the controllers' friction-compensation files from a map or a
//! fit), [`dynamics`] (a feed drive's natural frequencies and resonance risks, paper 001),
//! [`plan`] (the NC programs of the tests, with run time and sample counts), [`simulate`] (the
//! twin's trace of a drive whose friction is known), [`import`] (a controller's export as a
//! trace), [`history`] (a test analysed and stored; list, show, remove), [`trend`] (an axis's
//! indicators over its stored tests, the position-resolved comparison and the diagnosis),
//! [`transfer`] (a history exported or migrated), [`watch`] (the gateway that stores the tests
//! a live control runs) and [`demo`] (the demo's simulated axis and its weekly history).
//!
//! The pictures people look at are drawn here too: [`plot`] (SVG line charts and heat maps
//! with unit-labelled axes) and [`report`] (the condition report of an axis: its page model and
//! one self-contained HTML file).
//!
//! Every file a front end writes goes through [`output`]: it appears whole or not at all; every
//! history store a front end opens is named and opened through [`store`].
//!
//! # Example
//! Identify J and the Stribeck curve from a triangular-wave test run on the twin:
//! ```
//! use feedscope::plan::{triangle_program, Limits, TriangleParams};
//! use feedscope::sim::{simulate_profile, DynamicsMode, SamplingMode, SimConfig};
//! use feedscope_app::identify::{identify_recordings, IdentifyOptions};
//! use feedscope_app::{Quiet, Recording};
//!
//! let program = triangle_program(&TriangleParams::default(), &Limits::default()).unwrap();
//! let mut twin = SimConfig::default();
//! twin.dynamics.mode = DynamicsMode::Servo;
//! twin.sampling.mode = SamplingMode::Synchronous;
//! twin.sampling.synchronous_rate_hz = 500.0;
//! twin.axis.travel_min_mm = None;
//! twin.axis.travel_max_mm = None;
//! let run = simulate_profile(&twin, &program, &mut |_| {}).unwrap();
//! let test = Recording::in_memory(run.trace, "twin");
//! let options = IdentifyOptions::default();
//! let done = identify_recordings(&test, None, &twin.axis, &options, &Quiet).unwrap();
//! let j = done.report.set.motor.j_total_kgm2;
//! let truth = done.report.axis_j_total_kgm2.unwrap(); // motor + screw + table
//! assert!((j - truth).abs() < 0.05 * truth, "J {j} against {truth}");
//! ```

pub mod analyze;
pub mod compensation;
pub mod demo;
pub mod dynamics;
pub mod error;
pub mod estimate;
pub mod front;
pub mod history;
pub mod identify;
pub mod import;
pub mod map;
pub mod outcome;
pub mod output;
pub mod plan;
pub mod plot;
pub mod recording;
pub mod report;
pub mod simulate;
pub mod store;
pub mod stribeck;
pub mod transfer;
pub mod trend;
pub mod watch;

pub use error::AppError;
pub use front::{FrontEnd, Quiet};
pub use outcome::Outcome;
pub use recording::Recording;
