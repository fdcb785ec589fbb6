//! The SHDR adapter stream: a TCP client that reads an adapter as an MTConnect agent does.
//!
//! - Lines `timestamp|key|value|key|value…` are split by the importer's tokenizer
//!   ([`feedscope_io::import::shdr::tokenize`]) and each key takes the fields its data item's
//!   kind needs ([`feedscope_io::import::devices::Shape`]), so a CONDITION's five fields are
//!   never read as keys; in SHDR version 1 a text item ends the line.
//! - `* PING` is the agent's heartbeat: the client sends it on connecting and then every
//!   heartbeat interval once the adapter answered `* PONG <ms>`; a connection silent for twice
//!   that long is taken as dead. An adapter that pings the client is answered
//!   `* PONG <ms>`. Other `*` commands, asset commands and multi-line asset bodies are skipped.
//! - `UNAVAILABLE` on the position or load item is [`GapReason::Unavailable`].
//! - Timestamps come from the lines. A line stamped more than
//!   [`SEGMENT_BACKSTEP_S`] before the latest
//!   (an adapter that restarted and replays its state, a clock reset) is a
//!   [`GapReason::TimeStepBack`]; after a reconnection, lines stamped before the latest time
//!   already delivered are the adapter's state dump and are dropped (counted in
//!   [`ShdrStats::stale`]). A sample earlier than its channel's previous sample is dropped and
//!   counted ([`ShdrStats::reordered`]); it cannot enter a trace.
//! - When the adapter goes away the client reports [`GapReason::Reconnected`] at once (an
//!   adapter does not replay what it said meanwhile) and reconnects with a doubling back-off.
use std::collections::VecDeque;
use std::io::{BufRead, BufReader, ErrorKind, Write};
use std::net::{TcpStream, ToSocketAddrs};
use std::time::{Duration, Instant};

use feedscope::trace::EffortKind;
use feedscope_io::import::devices::{DeviceModel, Shape};
use feedscope_io::import::shdr::{tokenize, SEGMENT_BACKSTEP_S};

use super::{parse_time_s, AxisSelection, Backoff, IntervalEstimate, ResolvedAxis};
use crate::source::{Event, GapReason, LiveError, Quantity, Source};

/// Default adapter port.
pub const DEFAULT_PORT: u16 = 7878;

/// Settings of [`ShdrSource`].
#[derive(Debug, Clone, PartialEq)]
pub struct ShdrParams {
    /// `host:port` of the adapter (port [`DEFAULT_PORT`] when left out).
    pub adapter: String,
    /// Timeout of one connection attempt. Default 5 s.
    pub connect_timeout: Duration,
    /// First wait after a failed attempt, doubled up to `max_backoff`. Default 0.5 s.
    pub first_backoff: Duration,
    /// Longest wait between attempts. Default 30 s.
    pub max_backoff: Duration,
    /// Failed attempts in a row before the source gives up; `None` (default) never.
    pub max_attempts: Option<u32>,
    /// The heartbeat the client offers when an adapter pings it (ms). Default 10 000.
    pub pong_ms: u64,
}

impl Default for ShdrParams {
    fn default() -> Self {
        Self {
            adapter: format!("127.0.0.1:{DEFAULT_PORT}"),
            connect_timeout: Duration::from_secs(5),
            first_backoff: Duration::from_millis(500),
            max_backoff: Duration::from_secs(30),
            max_attempts: None,
            pong_ms: 10_000,
        }
    }
}

/// What the client has read, for the log and for tests.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ShdrStats {
    /// Data lines read (timestamped lines that are not asset commands).
    pub data_lines: u64,
    /// Observations of the position item (`UNAVAILABLE` included).
    pub position_observations: u64,
    /// Observations of the load item (`UNAVAILABLE` included).
    pub load_observations: u64,
    /// `UNAVAILABLE` observations of either.
    pub unavailable: u64,
    /// Observations dropped as the adapter's state dump after a reconnection.
    pub stale: u64,
    /// Samples dropped for being earlier than their channel's previous sample.
    pub reordered: u64,
    /// Backward time steps reported as gaps.
    pub time_step_backs: u64,
    /// Connections made.
    pub connections: u64,
    /// `* PONG` answers received and `* PING`s answered.
    pub heartbeats: u64,
}

