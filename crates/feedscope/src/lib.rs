//! feedscope: sensorless friction and condition analysis of CNC ball-screw feed drives.
//!
//! From what the controller already records (axis position and servo current or torque, with
//! timestamps) feedscope estimates the friction of the drive along its whole travel.
//!
//! This crate works on values in memory and opens no file; trace files, controller imports
//! and feedscope's own tables are read and written by the crate `feedscope-io`.
//!
//! # The layers
//! ```text
//!   feedscope           maths: estimation, fits, identification, the twin     ← this crate
//!       ↑
//!   feedscope-io        files       feedscope-store   the condition history
//!   feedscope-live      live sources (MTConnect, OPC UA)
//!       ↑
//!   feedscope-app       use cases: Request → run → Report
//!       ↑
//!   feedscope-cli (`feedscope`), feedscope-py (`import feedscope`), a server
//! ```
//! A newcomer reads this map first: a use case that touches a file or the store belongs in
//! `feedscope-app`, not here.
//!
//! # The modules, in the order of the method
//! - Input: [`trace`] (the samples and their glitch screen), [`axis`] (the drive's
//!   parameters), [`units`], [`stroke`] and [`label`].
//! - Friction along the travel (paper 000 Eq. 5): [`estimate`] (segmentation, the spline, the
//!   inversion, the noise floor, streaming), [`spline`] (not-a-knot splines with derivatives),
//!   [`profile`] (the slow profile, IAFV) and [`order`] (the fluctuation in screw orders).
//! - What the data support: [`verdict`], and every warning's code in [`diag`].
//! - Friction against feed: [`stribeck`] (paper 000 Eq. 9, paper 001), [`map`] (F(z, v) of a
//!   test set), [`lugre`] and [`compensation`] (tables for the control).
//! - One short test: [`ident`] (paper 002, triangular wave), [`dynamics`] (natural frequency
//!   against feed).
//! - Over weeks: [`history`] (trends, limits, local wear), [`study`] (a test analysed for the
//!   history), [`calendar`].
//! - Producing data: [`plan`] and [`nc`] (NC test programs), [`sim`] (the digital twin, whose
//!   friction is known).
//! - [`error`]: the kinds every error maps to.
//!
//! # Example
//! The twin runs a stroke test (8 mm lead, 250 kg, sampled at 1 kHz) against a friction it
//! knows; the estimate gets each stroke's mean friction back:
//! ```
//! use feedscope::estimate::{estimate, EstimateParams};
//! use feedscope::sim::{simulate, SamplingMode, SimConfig, StrokeConfig};
//!
//! let mut twin = SimConfig::default();
//! twin.axis.lead_mm = 8.0;
//! twin.axis.table_mass_kg = 250.0;
//! twin.sampling.mode = SamplingMode::Synchronous;
//! twin.sampling.synchronous_rate_hz = 1000.0;
//! twin.motion.start_mm = 0.0;
//! twin.motion.strokes = vec![
//!     StrokeConfig { to_mm: 60.0, feed_mm_min: 1200.0, dwell_s: 0.5 },
//!     StrokeConfig { to_mm: 0.0, feed_mm_min: 1200.0, dwell_s: 0.5 },
//! ];
//! let run = simulate(&twin, &mut |_| {}).unwrap();
//! let est = estimate(&run.trace, &twin.axis, &EstimateParams::default()).unwrap();
//! assert_eq!(est.strokes.len(), 2);
//! for s in &est.strokes {
//!     // Friction opposes the motion: Eq. 5 signs it with the direction.
//!     let sign = s.summary.direction.sign();
//!     let v_m_s = sign * s.summary.feed_mm_min / 60_000.0;
//!     let truth = sign * run.truth.friction.mean_friction_n(s.summary.direction, 0.03, v_m_s);
//!     let got = s.summary.mean_friction_n;
//!     assert!((got - truth).abs() < 0.02 * truth.abs(), "{got} N against {truth} N");
//! }
//! ```
#![warn(missing_docs)]
#![deny(clippy::float_cmp)]

pub mod axis;
pub mod calendar;
pub mod compensation;
pub mod diag;
pub mod dynamics;
pub mod error;
pub mod estimate;
pub mod history;
pub mod ident;
pub mod label;
pub mod lugre;
pub mod map;
pub mod nc;
pub mod order;
pub mod plan;
pub mod profile;
pub mod sim;
pub mod spline;
pub mod stribeck;
pub mod stroke;
pub mod study;
pub mod trace;
pub mod units;
pub mod verdict;

pub use error::ErrorKind;
