//! The watch gateway (docs/live.md): follow one axis of a running control through a live
//! [`Source`], recognise the planned tests it runs ([`Recognizer`]) and store each in the
//! history as `history add` stores a trace file.
//!
//! [`WatchRequest`] says what to look for and where it goes (the test kind, the machine and
//! axis names, the standstill that ends a motion episode, the intervals of the indicators);
//! [`WatchRequest::gateway`] checks it, naming a bad field, and reads its axis file into a
//! [`Gateway`] before anything is connected. [`Gateway::run`] is the event loop: it takes the
//! source, the open store, a stop flag (set by Ctrl-C, a service manager or a server shutting
//! down) and a log that receives every [`WatchEvent`] as it happens: the source's notices and
//! gaps, motion that is no test, discarded episodes, each test's verdict and its storing with
//! the axis's trend status. A front end prints them or sends them on; the words of each are
//! its [`Display`](std::fmt::Display).
//!
//! A test is stored only whole: an episode with a data gap, or cut by the stop, is discarded
//! and said so, never stored. The trace of a test goes through the CSV writer and reader as a
//! file given to `history add` would, so that the same samples give the same stored test (and
//! the same content hash, which finds duplicates).
use std::fmt;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use feedscope::axis::AxisParams;
use feedscope::study::{StrokeStudyParams, TestKind};
use feedscope::trace::GlitchParams;
use feedscope_io::trace::{parse_trace_with, write_csv, Layout, ReadOptions};
use feedscope_live::opcua::{EffortUnit, OpcUaConfig};
use feedscope_live::watch::{
    feed_for_order_m_s, FinishedTest, Outcome as Episode, Recognizer, RecognizerParams,
};
use feedscope_live::{Event, GapReason, LiveError, Source};
use feedscope_store::time::format_rfc3339;
use feedscope_store::{AddOutcome, Store};
use serde::{Deserialize, Serialize};

use crate::history::{analyse_for_store, axis_label, Analysed, TestMeta};
use crate::store::{add_error, StoreSpec};
use crate::trend::{axis_trend, TrendOptions};
use crate::{AppError, FrontEnd};

/// How long one wait for the source's next event lasts before the loop looks at the stop flag
/// and its clocks again.
const POLL: Duration = Duration::from_millis(200);

/// What a gateway looks for and how it stores what it finds (`feedscope watch`'s flags shared
/// by every source).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WatchRequest {
    /// Axis parameters (TOML or JSON), as for `history add`; a triangle test's may leave out
    /// what it identifies.
    pub axis_file: PathBuf,
    /// Machine name in the history.
    pub machine: String,
    /// Axis name in the history; default: the axis file's `name`, else its file stem.
    pub axis_name: Option<String>,
    /// Which test to recognise.
    pub kind: TestKind,
    /// Only motion while the control's program name contains this (ignoring case).
    pub program: Option<String>,
    /// Stop after the first stored test.
    pub once: bool,
    /// Standstill that ends a motion episode (s of control time).
    pub standstill_s: f64,
    /// Position changes up to this are no motion (mm).
    pub position_quantum_mm: f64,
    /// Width of the position intervals of the mean-friction indicators (mm).
    pub interval_mm: f64,
    /// Also say which feed resolves this screw order (cycles per lead) at the observed
    /// sample interval.
    pub want_order: Option<f64>,
    /// End the watch (bad input) when a channel delivers a value that is no number; without
    /// it the test around the value is discarded, said, and the watch goes on.
    pub stop_on_bad_value: bool,
}

impl Default for WatchRequest {
    fn default() -> Self {
        Self {
            axis_file: PathBuf::new(),
            machine: "machine".to_string(),
            axis_name: None,
            kind: TestKind::Strokes,
            program: None,
            once: false,
            // Longer than the dwells of a planned test.
            standstill_s: 2.0,
            // MTConnect positions are usually given to 0.001 mm.
            position_quantum_mm: 0.001,
            interval_mm: StrokeStudyParams::default().interval_mm,
            want_order: None,
            stop_on_bad_value: false,
        }
    }
}

