//! MTConnect SHDR adapter logs: `timestamp|key|value|key|value…`, one line per adapter poll,
//! change-only (a key appears when its value changes).
//!
//! # What is read
//! - The timestamp ([`Timestamp::parse`]), optionally followed by `@duration` (ignored).
//! - Each key is looked up in the chosen device of the model ([`DeviceModel`]); its kind fixes
//!   how many fields follow ([`Shape`]): one for samples and events, five for a CONDITION
//!   (`level|nativeCode|nativeSeverity|qualifier|text`), two for a MESSAGE, five for an ALARM,
//!   three for a TIME_SERIES, so the next key is never taken from a value. A key that is not in
//!   the model takes one value (the agent's rule) and is counted in
//!   [`ShdrLog::unknown_keys`]. A key `device:key` is looked up in that device.
//! - In SHDR version 1 (the default; a `* shdrVersion: 2` line switches) an item whose last
//!   field is text (CONDITION, MESSAGE, ALARM) ends the line, and any further `|` belong to its
//!   text: a message with pipes keeps them. Quoted fields (`"a \| b"`) are unquoted and `\`
//!   escapes the next character, as the agent's tokenizer does.
//! - `UNAVAILABLE` (any case) is a gap: counted, no sample.
//! - Asset commands (`@ASSET@`, `@UPDATE_ASSET@`, `@REMOVE_ASSET@`, `@REMOVE_ALL_ASSETS@`) and
//!   the multi-line asset bodies (`--multiline--TAG` … `--multiline--TAG`) are skipped, as are
//!   `*` command lines and blank lines.
//!
//! # Errors
//! A malformed timestamp, a line with a timestamp and no key, and an item cut short (fewer
//! fields than its kind needs, e.g. a CONDITION line truncated mid-write) are errors naming the
//! file and line: a log that is damaged there may be damaged elsewhere, and a silent shift of
//! fields would turn text into numbers.
use std::collections::{BTreeMap, HashMap};
use std::path::Path;

use super::devices::{Category, DeviceModel, Shape};
use super::{read_text, shorten, split_lines, ChannelReport, ImportError, ImportReport, Imported};
use super::{LineEndings, Timestamp};
use feedscope::diag::{Code, Diagnostic};
use feedscope::trace::{Channel, EffortKind, RecordingFacts, Trace, MIN_SAMPLES};

/// Data items named in full in a message; the rest are counted.
const SHOWN_ITEMS: usize = 16;

/// Observations of one key.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct KeySeries {
    /// The key as written in the log (without a `device:` prefix).
    pub key: String,
    /// Index of its data item in the device, `None` when the model does not declare it.
    pub item: Option<usize>,
    /// Observations, `UNAVAILABLE` included.
    pub observations: usize,
    /// `UNAVAILABLE` observations.
    pub unavailable: usize,
    /// Earliest and latest observation time.
    pub first: Option<Timestamp>,
    /// See `first`.
    pub last: Option<Timestamp>,
    /// Numeric samples in file order (`None` = `UNAVAILABLE`); kept for single-valued SAMPLE
    /// items only.
    pub values: Vec<(Timestamp, Option<f64>)>,
    /// Observations of a SAMPLE item that were neither a number nor `UNAVAILABLE`.
    pub non_numeric: usize,
}

/// A parsed SHDR log.
#[derive(Debug, Clone)]
pub struct ShdrLog {
    /// The file.
    pub source_name: String,
    /// Index of the device in the model the log was read against.
    pub device: usize,
    /// How the device was chosen, in words.
    pub device_rule: String,
    /// Timestamp of the first data line (file order).
    pub first_line_time: Timestamp,
    /// Observations per key, by key.
    pub series: BTreeMap<String, KeySeries>,
    /// Keys not declared in the model, with their counts.
    pub unknown_keys: BTreeMap<String, usize>,
    /// Data lines read.
    pub data_lines: u64,
    /// Asset lines skipped (commands and multi-line bodies).
    pub asset_lines: u64,
    /// Observations of other devices (`device:key`), skipped.
    pub other_device_observations: u64,
    /// Line endings seen.
    pub endings: LineEndings,
    /// Stretches of the log whose data lines run forward in time; a new one starts where a
    /// line's timestamp is more than [`SEGMENT_BACKSTEP_S`] before the latest one so far.
    pub segments: Vec<Segment>,
}

/// A backward time step larger than this (s) between data lines starts a new [`Segment`]:
/// adapters stamp items of one poll up to ~0.1 s out of order, a new recording jumps by
/// minutes.
pub const SEGMENT_BACKSTEP_S: f64 = 1.0;

/// A stretch of a log written forward in time (one recording).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Segment {
    /// Its first line (1-based).
    pub first_line: u64,
    /// Earliest and latest timestamp of its data lines.
    pub start: Timestamp,
    /// See `start`.
    pub end: Timestamp,
    /// Data lines in it.
    pub lines: u64,
}

/// Where time 0 of the converted trace is (serialised as `first_line`, `first_sample`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TimeOrigin {
    /// The timestamp of the first data line of the file (shared by every axis converted from
    /// the same log).
    #[default]
    FirstLine,
    /// The first sample of the trace's own channels. Logs that open with a state dump stamped
    /// days earlier (the NIST logs do) otherwise start their trace days after time 0.
    FirstSample,
}

/// Options of [`ShdrLog::to_trace`].
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ShdrConvertParams {
    /// Position data item key; default: the axis's `POSITION` `ACTUAL` sample, in machine
    /// coordinates when there are several.
    pub position_key: Option<String>,
    /// Load data item key; default: the axis's only `LOAD` sample.
    pub load_key: Option<String>,
    /// Motor torque at 100 % load (N·m). Required: SHDR load is a percentage and feedscope
    /// will not guess a drive's rating.
    pub torque_per_load_nm: Option<f64>,
    /// Time 0 of the trace.
    pub time_origin: TimeOrigin,
}

