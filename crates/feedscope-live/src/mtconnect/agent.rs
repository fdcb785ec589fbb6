//! The MTConnect agent's REST API: `/probe`, `/current`, then `/sample?from=N&count=M`
//! following the sequence numbers.
//!
//! - `/probe` is read as a device model ([`DeviceModel::parse`], namespace-agnostic, MTConnect
//!   1.x-2.x) and the axis's items are chosen as by `feedscope import shdr`.
//! - `/current` gives `instanceId` and `nextSequence`; from there each `/sample` starts at the
//!   previous answer's `nextSequence`, so no observation is skipped or read twice, and
//!   observations are handled in sequence order (several may share a timestamp).
//! - `OUT_OF_RANGE` (`from` has left the agent's buffer): a [`GapReason::Skipped`] with the
//!   number lost, and the client goes on from the buffer's `firstSequence`.
//! - A refused `count` (cppagent 2.x: `OUT_OF_RANGE` `'count' must be less than 257`, with a
//!   `QueryParameter name="count"` and its `Maximum` from schema 2.6; the PyPI `mtconnect`
//!   package: `Count must not be greater than 256`): told apart from the `from` case by the
//!   parameter it names, not by the code. The client lowers its count to the limit the error
//!   gives (else the header's `bufferSize`, else half), says so once in an [`Event::Notice`],
//!   waits one poll interval and reads on from the same `from`: nothing is lost, no gap.
//! - A new `instanceId` (the agent restarted, its sequence numbers start again): a
//!   [`GapReason::Restart`], and the client goes on from the new buffer's `firstSequence`.
//! - Timestamps of the axis's items stepping back more than [`SEGMENT_BACKSTEP_S`] (an
//!   adapter that restarted and replays its state, a clock reset): a
//!   [`GapReason::TimeStepBack`], as in the SHDR stream; a smaller step back of one channel
//!   drops that sample (counted in [`AgentStats::reordered`]).
//! - HTTP errors and timeouts: retried with a doubling back-off from the same `from`; an
//!   [`Event::Notice`] says so, and a gap follows only if data was lost meanwhile.
use std::collections::VecDeque;
use std::time::{Duration, Instant};

use feedscope::trace::EffortKind;
use feedscope_io::import::devices::DeviceModel;
use feedscope_io::import::shdr::SEGMENT_BACKSTEP_S;

use super::{parse_time_s, AxisSelection, Backoff, IntervalEstimate, ResolvedAxis};
use crate::source::{Event, GapReason, LiveError, Quantity, Source};

/// Settings of [`AgentSource`].
#[derive(Debug, Clone, PartialEq)]
pub struct AgentParams {
    /// Base URL of the agent, e.g. `http://127.0.0.1:5000`.
    pub url: String,
    /// Observations asked per `/sample`. Default 1000.
    pub count: u64,
    /// Wait between polls when the agent had nothing more. Default 0.25 s.
    pub poll: Duration,
    /// Timeout of one HTTP request. Default 5 s.
    pub timeout: Duration,
    /// Longest wait between retries. Default 30 s.
    pub max_backoff: Duration,
    /// Failed requests in a row before giving up; `None` (default) never.
    pub max_attempts: Option<u32>,
}

impl Default for AgentParams {
    fn default() -> Self {
        Self {
            url: "http://127.0.0.1:5000".into(),
            count: 1000,
            poll: Duration::from_millis(250),
            timeout: Duration::from_secs(5),
            max_backoff: Duration::from_secs(30),
            max_attempts: None,
        }
    }
}

/// The `Header` of an MTConnectStreams or MTConnectError document.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Header {
    /// `instanceId`.
    pub instance_id: String,
    /// `firstSequence`.
    pub first_sequence: Option<u64>,
    /// `nextSequence`.
    pub next_sequence: Option<u64>,
    /// `lastSequence`.
    pub last_sequence: Option<u64>,
    /// `bufferSize` (observations the agent keeps).
    pub buffer_size: Option<u64>,
}