impl WatchRequest {
    /// Check the settings without reading anything.
    ///
    /// # Errors
    /// [`AppError::invalid`] naming the field in the front end's spelling: a standstill that
    /// is not a positive time, a negative position quantum, an interval that is not a positive
    /// length, a wanted order that is not positive.
    pub fn validate(&self, front: &dyn FrontEnd) -> Result<(), AppError> {
        let invalid = |field: &'static str, what: &str| {
            Err(AppError::invalid(
                field,
                format!("{} must be {what}", front.name(field)),
            ))
        };
        if !(self.standstill_s.is_finite() && self.standstill_s > 0.0) {
            return invalid("standstill_s", "a positive time");
        }
        if !(self.position_quantum_mm.is_finite() && self.position_quantum_mm >= 0.0) {
            return invalid("position_quantum_mm", "≥ 0");
        }
        if !(self.interval_mm.is_finite() && self.interval_mm > 0.0) {
            return invalid("interval_mm", "a positive length");
        }
        if self.want_order.is_some_and(|k| !(k.is_finite() && k > 0.0)) {
            return invalid("want_order", "a positive order");
        }
        Ok(())
    }

    /// Check the request and read its axis file: the gateway, ready to run once a source is
    /// connected and a store opened. Its source says nothing of its effort channel until
    /// [`Gateway::with_effort`].
    ///
    /// # Errors
    /// As [`WatchRequest::validate`]; the axis file's reader (naming the file and key, the
    /// field `axis_file`).
    pub fn gateway(&self, front: &dyn FrontEnd) -> Result<Gateway, AppError> {
        self.validate(front)?;
        let axis = match self.kind {
            TestKind::Triangle => feedscope_io::axis::load_for_identification(&self.axis_file),
            _ => feedscope_io::axis::load(&self.axis_file),
        }
        .map_err(|e| AppError::from_error(e).for_field("axis_file"))?;
        let axis_name = axis_label(self.axis_name.as_deref(), &axis, Some(&self.axis_file));
        Ok(Gateway {
            request: self.clone(),
            axis,
            axis_name,
            effort: EffortHints::default(),
        })
    }
}

/// What a source says about its effort channel, for the analysis of each test.
#[derive(Debug, Default, Clone, Copy, PartialEq, Serialize)]
pub struct EffortHints {
    /// Resolution of the effort in SI units (A or N·m), when the protocol fixes it.
    pub quantum: Option<f64>,
    /// `Some(false)` for a magnitude (a drive load), `None` to judge from the data.
    pub signed: Option<bool>,
}

impl EffortHints {
    /// A drive load as MTConnect reports it (an agent's or an adapter's `LOAD`): whole percent
    /// of the motor torque at 100 % load, `torque_per_load_nm` (N·m), a magnitude.
    ///
    /// # Errors
    /// [`AppError::invalid`] naming `torque_per_load_nm` when it is not a positive torque.
    pub fn drive_load(torque_per_load_nm: f64, front: &dyn FrontEnd) -> Result<Self, AppError> {
        if !(torque_per_load_nm.is_finite() && torque_per_load_nm > 0.0) {
            return Err(AppError::invalid(
                "torque_per_load_nm",
                format!(
                    "{} must be a positive torque",
                    front.name("torque_per_load_nm")
                ),
            ));
        }
        Ok(Self {
            quantum: Some(torque_per_load_nm / 100.0),
            signed: Some(false),
        })
    }

    /// The effort node of an OPC UA source: a load reading is a magnitude whose resolution is
    /// not known in advance; a current or torque says nothing in advance.
    pub fn opcua(config: &OpcUaConfig) -> Self {
        match config.effort.unit {
            EffortUnit::Percent { .. } => Self {
                quantum: None,
                signed: Some(false),
            },
            _ => Self::default(),
        }
    }
}

/// A live source's error as the user needs it: a configuration that is wrong (a file, field
/// and what is wrong with it) is bad input; the others (cannot connect, the source ended) are
/// not the input's fault.
pub fn source_error(e: LiveError) -> AppError {
    match e {
        LiveError::Config { .. } => AppError::bad_input(e.to_string()),
        e => AppError::from_error(e),
    }
}

