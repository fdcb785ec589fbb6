//! The golden reports: every use case of the application layer run through its request on the
//! fixed inputs of `tests/golden/inputs/` (how each was made: the README there), its report
//! serialised with serde_json (the JSON layout the front ends write or return), normalised and
//! compared with `tests/golden/<case>.json`.
//!
//! The Python binding's pytest suite (`crates/feedscope-py/tests/test_golden.py`) runs the same
//! use cases through `import feedscope` on the same inputs and compares its `to_dict()` with the
//! same files, by the same rules: so the two front ends cannot drift apart in a layout without
//! one of the suites failing.
//!
//! Normalisation (what a run may change without the analysis changing): in every string, the
//! inputs folder, the repository's import fixtures folder and the scratch folder of the run,
//! each followed by a path separator, are removed (an absolute path becomes its name below
//! them, in a message too); the value of every `added_utc` key (the wall-clock time a test was
//! stored) becomes `"<wall clock>"`.
//!
//! Comparison: the same keys, array lengths, strings, booleans and nulls; numbers within a
//! relative 1e-9 plus an absolute 1e-12 (see [`close`]); a failure names the JSON path of the
//! first difference. `FEEDSCOPE_BLESS=1 cargo test -p feedscope-app --test golden` rewrites
//! the files (then review the diff: it is the change of every report a user reads).
use std::collections::BTreeMap;
use std::path::{Path, PathBuf, MAIN_SEPARATOR};

use feedscope::study::TestKind;
use feedscope_app::analyze::AnalyzeRequest;
use feedscope_app::estimate::EstimateRequest;
use feedscope_app::history::{AddOptions, AddReport, AddRequest};
use feedscope_app::identify::IdentifyRequest;
use feedscope_app::import::ImportRequest;
use feedscope_app::map::MapRequest;
use feedscope_app::stribeck::{FitStribeckOptions, FitStribeckRequest};
use feedscope_app::trend::{axis_trend, TrendOptions};
use feedscope_app::Quiet;
use feedscope_store::{SqliteStore, Store};
use serde::Serialize;
use serde_json::Value;

/// The folder of the golden reports.
fn golden_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden")
}

/// The fixed inputs.
fn inputs() -> PathBuf {
    golden_dir().join("inputs")
}

/// The repository's real controller excerpts (read in place by the import case).
fn import_fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../feedscope-cli/tests/data/import")
}

fn input(name: &str) -> PathBuf {
    inputs().join(name)
}

/// A relative difference of 1e-9 (plus 1e-12 absolute, for values that are zero up to
/// rounding) is far above what the same code gives on another machine (libm's `exp`, `ln`
/// and `pow` may differ in the last bit, which an iterative fit amplifies by its conditioning,
/// at most ~1e6 here), and far below any change of the analysis a user could see in a report
/// (which prints 4 to 6 significant digits).
fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-12 + 1e-9 * a.abs().max(b.abs())
}

/// `value` with the volatile parts removed: the `roots` (folders), each followed by a path
/// separator, cut out of every string, and every `added_utc` made `"<wall clock>"`.
fn normalised(value: Value, roots: &[PathBuf]) -> Value {
    match value {
        Value::String(mut s) => {
            for root in roots {
                s = s.replace(&format!("{}{MAIN_SEPARATOR}", root.display()), "");
            }
            Value::String(s)
        }
        Value::Array(a) => Value::Array(a.into_iter().map(|v| normalised(v, roots)).collect()),
        Value::Object(m) => Value::Object(
            m.into_iter()
                .map(|(k, v)| {
                    let v = if k == "added_utc" {
                        Value::String("<wall clock>".into())
                    } else {
                        normalised(v, roots)
                    };
                    (k, v)
                })
                .collect(),
        ),
        other => other,
    }
}