/// Read and parse an SHDR log file against a device model.
///
/// # Errors
/// As [`parse_shdr`], and [`ImportError::Io`].
pub fn read_shdr(
    path: &Path,
    model: &DeviceModel,
    device: Option<&str>,
) -> Result<ShdrLog, ImportError> {
    let text = read_text(path)?;
    parse_shdr(&text, &path.display().to_string(), model, device)
}

/// Split an SHDR line into fields: on `|`, fields trimmed of white space; a field that starts
/// with `"` runs to the closing `"` before a `|` or the line end, `\` escaping the next
/// character, and is unquoted (the agent's tokenizer rules).
pub fn tokenize(line: &str) -> Vec<String> {
    let b = line.as_bytes();
    let mut out = Vec::new();
    let mut i = 0usize;
    loop {
        while i < b.len() && b[i].is_ascii_whitespace() && b[i] != b'|' {
            i += 1;
        }
        if i < b.len() && b[i] == b'"' {
            // Quoted: find the closing quote followed by `|` or the end.
            let mut s = String::new();
            let mut j = i + 1;
            let mut closed = None;
            while j < line.len() {
                let c = line[j..].chars().next().expect("in bounds");
                if c == '\\' && j + 1 < line.len() {
                    let n = line[j + 1..].chars().next().expect("in bounds");
                    s.push(n);
                    j += 1 + n.len_utf8();
                    continue;
                }
                if c == '"' {
                    let rest = line[j + 1..].trim_start();
                    if rest.is_empty() || rest.starts_with('|') {
                        closed = Some(line.len() - rest.len());
                        break;
                    }
                }
                if c == '|' {
                    break;
                }
                s.push(c);
                j += c.len_utf8();
            }
            if let Some(after) = closed {
                out.push(s);
                i = after;
                if i >= b.len() {
                    return out;
                }
                i += 1; // the `|`
                if i == b.len() {
                    out.push(String::new());
                    return out;
                }
                continue;
            }
            // No closing quote: an ordinary field (quote kept), as the agent does.
        }
        let end = memchr::memchr(b'|', &b[i..]).map_or(b.len(), |k| i + k);
        out.push(line[i..end].trim().to_string());
        if end == b.len() {
            return out;
        }
        i = end + 1;
        if i == b.len() {
            out.push(String::new());
            return out;
        }
    }
}

fn is_unavailable(s: &str) -> bool {
    s.eq_ignore_ascii_case("UNAVAILABLE")
}

/// Choose the device whose data items match the most distinct keys of the log (first key of
/// each line, which is a key whatever the items are).
fn choose_device(
    text: &str,
    source_name: &str,
    model: &DeviceModel,
    device: Option<&str>,
) -> Result<(usize, String), ImportError> {
    let dev_err = |reason: String| ImportError::Device {
        source_name: model.source_name.clone(),
        reason,
        found: model.devices_list(),
    };
    if let Some(w) = device {
        return model
            .find_device(w)
            .map(|d| (d, format!("--device {w}")))
            .ok_or_else(|| dev_err(format!("no device `{w}`")));
    }
    if model.devices.len() == 1 {
        return Ok((0, "the only device of the model".into()));
    }
    let mut keys = std::collections::HashSet::new();
    let mut endings = LineEndings::default();
    for (_, line) in split_lines(text, &mut endings) {
        let mut it = line.split('|');
        if let (Some(_), Some(k)) = (it.next(), it.next()) {
            let k = k.trim();
            if !k.is_empty() && !k.starts_with('@') && !k.contains(':') {
                keys.insert(k);
            }
        }
    }
    let score: Vec<usize> = model
        .devices
        .iter()
        .map(|d| keys.iter().filter(|k| d.find_item(k).is_some()).count())
        .collect();
    if keys.is_empty() {
        // No data line at all: say so rather than that no key matched.
        return Err(ImportError::Empty {
            source_name: source_name.to_string(),
        });
    }
    let best = *score.iter().max().unwrap_or(&0);
    if best == 0 {
        return Err(dev_err(format!(
            "none of the {} keys of {source_name} is declared in any device",
            keys.len()
        )));
    }
    let winners: Vec<usize> = (0..score.len()).filter(|&i| score[i] == best).collect();
    if winners.len() > 1 {
        return Err(dev_err(format!(
            "the keys of {source_name} match devices {} equally well ({best} keys each); \
             choose one with --device",
            winners
                .iter()
                .map(|&i| model.devices[i].label())
                .collect::<Vec<_>>()
                .join(", ")
        )));
    }
    let d = winners[0];
    Ok((
        d,
        format!(
            "{best} of {} keys of the log are its data items",
            keys.len()
        ),
    ))
}