/// One error of an MTConnectError document, in the legacy form (`<Error errorCode="…">text`)
/// or the schema 2.6 form (`<OutOfRange errorCode="…">` with `ErrorMessage` and
/// `QueryParameter`).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct AgentError {
    /// `errorCode`, e.g. `OUT_OF_RANGE`.
    pub code: String,
    /// The error's text (the element's own text, or its `ErrorMessage`).
    pub text: String,
    /// `QueryParameter/@name`, when given (schema 2.6+).
    pub parameter: Option<String>,
    /// `QueryParameter/Maximum`, when given (schema 2.6+).
    pub maximum: Option<i64>,
}

impl AgentError {
    /// When this error refuses the `count` of a request: the largest count it allows, if it
    /// says (`QueryParameter/Maximum`; cppagent's `'count' must be less than N` gives N − 1;
    /// the `mtconnect` package's `Count must not be greater than N` gives N). `None` when the
    /// error is about something else (e.g. `'from' must be greater than 499`).
    pub fn refused_count(&self) -> Option<Option<u64>> {
        let text = self
            .text
            .trim()
            .trim_start_matches(['\'', '"'])
            .to_lowercase();
        let about_count = match &self.parameter {
            Some(p) => p == "count",
            None => text.starts_with("count"),
        };
        if !about_count {
            return None;
        }
        let number_after = |key: &str| -> Option<i64> {
            let rest = &text[text.find(key)? + key.len()..];
            let digits: String = rest
                .trim_start()
                .chars()
                .take_while(|c| c.is_ascii_digit() || *c == '-')
                .collect();
            digits.parse().ok()
        };
        let limit = self
            .maximum
            .or_else(|| {
                number_after("not be greater than").or(number_after("less than").map(|n| n - 1))
            })
            .filter(|&n| n >= 1)
            .map(|n| n as u64);
        Some(limit)
    }
}

/// One observation of a streams document.
#[derive(Debug, Clone, PartialEq)]
pub struct Observation {
    /// `sequence`.
    pub sequence: u64,
    /// `dataItemId`.
    pub data_item_id: String,
    /// `name`, when given.
    pub name: Option<String>,
    /// `timestamp` (s since the epoch).
    pub time_s: f64,
    /// The element's text.
    pub value: String,
}

/// A parsed answer of `/current` or `/sample`.
#[derive(Debug, Clone, PartialEq)]
pub enum Streams {
    /// `MTConnectStreams`: the header and the observations of the device, in sequence order.
    Data(Header, Vec<Observation>),
    /// `MTConnectError`: the header (if any) and the errors.
    Error(Option<Header>, Vec<AgentError>),
}

fn attr_u64(n: roxmltree::Node<'_, '_>, a: &str) -> Option<u64> {
    n.attribute(a).and_then(|v| v.trim().parse().ok())
}