/// Where `got` first differs from `want`, as a JSON path and what differs; `None` when they
/// agree (numbers by [`close`]).
fn first_difference(got: &Value, want: &Value, path: &str) -> Option<String> {
    match (got, want) {
        (Value::Number(g), Value::Number(w)) => {
            let (g, w) = (g.as_f64()?, w.as_f64()?);
            (!close(g, w)).then(|| format!("{path}: {g} here, {w} in the golden file"))
        }
        (Value::Array(g), Value::Array(w)) => {
            if g.len() != w.len() {
                return Some(format!(
                    "{path}: {} elements here, {} in the golden file",
                    g.len(),
                    w.len()
                ));
            }
            g.iter()
                .zip(w)
                .enumerate()
                .find_map(|(k, (g, w))| first_difference(g, w, &format!("{path}[{k}]")))
        }
        (Value::Object(g), Value::Object(w)) => {
            if let Some(k) = w.keys().find(|k| !g.contains_key(*k)) {
                return Some(format!("{path}.{k}: missing here"));
            }
            if let Some(k) = g.keys().find(|k| !w.contains_key(*k)) {
                return Some(format!("{path}.{k}: not in the golden file"));
            }
            w.iter()
                .find_map(|(k, w)| first_difference(&g[k], w, &format!("{path}.{k}")))
        }
        (g, w) if g == w => None,
        (g, w) => Some(format!("{path}: {g} here, {w} in the golden file")),
    }
}

/// Compare `report` (normalised against the inputs' folders and the run's `scratch` folder)
/// with the golden file of `case`, or rewrite that file under `FEEDSCOPE_BLESS`.
fn check(case: &str, report: &impl Serialize, scratch: Option<&Path>) {
    let mut roots = vec![inputs(), import_fixtures()];
    roots.extend(scratch.map(Path::to_path_buf));
    let got = normalised(serde_json::to_value(report).unwrap(), &roots);
    let path = golden_dir().join(format!("{case}.json"));
    if std::env::var_os("FEEDSCOPE_BLESS").is_some() {
        let text = serde_json::to_string_pretty(&got).unwrap() + "\n";
        std::fs::write(&path, text).unwrap_or_else(|e| panic!("writing {}: {e}", path.display()));
        return;
    }
    let bless = "`FEEDSCOPE_BLESS=1 cargo test -p feedscope-app --test golden` rewrites it";
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("reading {}: {e} ({bless})", path.display()));
    let want: Value = serde_json::from_str(&text).unwrap();
    if let Some(d) = first_difference(&got, &want, "$") {
        panic!(
            "the {case} report differs from {}: {d}\n(if the change is meant, {bless}, and \
             review the diff)",
            path.display()
        );
    }
}

#[test]
fn the_comparison_names_the_first_difference_and_allows_only_rounding() {
    let want = serde_json::json!({"a": [1.0, {"b": 2.5}], "c": "x"});
    let mut got = want.clone();
    assert_eq!(first_difference(&got, &want, "$"), None);
    got["a"][1]["b"] = (2.5 * (1.0 + 1e-12)).into();
    assert_eq!(first_difference(&got, &want, "$"), None);
    got["a"][1]["b"] = (2.5 * (1.0 + 1e-8)).into();
    let d = first_difference(&got, &want, "$").unwrap();
    assert!(d.starts_with("$.a[1].b: "), "{d}");
    got["a"][1]["b"] = 2.5.into();
    got["c"] = "y".into();
    assert!(first_difference(&got, &want, "$")
        .unwrap()
        .starts_with("$.c: "));
    let scratch = PathBuf::from("/scratch");
    let v = serde_json::json!({
        "source": format!("/scratch{MAIN_SEPARATOR}t.csv: cut"),
        "tests": [{"added_utc": "2026-12-07T23:00:00Z"}]
    });
    let n = normalised(v, &[scratch]);
    assert_eq!(n["source"], "t.csv: cut");
    assert_eq!(n["tests"][0]["added_utc"], "<wall clock>");
}

#[test]
fn estimate() {
    let d = tempfile::tempdir().unwrap();
    let request = EstimateRequest {
        input: input("strokes.csv"),
        axis: input("axis.toml"),
        output: d.path().join("friction.csv"),
        ..EstimateRequest::default()
    };
    check(
        "estimate",
        &request.run(&Quiet).unwrap().report,
        Some(d.path()),
    );
}