/// Turns SHDR lines into [`Event`]s of one axis (no I/O: fed by [`ShdrSource`], and by tests
/// with recorded lines).
#[derive(Debug, Clone)]
pub struct LineDecoder {
    model: DeviceModel,
    axis: ResolvedAxis,
    version: u32,
    multiline: Option<String>,
    /// Latest line time so far (s since the epoch).
    latest_s: Option<f64>,
    /// After a reconnection: lines up to this time are the adapter's state dump.
    stale_until_s: Option<f64>,
    last_position_s: Option<f64>,
    last_load_s: Option<f64>,
    /// Counters.
    pub stats: ShdrStats,
    interval: IntervalEstimate,
}

impl LineDecoder {
    /// A decoder for the axis `axis` of `model`.
    pub fn new(model: DeviceModel, axis: ResolvedAxis) -> Self {
        Self {
            model,
            axis,
            version: 1,
            multiline: None,
            latest_s: None,
            stale_until_s: None,
            last_position_s: None,
            last_load_s: None,
            stats: ShdrStats::default(),
            interval: IntervalEstimate::default(),
        }
    }

    /// The items followed.
    pub fn axis(&self) -> &ResolvedAxis {
        &self.axis
    }

    /// The connection was lost: later lines up to the latest time seen are a state dump.
    pub fn reconnected(&mut self) {
        self.stale_until_s = self.latest_s;
        self.multiline = None;
        self.version = 1;
        self.interval.break_here();
    }

    /// Median interval between position samples (s).
    pub fn sample_interval_s(&self) -> Option<f64> {
        self.interval.median_s()
    }

    /// Decode one line (without its end) into `out`; returns a reply to send to the adapter
    /// (`* PONG …` to a ping) or its heartbeat (`Some(ms)` from `* PONG ms`).
    ///
    /// # Errors
    /// A [`LiveError::Protocol`] for a line whose timestamp does not parse.
    pub fn decode(&mut self, line: &str, out: &mut VecDeque<Event>) -> Result<Reply, LiveError> {
        if let Some(tag) = &self.multiline {
            if line.trim() == tag {
                self.multiline = None;
            }
            return Ok(Reply::None);
        }
        let trimmed = line.trim();
        if trimmed.is_empty() {
            return Ok(Reply::None);
        }
        if let Some(cmd) = trimmed.strip_prefix('*') {
            let cmd = cmd.trim();
            if let Some(v) = cmd.strip_prefix("shdrVersion:") {
                self.version = v.trim().parse().unwrap_or(1);
            } else if cmd == "PING" {
                return Ok(Reply::Ping);
            } else if let Some(ms) = cmd.strip_prefix("PONG") {
                return Ok(Reply::Pong(ms.trim().parse().ok()));
            }
            return Ok(Reply::None);
        }
        let tokens = tokenize(line);
        let Some(time_s) = parse_time_s(&tokens[0]) else {
            return Err(LiveError::Protocol {
                endpoint: "adapter".into(),
                detail: format!("bad timestamp in SHDR line `{}`", shorten(trimmed)),
            });
        };
        if tokens.len() < 2 || tokens[1].is_empty() {
            return Ok(Reply::None);
        }
        if tokens[1].starts_with('@') {
            if let Some(tag) = tokens.last().filter(|t| t.starts_with("--multiline--")) {
                self.multiline = Some(tag.clone());
            }
            return Ok(Reply::None);
        }
        self.stats.data_lines += 1;
        let stale = self.stale_until_s.is_some_and(|s| time_s <= s);
        if !stale {
            self.stale_until_s = None;
            if let Some(l) = self.latest_s {
                if l - time_s > SEGMENT_BACKSTEP_S {
                    self.stats.time_step_backs += 1;
                    out.push_back(Event::Gap {
                        time_s: Some(l),
                        reason: GapReason::TimeStepBack { back_s: l - time_s },
                    });
                    self.latest_s = Some(time_s);
                    self.last_position_s = None;
                    self.last_load_s = None;
                    self.interval.break_here();
                }
            }
            self.latest_s = Some(self.latest_s.map_or(time_s, |l| l.max(time_s)));
        }
        let mut i = 1usize;
        while i < tokens.len() {
            let raw = tokens[i].as_str();
            if raw.is_empty() && i + 1 == tokens.len() {
                break;
            }
            let (prefix, key) = match raw.split_once(':') {
                Some((d, k)) => (Some(d), k),
                None => (None, raw),
            };
            let other_device = prefix.is_some_and(|d| {
                self.model
                    .find_device(d)
                    .is_some_and(|k| k != self.axis.device)
            });
            let shape = if other_device {
                let d = self.model.find_device(prefix.unwrap_or("")).unwrap_or(0);
                let od = &self.model.devices[d];
                od.find_item(key)
                    .map_or(Shape::Single, |k| od.items[k].shape())
            } else {
                let dev = &self.model.devices[self.axis.device];
                dev.find_item(key)
                    .map_or(Shape::Single, |k| dev.items[k].shape())
            };
            let value = tokens.get(i + 1).map(String::as_str).unwrap_or("");
            if !other_device {
                self.observe(key, value, time_s, stale, out);
            }
            if self.version < 2 && shape.ends_in_text() {
                break;
            }
            i += 1 + shape.fields();
        }
        Ok(Reply::None)
    }