/// Parse an MTConnectStreams or MTConnectError document (any namespace, 1.x-2.x); only the
/// streams of the device `device` (name, uuid or id; all devices when `None`) are kept.
///
/// # Errors
/// The XML parser's words, or what is missing.
pub fn parse_streams(xml: &str, device: Option<&str>) -> Result<Streams, String> {
    let doc = roxmltree::Document::parse(xml).map_err(|e| e.to_string())?;
    let root = doc.root_element();
    let header = root
        .children()
        .find(|n| n.is_element() && n.tag_name().name() == "Header")
        .map(|h| Header {
            instance_id: h.attribute("instanceId").unwrap_or("").to_string(),
            first_sequence: attr_u64(h, "firstSequence"),
            next_sequence: attr_u64(h, "nextSequence"),
            last_sequence: attr_u64(h, "lastSequence"),
            buffer_size: attr_u64(h, "bufferSize"),
        });
    match root.tag_name().name() {
        "MTConnectError" => {
            let child_text = |n: roxmltree::Node<'_, '_>, tag: &str| {
                n.descendants()
                    .find(|c| c.is_element() && c.tag_name().name() == tag)
                    .and_then(|c| c.text())
                    .map(|t| t.trim().to_string())
            };
            // Every element with an errorCode under <Errors>: `Error` (legacy) or the schema
            // 2.6 elements (`OutOfRange`, `InvalidParameterValue`, ...).
            let errs = root
                .descendants()
                .filter(|n| {
                    n.is_element()
                        && n.attribute("errorCode").is_some()
                        && n.parent_element()
                            .is_some_and(|p| p.tag_name().name() == "Errors")
                })
                .map(|n| {
                    let own = n
                        .children()
                        .filter(|c| c.is_text())
                        .filter_map(|c| c.text())
                        .collect::<String>()
                        .trim()
                        .to_string();
                    let qp = n
                        .children()
                        .find(|c| c.is_element() && c.tag_name().name() == "QueryParameter");
                    AgentError {
                        code: n.attribute("errorCode").unwrap_or("").to_string(),
                        text: if own.is_empty() {
                            child_text(n, "ErrorMessage").unwrap_or_default()
                        } else {
                            own
                        },
                        parameter: qp.and_then(|q| q.attribute("name")).map(str::to_string),
                        maximum: qp
                            .and_then(|q| child_text(q, "Maximum"))
                            .and_then(|m| m.parse().ok()),
                    }
                })
                .collect();
            Ok(Streams::Error(header, errs))
        }
        "MTConnectStreams" => {
            let header = header.ok_or("no <Header>")?;
            let mut obs = Vec::new();
            for ds in root
                .descendants()
                .filter(|n| n.is_element() && n.tag_name().name() == "DeviceStream")
            {
                let mine = device.is_none_or(|d| {
                    [
                        ds.attribute("name"),
                        ds.attribute("uuid"),
                        ds.attribute("id"),
                    ]
                    .contains(&Some(d))
                });
                if !mine {
                    continue;
                }
                for n in ds.descendants().filter(|n| {
                    n.is_element()
                        && n.attribute("dataItemId").is_some()
                        && n.attribute("sequence").is_some()
                }) {
                    let sequence = attr_u64(n, "sequence").ok_or_else(|| {
                        format!("bad sequence `{}`", n.attribute("sequence").unwrap_or(""))
                    })?;
                    let ts = n.attribute("timestamp").unwrap_or("");
                    let time_s = parse_time_s(ts)
                        .ok_or_else(|| format!("bad timestamp `{ts}` (sequence {sequence})"))?;
                    obs.push(Observation {
                        sequence,
                        data_item_id: n.attribute("dataItemId").unwrap_or("").to_string(),
                        name: n.attribute("name").map(str::to_string),
                        time_s,
                        value: n.text().unwrap_or("").trim().to_string(),
                    });
                }
            }
            obs.sort_by_key(|o| o.sequence);
            Ok(Streams::Data(header, obs))
        }
        other => Err(format!(
            "<{other}> is neither MTConnectStreams nor MTConnectError"
        )),
    }
}

/// Counters of what was read, for the log and for tests.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct AgentStats {
    /// `/sample` requests answered.
    pub requests: u64,
    /// Observations of the device handled (each sequence number once).
    pub observations: u64,
    /// Position and load samples delivered.
    pub samples: u64,
    /// Observations seen twice (sequence below the next expected), ignored.
    pub duplicates: u64,
    /// `OUT_OF_RANGE` answers.
    pub out_of_range: u64,
    /// Observations lost (left the buffer before they were read).
    pub lost: u64,
    /// Agent restarts seen.
    pub restarts: u64,
    /// Failed requests (HTTP errors, timeouts, errors other than the ones handled).
    pub failures: u64,
    /// `/sample` requests whose `count` the agent refused (the count was lowered each time).
    pub count_refusals: u64,
    /// Samples dropped for being earlier than their channel's previous sample.
    pub reordered: u64,
    /// Backward time steps of more than [`SEGMENT_BACKSTEP_S`] reported as gaps.
    pub time_step_backs: u64,
}