/// A checked [`WatchRequest`] with its axis: plan once ([`WatchRequest::gateway`]), then
/// [`run`](Gateway::run) against a source.
#[derive(Debug, Clone)]
pub struct Gateway {
    request: WatchRequest,
    axis: AxisParams,
    axis_name: String,
    effort: EffortHints,
}

/// How a watch ended when it did not fail.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Ended {
    /// The stop flag was set.
    Stopped,
    /// The first test was stored ([`WatchRequest::once`]).
    Once,
}

/// What a watch did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct WatchReport {
    /// Tests stored (a duplicate of a stored one counts: it is in the history).
    pub stored: usize,
    /// How it ended.
    pub ended: Ended,
}

/// A test the gateway recognised, analysed and stored: the JSON a server sends on, and the
/// lines a log shows ([`StoredTest::status_line`], [`StoredTest::resolution_line`],
/// [`StoredTest::latency_line`]).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StoredTest {
    /// Test id in the store.
    pub id: i64,
    /// The same trace content was stored before (nothing added).
    pub duplicate: bool,
    /// Machine name.
    pub machine: String,
    /// Axis name.
    pub axis: String,
    /// Kind of test.
    pub kind: TestKind,
    /// Test time (its first sample), RFC 3339 UTC.
    pub time_utc: String,
    /// Moves with a steady stroke, both directions.
    pub strokes: usize,
    /// The distinct feeds of its strokes (mm/min), ascending.
    pub feeds_mm_min: Vec<f64>,
    /// Median interval between its position samples (s).
    pub sample_interval_s: f64,
    /// Screw lead (mm).
    pub lead_mm: f64,
    /// Highest screw order resolvable at the highest feed (Nyquist, docs/live.md).
    pub resolvable_order: f64,
    /// The order asked for ([`WatchRequest::want_order`]) and the highest feed (mm/min) that
    /// resolves it at this sample interval.
    pub wanted_order: Option<(f64, f64)>,
    /// The axis's trend after this test in a few words ([`crate::trend::AxisTrends::status_line`]),
    /// or why there is none.
    pub trend: String,
    /// From the arrival of the test's last sample to the test stored with its trend (s).
    pub latency_s: f64,
}

impl StoredTest {
    /// `TIME  N strokes  feed F1/F2 mm/min  stored test ID  trend STATUS`.
    pub fn status_line(&self) -> String {
        let feeds: Vec<String> = self
            .feeds_mm_min
            .iter()
            .map(|f| format!("{f:.1}"))
            .collect();
        let stored = if self.duplicate {
            format!("duplicate of test {}", self.id)
        } else {
            format!("stored test {}", self.id)
        };
        format!(
            "{}  {} strokes  feed {} mm/min  {stored}  trend {}",
            self.time_utc,
            self.strokes,
            feeds.join("/"),
            self.trend
        )
    }

    /// Which screw orders the stream resolved, indented under the status line.
    pub fn resolution_line(&self) -> String {
        format!(
            "  sample interval {:.3} s: screw orders up to {:.1} resolvable at {:.1} mm/min \
             (lead {} mm){}",
            self.sample_interval_s,
            self.resolvable_order,
            self.feeds_mm_min.last().copied().unwrap_or(f64::NAN),
            self.lead_mm,
            match self.wanted_order {
                Some((o, feed_mm_min)) =>
                    format!("; order {o} needs a feed ≤ {feed_mm_min:.1} mm/min"),
                None => String::new(),
            }
        )
    }

    /// How long analysing and storing took after the test's last sample arrived.
    pub fn latency_line(&self) -> String {
        format!(
            "analysed and stored {:.0} ms after the test's last sample arrived",
            self.latency_s * 1e3
        )
    }
}