    fn observe(
        &mut self,
        key: &str,
        value: &str,
        time_s: f64,
        stale: bool,
        out: &mut VecDeque<Event>,
    ) {
        let is = |pair: &(String, String)| pair.0 == key || pair.1 == key;
        let quantity = if is(&self.axis.position) {
            self.stats.position_observations += 1;
            Quantity::Position
        } else if is(&self.axis.load) {
            self.stats.load_observations += 1;
            Quantity::Effort(EffortKind::TorqueNm)
        } else {
            if self.axis.program.as_ref().is_some_and(is) && !stale {
                out.push_back(Event::Program {
                    time_s,
                    name: value.to_string(),
                });
            }
            return;
        };
        if stale {
            self.stats.stale += 1;
            return;
        }
        if value.eq_ignore_ascii_case("UNAVAILABLE") {
            self.stats.unavailable += 1;
            out.push_back(Event::Gap {
                time_s: Some(time_s),
                reason: GapReason::Unavailable { quantity },
            });
            return;
        }
        let Ok(v) = value.parse::<f64>() else {
            return;
        };
        if !v.is_finite() {
            return;
        }
        let last = match quantity {
            Quantity::Position => &mut self.last_position_s,
            Quantity::Effort(_) => &mut self.last_load_s,
        };
        if last.is_some_and(|l| time_s < l) {
            self.stats.reordered += 1;
            return;
        }
        *last = Some(time_s);
        let value = match quantity {
            Quantity::Position => {
                self.interval.observe(time_s);
                v * 1e-3
            }
            Quantity::Effort(_) => v * self.axis.torque_per_percent_nm,
        };
        out.push_back(Event::Sample {
            quantity,
            time_s,
            value,
        });
    }
}

/// What a decoded line asks of the connection.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reply {
    /// Nothing.
    None,
    /// The adapter pinged: answer `* PONG <ms>`.
    Ping,
    /// The adapter answered a ping with its heartbeat (ms), if it gave one.
    Pong(Option<u64>),
}

fn shorten(s: &str) -> String {
    if s.len() <= 80 {
        s.to_string()
    } else {
        let mut end = 80;
        while !s.is_char_boundary(end) {
            end -= 1;
        }
        format!("{}…", &s[..end])
    }
}

/// One axis of an SHDR adapter over TCP.
pub struct ShdrSource {
    params: ShdrParams,
    decoder: LineDecoder,
    stream: Option<BufReader<TcpStream>>,
    line: Vec<u8>,
    pending: VecDeque<Event>,
    backoff: Backoff,
    /// Heartbeat agreed with the adapter (`* PONG ms`).
    heartbeat: Option<Duration>,
    last_ping: Instant,
    last_data: Instant,
    /// Why the previous connection ended, to report on the next one.
    lost: Option<String>,
}