/// One axis of an MTConnect agent.
pub struct AgentSource {
    params: AgentParams,
    http: ureq::Agent,
    device_label: String,
    axis: ResolvedAxis,
    instance_id: String,
    next_sequence: u64,
    pending: VecDeque<Event>,
    backoff: Backoff,
    next_poll: Instant,
    last_time_s: Option<f64>,
    last_position_s: Option<f64>,
    last_load_s: Option<f64>,
    interval: IntervalEstimate,
    failing: bool,
    /// Observations asked per `/sample`: [`AgentParams::count`] until the agent refuses it.
    count: u64,
    /// Counters.
    pub stats: AgentStats,
}

impl AgentSource {
    /// Read `/probe` and `/current` and choose the axis's items.
    ///
    /// # Errors
    /// [`LiveError::Connect`] when the agent cannot be reached, [`LiveError::Protocol`] for
    /// documents that are not MTConnect, [`LiveError::Config`] when the device or the axis's
    /// items cannot be chosen.
    pub fn connect(params: AgentParams, sel: &AxisSelection) -> Result<Self, LiveError> {
        let http: ureq::Agent = ureq::Agent::config_builder()
            .timeout_global(Some(params.timeout))
            .http_status_as_error(false)
            .build()
            .into();
        let base = params.url.trim_end_matches('/').to_string();
        let probe = get(&http, &format!("{base}/probe")).map_err(|detail| LiveError::Connect {
            endpoint: base.clone(),
            detail,
        })?;
        let model = DeviceModel::parse(&probe.1, &format!("{base}/probe")).map_err(|e| {
            LiveError::Protocol {
                endpoint: base.clone(),
                detail: e.to_string(),
            }
        })?;
        let device = super::choose_device(&model, sel.device.as_deref())?;
        let axis = ResolvedAxis::resolve(&model, device, sel, &base)?;
        let dev = &model.devices[device];
        let device_label = dev.name.clone().unwrap_or_else(|| dev.id.clone());
        let backoff = Backoff::new(Duration::from_millis(500), params.max_backoff);
        let count = params.count.max(1);
        let mut s = Self {
            params,
            http,
            device_label,
            axis,
            instance_id: String::new(),
            next_sequence: 0,
            pending: VecDeque::new(),
            backoff,
            next_poll: Instant::now(),
            last_time_s: None,
            last_position_s: None,
            last_load_s: None,
            interval: IntervalEstimate::default(),
            failing: false,
            count,
            stats: AgentStats::default(),
        };
        let h = s.current().map_err(|detail| LiveError::Connect {
            endpoint: s.base(),
            detail,
        })?;
        s.instance_id = h.instance_id.clone();
        s.next_sequence = h.next_sequence.ok_or_else(|| LiveError::Protocol {
            endpoint: s.base(),
            detail: "/current: the Header has no nextSequence".into(),
        })?;
        Ok(s)
    }

    /// Observations asked per `/sample` now: [`AgentParams::count`], or less once the agent
    /// refused that.
    pub fn count(&self) -> u64 {
        self.count
    }

    /// The items followed.
    pub fn axis(&self) -> &ResolvedAxis {
        &self.axis
    }

    fn base(&self) -> String {
        self.params.url.trim_end_matches('/').to_string()
    }

    fn current(&self) -> Result<Header, String> {
        let (_, body) = get(&self.http, &format!("{}/current", self.base()))?;
        match parse_streams(&body, Some(&self.device_label))? {
            Streams::Data(h, _) => Ok(h),
            Streams::Error(_, e) => Err(format!("/current: {e:?}")),
        }
    }

    /// Start again from the buffer's first sequence after a restart or OUT_OF_RANGE.
    fn resync(&mut self, h: &Header) {
        self.next_sequence = h.first_sequence.or(h.next_sequence).unwrap_or(0);
        self.last_position_s = None;
        self.last_load_s = None;
        self.last_time_s = None;
        self.interval.break_here();
    }