/// Parse an SHDR log held in memory; `device` names the model's device (name, id or uuid),
/// `None` picks the device whose data items match the most keys.
///
/// # Errors
/// [`ImportError::Empty`] when there is no data line, [`ImportError::BadTimestamp`],
/// [`ImportError::Malformed`] and [`ImportError::TruncatedItem`] with the line, and
/// [`ImportError::Device`] when no device fits.
pub fn parse_shdr(
    text: &str,
    source_name: &str,
    model: &DeviceModel,
    device: Option<&str>,
) -> Result<ShdrLog, ImportError> {
    check_looks_like_shdr(text, source_name)?;
    let (dev, device_rule) = choose_device(text, source_name, model, device)?;
    let device_model = &model.devices[dev];
    let mut log = ShdrLog {
        source_name: source_name.to_string(),
        device: dev,
        device_rule,
        first_line_time: Timestamp {
            unix_s: 0,
            nanos: 0,
        },
        series: BTreeMap::new(),
        unknown_keys: BTreeMap::new(),
        data_lines: 0,
        asset_lines: 0,
        other_device_observations: 0,
        endings: LineEndings::default(),
        segments: Vec::new(),
    };
    let mut latest: Option<Timestamp> = None;
    let mut have_first = false;
    let mut version = 1u32;
    let mut multiline: Option<String> = None;
    // Index of each key's series, to avoid a BTreeMap lookup per observation.
    let mut index: HashMap<String, KeySeries> = HashMap::new();
    let mut endings = LineEndings::default();
    for (line_no, line) in split_lines(text, &mut endings) {
        if let Some(tag) = &multiline {
            log.asset_lines += 1;
            if line.trim() == tag {
                multiline = None;
            }
            continue;
        }
        let trimmed = line.trim();
        if trimmed.is_empty() {
            continue;
        }
        if let Some(cmd) = trimmed.strip_prefix('*') {
            // Agent commands: only the protocol version matters here.
            if let Some(v) = cmd.trim().strip_prefix("shdrVersion:") {
                version = v.trim().parse().unwrap_or(1);
            }
            continue;
        }
        let tokens = tokenize(line);
        let ts_text = tokens[0].split('@').next().unwrap_or("");
        let time = Timestamp::parse(ts_text).map_err(|reason| ImportError::BadTimestamp {
            source_name: source_name.to_string(),
            line: line_no,
            text: shorten(&tokens[0]),
            reason,
        })?;
        if tokens.len() < 2 || tokens[1].is_empty() {
            return Err(ImportError::Malformed {
                source_name: source_name.to_string(),
                line: line_no,
                reason: "a timestamp and no data item key".into(),
            });
        }
        if tokens[1].starts_with('@') {
            // Asset commands take the rest of the line; a body may continue on later lines.
            log.asset_lines += 1;
            if let Some(tag) = tokens.last().filter(|t| t.starts_with("--multiline--")) {
                multiline = Some(tag.clone());
            }
            continue;
        }
        if !have_first {
            log.first_line_time = time;
            have_first = true;
        }
        log.data_lines += 1;
        let new_segment = latest.is_none_or(|l| l.seconds_since(&time) > SEGMENT_BACKSTEP_S);
        if new_segment {
            log.segments.push(Segment {
                first_line: line_no,
                start: time,
                end: time,
                lines: 0,
            });
            latest = Some(time);
        }
        let seg = log.segments.last_mut().expect("pushed above");
        seg.start = seg.start.min(time);
        seg.end = seg.end.max(time);
        seg.lines += 1;
        latest = latest.map(|l| l.max(time));
        let mut i = 1usize;
        while i < tokens.len() {
            let raw_key = tokens[i].as_str();
            if raw_key.is_empty() && i + 1 == tokens.len() {
                break; // a trailing `|`
            }
            let (dev_prefix, key) = match raw_key.split_once(':') {
                Some((d, k)) => (Some(d), k),
                None => (None, raw_key),
            };
            let (owner, mine) = match dev_prefix.and_then(|d| model.find_device(d)) {
                Some(d) => (&model.devices[d], d == dev),
                None => (device_model, true),
            };
            let item = owner.find_item(key);
            let shape = item.map_or(Shape::Single, |k| owner.items[k].shape());
            let need = shape.fields();
            let have = tokens.len() - i - 1;
            let first_value = tokens.get(i + 1).map(String::as_str).unwrap_or("");
            let consumed = if have >= need {
                need
            } else if have >= 1 && is_unavailable(first_value) && shape != Shape::Single {
                // `cond|UNAVAILABLE` at the end of a line: a gap written short.
                have
            } else {
                return Err(ImportError::TruncatedItem {
                    source_name: source_name.to_string(),
                    line: line_no,
                    key: raw_key.to_string(),
                    kind: shape.name(),
                    expected: need,
                    found: have,
                });
            };
            if !mine {
                log.other_device_observations += 1;
            } else {
                let entry = index.entry(key.to_string()).or_insert_with(|| KeySeries {
                    key: key.to_string(),
                    item,
                    ..KeySeries::default()
                });
                entry.observations += 1;
                entry.first = Some(entry.first.map_or(time, |f| f.min(time)));
                entry.last = Some(entry.last.map_or(time, |l| l.max(time)));
                let numeric = item.is_some_and(|k| {
                    let it = &device_model.items[k];
                    it.category == Category::Sample && shape == Shape::Single
                });
                if is_unavailable(first_value) {
                    entry.unavailable += 1;
                    if numeric {
                        entry.values.push((time, None));
                    }
                } else if numeric {
                    match first_value.parse::<f64>() {
                        Ok(v) if v.is_finite() => entry.values.push((time, Some(v))),
                        _ => entry.non_numeric += 1,
                    }
                }
                if item.is_none() {
                    *log.unknown_keys.entry(key.to_string()).or_insert(0) += 1;
                }
            }
            if version < 2 && shape.ends_in_text() {
                // Old SHDR: the text field is last on the line and may hold `|`.
                break;
            }
            i += 1 + consumed;
        }
    }
    log.endings = endings;
    if !have_first {
        return Err(ImportError::Empty {
            source_name: source_name.to_string(),
        });
    }
    log.series = index.into_iter().collect();
    Ok(log)
}

