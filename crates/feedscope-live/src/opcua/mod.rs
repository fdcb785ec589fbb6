//! OPC UA: one axis of a control's OPC UA server as a [`Source`], by subscription to the
//! position and effort nodes (and optionally the program name), with the `async-opcua` client.
//!
//! How it works: [`OpcUaSource::connect`] starts a thread running a single-threaded tokio
//! runtime. That thread connects, creates one subscription with a monitored item per node,
//! and turns every data change into an [`Event`] on a channel that the synchronous
//! [`Source::next_event`] reads. A loss is reported when it is detected, as
//! [`GapReason::ConnectionLost`]: at once when the transport closes, after [`SILENCE_LOSS_S`]
//! without any answer otherwise (the session reads the server state every [`KEEP_ALIVE_S`]).
//! `async-opcua`'s session event loop reconnects by itself with exponential back-off (capped
//! at `connection.retry_max_ms`) and recreates the subscription on a new session; failed
//! attempts are [`Event::Notice`]s (at most one per [`RETRY_NOTICE_S`]) and the reconnection
//! a [`GapReason::Reconnected`].
//!
//! Timing: each sample carries the value's SourceTimestamp (the control's time of the value),
//! else its ServerTimestamp, else the client's clock; the two channels keep their own times.
//! A sample whose time is not after the channel's previous one is dropped: servers resend the
//! current value when a subscription is (re)created, and that value has been delivered.
//!
//! Values: numeric variants of any width are taken as `f64` and scaled to SI (m, A, N·m). A
//! bad status gives `Event::Gap { reason: Unavailable }`; an uncertain status is a sample; a
//! value that is no number (a String on the position node) gives
//! `Event::Gap { reason: BadValue }` naming the node and the type, and the stream goes on.
//!
//! ```no_run
//! use std::time::{Duration, Instant};
//! use feedscope_live::opcua::{OpcUaConfig, OpcUaSource};
//! use feedscope_live::Source;
//!
//! let config = OpcUaConfig::from_file("examples/opcua/companion.toml".as_ref())?;
//! let mut source = OpcUaSource::connect(config)?;
//! while let Some(event) = source.next_event(Instant::now() + Duration::from_secs(1))? {
//!     println!("{event:?}");
//! }
//! # Ok::<(), feedscope_live::LiveError>(())
//! ```
mod config;

use std::collections::{HashMap, VecDeque};
use std::str::FromStr;
use std::sync::{mpsc, Arc, Mutex};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use futures_core::Stream;
use opcua::client::transport::TransportPollResult;
use opcua::client::{
    ClientBuilder, DataChangeCallback, IdentityToken, MonitoredItem, Password, Session,
    SessionConnectMode, SessionPollResult,
};
use opcua::types::{
    DataChangeFilter, DataChangeTrigger, DataValue, DateTime, ExtensionObject, MessageSecurityMode,
    MonitoredItemCreateRequest, MonitoringMode, MonitoringParameters, NodeId, ReadValueId,
    StatusCode, TimestampsToReturn, Variant, VariantTypeId,
};

pub use config::{
    ConnectionParams, EffortNode, EffortUnit, LengthUnit, OpcUaConfig, PositionNode, Security,
    SubscriptionParams, Trigger, SINUMERIK_MIN_SAMPLING_MS,
};

use crate::source::{Event, GapReason, LiveError, Quantity, Source};

/// 100 ns ticks from the OPC UA epoch (1601-01-01) to the Unix epoch (1970-01-01).
const UNIX_EPOCH_TICKS: i64 = 116_444_736_000_000_000;

/// Observed intervals kept for [`Source::sample_interval_s`] (a median over this many).
const INTERVAL_WINDOW: usize = 64;

/// What the client thread sends to [`OpcUaSource`].
enum Msg {
    /// Subscription made; the server's revised sampling interval of the position item (ms).
    Ready {
        revised_sampling_ms: f64,
    },
    Event(Event),
    Error(LiveError),
}

