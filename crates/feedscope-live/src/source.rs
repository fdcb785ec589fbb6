//! The [`Source`] trait: one axis of a live control as a stream of [`Event`]s.
//!
//! Every source converts to SI at its edge (position in metres, current in amperes, torque in
//! newton-metres) and stamps events with the control's own time (s since the Unix epoch) when
//! the protocol carries it, so that a trace built from the events has the control's timing,
//! not the network's.
use std::time::Instant;

use feedscope::trace::EffortKind;

/// Which channel of the axis a sample belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Quantity {
    /// Axis position (m).
    Position,
    /// Servo effort: motor current (A) or torque (N·m).
    Effort(EffortKind),
}

/// Why data may be missing between two events.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum GapReason {
    /// The source skipped sequence numbers (MTConnect `from` left the agent's buffer, or the
    /// next sequence was not the one expected).
    Skipped {
        /// Observations lost, when the protocol says how many.
        lost: Option<u64>,
    },
    /// The agent or server restarted (MTConnect instance id changed; OPC UA session lost).
    Restart {
        /// Words for the log, e.g. `instanceId 1700000000 -> 1700000123`.
        detail: String,
    },
    /// The connection was lost (the transport closed, or the server stopped answering): what
    /// the control did from here until a [`GapReason::Reconnected`] is unknown. Reported when
    /// the loss is detected, not when the server is back.
    ConnectionLost {
        /// What failed, in the transport's words.
        detail: String,
    },
    /// The connection dropped and was made again.
    Reconnected {
        /// What failed, in the transport's words.
        detail: String,
    },
    /// The control reported the channel unavailable (MTConnect `UNAVAILABLE`, OPC UA bad
    /// status).
    Unavailable {
        /// The channel.
        quantity: Quantity,
    },
    /// A channel delivered a value that is no number (e.g. a String on the position node): the
    /// value is dropped and what surrounds it cannot be trusted.
    BadValue {
        /// The channel.
        quantity: Quantity,
        /// The node or data item, as configured.
        node: String,
        /// The value's type as the protocol names it (e.g. `String`).
        value_type: String,
    },
    /// The control's timestamps stepped back (an adapter that restarted and replays its state,
    /// a clock reset): what came before and after cannot be joined into one trace.
    TimeStepBack {
        /// How far back (s).
        back_s: f64,
    },
}

impl std::fmt::Display for GapReason {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Skipped { lost: Some(n) } => write!(f, "{n} observations skipped"),
            Self::Skipped { lost: None } => write!(f, "observations skipped"),
            Self::Restart { detail } => write!(f, "the source restarted ({detail})"),
            Self::ConnectionLost { detail } => write!(f, "connection lost ({detail})"),
            Self::Reconnected { detail } => write!(f, "reconnected ({detail})"),
            Self::BadValue {
                quantity,
                node,
                value_type,
            } => write!(
                f,
                "node {node} ({quantity:?}) delivered a {value_type} value, not a number"
            ),
            Self::Unavailable { quantity } => write!(f, "{quantity:?} unavailable"),
            Self::TimeStepBack { back_s } => {
                write!(f, "control timestamps stepped back {back_s:.3} s")
            }
        }
    }
}

/// One thing a live source reports.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum Event {
    /// A new value of a channel.
    Sample {
        /// The channel.
        quantity: Quantity,
        /// Control time of the value (s since the Unix epoch).
        time_s: f64,
        /// The value in SI: m for position, A or N·m for effort.
        value: f64,
    },
    /// The control started running a program (name as the control reports it).
    Program {
        /// Control time (s since the Unix epoch).
        time_s: f64,
        /// Program name.
        name: String,
    },
    /// Data may be missing here: a test running across it cannot be trusted.
    Gap {
        /// Control time of the last event before the gap, when known (s since the Unix epoch).
        time_s: Option<f64>,
        /// Why.
        reason: GapReason,
    },
    /// News of the connection for the log (lost, retrying, made again) when no data is known
    /// to be missing: a source that resumes where it stopped (MTConnect sequence numbers)
    /// reports a lost connection here and a [`Event::Gap`] only if data was lost.
    Notice {
        /// Words for the log.
        message: String,
        /// Whether the source is connected now: while it is not, the caller's clock must not
        /// end an episode (the data of that time may still come).
        connected: bool,
    },
}

/// Errors of a live source.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LiveError {
    /// The source's configuration is wrong (a file, field and what is wrong with it).
    #[error("{file}: {field}: {reason}")]
    Config {
        /// The configuration file, or `command line`.
        file: String,
        /// The field or flag.
        field: String,
        /// What is wrong.
        reason: String,
    },
    /// The endpoint could not be reached (after the retries the source allows).
    #[error("cannot connect to {endpoint}: {detail}")]
    Connect {
        /// The endpoint.
        endpoint: String,
        /// The transport's words.
        detail: String,
    },
    /// The endpoint answered something this source does not understand.
    #[error("{endpoint}: {detail}")]
    Protocol {
        /// The endpoint.
        endpoint: String,
        /// What was wrong, naming the element, line or field.
        detail: String,
    },
    /// The source ended for good (a replay finished, the peer closed and retries ran out).
    #[error("{endpoint}: the source ended ({detail})")]
    Ended {
        /// The endpoint.
        endpoint: String,
        /// Why.
        detail: String,
    },
}

/// One axis of a live control.
pub trait Source {
    /// The endpoint and channels in words, for the log (e.g.
    /// `MTConnect agent http://127.0.0.1:5000 device Mazak axis X`).
    fn describe(&self) -> String;

    /// The next event, waiting at most until `deadline`; `Ok(None)` when none came by then
    /// (so that the caller can look at Ctrl-C and its own clocks). A source reconnects by
    /// itself where its protocol allows and reports that as [`Event::Gap`].
    ///
    /// # Errors
    /// [`LiveError`] when the source cannot go on.
    fn next_event(&mut self, deadline: Instant) -> Result<Option<Event>, LiveError>;

    /// Typical interval between samples the source was asked for or observes (s), for the
    /// statement of resolvable orders; `None` until known.
    fn sample_interval_s(&self) -> Option<f64>;

    /// The latest wall-clock instant up to which the source knows it has delivered every
    /// change (the server answered since). A caller that lets the wall clock stand in for
    /// control time while the stream is silent must not run it past this instant: a server
    /// that stopped answering may still be found lost. `None` (the default): up to now.
    fn confirmed_until(&self) -> Option<Instant> {
        None
    }
}