/// One thing that happened during a watch, in the order it happened. Its
/// [`Display`](fmt::Display) is the line a log shows for it.
#[derive(Debug)]
#[non_exhaustive]
pub enum WatchEvent<'a> {
    /// The watch begins: the source in words, the kind looked for, the machine and axis it is
    /// stored as, the store in words (its password hidden).
    Watching {
        /// [`Source::describe`].
        source: &'a str,
        /// The test looked for.
        kind: TestKind,
        /// Machine name.
        machine: &'a str,
        /// Axis name.
        axis: &'a str,
        /// [`StoreSpec::describe`].
        store: &'a str,
    },
    /// News of the connection from the source (lost, retrying, made again).
    Notice(&'a str),
    /// Data may be missing here: a test running across it is discarded.
    Gap(&'a GapReason),
    /// A motion episode that is no test of the kind looked for.
    NotATest {
        /// Control time of its start (s since the Unix epoch).
        start_time_s: f64,
        /// The test looked for.
        kind: TestKind,
        /// Why not.
        reason: &'a str,
    },
    /// An episode thrown away (a gap in it, longer than the recognizer keeps).
    Discarded {
        /// Control time of its start (s since the Unix epoch).
        start_time_s: f64,
        /// Why.
        reason: &'a str,
    },
    /// A line of a recognised test's verdict (what its data support), before it is stored.
    Verdict(&'a str),
    /// A test analysed and stored.
    Stored(&'a StoredTest),
    /// A recognised test that could not be analysed or stored; the watch goes on.
    NotStored {
        /// Control time of its start (s since the Unix epoch).
        start_time_s: f64,
        /// Why, with its causes.
        error: &'a AppError,
    },
    /// The stop flag ended a motion episode in progress: discarded, never stored.
    StoppedInMotion {
        /// Control time of its start (s since the Unix epoch).
        start_time_s: f64,
        /// Why it is not stored.
        reason: &'a str,
    },
    /// The watch stopped on its flag.
    Stopped {
        /// Tests stored.
        stored: usize,
    },
}

impl fmt::Display for WatchEvent<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            WatchEvent::Watching {
                source,
                kind,
                machine,
                axis,
                store,
            } => write!(
                f,
                "watching {source} for {} tests of machine {machine:?} axis {axis:?} (store \
                 {store})",
                kind.as_str()
            ),
            WatchEvent::Notice(message) | WatchEvent::Verdict(message) => f.write_str(message),
            WatchEvent::Gap(reason) => write!(f, "gap: {reason}"),
            WatchEvent::NotATest {
                start_time_s,
                kind,
                reason,
            } => write!(
                f,
                "motion at {}: not a {} test ({reason})",
                format_rfc3339(*start_time_s),
                kind.as_str()
            ),
            WatchEvent::Discarded {
                start_time_s,
                reason,
            } => write!(
                f,
                "motion at {} discarded: {reason}",
                format_rfc3339(*start_time_s)
            ),
            WatchEvent::Stored(t) => f.write_str(&t.status_line()),
            WatchEvent::NotStored {
                start_time_s,
                error,
            } => {
                write!(
                    f,
                    "test at {} not stored: {error}",
                    format_rfc3339(*start_time_s)
                )?;
                // The causes as anyhow's `{:#}` joins them.
                let mut cause = std::error::Error::source(*error);
                while let Some(c) = cause {
                    write!(f, ": {c}")?;
                    cause = c.source();
                }
                Ok(())
            }
            WatchEvent::StoppedInMotion { reason, .. } => f.write_str(reason),
            WatchEvent::Stopped { stored } => write!(f, "stopped; {stored} test(s) stored"),
        }
    }
}

impl Gateway {
    /// The request the gateway was made from.
    pub fn request(&self) -> &WatchRequest {
        &self.request
    }

    /// The axis parameters read from the request's axis file.
    pub fn axis(&self) -> &AxisParams {
        &self.axis
    }

    /// The axis name the tests are stored under.
    pub fn axis_name(&self) -> &str {
        &self.axis_name
    }

    /// The same gateway, with what its source says about the effort channel.
    #[must_use]
    pub fn with_effort(mut self, effort: EffortHints) -> Self {
        self.effort = effort;
        self
    }

    /// The recognizer of the request's test in the source's units.
    fn recognizer(&self) -> Recognizer {
        let w = &self.request;
        Recognizer::new(RecognizerParams {
            kind: match w.kind {
                TestKind::Triangle => feedscope::plan::TestKind::Triangle,
                _ => feedscope::plan::TestKind::Strokes,
            },
            standstill_s: w.standstill_s,
            position_quantum_m: w.position_quantum_mm * 1e-3,
            program: w.program.clone(),
            effort_quantum: self.effort.quantum,
            effort_signed: self.effort.signed,
            ..RecognizerParams::default()
        })
    }

