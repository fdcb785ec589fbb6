//! `estimate --program`: strokes labelled with their NC block, G0 blocks as rapids, a program
//! the reader cannot interpret refused with its line (issue #10).
use crate::util::{expect_bad_input, feedscope, run, stderr};

const PROGRAM: &str = "%\nO2001\nG21 G90 G94 G61\nG00 X20.\nG01 X120. F600\nG04 P500\n\
                       G01 X20. F600\nG04 P500\nG00 X120.\nM30\n%\n";

fn setup(dir: &std::path::Path) {
    let cfg = format!(
        "seed = 5\n[axis]\nlead_mm = 16.0\ntable_mass_kg = 600.0\ninertia_kgm2 = 0.0025\n\
         damping_nms_per_rad = 0.0015\ntorque_constant_nm_per_a = 1.1\ntravel_min_mm = 0.0\n\
         travel_max_mm = 600.0\nrapid_rate_mm_min = 24000.0\n[motion]\nstart_mm = 60.0\n\
         acceleration_mm_s2 = 1500.0\njerk_mm_s3 = 30000.0\nprogram_axis = \"X\"\n\
         program = \"\"\"\n{PROGRAM}\"\"\"\n[sampling]\nmode = \"synchronous\"\n\
         synchronous_rate_hz = 500.0\neffort_kind = \"torque_nm\"\n[truth]\ninterval_ms = 100.0\n"
    );
    std::fs::write(dir.join("sim.toml"), cfg).unwrap();
    std::fs::write(dir.join("mill.nc"), PROGRAM).unwrap();
    let mut c = feedscope(dir);
    c.args(["simulate", "--config", "sim.toml", "--out", "s"]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn strokes_and_rapids_are_labelled_with_their_blocks() {
    let d = tempfile::tempdir().unwrap();
    setup(d.path());
    let mut c = feedscope(d.path());
    c.args([
        "estimate",
        "s/trace.csv",
        "--axis",
        "s/axis.toml",
        "-o",
        "f.csv",
        "--program",
        "mill.nc",
        "--program-axis",
        "X",
    ]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.path().join("f.json")).unwrap()).unwrap();
    let strokes = json["strokes"].as_array().unwrap();
    assert_eq!(strokes.len(), 2, "{json:#}");
    let lines: Vec<u64> = strokes
        .iter()
        .map(|s| s["program_line"].as_u64().unwrap())
        .collect();
    assert_eq!(lines, [5, 7]);
    for s in strokes {
        assert!((s["programmed_feed_mm_min"].as_f64().unwrap() - 600.0).abs() < 1e-9);
    }
    let moves = json["moves"].as_array().unwrap();
    let rapid_lines: Vec<u64> = moves
        .iter()
        .filter(|m| m["kind"] == "rapid")
        .map(|m| m["program_line"].as_u64().unwrap())
        .collect();
    assert_eq!(rapid_lines, [4, 9], "{moves:#?}");
    assert!(moves.iter().all(|m| m["kind"] != "jog"), "{moves:#?}");
}

#[test]
fn a_program_it_cannot_read_is_refused_naming_the_line() {
    let d = tempfile::tempdir().unwrap();
    setup(d.path());
    std::fs::write(
        d.path().join("bad.nc"),
        "G01 X20. F100\nWHILE [#1 LT 3] DO1\n",
    )
    .unwrap();
    let args = [
        "estimate",
        "s/trace.csv",
        "--axis",
        "s/axis.toml",
        "-o",
        "g.csv",
        "--program",
        "bad.nc",
        "--program-axis",
        "X",
    ];
    expect_bad_input(d.path(), &args, &["bad.nc", "line 2"]);
    assert!(!d.path().join("g.csv").exists());
}