    fn poll(&mut self) -> Result<(), String> {
        let url = format!(
            "{}/sample?from={}&count={}",
            self.base(),
            self.next_sequence,
            self.count
        );
        let (status, body) = get(&self.http, &url)?;
        let parsed = parse_streams(&body, Some(&self.device_label))
            .map_err(|e| format!("HTTP {status}: {e}"))?;
        self.stats.requests += 1;
        match parsed {
            Streams::Error(h, errs) => {
                // A refused count first: cppagent says OUT_OF_RANGE for it too, and reading it
                // as "`from` left the buffer" re-asked at once, forever.
                if let Some(limit) = errs.iter().find_map(AgentError::refused_count) {
                    return self.lower_count(limit, h.as_ref(), &errs);
                }
                if errs.iter().any(|e| e.code == "OUT_OF_RANGE") {
                    let h = match h.filter(|h| h.first_sequence.is_some()) {
                        Some(h) => h,
                        None => self.current()?,
                    };
                    if self.restarted(&h) {
                        self.stats.out_of_range += 1;
                        return Ok(());
                    }
                    let first = h.first_sequence.unwrap_or(self.next_sequence);
                    // Only `from` below the buffer is a loss; anything else (the agent's text
                    // and this client's view disagree) is a failure, retried with back-off.
                    if first <= self.next_sequence {
                        return Err(format!(
                            "HTTP {status}: {} (from={}, the agent's firstSequence {first})",
                            describe_errors(&errs),
                            self.next_sequence
                        ));
                    }
                    self.stats.out_of_range += 1;
                    let lost = first - self.next_sequence;
                    self.stats.lost += lost;
                    self.pending.push_back(Event::Gap {
                        time_s: self.last_time_s,
                        reason: GapReason::Skipped { lost: Some(lost) },
                    });
                    self.resync(&h);
                    return Ok(());
                }
                Err(format!("HTTP {status}: {}", describe_errors(&errs)))
            }
            Streams::Data(h, obs) => {
                if self.restarted(&h) {
                    return Ok(());
                }
                let full = obs.len() as u64 >= self.count;
                for o in obs {
                    if o.sequence < self.next_sequence {
                        self.stats.duplicates += 1;
                        continue;
                    }
                    self.stats.observations += 1;
                    self.observe(&o);
                }
                if let Some(n) = h.next_sequence {
                    self.next_sequence = self.next_sequence.max(n);
                }
                // More waiting in the buffer: ask again at once.
                let behind = h.last_sequence.is_some_and(|l| l >= self.next_sequence);
                self.next_poll = if full || behind {
                    Instant::now()
                } else {
                    Instant::now() + self.params.poll
                };
                Ok(())
            }
        }
    }

    /// The agent refused the count: ask for `limit` (else the header's `bufferSize`, else
    /// half) from the same `from` after one poll interval, and say so.
    fn lower_count(
        &mut self,
        limit: Option<u64>,
        h: Option<&Header>,
        errs: &[AgentError],
    ) -> Result<(), String> {
        self.stats.count_refusals += 1;
        let old = self.count;
        let new = limit
            .or_else(|| h.and_then(|h| h.buffer_size))
            .unwrap_or(old / 2)
            .min(old.saturating_sub(1));
        if new == 0 {
            return Err(format!(
                "the agent refuses count={old}: {}",
                describe_errors(errs)
            ));
        }
        self.count = new;
        self.pending.push_back(Event::Notice {
            message: format!(
                "agent {} refuses count={old} ({}); asking for {new} observations per /sample \
                 from now on (sequence {} on, nothing lost)",
                self.base(),
                describe_errors(errs),
                self.next_sequence
            ),
            connected: true,
        });
        self.next_poll = Instant::now() + self.params.poll;
        Ok(())
    }