    /// Watch `src` until `stop` is set (or, with [`WatchRequest::once`], the first test is
    /// stored), storing each recognised test into `store` (`spec` names it in messages) and
    /// telling `log` every [`WatchEvent`] as it happens. An error of `log` (a closed output)
    /// ends the watch with it.
    ///
    /// Control time goes on while the axis stands still and a change-only stream says
    /// nothing: the wall clock since the last event stands in for it (so that the standstill
    /// ending a test is seen without another sample), unless the source is disconnected (the
    /// data of that time may still come), and only as far as the source vouches that nothing
    /// is missing ([`Source::confirmed_until`]).
    ///
    /// # Errors
    /// The source's error when it cannot go on; with [`WatchRequest::stop_on_bad_value`], bad
    /// input at the first value that is no number (saying how many tests were stored); `log`'s.
    pub fn run<E: From<AppError>>(
        &self,
        src: &mut dyn Source,
        store: &mut dyn Store,
        spec: &StoreSpec,
        stop: &AtomicBool,
        front: &dyn FrontEnd,
        log: &mut dyn FnMut(WatchEvent<'_>) -> Result<(), E>,
    ) -> Result<WatchReport, E> {
        let kind = self.request.kind;
        let mut rec = self.recognizer();
        log(WatchEvent::Watching {
            source: &src.describe(),
            kind,
            machine: &self.request.machine,
            axis: &self.axis_name,
            store: &spec.describe(),
        })?;
        let mut connected = true;
        let mut bad_value: Option<String> = None;
        let mut last_event = Instant::now();
        let mut stored = 0usize;
        loop {
            if stop.load(Ordering::SeqCst) {
                if let Some(Episode::Discarded {
                    start_time_s,
                    reason,
                }) = rec.shutdown()
                {
                    log(WatchEvent::StoppedInMotion {
                        start_time_s,
                        reason: &reason,
                    })?;
                }
                log(WatchEvent::Stopped { stored })?;
                return Ok(WatchReport {
                    stored,
                    ended: Ended::Stopped,
                });
            }
            let deadline = Instant::now() + POLL;
            let outcome = match src.next_event(deadline).map_err(AppError::from_error)? {
                Some(ev) => {
                    last_event = Instant::now();
                    match &ev {
                        Event::Notice {
                            message,
                            connected: c,
                        } => {
                            connected = *c;
                            log(WatchEvent::Notice(message))?;
                        }
                        Event::Gap { reason, .. } => {
                            log(WatchEvent::Gap(reason))?;
                            match reason {
                                GapReason::ConnectionLost { .. } => connected = false,
                                GapReason::Reconnected { .. } => connected = true,
                                GapReason::BadValue { .. } if self.request.stop_on_bad_value => {
                                    bad_value = Some(reason.to_string());
                                }
                                _ => {}
                            }
                        }
                        _ => {}
                    }
                    rec.push(&ev)
                }
                None if connected => {
                    let now = Instant::now();
                    let upto = src
                        .confirmed_until()
                        .map_or(now, |c| c.min(now))
                        .max(last_event);
                    rec.now_s()
                        .and_then(|t| rec.tick(t + (upto - last_event).as_secs_f64()))
                }
                None => None,
            };
            if let Some(why) = bad_value.take() {
                if let Some(Episode::Discarded {
                    start_time_s,
                    reason,
                }) = &outcome
                {
                    log(WatchEvent::Discarded {
                        start_time_s: *start_time_s,
                        reason,
                    })?;
                }
                return Err(AppError::bad_input(format!(
                    "{why} ({}); {stored} test(s) stored",
                    front.name("stop_on_bad_value")
                ))
                .into());
            }
            let Some(outcome) = outcome else { continue };
            match outcome {
                Episode::NotATest {
                    start_time_s,
                    reason,
                } => log(WatchEvent::NotATest {
                    start_time_s,
                    kind,
                    reason: &reason,
                })?,
                Episode::Discarded {
                    start_time_s,
                    reason,
                } => log(WatchEvent::Discarded {
                    start_time_s,
                    reason: &reason,
                })?,
                Episode::Test(t) => {
                    let finished = Instant::now();
                    let done = match self.analyse(&t) {
                        Ok(analysed) => {
                            for line in &analysed.verdict {
                                log(WatchEvent::Verdict(line))?;
                            }
                            self.store(store, spec, &t, analysed, front)
                        }
                        Err(e) => Err(e),
                    };
                    match done {
                        Ok(mut s) => {
                            s.latency_s = finished.elapsed().as_secs_f64();
                            log(WatchEvent::Stored(&s))?;
                            stored += 1;
                            if self.request.once {
                                return Ok(WatchReport {
                                    stored,
                                    ended: Ended::Once,
                                });
                            }
                        }
                        Err(error) => log(WatchEvent::NotStored {
                            start_time_s: t.start_time_s,
                            error: &error,
                        })?,
                    }
                }
            }
        }
    }

    /// Analyse a recognised test as `history add` analyses a trace file: the trace goes
    /// through the CSV writer and reader, as a file would (the same glitch screening, and its
    /// bytes identify duplicates).
    ///
    /// # Errors
    /// Reading the trace back; the analysis's errors.
    pub fn analyse(&self, t: &FinishedTest) -> Result<Analysed, AppError> {
        let mut bytes = Vec::new();
        write_csv(&t.trace, &mut bytes, Layout::Long).map_err(AppError::from_error)?;
        let source = format!("watch {}", format_rfc3339(t.start_time_s));
        let (trace, _) = parse_trace_with(
            &bytes,
            &source,
            &ReadOptions::default(),
            &GlitchParams::for_axis(&self.axis),
        )
        .map_err(AppError::from_error)?;
        let meta = TestMeta {
            machine: self.request.machine.clone(),
            axis: self.axis_name.clone(),
            time_s: t.start_time_s,
            source,
            program: t.program.clone(),
            reference: false,
            compensation: None,
        };
        let mut axis = self.axis.clone();
        analyse_for_store(
            &trace,
            &mut axis,
            self.request.kind,
            self.request.interval_mm,
            &bytes,
            meta,
        )
    }

    /// Store an analysed test and take the axis's trend after it.
    ///
    /// # Errors
    /// A failed add ([`add_error`]).
    fn store(
        &self,
        store: &mut dyn Store,
        spec: &StoreSpec,
        t: &FinishedTest,
        analysed: Analysed,
        front: &dyn FrontEnd,
    ) -> Result<StoredTest, AppError> {
        let outcome = store.add(&analysed.test).map_err(|e| add_error(e, spec))?;
        let (id, duplicate) = match outcome {
            AddOutcome::Added(id) => (id, false),
            AddOutcome::Duplicate(id) => (id, true),
        };
        let lead_m = self.axis.lead_m();
        Ok(StoredTest {
            id,
            duplicate,
            machine: self.request.machine.clone(),
            axis: self.axis_name.clone(),
            kind: self.request.kind,
            time_utc: analysed.test.time_utc,
            strokes: t.strokes,
            feeds_mm_min: t.feeds_m_s.iter().map(|f| f * 6e4).collect(),
            sample_interval_s: t.sample_interval_s,
            lead_mm: self.axis.lead_mm,
            resolvable_order: t.resolvable_order(lead_m),
            wanted_order: self
                .request
                .want_order
                .map(|o| (o, feed_for_order_m_s(lead_m, o, t.sample_interval_s) * 6e4)),
            trend: trend_status(store, &self.request.machine, &self.axis_name, front),
            latency_s: 0.0,
        })
    }
}

/// The axis's trend in a few words ([`crate::trend::AxisTrends::status_line`]), or why there
/// is none.
fn trend_status(store: &dyn Store, machine: &str, axis: &str, front: &dyn FrontEnd) -> String {
    let options = TrendOptions::default();
    match axis_trend(
        store,
        machine,
        Some(axis),
        &options,
        Default::default(),
        front,
    ) {
        Ok(t) => t.status_line(),
        Err(e) => format!("not available ({e})"),
    }
}
