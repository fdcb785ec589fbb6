//! Live sources for feedscope: what a running control reports about one axis, as a stream of
//! [`Event`]s in SI units, whatever the protocol.
//!
//! - [`source`]: the [`Source`] trait every protocol implements and the events it yields.
//! - [`mtconnect`]: the SHDR adapter stream and the agent REST client.
//! - [`opcua`]: an OPC UA server's monitored items.
//! - [`watch`]: the recognition of planned tests in a stream of events, and the screw orders
//!   such a stream resolves.
//!
//! Sampling honesty: MTConnect and OPC UA deliver change-only values every 0.1-1 s. That suits
//! the slow idle-stroke test (the friction profile at a few mm/min), not servo-rate traces; the
//! watch states the orders such a stream can resolve.
//!
//! # The layers
//! ```text
//!   feedscope           maths: estimation, fits, identification, the twin
//!       ↑
//!   feedscope-io        files       feedscope-store   the condition history
//!   feedscope-live      live sources (MTConnect, OPC UA)                      ← this crate
//!       ↑
//!   feedscope-app       use cases: Request → run → Report
//!       ↑
//!   feedscope-cli (`feedscope watch`), feedscope-py, a server
//! ```
//!
//! # Example
//! One SHDR line of an MTConnect adapter, decoded against the device model into events in SI
//! units (the position in m, the load as torque in N·m):
//! ```
//! use std::collections::VecDeque;
//! use feedscope::trace::EffortKind;
//! use feedscope_io::import::devices::DeviceModel;
//! use feedscope_live::mtconnect::{shdr::LineDecoder, AxisSelection, ResolvedAxis};
//! use feedscope_live::{Event, Quantity};
//!
//! let xml = r#"<MTConnectDevices><Devices><Device name="mill" id="d1"><Components>
//!   <Axes id="a"><Components><Linear name="X" id="x"><DataItems>
//!     <DataItem type="POSITION" subType="ACTUAL" category="SAMPLE" name="Xact"
//!       units="MILLIMETER" id="xp"/>
//!     <DataItem type="LOAD" category="SAMPLE" name="Xload" units="PERCENT" id="xl"/>
//!   </DataItems></Linear></Components></Axes>
//! </Components></Device></Devices></MTConnectDevices>"#;
//! let model = DeviceModel::parse(xml, "Devices.xml").unwrap();
//! let sel = AxisSelection {
//!     device: None,
//!     axis: "X".into(),
//!     position_key: None,
//!     load_key: None,
//!     torque_per_load_nm: Some(8.0), // motor torque at 100 % load
//! };
//! let axis = ResolvedAxis::resolve(&model, 0, &sel, "Devices.xml").unwrap();
//! let mut decoder = LineDecoder::new(model, axis);
//! let mut events = VecDeque::new();
//! decoder.decode("2026-03-02T10:00:00.000Z|Xact|12.5|Xload|25", &mut events).unwrap();
//! let values: Vec<(Quantity, f64)> = events
//!     .iter()
//!     .filter_map(|e| match e {
//!         Event::Sample { quantity, value, .. } => Some((*quantity, *value)),
//!         _ => None,
//!     })
//!     .collect();
//! assert_eq!(values.len(), 2);
//! assert!(values.iter().any(|&(q, v)| q == Quantity::Position && (v - 0.0125).abs() < 1e-12));
//! assert!(values
//!     .iter()
//!     .any(|&(q, v)| q == Quantity::Effort(EffortKind::TorqueNm) && (v - 2.0).abs() < 1e-12));
//! ```
#![warn(missing_docs)]
#![deny(clippy::float_cmp)]

pub mod mtconnect;
pub mod opcua;
pub mod source;
pub mod watch;

pub use source::{Event, GapReason, LiveError, Quantity, Source};