impl ShdrSource {
    /// A source for the axis chosen by `sel` in `model` (the adapter's `Devices.xml`); connects
    /// on the first [`Source::next_event`].
    ///
    /// # Errors
    /// [`LiveError::Config`] when the device, axis or items cannot be chosen, or the torque
    /// scale is missing.
    pub fn new(
        params: ShdrParams,
        model: DeviceModel,
        sel: &AxisSelection,
    ) -> Result<Self, LiveError> {
        let device = match &sel.device {
            Some(_) => super::choose_device(&model, sel.device.as_deref())?,
            None => {
                // The device that has the axis, when only one has.
                let with_axis: Vec<usize> = (0..model.devices.len())
                    .filter(|&d| model.devices[d].find_axis(&sel.axis, "").is_ok())
                    .collect();
                match with_axis.as_slice() {
                    [d] => *d,
                    _ => super::choose_device(&model, None)?,
                }
            }
        };
        let axis = ResolvedAxis::resolve(&model, device, sel, &params.adapter)?;
        let backoff = Backoff::new(params.first_backoff, params.max_backoff);
        Ok(Self {
            params,
            decoder: LineDecoder::new(model, axis),
            stream: None,
            line: Vec::new(),
            pending: VecDeque::new(),
            backoff,
            heartbeat: None,
            last_ping: Instant::now(),
            last_data: Instant::now(),
            lost: None,
        })
    }

    /// Counters of what was read.
    pub fn stats(&self) -> &ShdrStats {
        &self.decoder.stats
    }

    /// The items followed.
    pub fn axis(&self) -> &ResolvedAxis {
        self.decoder.axis()
    }

    fn address(&self) -> String {
        let a = self.params.adapter.trim();
        if a.rsplit_once(':')
            .is_some_and(|(_, p)| p.parse::<u16>().is_ok())
        {
            a.to_string()
        } else {
            format!("{a}:{DEFAULT_PORT}")
        }
    }

    fn connect(&mut self) -> Result<(), String> {
        let addr = self.address();
        let addrs: Vec<_> = addr
            .to_socket_addrs()
            .map_err(|e| format!("resolving {addr}: {e}"))?
            .collect();
        let mut last = format!("{addr}: no address");
        for a in addrs {
            match TcpStream::connect_timeout(&a, self.params.connect_timeout) {
                Ok(s) => {
                    let _ = s.set_nodelay(true);
                    let mut w = s.try_clone().map_err(|e| e.to_string())?;
                    // The agent's heartbeat request; an adapter that does not know it ignores it.
                    w.write_all(b"* PING\n").map_err(|e| e.to_string())?;
                    self.stream = Some(BufReader::new(s));
                    self.line.clear();
                    self.heartbeat = None;
                    self.last_ping = Instant::now();
                    self.last_data = Instant::now();
                    return Ok(());
                }
                Err(e) => last = e.to_string(),
            }
        }
        Err(last)
    }

    fn drop_connection(&mut self, why: String) {
        // An adapter does not replay what was said while nobody listened: data is lost.
        self.pending.push_back(Event::Gap {
            time_s: self.decoder.latest_s,
            reason: GapReason::Reconnected {
                detail: format!("connection to {} lost: {why}", self.address()),
            },
        });
        self.pending.push_back(Event::Notice {
            message: format!("adapter {}: {why}; reconnecting", self.address()),
            connected: false,
        });
        self.stream = None;
        self.line.clear();
        self.decoder.reconnected();
        self.lost = Some(why);
        self.backoff.failed();
    }

    fn send(&mut self, text: &str) -> std::io::Result<()> {
        if let Some(s) = &mut self.stream {
            s.get_mut().write_all(text.as_bytes())?;
        }
        Ok(())
    }
}

impl Source for ShdrSource {
    fn describe(&self) -> String {
        let a = self.decoder.axis();
        format!(
            "MTConnect SHDR adapter {} device {} axis {} (position {}, load {})",
            self.address(),
            a.device_label,
            a.axis_label,
            a.position.0,
            a.load.0
        )
    }