/// Which configured node a monitored item is (its client handle).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
enum Channel {
    Position,
    Effort,
    Program,
}

impl Channel {
    fn handle(self) -> u32 {
        match self {
            Self::Position => 1,
            Self::Effort => 2,
            Self::Program => 3,
        }
    }
}

/// Sample intervals observed on the position channel (s), shared with the client thread.
#[derive(Default)]
struct Intervals {
    revised_s: Option<f64>,
    observed_s: VecDeque<f64>,
}

/// An OPC UA server's view of one axis, as a [`Source`].
pub struct OpcUaSource {
    endpoint: String,
    describe: String,
    rx: mpsc::Receiver<Msg>,
    /// Events that arrived while `connect` waited for the subscription.
    pending: VecDeque<Event>,
    intervals: Arc<Mutex<Intervals>>,
    /// When the server last answered (for [`Source::confirmed_until`]).
    liveness: Arc<Mutex<Liveness>>,
    /// The publishing interval: changes of a moment reach the client up to this much later.
    publishing: Duration,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    thread: Option<std::thread::JoinHandle<()>>,
    failed: bool,
}

impl OpcUaSource {
    /// Connects (up to `connection.attempts` times), subscribes to the configured nodes and
    /// returns once the server has accepted every monitored item.
    ///
    /// # Errors
    /// - [`LiveError::Connect`] naming the endpoint when no connection was made;
    /// - [`LiveError::Protocol`] naming the node when the server refuses a node (unknown node
    ///   id, not a variable, ...) or the subscription;
    /// - [`LiveError::Config`] when a node id is not valid OPC UA text form or the client
    ///   cannot be set up (certificates).
    pub fn connect(config: OpcUaConfig) -> Result<Self, LiveError> {
        // Node ids are checked before any I/O.
        for (field, node) in config_nodes(&config) {
            NodeId::from_str(node).map_err(|_| LiveError::Config {
                file: config.origin.clone(),
                field: field.into(),
                reason: format!("{node:?} is not an OPC UA node id (e.g. ns=2;s=X.ActPos)"),
            })?;
        }
        let endpoint = config.endpoint.clone();
        let describe = format!(
            "OPC UA server {} position {} effort {}{}",
            config.endpoint,
            config.position.node,
            config.effort.node,
            config
                .program_node
                .as_deref()
                .map(|p| format!(" program {p}"))
                .unwrap_or_default()
        );
        let (tx, rx) = mpsc::channel();
        let (stop_tx, stop_rx) = tokio::sync::oneshot::channel();
        let intervals = Arc::new(Mutex::new(Intervals::default()));
        let shared = intervals.clone();
        let liveness = Arc::new(Mutex::new(Liveness::default()));
        let live = liveness.clone();
        let publishing =
            Duration::from_secs_f64(config.subscription.publishing_interval_ms.max(0.0) / 1000.0);
        let thread = std::thread::Builder::new()
            .name("feedscope-opcua".into())
            .spawn(move || {
                let rt = match tokio::runtime::Builder::new_current_thread()
                    .enable_all()
                    .build()
                {
                    Ok(rt) => rt,
                    Err(e) => {
                        let _ = tx.send(Msg::Error(LiveError::Connect {
                            endpoint: config.endpoint.clone(),
                            detail: format!("cannot start the async runtime: {e}"),
                        }));
                        return;
                    }
                };
                rt.block_on(run(config, tx, stop_rx, shared, live));
            })
            .map_err(|e| LiveError::Connect {
                endpoint: endpoint.clone(),
                detail: format!("cannot start the client thread: {e}"),
            })?;
        let mut source = Self {
            pending: VecDeque::new(),
            endpoint,
            describe,
            rx,
            intervals,
            liveness,
            publishing,
            stop: Some(stop_tx),
            thread: Some(thread),
            failed: false,
        };
        loop {
            match source.rx.recv() {
                Ok(Msg::Ready {
                    revised_sampling_ms,
                }) => {
                    source.intervals.lock().expect("not poisoned").revised_s =
                        Some(revised_sampling_ms / 1000.0);
                    return Ok(source);
                }
                Ok(Msg::Error(e)) => return Err(e),
                // The first values can come in before the subscription call has returned.
                Ok(Msg::Event(e)) => source.pending.push_back(e),
                Err(_) => {
                    return Err(LiveError::Connect {
                        endpoint: source.endpoint.clone(),
                        detail: "the client thread stopped before connecting".into(),
                    })
                }
            }
        }
    }
}