    /// True (and a gap queued, the client resynchronised) when the instance changed.
    fn restarted(&mut self, h: &Header) -> bool {
        if h.instance_id.is_empty() || h.instance_id == self.instance_id {
            return false;
        }
        self.stats.restarts += 1;
        self.pending.push_back(Event::Gap {
            time_s: self.last_time_s,
            reason: GapReason::Restart {
                detail: format!("instanceId {} -> {}", self.instance_id, h.instance_id),
            },
        });
        self.instance_id = h.instance_id.clone();
        let h = if h.first_sequence.is_some() {
            h.clone()
        } else {
            self.current().unwrap_or_else(|_| h.clone())
        };
        self.resync(&h);
        self.next_poll = Instant::now();
        true
    }

    fn observe(&mut self, o: &Observation) {
        let is = |p: &(String, String)| o.data_item_id == p.1;
        let quantity = if is(&self.axis.position) {
            Quantity::Position
        } else if is(&self.axis.load) {
            Quantity::Effort(EffortKind::TorqueNm)
        } else {
            if self.axis.program.as_ref().is_some_and(is) && o.value != "UNAVAILABLE" {
                self.pending.push_back(Event::Program {
                    time_s: o.time_s,
                    name: o.value.clone(),
                });
            }
            return;
        };
        match self.last_time_s {
            // The agent's timestamps stepped back (an adapter that restarted and replays its
            // state, a clock reset): what came before and after cannot be joined.
            Some(l) if l - o.time_s > SEGMENT_BACKSTEP_S => {
                self.stats.time_step_backs += 1;
                self.pending.push_back(Event::Gap {
                    time_s: Some(l),
                    reason: GapReason::TimeStepBack {
                        back_s: l - o.time_s,
                    },
                });
                self.last_position_s = None;
                self.last_load_s = None;
                self.interval.break_here();
                self.last_time_s = Some(o.time_s);
            }
            _ => self.last_time_s = Some(self.last_time_s.map_or(o.time_s, |l| l.max(o.time_s))),
        }
        if o.value.eq_ignore_ascii_case("UNAVAILABLE") {
            self.pending.push_back(Event::Gap {
                time_s: Some(o.time_s),
                reason: GapReason::Unavailable { quantity },
            });
            return;
        }
        let Some(v) = o.value.parse::<f64>().ok().filter(|v| v.is_finite()) else {
            return;
        };
        let last = match quantity {
            Quantity::Position => &mut self.last_position_s,
            Quantity::Effort(_) => &mut self.last_load_s,
        };
        if last.is_some_and(|l| o.time_s < l) {
            self.stats.reordered += 1;
            return;
        }
        *last = Some(o.time_s);
        let value = match quantity {
            Quantity::Position => {
                self.interval.observe(o.time_s);
                v * 1e-3
            }
            Quantity::Effort(_) => v * self.axis.torque_per_percent_nm,
        };
        self.stats.samples += 1;
        self.pending.push_back(Event::Sample {
            quantity,
            time_s: o.time_s,
            value,
        });
    }
}

/// `CODE 'text'; …` for the log.
fn describe_errors(errs: &[AgentError]) -> String {
    if errs.is_empty() {
        return "an MTConnectError without errors".into();
    }
    errs.iter()
        .map(|e| format!("{} {:?}", e.code, e.text))
        .collect::<Vec<_>>()
        .join("; ")
}

/// GET a URL: status and body, or the transport's words.
fn get(http: &ureq::Agent, url: &str) -> Result<(u16, String), String> {
    let mut resp = http.get(url).call().map_err(|e| format!("{url}: {e}"))?;
    let status = resp.status().as_u16();
    let body = resp
        .body_mut()
        .with_config()
        .limit(256 * 1024 * 1024)
        .read_to_string()
        .map_err(|e| format!("{url}: {e}"))?;
    if !(200..300).contains(&status) && !body.contains("MTConnectError") {
        return Err(format!("{url}: HTTP {status}"));
    }
    Ok((status, body))
}