    fn sample_interval_s(&self) -> Option<f64> {
        self.decoder.sample_interval_s()
    }

    fn next_event(&mut self, deadline: Instant) -> Result<Option<Event>, LiveError> {
        loop {
            if let Some(e) = self.pending.pop_front() {
                return Ok(Some(e));
            }
            let now = Instant::now();
            if self.stream.is_none() {
                if self
                    .params
                    .max_attempts
                    .is_some_and(|m| self.backoff.failures >= m)
                {
                    return Err(LiveError::Connect {
                        endpoint: self.address(),
                        detail: format!(
                            "{} attempts failed ({})",
                            self.backoff.failures,
                            self.lost.clone().unwrap_or_default()
                        ),
                    });
                }
                if self.backoff.next_try > now {
                    if deadline <= now {
                        return Ok(None);
                    }
                    std::thread::sleep(self.backoff.next_try.min(deadline) - now);
                    continue;
                }
                match self.connect() {
                    Ok(()) => {
                        self.decoder.stats.connections += 1;
                        self.backoff.succeeded();
                        if self.lost.take().is_some() {
                            self.pending.push_back(Event::Notice {
                                message: format!("adapter {}: connected again", self.address()),
                                connected: true,
                            });
                        }
                    }
                    Err(e) => {
                        self.lost = Some(e.clone());
                        self.backoff.failed();
                        self.pending.push_back(Event::Notice {
                            message: format!(
                                "adapter {}: {e}; retrying in {:.1} s",
                                self.address(),
                                self.backoff.delay().as_secs_f64() / 2.0
                            ),
                            connected: false,
                        });
                    }
                }
                continue;
            }
            // Heartbeat: ping when due; silence for twice the heartbeat is a dead connection.
            if let Some(hb) = self.heartbeat {
                if now.duration_since(self.last_data) > 2 * hb {
                    self.drop_connection(format!(
                        "no data nor heartbeat for {:.1} s",
                        now.duration_since(self.last_data).as_secs_f64()
                    ));
                    continue;
                }
                if now.duration_since(self.last_ping) >= hb {
                    self.last_ping = now;
                    if let Err(e) = self.send("* PING\n") {
                        self.drop_connection(format!("sending a heartbeat: {e}"));
                        continue;
                    }
                }
            }
            if deadline <= now {
                return Ok(None);
            }
            let mut wait = deadline - now;
            if let Some(hb) = self.heartbeat {
                wait = wait.min(hb.saturating_sub(now.duration_since(self.last_ping)));
            }
            let wait = wait.max(Duration::from_millis(1));
            let stream = self.stream.as_mut().expect("connected above");
            let _ = stream.get_ref().set_read_timeout(Some(wait));
            match stream.read_until(b'\n', &mut self.line) {
                Ok(0) => {
                    self.drop_connection("the adapter closed the connection".into());
                    continue;
                }
                Ok(_) if self.line.last() == Some(&b'\n') => {
                    self.last_data = Instant::now();
                    let text = String::from_utf8_lossy(&self.line).into_owned();
                    self.line.clear();
                    let text = text.trim_end_matches(['\n', '\r']);
                    match self.decoder.decode(text, &mut self.pending) {
                        Ok(Reply::None) => {}
                        Ok(Reply::Ping) => {
                            self.decoder.stats.heartbeats += 1;
                            let pong = format!("* PONG {}\n", self.params.pong_ms);
                            if let Err(e) = self.send(&pong) {
                                self.drop_connection(format!("answering a ping: {e}"));
                            }
                        }
                        Ok(Reply::Pong(ms)) => {
                            self.decoder.stats.heartbeats += 1;
                            if let Some(ms) = ms.filter(|&m| m > 0) {
                                self.heartbeat = Some(Duration::from_millis(ms));
                            }
                        }
                        Err(LiveError::Protocol { detail, .. }) => {
                            return Err(LiveError::Protocol {
                                endpoint: self.address(),
                                detail,
                            })
                        }
                        Err(e) => return Err(e),
                    }
                }
                // A partial line: the rest comes with the next read.
                Ok(_) => {}
                Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {}
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(e) => self.drop_connection(e.to_string()),
            }
        }
    }
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
        </Components></Axes>
        <Controller id="c"><DataItems>
          <DataItem id="sys" name="system" category="CONDITION" type="SYSTEM"/>
          <DataItem id="msg" name="message" category="EVENT" type="MESSAGE"/>
          <DataItem id="pgm" name="program" category="EVENT" type="PROGRAM"/>
        </DataItems></Controller>
      </Components></Device>
    </Devices></MTConnectDevices>"#;

