//! MTConnect: the SHDR adapter stream ([`shdr`]) and the agent's REST API ([`agent`]).
//!
//! Both choose the axis's items by the rules of `feedscope import shdr`
//! ([`feedscope_io::import::shdr::axis_items`]): the axis's `POSITION` `ACTUAL` sample (machine
//! coordinates when there are several) in MILLIMETER, its only `LOAD` sample in PERCENT, or the
//! keys given; the load becomes a torque with the required torque at 100 % load (feedscope never
//! guesses a drive's rating).
use std::time::{Duration, Instant};

use feedscope_io::import::devices::{Category, DeviceModel};
use feedscope_io::import::shdr::axis_items;
use feedscope_io::import::Timestamp;

use crate::source::LiveError;

pub mod agent;
pub mod shdr;

/// Which axis and items to follow, and how load converts to torque.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisSelection {
    /// Device name, id or uuid; `None`: the only device (SHDR: the device whose items match,
    /// as the importer; agent: the only device the agent serves).
    pub device: Option<String>,
    /// Axis name, id or native name (`X`, `Z1`).
    pub axis: String,
    /// Position data item key or id; default: the axis's `POSITION` `ACTUAL` sample.
    pub position_key: Option<String>,
    /// Load data item key or id; default: the axis's only `LOAD` sample.
    pub load_key: Option<String>,
    /// Motor torque at 100 % load (N·m). Required.
    pub torque_per_load_nm: Option<f64>,
}

/// The items of the chosen axis, resolved against a device model.
#[derive(Debug, Clone, PartialEq)]
pub struct ResolvedAxis {
    /// Index of the device in the model.
    pub device: usize,
    /// Device label (name, else id).
    pub device_label: String,
    /// Axis label.
    pub axis_label: String,
    /// Position item: (SHDR key, data item id).
    pub position: (String, String),
    /// Load item: (SHDR key, data item id).
    pub load: (String, String),
    /// Program item of the device (first `PROGRAM` event), if any: (key, id).
    pub program: Option<(String, String)>,
    /// N·m per % of load.
    pub torque_per_percent_nm: f64,
}

impl ResolvedAxis {
    /// Resolve `sel` in `model` (device `device` when the caller chose it already); `source`
    /// names the data source in messages.
    ///
    /// # Errors
    /// [`LiveError::Config`] with the importer's words (no such axis, device or item; missing
    /// or bad torque scale; units).
    pub fn resolve(
        model: &DeviceModel,
        device: usize,
        sel: &AxisSelection,
        source: &str,
    ) -> Result<Self, LiveError> {
        let items = axis_items(
            model,
            device,
            &sel.axis,
            sel.position_key.as_deref(),
            sel.load_key.as_deref(),
            sel.torque_per_load_nm,
            source,
        )
        .map_err(|e| LiveError::Config {
            file: model.source_name.clone(),
            field: format!("axis {}", sel.axis),
            reason: e.to_string(),
        })?;
        let dev = &model.devices[device];
        let pair = |k: usize| (dev.items[k].key().to_string(), dev.items[k].id.clone());
        let program = dev
            .items
            .iter()
            .position(|d| d.category == Category::Event && d.type_name == "PROGRAM")
            .map(pair);
        Ok(Self {
            device,
            device_label: dev.label().to_string(),
            axis_label: dev.axes[items.axis].label().to_string(),
            position: pair(items.position),
            load: pair(items.load),
            program,
            torque_per_percent_nm: items.torque_per_load_nm / 100.0,
        })
    }
}

/// Find a device by name, id or uuid, or the only one.
///
/// # Errors
/// [`LiveError::Config`] naming the devices there are.
pub fn choose_device(model: &DeviceModel, wanted: Option<&str>) -> Result<usize, LiveError> {
    let err = |reason: String| LiveError::Config {
        file: model.source_name.clone(),
        field: "device".into(),
        reason: format!("{reason} (devices: {})", model.devices_list()),
    };
    match wanted {
        Some(w) => model
            .find_device(w)
            .ok_or_else(|| err(format!("no device `{w}`"))),
        None if model.devices.len() == 1 => Ok(0),
        None => Err(err("several devices; choose one".into())),
    }
}

/// An MTConnect timestamp (ISO 8601 UTC) as s since the Unix epoch.
pub fn parse_time_s(text: &str) -> Option<f64> {
    let t = Timestamp::parse(text.split('@').next()?.trim()).ok()?;
    Some(t.unix_s as f64 + f64::from(t.nanos) * 1e-9)
}

/// Median of the last intervals between position samples (s): the stream's observed rate.
#[derive(Debug, Clone, Default)]
pub(crate) struct IntervalEstimate {
    last_s: Option<f64>,
    recent: std::collections::VecDeque<f64>,
}

impl IntervalEstimate {
    const KEEP: usize = 64;

    pub(crate) fn observe(&mut self, time_s: f64) {
        if let Some(l) = self.last_s {
            let d = time_s - l;
            if d > 0.0 {
                if self.recent.len() == Self::KEEP {
                    self.recent.pop_front();
                }
                self.recent.push_back(d);
            }
        }
        self.last_s = Some(time_s);
    }

    /// Forget the last time (after a gap the next interval would span it).
    pub(crate) fn break_here(&mut self) {
        self.last_s = None;
    }

    pub(crate) fn median_s(&self) -> Option<f64> {
        if self.recent.is_empty() {
            return None;
        }
        let mut v: Vec<f64> = self.recent.iter().copied().collect();
        v.sort_by(f64::total_cmp);
        Some(v[v.len() / 2])
    }
}

/// Doubling back-off between connection attempts, from `first` up to `max`.
#[derive(Debug, Clone)]
pub(crate) struct Backoff {
    first: Duration,
    max: Duration,
    current: Duration,
    /// When the next attempt may be made.
    pub(crate) next_try: Instant,
    /// Failed attempts in a row.
    pub(crate) failures: u32,
}

impl Backoff {
    pub(crate) fn new(first: Duration, max: Duration) -> Self {
        Self {
            first,
            max,
            current: first,
            next_try: Instant::now(),
            failures: 0,
        }
    }

    pub(crate) fn failed(&mut self) {
        self.failures += 1;
        self.next_try = Instant::now() + self.current;
        self.current = (self.current * 2).min(self.max);
    }

    pub(crate) fn succeeded(&mut self) {
        self.failures = 0;
        self.current = self.first;
    }

    pub(crate) fn delay(&self) -> Duration {
        self.current
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn times_and_intervals() {
        let t = parse_time_s("2022-08-08T13:51:34.716Z").unwrap();
        // 2022-08-08T00:00:00Z = 1659916800 s; µs tolerance for the f64 sum.
        assert!((t - (1_659_916_800.0 + 13.0 * 3600.0 + 51.0 * 60.0 + 34.716)).abs() < 1e-6);
        assert!(parse_time_s("yesterday").is_none());
        let mut e = IntervalEstimate::default();
        for (i, t) in [0.0, 0.3, 0.6, 1.0, 1.3].iter().enumerate() {
            e.observe(*t);
            assert_eq!(e.median_s().is_some(), i > 0);
        }
        assert!((e.median_s().unwrap() - 0.3).abs() < 1e-9);
    }
}