impl Source for OpcUaSource {
    fn describe(&self) -> String {
        self.describe.clone()
    }

    fn next_event(&mut self, deadline: Instant) -> Result<Option<Event>, LiveError> {
        if let Some(e) = self.pending.pop_front() {
            return Ok(Some(e));
        }
        if self.failed {
            return Err(LiveError::Ended {
                endpoint: self.endpoint.clone(),
                detail: "the source failed earlier".into(),
            });
        }
        let wait = deadline.saturating_duration_since(Instant::now());
        match self.rx.recv_timeout(wait) {
            Ok(Msg::Event(e)) => Ok(Some(e)),
            Ok(Msg::Error(e)) => {
                self.failed = true;
                Err(e)
            }
            Ok(Msg::Ready { .. }) => Ok(None),
            Err(mpsc::RecvTimeoutError::Timeout) => Ok(None),
            Err(mpsc::RecvTimeoutError::Disconnected) => {
                self.failed = true;
                Err(LiveError::Ended {
                    endpoint: self.endpoint.clone(),
                    detail: "the OPC UA client stopped".into(),
                })
            }
        }
    }

    /// The last answer of the server less one publishing interval (a change made before a
    /// keep-alive answer may come with the next publish); while the link is lost, the instant
    /// it was last heard.
    fn confirmed_until(&self) -> Option<Instant> {
        let heard = self.liveness.lock().expect("not poisoned").heard?;
        Some(heard.checked_sub(self.publishing).unwrap_or(heard))
    }

    /// The median interval between the last position samples (control time), once eight have
    /// been seen; before that the sampling interval the server revised the request to.
    fn sample_interval_s(&self) -> Option<f64> {
        let iv = self.intervals.lock().expect("not poisoned");
        if iv.observed_s.len() >= 8 {
            let mut v: Vec<f64> = iv.observed_s.iter().copied().collect();
            v.sort_by(f64::total_cmp);
            Some(v[v.len() / 2])
        } else {
            iv.revised_s
        }
    }
}

impl Drop for OpcUaSource {
    fn drop(&mut self) {
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn config_nodes(config: &OpcUaConfig) -> Vec<(&'static str, &str)> {
    let mut v = vec![
        ("position.node", config.position.node.as_str()),
        ("effort.node", config.effort.node.as_str()),
    ];
    if let Some(p) = &config.program_node {
        v.push(("program.node", p.as_str()));
    }
    v
}

/// The type of a value in OPC UA's words (`String`, `Boolean`, `Double[]`, `Empty`).
fn variant_type(v: &Variant) -> String {
    match v.type_id() {
        VariantTypeId::Empty => "Empty".into(),
        VariantTypeId::Scalar(t) => format!("{t:?}"),
        VariantTypeId::Array(t, _) => format!("{t:?}[]"),
    }
}

/// OPC UA time to s since the Unix epoch.
fn unix_s(t: &DateTime) -> f64 {
    (t.ticks() - UNIX_EPOCH_TICKS) as f64 * 1e-7
}

fn now_unix_s() -> f64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_secs_f64())
        .unwrap_or(0.0)
}