#[test]
fn analyze() {
    let request = AnalyzeRequest {
        input: input("strokes.csv"),
        axis: input("axis.toml"),
        ..AnalyzeRequest::default()
    };
    check("analyze", &request.run(&Quiet).unwrap().report, None);
}

#[test]
fn map() {
    let request = MapRequest {
        index: input("map/index.csv"),
        axis: input("map/axis.toml"),
        ..MapRequest::default()
    };
    let mapped = request.run(&Quiet).unwrap();
    check("map", &mapped.report, None);
    check("map_stribeck", &mapped.stribeck, None);
}

#[test]
fn fit_stribeck() {
    // A noise level given: the residual's estimate would be inflated by the very fall the
    // non-conventional check is to find.
    let request = FitStribeckRequest {
        table: input("stribeck.csv"),
        axis: Some(input("axis.toml")),
        options: FitStribeckOptions {
            noise_n: Some(2.0),
            ..FitStribeckOptions::default()
        },
        ..FitStribeckRequest::default()
    };
    check("fit_stribeck", &request.run(&Quiet).unwrap().report, None);
}

#[test]
fn identify() {
    let request = IdentifyRequest {
        trace: input("triangle.csv"),
        axis: input("axis.toml"),
        ..IdentifyRequest::default()
    };
    check("identify", &request.run(&Quiet).unwrap().report, None);
}

#[test]
fn identify_with_compare() {
    let request = IdentifyRequest {
        trace: input("triangle.csv"),
        axis: input("axis.toml"),
        compare: Some(input("groups.csv")),
        ..IdentifyRequest::default()
    };
    check(
        "identify_compare",
        &request.run(&Quiet).unwrap().report,
        None,
    );
}

/// The history's tests: trace, kind, time, reference. Two stroke tests make the baseline, a
/// triangle test identifies the axis, and a stroke test on the worn axis comes last.
const HISTORY: [(&str, TestKind, &str, bool); 4] = [
    (
        "strokes.csv",
        TestKind::Strokes,
        "2026-11-02T08:00:00Z",
        true,
    ),
    (
        "strokes_2.csv",
        TestKind::Strokes,
        "2026-11-09T08:00:00Z",
        false,
    ),
    (
        "triangle.csv",
        TestKind::Triangle,
        "2026-11-09T09:00:00Z",
        false,
    ),
    (
        "strokes_worn.csv",
        TestKind::Strokes,
        "2026-11-16T08:00:00Z",
        false,
    ),
];

#[test]
fn history_add_and_trend() {
    let d = tempfile::tempdir().unwrap();
    let mut store = SqliteStore::open(&d.path().join("history.db")).unwrap();
    let mut added = Vec::new();
    for (trace, kind, time, reference) in HISTORY {
        let request = AddRequest {
            trace: input(trace),
            axis: input("axis.toml"),
            options: AddOptions {
                kind,
                time: Some(time.into()),
                machine: "lathe".into(),
                reference,
                ..AddOptions::default()
            },
        };
        let analysed = request.prepare(&Quiet).unwrap();
        let outcome = store.add(&analysed.test).unwrap();
        added.push(AddReport::new(&analysed.test, outcome));
    }
    check("history_add", &added, Some(d.path()));
    // Baselines of two tests, so that three stroke tests give every indicator a trend.
    let options = TrendOptions {
        baseline_tests: 2,
        profile_baseline_tests: 2,
        ..TrendOptions::default()
    };
    let trend = axis_trend(&store, "lathe", None, &options, BTreeMap::new(), &Quiet).unwrap();
    check("history_trend", &trend, Some(d.path()));
}

#[test]
fn import() {
    let d = tempfile::tempdir().unwrap();
    let body = serde_json::json!({
        "source": {"shdr": {
            "log": import_fixtures().join("okuma_head640.txt"),
            "devices": import_fixtures().join("okuma_Devices.xml"),
            "axis": "Z1",
            "params": {"torque_per_load_nm": 20.0}
        }},
        "output": d.path().join("z1.csv"),
    });
    let request: ImportRequest = serde_json::from_value(body).unwrap();
    check("import", &request.run(&Quiet).unwrap(), Some(d.path()));
}