    fn decoder() -> LineDecoder {
        let model = DeviceModel::parse(MODEL, "Devices.xml").unwrap();
        let sel = AxisSelection {
            device: None,
            axis: "X".into(),
            position_key: None,
            load_key: None,
            torque_per_load_nm: Some(20.0),
        };
        let axis = ResolvedAxis::resolve(&model, 0, &sel, "test").unwrap();
        LineDecoder::new(model, axis)
    }

    fn decode_all(d: &mut LineDecoder, text: &str) -> Vec<Event> {
        let mut out = VecDeque::new();
        for l in text.lines() {
            d.decode(l, &mut out).unwrap();
        }
        out.into_iter().collect()
    }

    #[test]
    fn samples_in_si_with_conditions_messages_and_program() {
        let mut d = decoder();
        let ev = decode_all(
            &mut d,
            "* shdrVersion: 2\n\
             2024-01-01T00:00:00Z|system|FAULT|E1|HIGH||servo|Xabs|12.5|Xload|10\n\
             2024-01-01T00:00:01Z|program|O1234|message|M1|a text\n\
             2024-01-01T00:00:02Z|@ASSET@|t1|CuttingTool|--multiline--AB\n\
             <CuttingTool>|Xabs|99</CuttingTool>\n\
             --multiline--AB\n\
             2024-01-01T00:00:03Z|Xabs|UNAVAILABLE\n",
        );
        let t0 = parse_time_s("2024-01-01T00:00:00Z").unwrap();
        assert_eq!(ev.len(), 4, "{ev:?}");
        assert_eq!(
            ev[0],
            Event::Sample {
                quantity: Quantity::Position,
                time_s: t0,
                value: 0.0125
            }
        );
        match &ev[1] {
            // 10 % of 20 N·m.
            Event::Sample { value, .. } => assert!((value - 2.0).abs() < 1e-12),
            e => panic!("{e:?}"),
        }
        assert!(matches!(&ev[2], Event::Program { name, .. } if name == "O1234"));
        assert!(matches!(
            &ev[3],
            Event::Gap {
                reason: GapReason::Unavailable {
                    quantity: Quantity::Position
                },
                ..
            }
        ));
        assert_eq!(d.stats.position_observations, 2);
    }

    #[test]
    fn back_steps_are_gaps_and_state_dumps_after_reconnect_are_dropped() {
        let mut d = decoder();
        let ev = decode_all(
            &mut d,
            "2024-01-01T00:00:10Z|Xabs|1\n\
             2024-01-01T00:00:09.95Z|Xload|3\n\
             2024-01-01T00:00:11Z|Xabs|2\n\
             2024-01-01T00:00:05Z|Xabs|3\n",
        );
        assert_eq!(ev.len(), 5, "{ev:?}");
        assert!(matches!(
            &ev[3],
            Event::Gap { reason: GapReason::TimeStepBack { back_s }, .. } if (back_s - 6.0).abs() < 1e-9
        ));
        d.reconnected();
        let ev = decode_all(
            &mut d,
            "2024-01-01T00:00:04Z|Xabs|3|Xload|3\n2024-01-01T00:00:06Z|Xabs|4\n",
        );
        assert_eq!(d.stats.stale, 2);
        assert_eq!(ev.len(), 1);
        // Whole-second heartbeat commands.
        let mut out = VecDeque::new();
        assert_eq!(d.decode("* PING", &mut out).unwrap(), Reply::Ping);
        assert_eq!(
            d.decode("* PONG 10000", &mut out).unwrap(),
            Reply::Pong(Some(10_000))
        );
    }
}