/// Turns data changes into events; lives in the subscription callback.
struct Converter {
    tx: mpsc::Sender<Msg>,
    position: (String, f64),
    effort: (String, f64, Quantity),
    program: Option<String>,
    last_time_s: HashMap<Channel, f64>,
    last_event_s: Arc<Mutex<Option<f64>>>,
    intervals: Arc<Mutex<Intervals>>,
}

impl Converter {
    fn on_value(&mut self, dv: DataValue, item: &MonitoredItem) {
        let channel = match item.client_handle() {
            1 => Channel::Position,
            2 => Channel::Effort,
            3 => Channel::Program,
            _ => return,
        };
        let time_s = dv
            .source_timestamp
            .as_ref()
            .or(dv.server_timestamp.as_ref())
            .map(unix_s)
            .unwrap_or_else(now_unix_s);
        let (node, quantity, scale) = match channel {
            Channel::Position => (&self.position.0, Quantity::Position, self.position.1),
            Channel::Effort => (&self.effort.0, self.effort.2, self.effort.1),
            Channel::Program => (
                self.program.as_ref().expect("program item"),
                Quantity::Position,
                1.0,
            ),
        };
        let status = dv.status.unwrap_or(StatusCode::Good);
        if status.is_bad() {
            if channel != Channel::Program {
                self.send(Event::Gap {
                    time_s: Some(time_s),
                    reason: GapReason::Unavailable { quantity },
                });
            }
            return;
        }
        if let Some(&last) = self.last_time_s.get(&channel) {
            if time_s <= last {
                return; // resent on a (re)created subscription: already delivered
            }
        }
        let event = match (channel, &dv.value) {
            (Channel::Program, Some(Variant::String(s))) => Event::Program {
                time_s,
                name: s.to_string(),
            },
            (Channel::Program, _) => return, // empty or not a string: no program
            (_, Some(v)) => match v.as_f64() {
                Some(x) => Event::Sample {
                    quantity,
                    time_s,
                    value: x * scale,
                },
                None => {
                    // A value of the wrong type (a String on the position node): this value
                    // is no sample and the episode around it cannot be trusted; the stream
                    // goes on (the caller decides whether to stop).
                    self.send(Event::Gap {
                        time_s: Some(time_s),
                        reason: GapReason::BadValue {
                            quantity,
                            node: node.clone(),
                            value_type: variant_type(v),
                        },
                    });
                    return;
                }
            },
            (_, None) => Event::Gap {
                time_s: Some(time_s),
                reason: GapReason::Unavailable { quantity },
            },
        };
        if let Some(last) = self.last_time_s.insert(channel, time_s) {
            if channel == Channel::Position {
                let mut iv = self.intervals.lock().expect("not poisoned");
                iv.observed_s.push_back(time_s - last);
                if iv.observed_s.len() > INTERVAL_WINDOW {
                    iv.observed_s.pop_front();
                }
            }
        }
        self.send(event);
    }

    fn send(&self, event: Event) {
        if let Event::Sample { time_s, .. } | Event::Program { time_s, .. } = &event {
            *self.last_event_s.lock().expect("not poisoned") = Some(*time_s);
        }
        let _ = self.tx.send(Msg::Event(event));
    }
}

