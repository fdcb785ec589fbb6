//! The watch gateway's event loop (`feedscope_app::watch`) driven by a scripted in-memory
//! source that replays what a control would send: a motion that is no test, then an idle-stroke
//! test of the twin. The test is stored under the request's machine and axis, as `history add`
//! stores it; the other motion is said to be no test; a gap in the test discards it; a value
//! that is no number ends the watch when asked to; bad settings name their field.
use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use feedscope::sim::{simulate, SamplingMode, SimConfig, StrokeConfig};
use feedscope::trace::{EffortKind, Trace};
use feedscope::ErrorKind;
use feedscope_app::history::ListRequest;
use feedscope_app::store::StoreSpec;
use feedscope_app::watch::{EffortHints, Ended, WatchEvent, WatchRequest};
use feedscope_app::{AppError, Quiet};
use feedscope_live::{Event, GapReason, LiveError, Quantity, Source};
use feedscope_store::{SqliteStore, Store, TestKind};

/// Control time of the first event (s since the Unix epoch): 2026-11-26T10:00:00Z.
const T0_S: f64 = 1_795_687_200.0;

/// A source that replays `events`, then sets `stop` (as Ctrl-C would) and says nothing more.
struct Script<'a> {
    events: VecDeque<Event>,
    stop: &'a AtomicBool,
}

impl Source for Script<'_> {
    fn describe(&self) -> String {
        "scripted source".into()
    }

    fn next_event(&mut self, _deadline: Instant) -> Result<Option<Event>, LiveError> {
        let e = self.events.pop_front();
        if e.is_none() {
            self.stop.store(true, Ordering::SeqCst);
        }
        Ok(e)
    }

    fn sample_interval_s(&self) -> Option<f64> {
        Some(0.15)
    }
}

fn sample(quantity: Quantity, time_s: f64, value: f64) -> Event {
    Event::Sample {
        quantity,
        time_s,
        value,
    }
}

/// The simulator's lathe Z axis running `feedscope plan strokes`'s idle test at an
/// MTConnect-like rate: 0 → 100 → 0 mm twice at 300 mm/min with 1 s dwells (shorter than the
/// gateway's 2 s standstill), 4 s still after, sampled asynchronously every 150 ± 40 ms, the
/// effort as torque.
fn twin() -> (SimConfig, Trace) {
    let mut cfg = SimConfig::default();
    cfg.motion.start_mm = 0.0;
    cfg.motion.lead_in_s = 0.5;
    cfg.motion.lead_out_s = 4.0;
    cfg.motion.strokes = [100.0, 0.0, 100.0, 0.0]
        .into_iter()
        .map(|to_mm| StrokeConfig {
            to_mm,
            feed_mm_min: 300.0,
            dwell_s: 1.0,
        })
        .collect();
    assert_eq!(cfg.sampling.mode, SamplingMode::Asynchronous);
    cfg.sampling.effort_kind = EffortKind::TorqueNm;
    for (interval_ms, jitter_ms) in [
        (
            &mut cfg.sampling.position.interval_ms,
            &mut cfg.sampling.position.jitter_ms,
        ),
        (
            &mut cfg.sampling.effort.interval_ms,
            &mut cfg.sampling.effort.jitter_ms,
        ),
    ] {
        (*interval_ms, *jitter_ms) = (150.0, 40.0);
    }
    cfg.sampling.effort.start_offset_ms = 75.0;
    let out = simulate(&cfg, &mut |_| {}).unwrap();
    (cfg, out.trace)
}

/// The trace's samples as events from control time `t0_s` on, in time order.
fn events_of(trace: &Trace, t0_s: f64) -> Vec<Event> {
    let effort = Quantity::Effort(trace.effort_kind);
    let mut ev: Vec<(f64, Event)> = Vec::new();
    for (q, c) in [
        (Quantity::Position, &trace.position_m),
        (effort, &trace.effort),
    ] {
        for (&t, &v) in c.time_s.iter().zip(&c.value) {
            ev.push((t0_s + t, sample(q, t0_s + t, v)));
        }
    }
    ev.sort_by(|a, b| a.0.total_cmp(&b.0));
    ev.into_iter().map(|(_, e)| e).collect()
}

/// One move 0 → 30 mm and back at 600 mm/min, sampled every 0.15 s, then 5 s still: motion
/// that is no stroke test (one stroke each way, the test has at least two).
fn other_motion(t0_s: f64) -> Vec<Event> {
    let mut ev = vec![
        sample(Quantity::Position, t0_s, 0.0),
        sample(Quantity::Effort(EffortKind::TorqueNm), t0_s, 0.0),
    ];
    let mut t = t0_s + 0.5;
    for (from, to) in [(0.0, 0.03), (0.03, 0.0)] {
        let n = 20;
        let sign: f64 = if to > from { 1.0 } else { -1.0 };
        for i in 1..=n {
            t += 0.15;
            let z = from + (to - from) * f64::from(i) / f64::from(n);
            ev.push(sample(Quantity::Position, t, z));
            ev.push(sample(
                Quantity::Effort(EffortKind::TorqueNm),
                t,
                sign * 1.2,
            ));
        }
    }
    for k in 1..=5 {
        ev.push(sample(
            Quantity::Effort(EffortKind::TorqueNm),
            t + f64::from(k),
            0.0,
        ));
    }
    ev
}