/// Refuse text whose first data line is no SHDR line (no `|`): a CSV or another log given by
/// mistake would otherwise fail later with a message about timestamps or devices.
fn check_looks_like_shdr(text: &str, source_name: &str) -> Result<(), ImportError> {
    let mut endings = LineEndings::default();
    let first = split_lines(text, &mut endings).find(|(_, l)| {
        // Agent commands (`*`), and the comments a CSV trace opens with (`#`).
        let t = l.trim_start();
        !t.is_empty() && !t.starts_with('*') && !t.starts_with('#')
    });
    let Some((line, l)) = first else {
        return Ok(()); // empty: said as such by the parser
    };
    // A lone timestamp is an SHDR line cut short; the parser names what is missing.
    if l.contains('|') || Timestamp::parse(l.trim()).is_ok() {
        return Ok(());
    }
    let hint = if l.contains(',') || l.contains(';') {
        " It looks like CSV: a feedscope trace (`time_s,channel,value`) is read directly by \
         `feedscope estimate`; a UMich mill CSV converts with `feedscope import umich`."
    } else {
        ""
    };
    Err(ImportError::Malformed {
        source_name: source_name.to_string(),
        line,
        reason: format!(
            "not an MTConnect SHDR log: `{}` has no `|`; SHDR lines are \
             `timestamp|key|value|…`, e.g. `2022-08-08T13:51:34.716Z|Zabs|123.456`.{hint}",
            shorten(l.trim())
        ),
    })
}

/// The text field of a multi-field item in SHDR version 1: the fields from `start` joined by `|`
/// (the pipes were part of the text).
pub fn text_from(tokens: &[String], start: usize) -> String {
    tokens.get(start..).map(|t| t.join("|")).unwrap_or_default()
}

/// The position and load data items of one axis and the torque per percent of load, chosen by
/// the rules of [`ShdrLog::to_trace`] (shared with the live MTConnect sources).
#[derive(Debug, Clone, PartialEq)]
pub struct AxisItems {
    /// Index of the axis in [`super::devices::Device::axes`].
    pub axis: usize,
    /// Index of the position item in [`super::devices::Device::items`].
    pub position: usize,
    /// Index of the load item.
    pub load: usize,
    /// Motor torque at 100 % load (N·m), checked positive: a load value `L` (%) is a torque
    /// of `L / 100 × torque_per_load_nm`.
    pub torque_per_load_nm: f64,
    /// What was assumed (units not declared).
    pub warnings: Vec<Diagnostic>,
}

/// Choose the position and load items of `axis` in device `device` of `model`: the explicit
/// keys when given, else the axis's `POSITION` `ACTUAL` sample (machine coordinates when there
/// are several) and its only `LOAD` sample; check their units (mm, %) and the required torque
/// scale. `source_name` names the data source in [`ImportError::NeedTorqueScale`].
///
/// # Errors
/// As [`ShdrLog::to_trace`], apart from the sample counts.
pub fn axis_items(
    model: &DeviceModel,
    device: usize,
    axis: &str,
    position_key: Option<&str>,
    load_key: Option<&str>,
    torque_per_load_nm: Option<f64>,
    source_name: &str,
) -> Result<AxisItems, ImportError> {
    let dev = &model.devices[device];
    let a = dev.find_axis(axis, &model.source_name)?;
    let ax = &dev.axes[a];
    let item_err = |reason: String| ImportError::Item {
        source_name: model.source_name.clone(),
        axis: ax.label().to_string(),
        reason,
    };
    // Names in a message: each once, at most SHOWN_ITEMS, then a count (a model may
    // declare thousands of items on an axis).
    let shown = |names: Vec<String>| {
        let mut seen = std::collections::HashSet::new();
        let unique: Vec<String> = names
            .into_iter()
            .filter(|n| seen.insert(n.clone()))
            .collect();
        let more = unique.len().saturating_sub(SHOWN_ITEMS);
        let mut text = unique
            .into_iter()
            .take(SHOWN_ITEMS)
            .collect::<Vec<_>>()
            .join(", ");
        if more > 0 {
            text.push_str(&format!(" and {more} more"));
        }
        text
    };
    let list = |v: &[usize]| shown(v.iter().map(|&k| dev.items[k].key().to_string()).collect());
    let all_items = || {
        shown(
            ax.items
                .iter()
                .map(|&k| format!("{} ({})", dev.items[k].key(), dev.items[k].type_label()))
                .collect(),
        )
    };
    let pick = |wanted: &Option<String>,
                what: &str,
                option: &str,
                ok: &dyn Fn(usize) -> bool,
                prefer: &dyn Fn(usize) -> bool|
     -> Result<usize, ImportError> {
        if let Some(w) = wanted {
            return match dev.find_item(w) {
                Some(k) => Ok(k),
                None => Err(item_err(format!(
                    "{option} {w}: no such data item in device {}",
                    dev.label()
                ))),
            };
        }
        let cands: Vec<usize> = ax.items.iter().copied().filter(|&k| ok(k)).collect();
        let preferred: Vec<usize> = cands.iter().copied().filter(|&k| prefer(k)).collect();
        match (cands.as_slice(), preferred.as_slice()) {
            ([], _) => Err(item_err(format!(
                "no {what} data item (items: {}); choose one with {option}",
                if ax.items.is_empty() {
                    "none".to_string()
                } else {
                    all_items()
                }
            ))),
            ([k], _) | (_, [k]) => Ok(*k),
            (many, _) => Err(item_err(format!(
                "several {what} data items ({}); choose one with {option}",
                list(many)
            ))),
        }
    };
    let it = |k: usize| &dev.items[k];
    let pos = pick(
        &position_key.map(str::to_string),
        "POSITION (ACTUAL)",
        "--position-key",
        &|k| {
            it(k).category == Category::Sample
                && it(k).type_name == "POSITION"
                && it(k).sub_type.as_deref().is_none_or(|s| s == "ACTUAL")
        },
        &|k| it(k).coordinate_system.as_deref() == Some("MACHINE"),
    )?;
    let load = pick(
        &load_key.map(str::to_string),
        "LOAD",
        "--load-key",
        &|k| it(k).category == Category::Sample && it(k).type_name == "LOAD",
        &|_| false,
    )?;
    let mut warnings = Vec::new();
    match it(pos).units.as_deref() {
        Some("MILLIMETER") => {}
        None => warnings.push(Diagnostic::new(
            Code::PositionUnitsAssumed,
            format!(
                "{} declares no units; taken as MILLIMETER (the MTConnect unit of POSITION)",
                it(pos).key()
            ),
        )),
        Some(u) => {
            return Err(item_err(format!(
                "{} is in {u}; feedscope traces need a linear position in MILLIMETER{}",
                it(pos).key(),
                if ax.kind == "Rotary" {
                    " (this is a rotary axis)"
                } else {
                    ""
                }
            )))
        }
    }
    match it(load).units.as_deref() {
        Some("PERCENT") | None => {}
        Some(u) => {
            return Err(item_err(format!(
                "{} is in {u}; only PERCENT load is converted",
                it(load).key()
            )))
        }
    }
    let scale = match torque_per_load_nm {
        None => {
            return Err(ImportError::NeedTorqueScale {
                source_name: source_name.to_string(),
                load_key: it(load).key().to_string(),
            })
        }
        Some(x) if x.is_finite() && x > 0.0 => x,
        Some(x) => {
            return Err(ImportError::BadParam(format!(
                "--torque-per-load-nm {x} must be a positive torque"
            )))
        }
    };
    Ok(AxisItems {
        axis: a,
        position: pos,
        load,
        torque_per_load_nm: scale,
        warnings,
    })
}