/// The client thread: connect, subscribe, then drive the session until told to stop.
async fn run(
    config: OpcUaConfig,
    tx: mpsc::Sender<Msg>,
    mut stop: tokio::sync::oneshot::Receiver<()>,
    intervals: Arc<Mutex<Intervals>>,
    liveness: Arc<Mutex<Liveness>>,
) {
    let endpoint = config.endpoint.clone();
    let connect_err = |detail: String| LiveError::Connect {
        endpoint: endpoint.clone(),
        detail,
    };
    let conn = &config.connection;
    // Two clients: one that never retries, for GetEndpoints (the first connection's attempts
    // are counted here), and the session's, which reconnects for as long as the source lives.
    // async-opcua takes both the channel's and the session's retries from one setting.
    let make = |retry_limit: i32| {
        let mut b = ClientBuilder::new()
            .application_name("feedscope")
            .application_uri("urn:feedscope:client")
            .product_uri("urn:feedscope")
            .pki_dir(conn.pki_dir.clone())
            .session_retry_limit(retry_limit)
            .session_retry_initial(Duration::from_millis(conn.retry_initial_ms))
            .session_retry_max(Duration::from_millis(conn.retry_max_ms))
            // Traffic at least every second, so that silence means loss (SILENCE_LOSS_S); a
            // stuck server's session is closed and made again after two failed reads.
            .keep_alive_interval(Duration::from_secs_f64(KEEP_ALIVE_S))
            .max_failed_keep_alive_count(2)
            .request_timeout(Duration::from_secs(10))
            .min_publish_interval(Duration::from_millis(
                (config.subscription.publishing_interval_ms as u64).clamp(1, 100),
            ));
        if let Security::Secure {
            certificate,
            private_key,
            trust_server_certificate,
            ..
        } = &config.security
        {
            b = b
                .certificate_path(certificate.clone())
                .private_key_path(private_key.clone())
                .trust_server_certs(*trust_server_certificate);
        }
        b.client().map_err(|errs| LiveError::Config {
            file: config.origin.clone(),
            field: "server".into(),
            reason: format!("the OPC UA client refuses its setup: {}", errs.join("; ")),
        })
    };
    let (discovery, client) = match (make(0), make(-1)) {
        (Ok(d), Ok(c)) => (d, c),
        (Err(e), _) | (_, Err(e)) => {
            let _ = tx.send(Msg::Error(e));
            return;
        }
    };
    let (policy_uri, mode) = match &config.security {
        Security::None => (
            "http://opcfoundation.org/UA/SecurityPolicy#None".to_string(),
            MessageSecurityMode::None,
        ),
        Security::Secure {
            encrypt,
            policy_uri,
            ..
        } => {
            let mode = if *encrypt {
                MessageSecurityMode::SignAndEncrypt
            } else {
                MessageSecurityMode::Sign
            };
            (policy_uri.clone(), mode)
        }
    };
    let identity = match &config.user {
        Some((u, p)) => IdentityToken::UserName(u.clone(), Password(p.clone())),
        None => IdentityToken::Anonymous,
    };

    // First contact: GetEndpoints up to `attempts` times, waiting as the session will later.
    let mut wait = Duration::from_millis(conn.retry_initial_ms);
    let mut attempt = 0;
    let endpoints = loop {
        attempt += 1;
        match discovery
            .get_server_endpoints_from_url(config.endpoint.as_str())
            .await
        {
            Ok(e) => break e,
            Err(e) if attempt >= conn.attempts => {
                let _ = tx.send(Msg::Error(connect_err(format!(
                    "{e} (after {attempt} attempts)"
                ))));
                return;
            }
            Err(_) => {
                tokio::time::sleep(wait).await;
                wait = (wait * 2).min(Duration::from_millis(conn.retry_max_ms));
            }
        }
    };
    drop(discovery);
    let built = client
        .session_builder()
        .with_endpoints(endpoints)
        .connect_to_matching_endpoint((config.endpoint.as_str(), policy_uri.as_str(), mode))
        .map(|b| {
            b.user_identity_token(identity)
                .build(client.certificate_store().clone())
        });
    let (session, event_loop) = match built {
        Ok(Ok(s)) => s,
        Ok(Err(e)) | Err(e) => {
            let _ = tx.send(Msg::Error(connect_err(format!(
                "no endpoint with security policy {policy_uri} and mode {mode:?}: {e}"
            ))));
            return;
        }
    };

    let last_event_s = Arc::new(Mutex::new(None));
    let (state_tx, mut state_rx) = tokio::sync::watch::channel(LinkState::Connecting);
    let drive = tokio::spawn(drive_session(
        event_loop.enter(),
        session.clone(),
        tx.clone(),
        state_tx,
        conn.attempts,
        last_event_s.clone(),
        liveness,
        endpoint.clone(),
    ));
    // Wait for the session (or for the event loop to give up).
    loop {
        match &*state_rx.borrow_and_update() {
            LinkState::Connected => break,
            LinkState::Failed(detail) => {
                let _ = tx.send(Msg::Error(connect_err(detail.clone())));
                drive.abort();
                return;
            }
            LinkState::Connecting => {}
        }
        if state_rx.changed().await.is_err() {
            let _ = tx.send(Msg::Error(connect_err("the session ended".into())));
            return;
        }
    }

    let converter = Converter {
        tx: tx.clone(),
        position: (config.position.node.clone(), config.position.unit.to_m()),
        effort: (
            config.effort.node.clone(),
            config.effort.to_si(),
            Quantity::Effort(config.effort.kind()),
        ),
        program: config.program_node.clone(),
        last_time_s: HashMap::new(),
        last_event_s,
        intervals,
    };
    match subscribe(&session, &config, converter).await {
        Ok(revised_sampling_ms) => {
            let _ = tx.send(Msg::Ready {
                revised_sampling_ms,
            });
        }
        Err(e) => {
            let _ = tx.send(Msg::Error(e));
            let _ = tokio::time::timeout(Duration::from_secs(2), session.disconnect()).await;
            drive.abort();
            return;
        }
    }

    // Run until the source is dropped or the session gives up for good.
    let mut drive = drive;
    tokio::select! {
        _ = &mut stop => {
            let _ = tokio::time::timeout(Duration::from_secs(2), session.disconnect()).await;
            drive.abort();
        }
        _ = &mut drive => {}
    }
}

