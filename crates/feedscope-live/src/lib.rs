//! Live sources for feedscope: what a running control reports about one axis, as a stream of
//! [`Event`]s in SI units, whatever the protocol.
//!
//! - [`source`]: the [`Source`] trait every protocol implements and the events it yields.
//! - [`mtconnect`]: the SHDR adapter stream and the agent REST client.
//! - [`watch`]: the recognition of planned tests in a stream of events, and the screw orders
//!   such a stream resolves.
//!
//! Sampling honesty: MTConnect and OPC UA deliver change-only values every 0.1-1 s. That suits
//! the slow idle-stroke test (the friction profile at a few mm/min), not servo-rate traces; the
//! watch states the orders such a stream can resolve.
#![warn(missing_docs)]
#![deny(clippy::float_cmp)]

pub mod mtconnect;
pub mod opcua;
pub mod source;
pub mod watch;

pub use source::{Event, GapReason, LiveError, Quantity, Source};