impl ShdrLog {
    /// True when the spans of two segments overlap (a recording may still fit in a pause of
    /// another; [`ChannelReport::interleaved`] tells whether samples really interleave).
    pub fn segments_overlap(&self) -> bool {
        let mut v: Vec<(Timestamp, Timestamp)> =
            self.segments.iter().map(|g| (g.start, g.end)).collect();
        v.sort();
        v.windows(2).any(|w| w[1].0 < w[0].1)
    }

    /// The device the log was read against.
    pub fn device<'m>(&self, model: &'m DeviceModel) -> &'m super::devices::Device {
        &model.devices[self.device]
    }

    /// Convert the position and load of one axis into a trace (position in m, torque in N·m,
    /// time in s from [`ShdrConvertParams::time_origin`]).
    ///
    /// Samples stay where the log has them (no forward fill): a change-only log writes a value
    /// when it changes, so between two samples the true value held and then jumped, while a
    /// trace reader interpolates. Repeated timestamps keep the last value; samples earlier than
    /// the channel's previous one are dropped; both are counted in the report.
    ///
    /// # Errors
    /// [`ImportError::UnknownAxis`] listing the axes; [`ImportError::Item`] when the axis has no
    /// position or load item, several and no choice, or units that are not mm / %;
    /// [`ImportError::NeedTorqueScale`] without `torque_per_load_nm`;
    /// [`ImportError::TooFewSamples`] when a channel has fewer than [`MIN_SAMPLES`].
    pub fn to_trace(
        &self,
        model: &DeviceModel,
        axis: &str,
        params: &ShdrConvertParams,
    ) -> Result<Imported, ImportError> {
        let dev = self.device(model);
        let AxisItems {
            position: pos,
            load,
            torque_per_load_nm: scale,
            mut warnings,
            ..
        } = axis_items(
            model,
            self.device,
            axis,
            params.position_key.as_deref(),
            params.load_key.as_deref(),
            params.torque_per_load_nm,
            &self.source_name,
        )?;
        let it = |k: usize| &dev.items[k];
        let empty = Vec::new();
        let values = |k: usize| {
            self.series
                .get(dev.items[k].key())
                .map_or(&empty, |s| &s.values)
        };
        let (pv, lv) = (values(pos), values(load));
        let origin = match params.time_origin {
            TimeOrigin::FirstLine => self.first_line_time,
            TimeOrigin::FirstSample => pv
                .iter()
                .chain(lv.iter())
                .filter(|(_, v)| v.is_some())
                .map(|(t, _)| *t)
                .min()
                .unwrap_or(self.first_line_time),
        };
        let (position_m, mut prep) = build_channel(pv, &origin, 1e-3);
        let (effort, mut lrep) = build_channel(lv, &origin, scale / 100.0);
        prep.source_key = format!(
            "{} (POSITION {}, mm{})",
            it(pos).key(),
            it(pos).sub_type.as_deref().unwrap_or(""),
            it(pos)
                .coordinate_system
                .as_deref()
                .map(|c| format!(", {c} coordinates"))
                .unwrap_or_default()
        );
        lrep.source_key = format!("{} (LOAD, %)", it(load).key());
        for (ch, rep) in [(&position_m, &prep), (&effort, &lrep)] {
            if ch.len() < MIN_SAMPLES {
                return Err(ImportError::TooFewSamples {
                    source_name: self.source_name.clone(),
                    channel: rep.source_key.clone(),
                    found: ch.len(),
                    needed: MIN_SAMPLES,
                });
            }
        }
        warnings.push(Diagnostic::new(
            Code::LoadWholePercent,
            format!(
                "load is integer percent: torque is quantised in steps of 1 % = {:.4} N·m",
                scale / 100.0
            ),
        ));
        if effort.value.iter().all(|&v| v >= 0.0) {
            warnings.push(Diagnostic::new(
                Code::LoadUnsigned,
                "the load is never negative: drives usually report its magnitude, so the torque \
                 sign (and the sign of friction on backward strokes) is lost",
            ));
        }
        if self.segments.len() > 1 {
            warnings.push(Diagnostic::new(
                Code::PiecedRecording,
                format!(
                    "the log is pieced together from {} recordings (time jumps back at lines {}); \
                 samples were put in time order, with gaps between the recordings",
                    self.segments.len(),
                    self.segments[1..]
                        .iter()
                        .map(|g| g.first_line.to_string())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            ));
        }
        for (rep, what) in [(&prep, "position"), (&lrep, "load")] {
            if rep.interleaved {
                warnings.push(Diagnostic::new(
                    Code::RecordingsInterleave,
                    format!(
                        "{what}: recordings of the log overlap in time and their samples \
                     interleave; check the trace before estimating"
                    ),
                ));
            }
        }
        let t0_lag = prep.span_s.0.min(lrep.span_s.0);
        if t0_lag > 3600.0 {
            warnings.push(Diagnostic::new(
                Code::FirstLineLongBefore,
                format!(
                    "the first line of the log is {:.1} h before the first sample of this axis \
                 (a state dump?); --time-origin trace starts the trace at its first sample",
                    t0_lag / 3600.0
                ),
            ));
        }
        let unsigned = effort.value.iter().all(|&v| v >= 0.0);
        // A spindle that turns anywhere in the log means the program may cut: the load then
        // holds process forces besides friction.
        let spindle = self
            .series
            .iter()
            .filter(|(_, s)| {
                s.item.is_some_and(|k| {
                    let t = dev.items[k].type_name.as_str();
                    dev.items[k].category == Category::Sample
                        && (t == "ROTARY_VELOCITY" || t == "SPINDLE_SPEED")
                })
            })
            .filter_map(|(key, s)| {
                let top = s
                    .values
                    .iter()
                    .filter_map(|(_, v)| *v)
                    .fold(0.0_f64, |m, v| m.max(v.abs()));
                (top > 0.0).then(|| (key.clone(), top))
            })
            .max_by(|a, b| a.1.total_cmp(&b.1));
        if let Some((key, top)) = &spindle {
            warnings.push(Diagnostic::new(
                Code::ProcessLoad,
                format!(
                "a spindle turns in this log ({key} up to {top:.0}/min): the program may cut, so \
                 the load may hold process forces besides friction; only mean levels are \
                 reported as upper bounds"
            ),
            ));
        }
        let trace = Trace {
            position_m,
            effort,
            effort_kind: EffortKind::TorqueNm,
            // What the log knows and the samples alone would not say: whole-percent load
            // (a magnitude when never negative), pieced from several recordings.
            facts: RecordingFacts {
                effort_quantum: Some(scale / 100.0),
                effort_signed: unsigned.then_some(false),
                process_load: spindle.is_some().then_some(true),
                recordings: Some(self.segments.len().max(1)),
            },
        };
        let mut report = ImportReport {
            source_name: self.source_name.clone(),
            time_zero: Some(origin),
            time_zero_rule: match params.time_origin {
                TimeOrigin::FirstLine => "first data line of the log".into(),
                TimeOrigin::FirstSample => "first sample of this trace".into(),
            },
            position: prep,
            effort: lrep,
            effort_rule: format!(
                "torque_nm = {} (%) / 100 × {scale} N·m (--torque-per-load-nm)",
                it(load).key()
            ),
            warnings,
        };
        super::sampling_warnings(&mut report, &trace);
        let imported = Imported { trace, report };
        super::check_limits(&imported)?;
        Ok(imported)
    }
}

