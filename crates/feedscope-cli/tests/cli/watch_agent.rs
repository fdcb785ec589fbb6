//! The MTConnect agent client and `feedscope watch mtconnect` against a real HTTP server on
//! loopback (run by scripts/live-tests.sh): `scripts/mtconnect-test-agent.py`, whose documents
//! the PyPI `mtconnect` package builds, fed from the twin test's SHDR log and the real Okuma
//! log. Its journal (every observation it put into its buffer, with its sequence number) is the
//! oracle of what the client must read.
use std::io::{BufRead, BufReader, Read, Write};
use std::path::Path;
use std::process::{Child, ChildStdout, Command, Stdio};
use std::time::{Duration, Instant};

use feedscope_io::import::devices::DeviceModel;
use feedscope_live::mtconnect::agent::{AgentParams, AgentSource};
use feedscope_live::mtconnect::{parse_time_s, AxisSelection};
use feedscope_live::{Event, GapReason, Quantity, Source};

use crate::util::{feedscope, stderr, stdout};
use crate::watch::{
    assert_stored_as_history_add, python, repo, twin, twin_devices, TWIN_TORQUE_PER_LOAD_NM,
};

/// The test agent; closing its stdin (dropping it) ends it.
struct Agent {
    child: Child,
    out: BufReader<ChildStdout>,
    port: u16,
}

impl Drop for Agent {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn agent(devices: &Path, log: &Path, journal: &Path, args: &[&str]) -> Agent {
    let mut child = Command::new(python())
        .arg(repo().join("scripts/mtconnect-test-agent.py"))
        .arg("--devices")
        .arg(devices)
        .arg("--log")
        .arg(log)
        .arg("--journal")
        .arg(journal)
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .expect("starting scripts/mtconnect-test-agent.py");
    let mut out = BufReader::new(child.stdout.take().unwrap());
    let mut line = String::new();
    out.read_line(&mut line).unwrap();
    let port = line
        .trim()
        .strip_prefix("PORT ")
        .unwrap_or_else(|| panic!("PORT line, got {line:?}"))
        .parse()
        .unwrap();
    Agent { child, out, port }
}

impl Agent {
    fn url(&self) -> String {
        format!("http://127.0.0.1:{}", self.port)
    }

    /// GET a control endpoint (`/feed?lines=N`, `/restart`, `/status`): the body.
    fn get(&self, path: &str) -> String {
        let mut s = std::net::TcpStream::connect(("127.0.0.1", self.port)).unwrap();
        write!(s, "GET {path} HTTP/1.0\r\nHost: 127.0.0.1\r\n\r\n").unwrap();
        let mut r = String::new();
        s.read_to_string(&mut r).unwrap();
        let body = r.split_once("\r\n\r\n").map_or("", |x| x.1).to_string();
        assert!(r.starts_with("HTTP/1.0 200"), "{path}: {r}");
        body
    }

    /// `instanceId first last next fed total`.
    fn status(&self) -> (String, u64, u64, u64, usize, usize) {
        let b = self.get("/status");
        let f: Vec<&str> = b.split_whitespace().collect();
        (
            f[0].to_string(),
            f[1].parse().unwrap(),
            f[2].parse().unwrap(),
            f[3].parse().unwrap(),
            f[4].parse().unwrap(),
            f[5].parse().unwrap(),
        )
    }
}

/// One observation the agent put into its buffer.
#[derive(Debug, Clone)]
struct Journal {
    instance: String,
    sequence: u64,
    item: String,
    time: String,
    value: String,
}

fn journal(path: &Path) -> Vec<Journal> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| {
            let mut f = l.splitn(5, ' ');
            let mut next = || f.next().unwrap().to_string();
            Journal {
                instance: next(),
                sequence: next().parse().unwrap(),
                item: next(),
                time: next(),
                value: next(),
            }
        })
        .collect()
}

/// Everything the client yields until it has been quiet for `quiet` (or `limit` passed).
fn drain(src: &mut AgentSource, quiet: Duration, limit: Duration) -> Vec<Event> {
    let (t0, mut out) = (Instant::now(), Vec::new());
    while t0.elapsed() < limit {
        match src.next_event(Instant::now() + quiet).unwrap() {
            Some(e) => out.push(e),
            None => break,
        }
    }
    out
}

