//! feedscope: sensorless friction and condition analysis of CNC ball-screw feed drives.
//!
//! From what the controller already records (axis position and servo current or torque, with
//! timestamps) feedscope estimates the friction of the drive along its whole travel.
//!
//! This crate works on values in memory and opens no file; trace files, controller imports
//! and feedscope's own tables are read and written by the crate `feedscope-io`.
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