/// Build a channel from numeric observations in file order: gaps skipped, the samples put in
/// time order (a stable sort, so of samples with the same timestamp the one written last is
/// kept), values multiplied by `scale`.
fn build_channel(
    obs: &[(Timestamp, Option<f64>)],
    origin: &Timestamp,
    scale: f64,
) -> (Channel, ChannelReport) {
    let mut rep = ChannelReport::default();
    // (time, value, run): a run is this channel's own stretch written forward in time, split
    // as the log's segments are. After sorting, a recording that fits in a pause of another
    // switches runs twice; runs alternating more often than 3 times per run means two
    // recordings cover the same time sample by sample.
    let mut avail: Vec<(Timestamp, f64, usize)> = Vec::with_capacity(obs.len());
    // Latest time written so far (for `reordered`) and latest of the current run.
    let mut latest: Option<Timestamp> = None;
    let mut latest_run: Option<Timestamp> = None;
    let mut run = 0usize;
    for &(t, v) in obs {
        let Some(v) = v else {
            rep.unavailable += 1;
            continue;
        };
        if latest.is_some_and(|l| t < l) {
            rep.reordered += 1;
        }
        latest = Some(latest.map_or(t, |l| l.max(t)));
        if latest_run.is_some_and(|l| l.seconds_since(&t) > SEGMENT_BACKSTEP_S) {
            run += 1;
            latest_run = Some(t);
        }
        latest_run = Some(latest_run.map_or(t, |l| l.max(t)));
        avail.push((t, v, run));
    }
    avail.sort_by_key(|&(t, _, _)| t);
    let switches = avail.windows(2).filter(|w| w[0].2 != w[1].2).count();
    rep.interleaved = switches > 3 * (run + 1);
    let mut ch = Channel::default();
    let mut last: Option<Timestamp> = None;
    for (t, v, _) in avail {
        if last == Some(t) {
            rep.repeated_times += 1;
            *ch.value.last_mut().expect("a previous sample") = v * scale;
        } else {
            ch.time_s.push(t.seconds_since(origin));
            ch.value.push(v * scale);
            last = Some(t);
        }
    }
    rep.finish(&ch);
    (ch, rep)
}