/// The session's state as the first connection sees it.
#[derive(Debug, Clone)]
enum LinkState {
    Connecting,
    Connected,
    Failed(String),
}

/// Silence after which a connected session counts as lost (s): the client reads the server's
/// state every [`KEEP_ALIVE_S`], so a server that answers nothing for this long is gone or
/// stuck, even while the TCP connection stays open.
pub const SILENCE_LOSS_S: f64 = 3.0;

/// Interval of the session keep-alive (a read of the server state), s.
pub const KEEP_ALIVE_S: f64 = 1.0;

/// While no connection can be made: the first failure is reported at once, then at most one
/// message per this many seconds.
pub const RETRY_NOTICE_S: f64 = 10.0;

/// What the session loop shares with [`OpcUaSource`]: when the server last answered.
#[derive(Debug, Default)]
struct Liveness {
    /// Wall clock of the last message from the server while the link was not lost (frozen
    /// while it is).
    heard: Option<Instant>,
}

/// Polls the session event loop: it connects, keeps the session alive, publishes, and
/// reconnects. A loss is reported when it is detected: [`GapReason::ConnectionLost`] when the
/// transport closes or the server has said nothing for [`SILENCE_LOSS_S`]; failed reconnects
/// as [`Event::Notice`] (the first at once, then every [`RETRY_NOTICE_S`]); the reconnection
/// as [`GapReason::Reconnected`].
#[allow(clippy::too_many_arguments)]
async fn drive_session(
    stream: impl Stream<Item = Result<SessionPollResult, StatusCode>>,
    session: Arc<Session>,
    tx: mpsc::Sender<Msg>,
    state: tokio::sync::watch::Sender<LinkState>,
    first_attempts: u32,
    last_event_s: Arc<Mutex<Option<f64>>>,
    liveness: Arc<Mutex<Liveness>>,
    endpoint: String,
) {
    let mut stream = std::pin::pin!(stream);
    let mut connected_once = false;
    let mut failures = 0u32;
    // Since when and why the link is lost (reported), whether only by silence (the transport
    // still open), and when the last retry notice went out.
    let mut lost: Option<(Instant, String, bool)> = None;
    let mut last_notice: Option<Instant> = None;
    let mut heard = Instant::now();
    let mut watchdog = tokio::time::interval(Duration::from_millis(250));
    let send = |e: Event| {
        let _ = tx.send(Msg::Event(e));
    };
    let report_loss = |detail: String| {
        send(Event::Gap {
            time_s: *last_event_s.lock().expect("not poisoned"),
            reason: GapReason::ConnectionLost { detail },
        });
    };
    loop {
        let item = tokio::select! {
            item = std::future::poll_fn(|cx| stream.as_mut().poll_next(cx)) => item,
            _ = watchdog.tick() => {
                let silent = heard.elapsed().as_secs_f64();
                if connected_once && lost.is_none() && silent >= SILENCE_LOSS_S {
                    let detail = format!("no answer from {endpoint} for {silent:.1} s");
                    report_loss(detail.clone());
                    lost = Some((Instant::now(), detail, true));
                }
                continue;
            }
        };
        let Some(item) = item else { break };
        match item {
            Ok(SessionPollResult::Transport(TransportPollResult::IncomingMessage)) => {
                heard = Instant::now();
                // A server that was silent on an open connection answers again: the episode
                // was discarded at the loss; the stream goes on.
                if let Some((since, _, true)) = &lost {
                    send(Event::Notice {
                        message: format!(
                            "{endpoint} answers again after {:.1} s of silence",
                            since.elapsed().as_secs_f64()
                        ),
                        connected: true,
                    });
                    lost = None;
                }
                if lost.is_none() {
                    liveness.lock().expect("not poisoned").heard = Some(heard);
                }
            }
            Ok(SessionPollResult::Reconnected(mode)) => {
                heard = Instant::now();
                if !connected_once {
                    connected_once = true;
                    let _ = state.send(LinkState::Connected);
                } else {
                    // async-opcua 0.19 recreates the subscriptions while it reconnects, but its
                    // new publish loop starts idle and only wakes on a trigger made after it
                    // was built, so without this nothing is published on the new session.
                    session.trigger_publish_now();
                }
                if let Some((since, why, _)) = lost.take() {
                    send(Event::Gap {
                        time_s: *last_event_s.lock().expect("not poisoned"),
                        reason: GapReason::Reconnected {
                            detail: format!(
                                "connection lost ({why}); reconnected after {:.1} s and {failures} \
                                 failed attempts, {}",
                                since.elapsed().as_secs_f64(),
                                match mode {
                                    SessionConnectMode::NewSession(_) =>
                                        "new session, subscription made again",
                                    SessionConnectMode::ReactivatedSession(_) =>
                                        "session reactivated",
                                }
                            ),
                        },
                    });
                }
                liveness.lock().expect("not poisoned").heard = Some(heard);
                failures = 0;
                last_notice = None;
            }
            Ok(SessionPollResult::ConnectionLost(code)) => {
                match &mut lost {
                    None => {
                        report_loss(code.to_string());
                        lost = Some((Instant::now(), code.to_string(), false));
                    }
                    // Found silent before; now the transport is gone too.
                    Some(l) => l.2 = false,
                }
            }
            Ok(SessionPollResult::ReconnectFailed(code)) => {
                failures += 1;
                if !connected_once && failures >= first_attempts {
                    let _ = state.send(LinkState::Failed(format!(
                        "{code} (after {failures} attempts)"
                    )));
                    return;
                }
                let due = last_notice.is_none_or(|t| t.elapsed().as_secs_f64() >= RETRY_NOTICE_S);
                if connected_once && due {
                    let since = lost.as_ref().map_or(0.0, |l| l.0.elapsed().as_secs_f64());
                    send(Event::Notice {
                        message: format!(
                            "no connection to {endpoint} for {since:.0} s ({failures} failed \
                             attempt(s), last {code}); retrying"
                        ),
                        connected: false,
                    });
                    last_notice = Some(Instant::now());
                }
            }
            Ok(_) => {}
            Err(code) => {
                if connected_once {
                    let _ = tx.send(Msg::Error(LiveError::Ended {
                        endpoint,
                        detail: format!("the session ended: {code}"),
                    }));
                } else {
                    let _ = state.send(LinkState::Failed(code.to_string()));
                }
                return;
            }
        }
    }
    let _ = tx.send(Msg::Error(LiveError::Ended {
        endpoint,
        detail: "the session was closed".into(),
    }));
}