/// What the client should have made of the journal's observations of the position and load
/// items: each sample in SI, `UNAVAILABLE` as a gap.
fn expected(j: &[Journal], position: &str, load: &str, per_percent: f64) -> Vec<Event> {
    let mut out = Vec::new();
    for o in j.iter().filter(|o| o.item == position || o.item == load) {
        let quantity = if o.item == position {
            Quantity::Position
        } else {
            Quantity::Effort(feedscope::trace::EffortKind::TorqueNm)
        };
        let time_s = parse_time_s(&o.time).unwrap();
        out.push(if o.value == "UNAVAILABLE" {
            Event::Gap {
                time_s: Some(time_s),
                reason: GapReason::Unavailable { quantity },
            }
        } else {
            let v: f64 = o.value.parse().unwrap();
            Event::Sample {
                quantity,
                time_s,
                value: if o.item == position {
                    v * 1e-3
                } else {
                    v * per_percent
                },
            }
        });
    }
    out
}

fn samples_and_unavailable(ev: &[Event]) -> Vec<Event> {
    ev.iter()
        .filter(|e| {
            matches!(
                e,
                Event::Sample { .. }
                    | Event::Gap {
                        reason: GapReason::Unavailable { .. },
                        ..
                    }
            )
        })
        .cloned()
        .collect()
}

fn selection(axis: &str, tpl: f64) -> AxisSelection {
    AxisSelection {
        device: None,
        axis: axis.into(),
        position_key: None,
        load_key: None,
        torque_per_load_nm: Some(tpl),
    }
}

fn params(url: String, count: u64) -> AgentParams {
    AgentParams {
        url,
        count,
        poll: Duration::from_millis(50),
        max_attempts: Some(3),
        ..AgentParams::default()
    }
}

/// The real Okuma log (38 min of control time) fed at 200× (its recorded timing; the pieced-in
/// older recordings and state dumps whose timestamps step back are fed at once) into an agent
/// whose buffer holds it all: the client reads every observation of the device exactly once,
/// in sequence; the Z1 position and load samples are those of the journal (but for samples
/// earlier than their channel's last, dropped and counted) and the Z1 positions those of the
/// log, in order, several observations sharing one timestamp included; each back-step of the
/// timestamps by more than 1 s is a TimeStepBack gap.
#[test]
#[ignore = "needs the live test servers: scripts/live-tests.sh"]
fn watch_agent_client_reads_every_observation_once_in_sequence() {
    let d = tempfile::tempdir().unwrap();
    let packed =
        std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/real/okuma.txt.zst"))
            .unwrap();
    let log = d.path().join("okuma.txt");
    std::fs::write(&log, zstd::decode_all(&packed[..]).unwrap()).unwrap();
    let devices = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/import/okuma_Devices.xml");
    let jpath = d.path().join("journal.txt");
    let mut ag = agent(
        &devices,
        &log,
        &jpath,
        &["--speed", "200", "--start-on-sample", "--buffer", "32768"],
    );
    let sel = AxisSelection {
        device: Some("OKUMA".into()),
        ..selection("Z1", 20.0)
    };
    let mut src = AgentSource::connect(params(ag.url(), 1000), &sel).unwrap();
    let mut events = Vec::new();
    let mut line = String::new();
    let t0 = Instant::now();
    // Until the feed is done, then until the client has caught up.
    std::thread::scope(|s| {
        let h = s.spawn(|| {
            let _ = ag.out.read_line(&mut line);
        });
        while !h.is_finished() {
            assert!(t0.elapsed() < Duration::from_secs(120), "feed too slow");
            if let Some(e) = src
                .next_event(Instant::now() + Duration::from_millis(100))
                .unwrap()
            {
                events.push(e);
            }
        }
    });
    assert!(line.starts_with("DONE"), "{line}");
    events.extend(drain(
        &mut src,
        Duration::from_millis(500),
        Duration::from_secs(30),
    ));

    let model = DeviceModel::read(&devices).unwrap();
    let dev = model.find_device("OKUMA").unwrap();
    let ids: std::collections::HashSet<&str> = model.devices[dev]
        .items
        .iter()
        .map(|i| i.id.as_str())
        .collect();
    let (inst, _, _, next, _, _) = ag.status();
    let j: Vec<Journal> = journal(&jpath)
        .into_iter()
        .filter(|o| o.instance == inst && ids.contains(o.item.as_str()))
        .collect();
    let first = j.first().unwrap().sequence;
    assert_eq!(j.last().unwrap().sequence + 1, next);
    // Every observation of the device from the first fed one, once.
    assert_eq!(src.stats.observations, j.len() as u64, "{:?}", src.stats);
    assert_eq!(
        (src.stats.duplicates, src.stats.lost, src.stats.out_of_range),
        (0, 0, 0)
    );
    assert!(
        first > 1,
        "the client started after the initial UNAVAILABLEs"
    );
    // Several observations share a timestamp (a line of the log).
    let shared = j.windows(2).filter(|w| w[0].time == w[1].time).count();
    assert!(shared > 1000, "{shared}");

    // Position and load as the journal says, except what the client must drop: samples of a
    // channel earlier than its previous one (counted), a TimeStepBack at the back-step.
    let a = src.axis().clone();
    let want = expected(&j, &a.position.1, &a.load.1, a.torque_per_percent_nm);
    let got = samples_and_unavailable(&events);
    let mut k = 0usize;
    let mut dropped = 0u64;
    for g in &got {
        while k < want.len() && want[k] != *g {
            dropped += 1;
            k += 1;
        }
        assert!(k < want.len(), "{g:?} is not in the journal's order");
        k += 1;
    }
    dropped += (want.len() - k) as u64;
    assert_eq!(dropped, src.stats.reordered, "{:?}", src.stats);
    assert!(got.len() > 2000, "{}", got.len());
    let backs: Vec<&Event> = events
        .iter()
        .filter(|e| {
            matches!(
                e,
                Event::Gap {
                    reason: GapReason::TimeStepBack { .. },
                    ..
                }
            )
        })
        .collect();
    assert!(!backs.is_empty());
    assert_eq!(backs.len() as u64, src.stats.time_step_backs);

    // The journal's Z1 positions are the log's, in order.
    let text = std::fs::read_to_string(&log).unwrap();
    let in_log: Vec<f64> = text
        .lines()
        .filter_map(|l| {
            let t: Vec<&str> = l.split('|').collect();
            t.iter()
                .position(|k| *k == a.position.0)
                .and_then(|i| t.get(i + 1))
                .map(|v| v.parse::<f64>().unwrap_or(f64::NAN))
        })
        .collect();
    let in_journal: Vec<f64> = j
        .iter()
        .filter(|o| o.item == a.position.1)
        .map(|o| o.value.parse::<f64>().unwrap_or(f64::NAN))
        .collect();
    assert_eq!(in_log.len(), in_journal.len());
    assert!(in_log
        .iter()
        .zip(&in_journal)
        .all(|(x, y)| x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan())));
    eprintln!(
        "agent client on the Okuma log at 200x: {} observations in {} requests, {} Z1 samples, \
         {} dropped as earlier than their channel's last, {:.1} s",
        src.stats.observations,
        src.stats.requests,
        got.len(),
        src.stats.reordered,
        t0.elapsed().as_secs_f64()
    );
}