#[cfg(test)]
mod tests {
    use super::*;

    const MODEL: &str = r#"<MTConnectDevices><Devices>
      <Device id="m" name="mill"><Components>
        <Axes id="ax"><Components>
          <Linear id="lx" name="X"><DataItems>
            <DataItem id="xp" name="Xabs" category="SAMPLE" type="POSITION" subType="ACTUAL" units="MILLIMETER"/>
            <DataItem id="xl" name="Xload" category="SAMPLE" type="LOAD" units="PERCENT"/>
          </DataItems></Linear>
          <Rotary id="rc" name="C"><DataItems>
            <DataItem id="cp" name="Cdeg" category="SAMPLE" type="ANGLE" subType="ACTUAL" units="DEGREE"/>
          </DataItems></Rotary>
        </Components></Axes>
        <Controller id="c"><DataItems>
          <DataItem id="sys" name="system" category="CONDITION" type="SYSTEM"/>
          <DataItem id="msg" name="message" category="EVENT" type="MESSAGE"/>
          <DataItem id="alm" name="alarm" category="EVENT" type="ALARM"/>
          <DataItem id="exe" name="execution" category="EVENT" type="EXECUTION"/>
          <DataItem id="ts" name="vib" category="SAMPLE" type="DISPLACEMENT" representation="TIME_SERIES"/>
        </DataItems></Controller>
      </Components></Device>
    </Devices></MTConnectDevices>"#;

    fn model() -> DeviceModel {
        DeviceModel::parse(MODEL, "Devices.xml").unwrap()
    }

    fn parse(text: &str) -> Result<ShdrLog, ImportError> {
        parse_shdr(text, "log.txt", &model(), None)
    }