struct Setup {
    _dir: tempfile::TempDir,
    request: WatchRequest,
    spec: StoreSpec,
    store: SqliteStore,
    twin: Trace,
}

fn setup() -> Setup {
    let dir = tempfile::tempdir().unwrap();
    let (cfg, twin) = twin();
    let axis_file = dir.path().join("lathe.toml");
    std::fs::write(&axis_file, toml::to_string_pretty(&cfg.axis).unwrap()).unwrap();
    let db = dir.path().join("w.db");
    let request = WatchRequest {
        axis_file,
        machine: "mill 7".into(),
        axis_name: Some("Z".into()),
        kind: TestKind::Strokes,
        ..WatchRequest::default()
    };
    Setup {
        store: SqliteStore::open(&db).unwrap(),
        spec: StoreSpec::Sqlite(db),
        _dir: dir,
        request,
        twin,
    }
}

/// What the loop told, as the lines a log shows (the stored test's status line for
/// [`WatchEvent::Stored`]), with the stored tests' machine, axis and kind.
#[derive(Default)]
struct Log {
    lines: Vec<String>,
    stored: Vec<(String, String, TestKind)>,
}

impl Log {
    fn take(&mut self, e: WatchEvent<'_>) -> Result<(), AppError> {
        if let WatchEvent::Stored(t) = &e {
            self.stored
                .push((t.machine.clone(), t.axis.clone(), t.kind));
            assert!(t.latency_s >= 0.0 && t.latency_s < 60.0, "{}", t.latency_s);
        }
        self.lines.push(e.to_string());
        Ok(())
    }
}

/// Run `s`'s request over `events` until they run out (then the script sets the stop flag).
fn run(
    s: &mut Setup,
    events: Vec<Event>,
) -> (Result<feedscope_app::watch::WatchReport, AppError>, Log) {
    let stop = AtomicBool::new(false);
    let mut src = Script {
        events: events.into(),
        stop: &stop,
    };
    let gateway = s
        .request
        .gateway(&Quiet)
        .unwrap()
        .with_effort(EffortHints::default());
    let mut log = Log::default();
    let r = gateway.run(&mut src, &mut s.store, &s.spec, &stop, &Quiet, &mut |e| {
        log.take(e)
    });
    (r, log)
}

#[test]
fn a_twin_test_is_stored_under_the_requests_names_and_other_motion_is_no_test() {
    let mut s = setup();
    let mut events = other_motion(T0_S);
    events.extend(events_of(&s.twin, T0_S + 20.0));
    let (report, log) = run(&mut s, events.clone());
    let report = report.unwrap();
    assert_eq!(
        (report.stored, report.ended),
        (1, Ended::Stopped),
        "{:#?}",
        log.lines
    );
    assert_eq!(
        log.lines[0],
        "watching scripted source for strokes tests of machine \"mill 7\" axis \"Z\" (store \
         "
        .to_string()
            + &s.spec.describe()
            + ")"
    );
    assert!(
        log.lines
            .iter()
            .any(|l| l.starts_with("motion at 2026-11-26T10:00:00")
                && l.contains(": not a strokes test (")),
        "{:#?}",
        log.lines
    );
    assert_eq!(
        log.stored,
        [("mill 7".to_string(), "Z".to_string(), TestKind::Strokes)]
    );
    let status = log
        .lines
        .iter()
        .find(|l| l.contains("stored test 1"))
        .expect("a status line");
    assert!(
        status.contains(
            "  4 strokes  feed 300.0 mm/min  stored test 1  trend baseline not yet formed"
        ),
        "{status}"
    );
    assert_eq!(log.lines.last().unwrap(), "stopped; 1 test(s) stored");

    // In the store as `history add` keeps a test: the request's names, the kind, the source.
    let rows = ListRequest::default().run(&s.store, &s.spec).unwrap();
    assert_eq!(rows.len(), 1);
    let r = &rows[0];
    assert_eq!(
        (r.machine.as_str(), r.axis.as_str(), r.kind),
        ("mill 7", "Z", TestKind::Strokes)
    );
    assert!(
        r.source.starts_with("watch 2026-11-26T10:00:"),
        "{}",
        r.source
    );
    let d = s.store.get(r.id).unwrap();
    assert!(
        d.indicators
            .iter()
            .any(|i| i.name.starts_with("mean_n/forward/")),
        "{:?}",
        d.indicators.iter().map(|i| &i.name).collect::<Vec<_>>()
    );

    // The same events again: the test recognised, found stored, not added twice.
    let (report, log) = run(&mut s, events);
    assert_eq!(report.unwrap().stored, 1);
    assert!(
        log.lines.iter().any(|l| l.contains("duplicate of test 1")),
        "{:#?}",
        log.lines
    );
    assert_eq!(
        ListRequest::default().run(&s.store, &s.spec).unwrap().len(),
        1
    );
}