/// The client on the twin's agent, fed by hand, after it read the first 20 lines.
fn twin_agent(d: &Path, buffer: &str) -> (Agent, AgentSource, std::path::PathBuf, Vec<Event>) {
    let tw = twin(d);
    let jpath = d.join("journal.txt");
    let ag = agent(&twin_devices(), &tw.log, &jpath, &["--buffer", buffer]);
    let mut src = AgentSource::connect(
        params(ag.url(), 50),
        &selection("X", TWIN_TORQUE_PER_LOAD_NM),
    )
    .unwrap();
    assert_eq!(ag.get("/feed?lines=20"), "OK 20");
    let ev = drain(
        &mut src,
        Duration::from_millis(400),
        Duration::from_secs(10),
    );
    assert_eq!(src.stats.observations, 22, "{:?}", src.stats);
    (ag, src, jpath, ev)
}

/// A 64-observation buffer overrun by 100 observations between two polls: OUT_OF_RANGE is one
/// Skipped gap with the number lost (the agent's firstSequence minus the client's next), and
/// the client goes on from firstSequence reading the rest exactly.
#[test]
#[ignore = "needs the live test servers: scripts/live-tests.sh"]
fn watch_agent_out_of_range_is_a_gap_with_the_number_lost() {
    let d = tempfile::tempdir().unwrap();
    let (ag, mut src, jpath, _) = twin_agent(d.path(), "64");
    let (_, _, _, next_read, _, _) = ag.status();
    assert_eq!(ag.get("/feed?lines=100"), "OK 100");
    let (inst, first, _, _, _, _) = ag.status();
    let ev = drain(
        &mut src,
        Duration::from_millis(400),
        Duration::from_secs(10),
    );
    let lost = first - next_read;
    assert!(lost > 0);
    assert!(
        matches!(&ev[0], Event::Gap { reason: GapReason::Skipped { lost: Some(n) }, .. } if *n == lost),
        "{:?}",
        &ev[..ev.len().min(3)]
    );
    assert_eq!((src.stats.out_of_range, src.stats.lost), (1, lost));
    let j: Vec<Journal> = journal(&jpath)
        .into_iter()
        .filter(|o| o.instance == inst && o.sequence >= first)
        .collect();
    let a = src.axis().clone();
    let want = expected(&j, &a.position.1, &a.load.1, a.torque_per_percent_nm);
    assert_eq!(samples_and_unavailable(&ev[1..]), want);
    assert_eq!(want.len(), 64);
}