    #[test]
    fn tokenizer_quotes_escapes_and_trailing_pipe() {
        assert_eq!(tokenize("a|b||c"), ["a", "b", "", "c"]);
        assert_eq!(tokenize("a|NORMAL||||"), ["a", "NORMAL", "", "", "", ""]);
        assert_eq!(tokenize(r#"a|"x \| y"|b"#), ["a", "x | y", "b"]);
        assert_eq!(tokenize(r#"a| "quoted" |b"#), ["a", "quoted", "b"]);
        // No closing quote: the field is taken as it stands.
        assert_eq!(tokenize(r#"a|"open|b"#), ["a", "\"open", "b"]);
        assert_eq!(tokenize(" a | b "), ["a", "b"]);
    }

    #[test]
    fn condition_fields_never_shift_into_keys() {
        // The CONDITION takes 5 fields; `Xabs` after it must not be read as a value of `system`
        // (shdrVersion 2: several items per line).
        let log = parse(
            "* shdrVersion: 2\n\
             2024-01-01T00:00:00Z|system|FAULT|E12|HIGH|OVERLOAD|servo overload|Xabs|12.5\n",
        )
        .unwrap();
        assert_eq!(log.series["system"].observations, 1);
        assert_eq!(
            log.series["Xabs"].values,
            vec![(log.first_line_time, Some(12.5))]
        );
        assert!(log.unknown_keys.is_empty());
    }

    #[test]
    fn message_with_pipes_keeps_its_text_in_version_1() {
        let log = parse(
            "2024-01-01T00:00:00Z|Xabs|1.0\n\
             2024-01-01T00:00:01Z|message|M42|tool|change|now\n\
             2024-01-01T00:00:02Z|alarm|OTHER|7|CRITICAL|ACTIVE|a|b\n",
        )
        .unwrap();
        assert_eq!(log.series["message"].observations, 1);
        assert_eq!(log.series["alarm"].observations, 1);
        // `change` and `now` were text, not keys.
        assert!(log.unknown_keys.is_empty(), "{:?}", log.unknown_keys);
        let t = tokenize("ts|message|M42|tool|change|now");
        assert_eq!(text_from(&t, 3), "tool|change|now");
    }

    #[test]
    fn unavailable_is_a_gap_and_time_series_takes_three_fields() {
        let log = parse(
            "2024-01-01T00:00:00.25Z|Xabs|UNAVAILABLE|Xload|unavailable|system|UNAVAILABLE\n\
             2024-01-01T00:00:01Z|vib|3|100|1 2 3|Xabs|2\n\
             2024-01-01T00:00:02Z|execution|ACTIVE|Xabs|3|mystery|9|Xload|4\n",
        )
        .unwrap();
        let x = &log.series["Xabs"];
        assert_eq!((x.observations, x.unavailable), (3, 1));
        assert_eq!(x.values[0].1, None);
        assert_eq!(x.values[1].1, Some(2.0));
        assert_eq!(log.series["Xload"].unavailable, 1);
        assert_eq!(log.series["system"].unavailable, 1);
        assert_eq!(log.unknown_keys["mystery"], 1);
        assert_eq!(log.series["Xload"].values[1].1, Some(4.0));
        assert_eq!(log.first_line_time.nanos, 250_000_000);
    }

    #[test]
    fn malformed_lines_name_the_line() {
        let e = parse("2024-01-01T00:00:00Z|Xabs|1\n2024-13-01T00:00:00Z|Xabs|2\n").unwrap_err();
        assert!(e.to_string().starts_with("log.txt:2: bad timestamp"), "{e}");
        let e = parse("2024-01-01T00:00:00Z|Xabs|1\n2024-01-01T00:00:01Z|system|FAULT|E1\n")
            .unwrap_err();
        assert!(
            matches!(
                e,
                ImportError::TruncatedItem {
                    line: 2,
                    expected: 5,
                    found: 2,
                    ..
                }
            ),
            "{e}"
        );
        let e = parse("\n\n").unwrap_err();
        assert!(matches!(e, ImportError::Empty { .. }), "{e}");
        let e = parse("2024-01-01T00:00:00Z\n").unwrap_err();
        assert!(e.to_string().starts_with("log.txt:1: "), "{e}");
    }

    #[test]
    fn csv_is_not_taken_for_shdr() {
        let e = parse("# a trace\ntime_s,channel,value\n0.0,position_mm,1.0\n").unwrap_err();
        let m = e.to_string();
        assert!(m.starts_with("log.txt:2: not an MTConnect SHDR log"), "{m}");
        assert!(
            m.contains("timestamp|key|value") && m.contains("looks like CSV"),
            "{m}"
        );
        assert!(e.kind() == feedscope::ErrorKind::BadInput);
    }

    #[test]
    fn assets_and_multiline_bodies_are_skipped() {
        let log = parse(
            "2024-01-01T00:00:00Z|Xabs|1\n\
             2023-01-01T00:00:00Z|@ASSET@|t1|CuttingTool|--multiline--AB\n\
             <CuttingTool toolId=\"1\">|not|data</CuttingTool>\n\
             --multiline--AB\n\
             2024-01-01T00:00:01Z|@REMOVE_ASSET@|t1\n\
             2024-01-01T00:00:02Z|Xabs|2\n",
        )
        .unwrap();
        assert_eq!(log.asset_lines, 4);
        assert_eq!(log.series["Xabs"].observations, 2);
        assert_eq!(log.data_lines, 2);
    }

    #[test]
    fn recordings_pieced_together_are_segments_and_come_out_in_time_order() {
        // A second recording that starts 5 s earlier; inside it a line stamped 0.1 s late
        // (poll jitter) is not a new segment.
        let text = "2024-01-01T10:00:05Z|Xabs|5|Xload|1\n\
                    2024-01-01T10:00:06Z|Xabs|6|Xload|1\n\
                    2024-01-01T10:00:07Z|Xabs|7|Xload|1\n\
                    2024-01-01T10:00:00Z|Xabs|0|Xload|2\n\
                    2024-01-01T10:00:01Z|Xabs|1|Xload|2\n\
                    2024-01-01T10:00:00.9Z|execution|ACTIVE\n\
                    2024-01-01T10:00:02Z|Xabs|2|Xload|2\n";
        let log = parse(text).unwrap();
        assert_eq!(log.segments.len(), 2);
        assert_eq!(log.segments[1].first_line, 4);
        assert_eq!(log.segments[1].lines, 4);
        assert!(!log.segments_overlap());
        let p = ShdrConvertParams {
            torque_per_load_nm: Some(10.0),
            ..Default::default()
        };
        let imp = log.to_trace(&model(), "X", &p).unwrap();
        let t = &imp.trace.position_m;
        assert_eq!(t.len(), 6);
        assert!(t.time_s.windows(2).all(|w| w[1] > w[0]));
        // Time 0 is the first line (10:00:05): the earlier recording comes out negative.
        assert!((t.time_s[0] + 5.0).abs() < 1e-12);
        assert_eq!(imp.report.position.reordered, 3);
        assert!(imp
            .report
            .warnings
            .iter()
            .any(|w| w.code == Code::PiecedRecording && w.message.contains("2 recordings")));
    }

    #[test]
    fn conversion_keeps_last_of_repeated_times_and_needs_the_torque_scale() {
        let text = "2024-01-01T00:00:00Z|Xabs|10|Xload|5\n\
                    2024-01-01T00:00:00.5Z|Xabs|11|Xload|6\n\
                    2024-01-01T00:00:00.5Z|Xload|7\n\
                    2024-01-01T00:00:01Z|Xabs|12|Xload|UNAVAILABLE\n\
                    2024-01-01T00:00:01.5Z|Xabs|13|Xload|8\n\
                    2024-01-01T00:00:02Z|Xabs|14|Xload|9\n";
        let log = parse(text).unwrap();
        let m = model();
        let e = log
            .to_trace(&m, "X", &ShdrConvertParams::default())
            .unwrap_err();
        assert!(e.to_string().contains("--torque-per-load-nm"), "{e}");
        let p = ShdrConvertParams {
            torque_per_load_nm: Some(10.0),
            ..Default::default()
        };
        let imp = log.to_trace(&m, "X", &p).unwrap();
        let t = &imp.trace;
        assert_eq!(t.position_m.len(), 5);
        assert_eq!(t.effort.len(), 4);
        assert_eq!(imp.report.effort.repeated_times, 1);
        assert_eq!(imp.report.effort.unavailable, 1);
        // 7 % of 10 N·m, the later of the two values at 0.5 s.
        assert!((t.effort.value[1] - 0.7).abs() < 1e-12);
        assert!((t.effort.time_s[1] - 0.5).abs() < 1e-12);
        assert!((t.position_m.value[4] - 0.014).abs() < 1e-15);
        let e = log.to_trace(&m, "C", &p).unwrap_err();
        assert!(e.to_string().contains("no POSITION"), "{e}");
        let e = log.to_trace(&m, "Q", &p).unwrap_err();
        assert!(
            e.to_string().contains("axes found: X (Linear, id lx), C"),
            "{e}"
        );
    }
}