/// Creates the subscription and its monitored items; returns the position item's revised
/// sampling interval (ms).
async fn subscribe(
    session: &Arc<Session>,
    config: &OpcUaConfig,
    mut converter: Converter,
) -> Result<f64, LiveError> {
    let endpoint = &config.endpoint;
    let sub = &config.subscription;
    let publishing = Duration::from_secs_f64(sub.publishing_interval_ms / 1000.0);
    // Lifetime and keep-alive counts in publishing intervals: keep-alive every ~10 s at most,
    // the subscription outlives 3 missed keep-alives (OPC UA Part 4, 5.13.2).
    let keep_alive = ((10_000.0 / sub.publishing_interval_ms).ceil() as u32).clamp(1, 1000);
    let sub_id = session
        .create_subscription(
            publishing,
            keep_alive * 3,
            keep_alive,
            0,
            0,
            true,
            DataChangeCallback::new(move |dv, item| converter.on_value(dv, item)),
        )
        .await
        .map_err(|e| LiveError::Protocol {
            endpoint: endpoint.clone(),
            detail: format!("the server refused the subscription: {e}"),
        })?;

    let trigger = match sub.trigger {
        Trigger::StatusValue => DataChangeTrigger::StatusValue,
        Trigger::StatusValueTimestamp => DataChangeTrigger::StatusValueTimestamp,
    };
    let mut channels = vec![
        (
            Channel::Position,
            "position.node",
            config.position.node.as_str(),
        ),
        (Channel::Effort, "effort.node", config.effort.node.as_str()),
    ];
    if let Some(p) = &config.program_node {
        channels.push((Channel::Program, "program.node", p.as_str()));
    }
    let requests: Vec<MonitoredItemCreateRequest> = channels
        .iter()
        .map(|&(ch, _, node)| {
            let node_id = NodeId::from_str(node).expect("checked in connect");
            // The program name is a string: a deadband-free value trigger is all it needs.
            let filter = if ch == Channel::Program {
                ExtensionObject::null()
            } else {
                ExtensionObject::from_message(DataChangeFilter {
                    trigger,
                    deadband_type: 0,
                    deadband_value: 0.0,
                })
            };
            MonitoredItemCreateRequest::new(
                ReadValueId::from(node_id),
                MonitoringMode::Reporting,
                MonitoringParameters {
                    client_handle: ch.handle(),
                    sampling_interval: sub.sampling_interval_ms,
                    filter,
                    queue_size: sub.queue_size,
                    discard_oldest: true,
                },
            )
        })
        .collect();
    let created = session
        .create_monitored_items(sub_id, TimestampsToReturn::Both, requests)
        .await
        .map_err(|e| LiveError::Protocol {
            endpoint: endpoint.clone(),
            detail: format!("the server refused the monitored items: {e}"),
        })?;
    let mut revised = sub.sampling_interval_ms;
    let mut refused = Vec::new();
    for ((ch, field, node), item) in channels.iter().zip(&created) {
        let status = item.result.status_code;
        if status.is_bad() {
            refused.push(format!("{field} {node}: {status}"));
        } else if *ch == Channel::Position {
            revised = item.result.revised_sampling_interval;
        }
    }
    if !refused.is_empty() {
        return Err(LiveError::Protocol {
            endpoint: endpoint.clone(),
            detail: format!("the server refused node(s): {}", refused.join("; ")),
        });
    }
    Ok(revised)
}