#[test]
fn once_ends_after_the_first_stored_test() {
    let mut s = setup();
    s.request.once = true;
    let mut events = events_of(&s.twin, T0_S);
    // A second test that is never looked at.
    events.extend(events_of(&s.twin, T0_S + 200.0));
    let (report, log) = run(&mut s, events);
    assert_eq!(report.unwrap().ended, Ended::Once);
    assert!(
        !log.lines.iter().any(|l| l.starts_with("stopped")),
        "{:#?}",
        log.lines
    );
    assert_eq!(s.store.list(&Default::default()).unwrap().len(), 1);
}

#[test]
fn a_gap_in_a_test_discards_it_and_a_bad_value_ends_the_watch_when_asked() {
    let gap_in_the_middle = |s: &Setup, reason: GapReason| {
        let mut events = events_of(&s.twin, T0_S);
        let t_mid = T0_S + 30.0;
        let at = events
            .iter()
            .position(|e| matches!(e, Event::Sample { time_s, .. } if *time_s > t_mid))
            .unwrap();
        events.insert(
            at,
            Event::Gap {
                time_s: Some(t_mid),
                reason,
            },
        );
        events
    };
    let mut s = setup();
    let events = gap_in_the_middle(&s, GapReason::Skipped { lost: Some(3) });
    let (report, log) = run(&mut s, events);
    assert_eq!(report.unwrap().stored, 0);
    assert!(
        log.lines
            .contains(&"gap: 3 observations skipped".to_string()),
        "{:#?}",
        log.lines
    );
    assert!(
        log.lines.iter().any(|l| l.contains(" discarded: data gap during the motion (3 observations skipped); the test is not stored")),
        "{:#?}",
        log.lines
    );
    assert!(s.store.list(&Default::default()).unwrap().is_empty());

    let bad = GapReason::BadValue {
        quantity: Quantity::Position,
        node: "ns=2;s=X.ActPos".into(),
        value_type: "String".into(),
    };
    // Without --stop-on-bad-value: discarded, and the watch goes on to its stop.
    let events = gap_in_the_middle(&s, bad.clone());
    let (report, _) = run(&mut s, events);
    assert_eq!(report.unwrap().ended, Ended::Stopped);
    // With it: bad input naming the setting, after the discarded motion is said.
    s.request.stop_on_bad_value = true;
    let events = gap_in_the_middle(&s, bad);
    let (report, log) = run(&mut s, events);
    let e = report.unwrap_err();
    assert_eq!(e.kind(), ErrorKind::BadInput);
    assert_eq!(
        e.to_string(),
        "node ns=2;s=X.ActPos (Position) delivered a String value, not a number \
         (`stop_on_bad_value`); 0 test(s) stored"
    );
    assert!(
        log.lines
            .last()
            .unwrap()
            .contains(" discarded: node ns=2;s=X.ActPos (Position) delivered a String value"),
        "{:#?}",
        log.lines
    );
}

#[test]
fn bad_settings_name_their_field() {
    let bad = |f: fn(&mut WatchRequest)| {
        let mut r = WatchRequest::default();
        f(&mut r);
        let e = r.validate(&Quiet).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::BadInput);
        (e.field().unwrap(), e.to_string())
    };
    assert_eq!(
        bad(|r| r.standstill_s = 0.0),
        (
            "standstill_s",
            "`standstill_s` must be a positive time".into()
        )
    );
    assert_eq!(
        bad(|r| r.position_quantum_mm = -1e-3),
        (
            "position_quantum_mm",
            "`position_quantum_mm` must be ≥ 0".into()
        )
    );
    assert_eq!(bad(|r| r.interval_mm = f64::NAN).0, "interval_mm");
    assert_eq!(bad(|r| r.want_order = Some(0.0)).0, "want_order");
    assert!(WatchRequest::default().validate(&Quiet).is_ok());

    let e = EffortHints::drive_load(0.0, &Quiet).unwrap_err();
    assert_eq!(e.field(), Some("torque_per_load_nm"));
    assert_eq!(
        e.to_string(),
        "`torque_per_load_nm` must be a positive torque"
    );
    let load = EffortHints::drive_load(8.0, &Quiet).unwrap();
    assert_eq!((load.quantum, load.signed), (Some(0.08), Some(false)));

    // The axis file is read before anything is connected; a missing one names the field.
    let r = WatchRequest {
        axis_file: "no/such/axis.toml".into(),
        ..WatchRequest::default()
    };
    let e = r.gateway(&Quiet).unwrap_err();
    assert_eq!(
        (e.kind(), e.field()),
        (ErrorKind::BadInput, Some("axis_file"))
    );

    // A server's JSON body is the request: defaults filled in, a misspelt key refused.
    let r: WatchRequest =
        serde_json::from_str(r#"{"axis_file": "z.toml", "kind": "triangle", "once": true}"#)
            .unwrap();
    assert_eq!(
        r,
        WatchRequest {
            axis_file: "z.toml".into(),
            kind: TestKind::Triangle,
            once: true,
            ..WatchRequest::default()
        }
    );
    assert!(serde_json::from_str::<WatchRequest>(r#"{"standstill": 3}"#).is_err());
}