/// The agent restarts (a new instanceId, sequences from 1): one Restart gap naming both ids,
/// then the new instance's observations from its first sequence (the UNAVAILABLE every item
/// starts with, then the fed samples).
#[test]
#[ignore = "needs the live test servers: scripts/live-tests.sh"]
fn watch_agent_restart_is_a_restart_gap() {
    let d = tempfile::tempdir().unwrap();
    let (ag, mut src, jpath, _) = twin_agent(d.path(), "1024");
    let (old, ..) = ag.status();
    let new = ag
        .get("/restart")
        .trim()
        .strip_prefix("OK ")
        .unwrap()
        .to_string();
    assert_ne!(old, new);
    assert_eq!(ag.get("/feed?lines=30"), "OK 30");
    let ev = drain(
        &mut src,
        Duration::from_millis(400),
        Duration::from_secs(10),
    );
    match &ev[0] {
        Event::Gap {
            reason: GapReason::Restart { detail },
            ..
        } => assert_eq!(detail, &format!("instanceId {old} -> {new}")),
        e => panic!("{e:?}"),
    }
    assert_eq!(src.stats.restarts, 1);
    let j: Vec<Journal> = journal(&jpath)
        .into_iter()
        .filter(|o| o.instance == new)
        .collect();
    let a = src.axis().clone();
    // The new instance's initial UNAVAILABLEs are stamped with the log time at the restart,
    // not journalled (the package pushes them itself): they come first, one per item.
    let got = samples_and_unavailable(&ev[1..]);
    let unavailable = got
        .iter()
        .take_while(|e| matches!(e, Event::Gap { .. }))
        .count();
    assert_eq!(unavailable, 2, "{got:?}");
    let want = expected(&j, &a.position.1, &a.load.1, a.torque_per_percent_nm);
    assert_eq!(got[unavailable..], want[..]);
    assert!(want.len() >= 29);
}

/// `feedscope watch mtconnect` on the twin fed at 20× from the first /sample: the test is
/// stored once, as `history add` of its samples stores it (as over SHDR).
#[test]
#[ignore = "needs the live test servers: scripts/live-tests.sh"]
fn watch_mtconnect_stores_the_twin_test() {
    let d = tempfile::tempdir().unwrap();
    let tw = twin(d.path());
    let ag = agent(
        &twin_devices(),
        &tw.log,
        &d.path().join("journal.txt"),
        &["--speed", "20", "--start-on-sample", "--buffer", "4096"],
    );
    let t0 = Instant::now();
    let o = feedscope(d.path())
        .args([
            "watch",
            "mtconnect",
            "--agent",
            &ag.url(),
            "--axis",
            "X",
            "--torque-per-load-nm",
            &TWIN_TORQUE_PER_LOAD_NM.to_string(),
            "--axis-file",
            "sim/axis.toml",
            "--kind",
            "strokes",
            "--db",
            "w.db",
            "--poll-ms",
            "100",
            "--once",
        ])
        .output()
        .unwrap();
    let (so, se) = (stdout(&o), stderr(&o));
    assert_eq!(o.status.code(), Some(0), "{se}");
    assert_eq!(so.matches("stored test 1").count(), 1, "{so}\n{se}");
    eprintln!(
        "watch mtconnect on the twin at 20x: stored after {:.1} s ({})",
        t0.elapsed().as_secs_f64(),
        se.lines()
            .find(|l| l.starts_with("analysed and stored"))
            .unwrap_or("?")
    );
    assert_stored_as_history_add(d.path(), &tw, "w.db");
}

