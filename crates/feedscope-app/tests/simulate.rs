//! The twin through the application layer: a short stroke (0 → 5 mm at 600 mm/min) simulated
//! from a request body, its four outputs written with no temporary file left and the trace
//! reading back with the samples simulated, progress reported to the end; a wide layout
//! without synchronous sampling, bad output names and a bad config are refused naming the
//! field or the key, with nothing written.
use std::path::PathBuf;
use std::sync::Mutex;

use feedscope::ErrorKind;
use feedscope_app::simulate::{SimulateRequest, TraceLayout};
use feedscope_app::{FrontEnd, Quiet};

/// The same short program as the CLI's simulate tests, so that a debug build finishes quickly.
const SHORT: &str = "seed = 7\n\
[motion]\nlead_in_s = 0.2\nlead_out_s = 0.2\n\
[[motion.stroke]]\nto_mm = 5\nfeed_mm_min = 600\n";

/// The command line's spelling, and the progress it was given.
#[derive(Default)]
struct Flags {
    progress: Mutex<Vec<(usize, usize)>>,
}
impl FrontEnd for Flags {
    fn progress(&self, _what: &str, done: usize, total: usize) {
        self.progress.lock().unwrap().push((done, total));
    }
    fn name(&self, field: &str) -> String {
        format!("--{}", field.replace('_', "-"))
    }
    fn spell(&self, field: &str, value: &str) -> String {
        format!("--{field} {value}")
    }
}

fn names(dir: &std::path::Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn a_short_stroke_is_simulated_and_written() {
    let d = tempfile::tempdir().unwrap();
    let cfg = d.path().join("sim.toml");
    std::fs::write(&cfg, SHORT).unwrap();
    let out = d.path().join("out");
    let body = serde_json::json!({"config": cfg, "out": out, "seed": 3});
    let request: SimulateRequest = serde_json::from_value(body).unwrap();
    assert_eq!(request.trace, "trace.csv");
    let front = Flags::default();
    let done = request.run(&front).unwrap();
    assert_eq!(done.dir, out);
    assert_eq!(
        names(&out),
        ["axis.toml", "trace.csv", "truth.csv", "truth.json"]
    );
    let (trace, _) =
        feedscope_io::trace::read_trace_file(&out.join("trace.csv"), &Default::default()).unwrap();
    assert_eq!(trace.position_m.len(), done.output.trace.position_m.len());
    assert_eq!(trace.effort.len(), done.output.trace.effort.len());
    let last = *front.progress.lock().unwrap().last().unwrap();
    assert_eq!(last, (1000, 1000), "the progress ends");
    // The seed of the request, not the file's, drew the noise: the same seed, the same trace.
    let again = SimulateRequest {
        out: d.path().join("again"),
        ..request.clone()
    };
    again.run(&Quiet).unwrap();
    assert_eq!(
        std::fs::read(out.join("trace.csv")).unwrap(),
        std::fs::read(d.path().join("again/trace.csv")).unwrap()
    );
}

#[test]
fn bad_requests_are_refused_naming_the_field_and_nothing_is_written() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("out");
    let request = |trace: &str| SimulateRequest {
        out: out.clone(),
        trace: trace.to_string(),
        ..SimulateRequest::default()
    };
    let front = Flags::default();
    for bad in ["sub/trace.csv", ".trace.csv", "truth.csv"] {
        let e = request(bad).validate(&front).unwrap_err();
        assert_eq!((e.kind(), e.field()), (ErrorKind::BadInput, Some("trace")));
        assert!(
            e.to_string().starts_with(&format!("--trace {bad}: ")),
            "{e}"
        );
    }

    // The default config samples each channel on its own clock: no wide layout.
    let wide = SimulateRequest {
        layout: TraceLayout::Wide,
        ..request("trace.csv")
    };
    let e = wide.run(&front).unwrap_err();
    assert_eq!(e.field(), Some("layout"));
    assert!(
        e.to_string()
            .starts_with("--layout wide needs both channels on the same timestamps")
            && e.to_string().ends_with("or use --layout long"),
        "{e}"
    );
    let file = d.path().join("a-file");
    std::fs::write(&file, "x").unwrap();
    let e = SimulateRequest {
        out: file,
        ..SimulateRequest::default()
    }
    .validate(&front)
    .unwrap_err();
    assert_eq!(e.field(), Some("out"));
    let e = SimulateRequest::default().validate(&front).unwrap_err();
    assert_eq!(e.field(), Some("out"));

    // A bad key of the config is bad input naming it; a missing config too.
    let cfg = d.path().join("bad.toml");
    std::fs::write(&cfg, "[[motion.stroke]]\nto_mm = 5\nfeed_mm_min = -600\n").unwrap();
    let e = SimulateRequest {
        config: Some(cfg),
        ..request("trace.csv")
    }
    .run(&front)
    .unwrap_err();
    assert_eq!(e.kind(), ErrorKind::BadInput);
    assert!(
        with_causes(&e).contains("motion.stroke[0].feed_mm_min"),
        "{e}"
    );
    let e = SimulateRequest {
        config: Some(PathBuf::from("no-such.toml")),
        ..request("trace.csv")
    }
    .run(&front)
    .unwrap_err();
    assert_eq!(e.kind(), ErrorKind::BadInput);
    assert!(
        e.to_string().starts_with("reading config no-such.toml"),
        "{e}"
    );
    assert!(!out.exists());
}

/// The error and its causes, joined as a front end prints them.
fn with_causes(e: &(dyn std::error::Error + 'static)) -> String {
    let mut s = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        s.push_str(": ");
        s.push_str(&c.to_string());
        cause = c.source();
    }
    s
}