impl Source for AgentSource {
    fn describe(&self) -> String {
        format!(
            "MTConnect agent {} device {} axis {} (position {}, load {})",
            self.base(),
            self.device_label,
            self.axis.axis_label,
            self.axis.position.1,
            self.axis.load.1
        )
    }

    fn sample_interval_s(&self) -> Option<f64> {
        self.interval.median_s()
    }

    fn next_event(&mut self, deadline: Instant) -> Result<Option<Event>, LiveError> {
        loop {
            if let Some(e) = self.pending.pop_front() {
                return Ok(Some(e));
            }
            let now = Instant::now();
            let due = if self.failing {
                self.backoff.next_try
            } else {
                self.next_poll
            };
            if due > now {
                if deadline <= now {
                    return Ok(None);
                }
                std::thread::sleep(due.min(deadline) - now);
                if due > deadline {
                    return Ok(None);
                }
                continue;
            }
            match self.poll() {
                Ok(()) => {
                    if self.failing {
                        self.pending.push_back(Event::Notice {
                            message: format!(
                                "agent {} answers again; resuming at sequence {}",
                                self.base(),
                                self.next_sequence
                            ),
                            connected: true,
                        });
                    }
                    self.failing = false;
                    self.backoff.succeeded();
                }
                Err(e) => {
                    self.stats.failures += 1;
                    self.failing = true;
                    self.backoff.failed();
                    if self
                        .params
                        .max_attempts
                        .is_some_and(|m| self.backoff.failures >= m)
                    {
                        return Err(LiveError::Connect {
                            endpoint: self.base(),
                            detail: e,
                        });
                    }
                    self.pending.push_back(Event::Notice {
                        message: format!(
                            "{e}; retrying from sequence {} in {:.1} s",
                            self.next_sequence,
                            self.backoff.delay().as_secs_f64() / 2.0
                        ),
                        connected: false,
                    });
                }
            }
            if deadline <= Instant::now() && self.pending.is_empty() {
                return Ok(None);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A cppagent 2.x answer (namespaced) and a 1.3 one without a namespace prefix.
    #[test]
    fn streams_any_version_in_sequence_order() {
        let v2 = r#"<?xml version="1.0" encoding="UTF-8"?>
<MTConnectStreams xmlns:m="urn:mtconnect.org:MTConnectStreams:2.0" xmlns="urn:mtconnect.org:MTConnectStreams:2.0">
  <Header creationTime="2024-01-01T00:00:01Z" instanceId="1700" version="2.0.0.1" bufferSize="131072" nextSequence="108" firstSequence="1" lastSequence="107"/>
  <Streams>
    <DeviceStream name="OKUMA" uuid="OKUMA.123">
      <ComponentStream component="Linear" name="Z1" componentId="Lz1">
        <Samples>
          <Load dataItemId="Z1load" name="Z1load" sequence="105" timestamp="2024-01-01T00:00:00.5Z">9</Load>
          <Position dataItemId="Z1actm" name="Z1actm" sequence="101" timestamp="2024-01-01T00:00:00.5Z" subType="ACTUAL">12.5</Position>
          <Position dataItemId="Z1actm" name="Z1actm" sequence="107" timestamp="2024-01-01T00:00:00.5Z" subType="ACTUAL">12.6</Position>
        </Samples>
      </ComponentStream>
    </DeviceStream>
    <DeviceStream name="other" uuid="x"><ComponentStream component="Device" componentId="d"><Events>
      <Availability dataItemId="avail" sequence="106" timestamp="2024-01-01T00:00:00Z">AVAILABLE</Availability>
    </Events></ComponentStream></DeviceStream>
  </Streams>
</MTConnectStreams>"#;
        let Streams::Data(h, obs) = parse_streams(v2, Some("OKUMA")).unwrap() else {
            panic!()
        };
        assert_eq!(h.next_sequence, Some(108));
        assert_eq!(h.instance_id, "1700");
        let seq: Vec<u64> = obs.iter().map(|o| o.sequence).collect();
        assert_eq!(seq, [101, 105, 107]);
        assert_eq!(obs[2].value, "12.6");
        let err = r#"<MTConnectError><Header instanceId="1" firstSequence="500" nextSequence="900" lastSequence="899"/>
            <Errors><Error errorCode="OUT_OF_RANGE">'from' must be greater than 499</Error></Errors></MTConnectError>"#;
        let Streams::Error(Some(h), e) = parse_streams(err, None).unwrap() else {
            panic!()
        };
        assert_eq!(h.first_sequence, Some(500));
        assert_eq!(e[0].code, "OUT_OF_RANGE");
        assert_eq!(
            e[0].refused_count(),
            None,
            "a `from` refusal is no count refusal"
        );
        assert!(parse_streams("<html/>", None).is_err());
    }

    fn errors(xml: &str) -> (Option<Header>, Vec<AgentError>) {
        match parse_streams(xml, None).unwrap() {
            Streams::Error(h, e) => (h, e),
            Streams::Data(..) => panic!("not an error document"),
        }
    }

    /// The count refusals of cppagent 2.x (src/mtconnect/sink/rest_sink/rest_service.cpp,
    /// `checkRange(…, "count", true)`; the legacy `<Error>` before schema 2.6, `<OutOfRange>`
    /// with a `QueryParameter` from 2.6, its header without sequence numbers) and of the PyPI
    /// `mtconnect` package; each gives the largest count allowed.
    #[test]
    fn count_refusals_give_the_limit() {
        let legacy = r#"<MTConnectError xmlns="urn:mtconnect.org:MTConnectError:2.5">
  <Header creationTime="2026-01-01T00:00:00Z" sender="a" instanceId="1700" version="2.5.0.0" bufferSize="256"/>
  <Errors><Error errorCode="OUT_OF_RANGE">'count' must be less than 257</Error></Errors></MTConnectError>"#;
        let (h, e) = errors(legacy);
        assert_eq!(h.as_ref().and_then(|h| h.buffer_size), Some(256));
        assert_eq!(h.and_then(|h| h.first_sequence), None);
        assert_eq!(e[0].refused_count(), Some(Some(256)));
        let v26 = r#"<MTConnectError xmlns="urn:mtconnect.org:MTConnectError:2.6">
  <Header instanceId="1700" bufferSize="256"/>
  <Errors><OutOfRange errorCode="OUT_OF_RANGE"><URI>/sample?count=1000</URI><Request>MTConnectStreams</Request>
    <ErrorMessage>'count' must be less than 257</ErrorMessage>
    <QueryParameter name="count"><Value>1000</Value><Minimum>-256</Minimum><Maximum>256</Maximum></QueryParameter>
  </OutOfRange></Errors></MTConnectError>"#;
        let (_, e) = errors(v26);
        assert_eq!(e[0].text, "'count' must be less than 257");
        assert_eq!(
            (e[0].parameter.as_deref(), e[0].maximum),
            (Some("count"), Some(256))
        );
        assert_eq!(e[0].refused_count(), Some(Some(256)));
        let from26 = r#"<MTConnectError><Errors><OutOfRange errorCode="OUT_OF_RANGE">
    <ErrorMessage>'from' must be greater than 499</ErrorMessage>
    <QueryParameter name="from"><Value>3</Value><Minimum>500</Minimum><Maximum>900</Maximum></QueryParameter>
  </OutOfRange></Errors></MTConnectError>"#;
        assert_eq!(errors(from26).1[0].refused_count(), None);
        let package = r#"<MTConnectError><Header instanceId="1"/><Errors>
  <Error errorCode="MTInvalidRange">Count must not be greater than 64</Error></Errors></MTConnectError>"#;
        assert_eq!(errors(package).1[0].refused_count(), Some(Some(64)));
        let bare = r#"<MTConnectError><Errors><Error errorCode="OUT_OF_RANGE">'count' is too large</Error></Errors></MTConnectError>"#;
        assert_eq!(errors(bare).1[0].refused_count(), Some(None));
    }
}
