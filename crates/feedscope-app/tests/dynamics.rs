//! A feed drive's dynamics through the application layer: the repository's example drive
//! (`examples/drive.toml`, the test drive of paper 001) analysed from a request body, its six
//! outputs written together with their documented headers, the summary's JSON layout and
//! text; a request that names no file and a bad drive file are refused naming the field or the
//! key, with nothing written.
use std::path::{Path, PathBuf};

use feedscope::ErrorKind;
use feedscope_app::dynamics::{drive_from_toml, DynamicsRequest};
use feedscope_app::{FrontEnd, Quiet};

fn example() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples/drive.toml")
}

/// The command line's spelling.
struct Flags;
impl FrontEnd for Flags {
    fn name(&self, field: &str) -> String {
        format!("--{}", field.replace('_', "-"))
    }
}

fn first_line(path: &Path) -> String {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .next()
        .unwrap_or_default()
        .to_string()
}

#[test]
fn the_example_drive_writes_its_outputs_and_summary() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("out");
    let body = serde_json::json!({"config": example(), "out": out});
    let request: DynamicsRequest = serde_json::from_value(body).unwrap();
    let done = request.run(&Quiet).unwrap();
    let names: Vec<String> = done
        .files
        .iter()
        .map(|f| f.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert_eq!(
        names,
        [
            "dynamics.json",
            "frequency_vs_feed.csv",
            "frequency_vs_position.csv",
            "resonance.csv",
            "frequency_vs_feed.svg",
            "frequency_vs_position.svg",
        ]
    );
    assert!(done
        .files
        .iter()
        .all(|f| f.starts_with(&out) && f.is_file()));
    // Nothing else in the folder: no temporary file left.
    assert_eq!(std::fs::read_dir(&out).unwrap().count(), 6);
    assert_eq!(
        first_line(&out.join("frequency_vs_feed.csv")),
        "feed_mm_min,mode,frequency_hz"
    );
    assert_eq!(
        first_line(&out.join("resonance.csv")),
        "harmonic,feed_mm_min,frequency_hz,mode,margin_hz,order,feed_low_mm_min,feed_high_mm_min"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("dynamics.json")).unwrap()).unwrap();
    assert_eq!(json, serde_json::to_value(&done.report).unwrap());
    // The paper's static figure (calibrated, docs/dynamics.md): 108 Hz within 0.1 Hz.
    assert!((done.report.static_first_hz - 108.0).abs() < 0.1);

    // The summary's serde form is the `--format json` layout.
    let summary = serde_json::to_value(done.summary()).unwrap();
    let keys: Vec<&str> = summary
        .as_object()
        .unwrap()
        .keys()
        .map(String::as_str)
        .collect();
    assert_eq!(
        keys,
        [
            "bearing_unload",
            "breakaway_first_hz",
            "name",
            "peak_feed_mm_min",
            "peak_first_hz",
            "position_mm",
            "resonances",
            "static_first_hz",
        ]
    );
    assert_eq!(summary["static_first_hz"], json["static_first_hz"]);
    let text = done.summary_text();
    assert!(
        text.starts_with("dynamics of Zhang et al. 2015 gantry test drive (nut at "),
        "{text}"
    );
    assert!(text.contains("rear bearing unloads at"), "{text}");
    assert_eq!(
        text.matches(" meets mode ").count(),
        done.report.resonances.len(),
        "{text}"
    );
}

#[test]
fn a_request_without_files_and_a_bad_drive_are_refused_and_nothing_is_written() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("o");
    let e = DynamicsRequest {
        config: PathBuf::new(),
        out: out.clone(),
    }
    .run(&Flags)
    .unwrap_err();
    assert_eq!((e.kind(), e.field()), (ErrorKind::BadInput, Some("config")));
    assert_eq!(e.to_string(), "--config names no drive file");
    let e = DynamicsRequest {
        config: example(),
        out: PathBuf::new(),
    }
    .validate(&Flags)
    .unwrap_err();
    assert_eq!(e.field(), Some("out"));

    let bad = d.path().join("bad.toml");
    std::fs::write(&bad, "[table]\nmass_kg = -216.0\n").unwrap();
    let e = DynamicsRequest {
        config: bad.clone(),
        out: out.clone(),
    }
    .run(&Flags)
    .unwrap_err();
    assert_eq!(e.kind(), ErrorKind::BadInput);
    let message = e.to_string();
    assert!(
        message.starts_with(&format!("invalid drive file {}: ", bad.display()))
            && message.contains("table.mass_kg"),
        "{message}"
    );
    let e = DynamicsRequest {
        config: d.path().join("missing.toml"),
        out: out.clone(),
    }
    .run(&Flags)
    .unwrap_err();
    assert_eq!(e.kind(), ErrorKind::BadInput);
    assert!(e.to_string().starts_with("cannot read drive file "), "{e}");
    assert!(!out.exists(), "no output before the drive is valid");

    // Keys given in memory (Python's dict) are named as such.
    let e = drive_from_toml(
        "[screw]\nlenght_mm = 1400.0\n",
        "drive config",
        "drive config",
    )
    .unwrap_err();
    assert!(
        e.to_string().starts_with("invalid drive config: ") && e.to_string().contains("lenght_mm"),
        "{e}"
    );
    // A misspelt key of a request body is refused, not ignored.
    let e = serde_json::from_value::<DynamicsRequest>(serde_json::json!({"configs": "d.toml"}))
        .unwrap_err();
    assert!(e.to_string().contains("configs"), "{e}");
}