/// `/sample` requests the agent answered and those it refused for their count.
fn sample_requests(ag: &Agent) -> (u64, u64) {
    let b = ag.get("/status");
    let f: Vec<&str> = b.split_whitespace().collect();
    (f[6].parse().unwrap(), f[7].parse().unwrap())
}

/// A count above the agent's buffer (1000 asked, 256 kept), refused as cppagent 2.x refuses it
/// (`OUT_OF_RANGE` `'count' must be less than 257`, schema 2.6 and legacy forms) and as the
/// `mtconnect` package does (`Count must not be greater than 256`), with the twin fed at 20×:
/// one refusal, one notice naming the new count, no gap, every observation of the journal
/// read, and the request rate bounded by the poll interval (one `/sample` per poll, plus one
/// per full answer).
#[test]
#[ignore = "needs the live test servers: scripts/live-tests.sh"]
fn watch_agent_lowers_a_count_the_agent_refuses() {
    let d = tempfile::tempdir().unwrap();
    let tw = twin(d.path());
    for mode in ["cppagent", "cppagent-legacy", "package"] {
        let jpath = d.path().join(format!("journal-{mode}.txt"));
        let mut ag = agent(
            &twin_devices(),
            &tw.log,
            &jpath,
            &[
                "--buffer",
                "256",
                "--count-refusal",
                mode,
                "--speed",
                "20",
                "--start-on-sample",
            ],
        );
        let p = params(ag.url(), 1000);
        let poll = p.poll;
        let mut src = AgentSource::connect(p, &selection("X", TWIN_TORQUE_PER_LOAD_NM)).unwrap();
        let t0 = Instant::now();
        let mut events = Vec::new();
        let mut line = String::new();
        std::thread::scope(|s| {
            let h = s.spawn(|| {
                let _ = ag.out.read_line(&mut line);
            });
            while !h.is_finished() {
                assert!(
                    t0.elapsed() < Duration::from_secs(60),
                    "{mode}: feed too slow"
                );
                if let Some(e) = src
                    .next_event(Instant::now() + Duration::from_millis(100))
                    .unwrap()
                {
                    events.push(e);
                }
            }
        });
        assert!(line.starts_with("DONE"), "{line}");
        events.extend(drain(
            &mut src,
            Duration::from_millis(500),
            Duration::from_secs(30),
        ));
        let elapsed_s = t0.elapsed().as_secs_f64();
        let notices: Vec<&String> = events
            .iter()
            .filter_map(|e| match e {
                Event::Notice { message, .. } => Some(message),
                _ => None,
            })
            .collect();
        assert_eq!(notices.len(), 1, "{mode}: {notices:?}");
        assert!(
            notices[0].contains("refuses count=1000") && notices[0].contains("asking for 256"),
            "{mode}: {}",
            notices[0]
        );
        assert!(
            !events.iter().any(|e| matches!(
                e,
                Event::Gap {
                    reason: GapReason::Skipped { .. },
                    ..
                }
            )),
            "{mode}: no observation skipped"
        );
        assert_eq!(src.count(), 256, "{mode}");
        let (inst, ..) = ag.status();
        let j: Vec<Journal> = journal(&jpath)
            .into_iter()
            .filter(|o| o.instance == inst)
            .collect();
        let a = src.axis().clone();
        let want = expected(&j, &a.position.1, &a.load.1, a.torque_per_percent_nm);
        assert_eq!(samples_and_unavailable(&events), want, "{mode}");
        assert_eq!(src.stats.observations, j.len() as u64, "{mode}");
        let (requests, refused) = sample_requests(&ag);
        assert_eq!(refused, 1, "{mode}: one refusal, then the lower count");
        assert_eq!(src.stats.count_refusals, 1, "{mode}");
        assert_eq!(requests, src.stats.requests, "{mode}");
        // The client asks again at once only when an answer was full (count observations):
        // at most one request per poll interval plus one per full answer.
        let bound = elapsed_s / poll.as_secs_f64() + (j.len() as f64 / 256.0) + 2.0;
        assert!(
            (requests as f64) <= bound,
            "{mode}: {requests} requests in {elapsed_s:.1} s (bound {bound:.0})"
        );
        eprintln!(
            "count refused ({mode}): {requests} /sample requests in {elapsed_s:.1} s \
             ({:.1}/s, poll {} ms), {} observations, all read",
            requests as f64 / elapsed_s,
            poll.as_millis(),
            j.len()
        );
    }
}
