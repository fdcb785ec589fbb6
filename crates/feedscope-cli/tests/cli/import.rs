//! `feedscope import`: real excerpts from `tests/data/import/` (see its README for sources and
//! licences), copied into a temp dir; sample counts checked against independent counts, the
//! round trip through the trace reader, malformed real files (exit 2, file and line named, no
//! output left) and golden `--list` output.
use std::path::{Path, PathBuf};

use feedscope::trace::Trace;
use feedscope_io::import::devices::DeviceModel;
use feedscope_io::import::shdr::{parse_shdr, ShdrConvertParams};
use feedscope_io::trace::{parse_trace, read_trace_file, write_csv, Layout, ReadOptions};

use crate::util::{feedscope, run, stderr, stdout};

const OKUMA: &str = "okuma_head640.txt";
const OKUMA_DEV: &str = "okuma_Devices.xml";
const NIST: &str = "mazak01_20161020_excerpt.txt";
const NIST_DEV: &str = "nist_Devices.xml";
const UMICH_CR: &str = "umich_experiment_12_head120.csv";
const UMICH_LF: &str = "umich_experiment_01_head120.csv";

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/import")
        .join(name)
}

/// A temp dir holding copies of the named excerpts (so messages show short relative paths).
fn setup(files: &[&str]) -> tempfile::TempDir {
    let d = tempfile::tempdir().unwrap();
    for f in files {
        std::fs::copy(data(f), d.path().join(f)).unwrap();
    }
    d
}

fn import(dir: &Path, args: &[&str]) -> std::process::Output {
    let mut c = feedscope(dir);
    c.arg("import").args(args);
    run(c)
}

fn assert_strictly_increasing(t: &[f64], what: &str) {
    assert!(
        t.windows(2).all(|w| w[1] > w[0]),
        "{what}: times not strictly increasing"
    );
}

/// Files in `dir` other than the inputs: an error must leave none behind (no temp file either).
fn leftovers(dir: &Path, inputs: &[&str]) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| !inputs.contains(&n.as_str()))
        .collect()
}

#[test]
fn okuma_z1_has_the_counted_samples_and_reads_back() {
    let files = [OKUMA, OKUMA_DEV];
    let d = setup(&files);
    let o = import(
        d.path(),
        &[
            "shdr",
            OKUMA,
            "--devices",
            OKUMA_DEV,
            "--axis",
            "Z1",
            "--torque-per-load-nm",
            "20",
            "-o",
            "z1.csv",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let (t, _) = read_trace_file(&d.path().join("z1.csv"), &ReadOptions::default()).unwrap();
    // Counted independently on the excerpt with
    //   grep -E '^[0-9]{4}-' okuma_head640.txt | grep '|Z1actm|' \
    //     | awk -F'|' '{for(i=2;i<=NF;i++) if($i=="Z1actm") print $1, $(i+1)}'
    // (same for Z1load): 192 Z1actm and 79 Z1load observations, none UNAVAILABLE, no repeated
    // or decreasing timestamps.
    assert_eq!(t.position_m.len(), 192);
    assert_eq!(t.effort.len(), 79);
    assert_strictly_increasing(&t.position_m.time_s, "position");
    assert_strictly_increasing(&t.effort.time_s, "effort");
    let text = std::fs::read_to_string(d.path().join("z1.csv")).unwrap();
    assert!(
        text.starts_with("# feedscope import from okuma_head640.txt\n"),
        "{text:.200}"
    );
    assert!(
        text.contains("# time zero: 2022-08-08T13:51:34.7167146Z (first data line of the log)"),
        "{text:.400}"
    );
    let out = stdout(&o);
    assert!(
        out.contains("192 samples") && out.contains("79 samples"),
        "{out}"
    );
    let err = stderr(&o);
    assert!(err.contains("load is integer percent"), "{err}");
}

#[test]
fn round_trip_through_the_trace_writer_and_reader_keeps_the_samples() {
    let model = DeviceModel::read(&data(OKUMA_DEV)).unwrap();
    let text = std::fs::read_to_string(data(OKUMA)).unwrap();
    let log = parse_shdr(&text, OKUMA, &model, None).unwrap();
    let p = ShdrConvertParams {
        torque_per_load_nm: Some(20.0),
        ..Default::default()
    };
    let imp = log.to_trace(&model, "Z1", &p).unwrap();
    let mut buf = Vec::new();
    feedscope_io::import::write_trace_csv(&imp, &mut buf).unwrap();
    let (back, _) = parse_trace(&buf, "mem", &ReadOptions::default()).unwrap();
    // The writer rounds to 6 decimals of the file's units: half a unit of the last place is
    // 5e-7 s, 5e-7 mm (5e-10 m) and 5e-7 N·m.
    let close = |a: &Trace, b: &Trace| {
        assert_eq!(a.position_m.len(), b.position_m.len());
        assert_eq!(a.effort.len(), b.effort.len());
        assert_eq!(a.effort_kind, b.effort_kind);
        for (x, y) in [(&a.position_m, &b.position_m), (&a.effort, &b.effort)] {
            for k in 0..x.len() {
                assert!((x.time_s[k] - y.time_s[k]).abs() <= 5.1e-7);
            }
        }
        for k in 0..a.position_m.len() {
            assert!((a.position_m.value[k] - b.position_m.value[k]).abs() <= 5.1e-10);
        }
        for k in 0..a.effort.len() {
            assert!((a.effort.value[k] - b.effort.value[k]).abs() <= 5.1e-7);
        }
    };
    close(&imp.trace, &back);
    // And the same for a UMich trace through `feedscope_io::trace::write_csv` directly.
    let t = feedscope_io::import::umich::read_umich(&data(UMICH_CR)).unwrap();
    let imp = t
        .to_trace("X", &feedscope_io::import::umich::UmichParams::default())
        .unwrap();
    let mut buf = Vec::new();
    write_csv(&imp.trace, &mut buf, Layout::Long).unwrap();
    let (back, _) = parse_trace(&buf, "mem", &ReadOptions::default()).unwrap();
    close(&imp.trace, &back);
}

#[test]
fn nist_mazak_x_picks_the_device_and_counts_gaps() {
    let files = [NIST, NIST_DEV];
    let d = setup(&files);
    let o = import(
        d.path(),
        &[
            "shdr",
            NIST,
            "--devices",
            NIST_DEV,
            "--axis",
            "X",
            "--torque-per-load-nm",
            "10",
            "-o",
            "x.csv",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let (t, _) = read_trace_file(&d.path().join("x.csv"), &ReadOptions::default()).unwrap();
    // Counted with `grep -E '\|Xabs\|' mazak01_20161020_excerpt.txt | awk -F'|' '{print $1, $3}'`:
    // 80 Xabs observations of which 2 UNAVAILABLE (the state dump's and the adapter's gap at
    // 15:43:04); 24 Xload, 2 UNAVAILABLE; timestamps unique and increasing.
    assert_eq!(t.position_m.len(), 78);
    assert_eq!(t.effort.len(), 22);
    assert_strictly_increasing(&t.position_m.time_s, "position");
    let out = stdout(&o);
    assert!(out.contains("2 UNAVAILABLE"), "{out}");
    // The log opens with a state dump stamped 2016-10-06: time 0 is two weeks before the data.
    assert!(stderr(&o).contains("state dump"), "{}", stderr(&o));
    assert!(t.position_m.time_s[0] > 13.0 * 86_400.0);
    let o = import(
        d.path(),
        &[
            "shdr",
            NIST,
            "--devices",
            NIST_DEV,
            "--axis",
            "X",
            "--torque-per-load-nm",
            "10",
            "--time-origin",
            "trace",
            "-o",
            "x2.csv",
        ],
    );
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let (t, _) = read_trace_file(&d.path().join("x2.csv"), &ReadOptions::default()).unwrap();
    let t0 = t.position_m.time_s[0].min(t.effort.time_s[0]);
    assert!(t0.abs() < 1e-9, "trace starts at {t0}");
}

#[test]
fn umich_cr_and_lf_excerpts_convert_at_10_hz() {
    let files = [UMICH_CR, UMICH_LF];
    let d = setup(&files);
    for f in files {
        let o = import(d.path(), &["umich", f, "--axis", "X", "-o", "x.csv"]);
        assert_eq!(o.status.code(), Some(0), "{f}: {}", stderr(&o));
        let (t, _) = read_trace_file(&d.path().join("x.csv"), &ReadOptions::default()).unwrap();
        // Both excerpts are the header plus 120 data rows (`tr -cd '\r' | wc -c` = 121 for the
        // CR file, `wc -l` = 121 for the LF file).
        assert_eq!(t.position_m.len(), 120, "{f}");
        assert_eq!(t.effort.len(), 120, "{f}");
        assert!((t.position_m.time_s[119] - 11.9).abs() < 1e-9, "{f}");
        assert_strictly_increasing(&t.position_m.time_s, f);
    }
}

#[test]
fn load_without_torque_scale_is_refused() {
    let files = [OKUMA, OKUMA_DEV];
    let d = setup(&files);
    let o = import(
        d.path(),
        &[
            "shdr",
            OKUMA,
            "--devices",
            OKUMA_DEV,
            "--axis",
            "Z1",
            "-o",
            "z1.csv",
        ],
    );
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(
        e.contains("okuma_head640.txt: `Z1load` is drive load in percent")
            && e.contains("--torque-per-load-nm"),
        "{e}"
    );
    assert!(leftovers(d.path(), &files).is_empty());
}

/// Run an import expected to fail with exit 2 and a message containing `needle`; check that
/// nothing was written.
fn expect_bad(d: &Path, inputs: &[&str], args: &[&str], needle: &str) {
    let o = import(d, args);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {e}");
    assert!(e.contains(needle), "{args:?}: expected `{needle}` in: {e}");
    assert_eq!(leftovers(d, inputs), Vec::<String>::new(), "{args:?}");
}

#[test]
fn malformed_real_files_exit_2_naming_file_and_line() {
    let d = setup(&[OKUMA, OKUMA_DEV, UMICH_LF]);
    let p = d.path();
    let real = std::fs::read_to_string(p.join(OKUMA)).unwrap();
    let lines: Vec<&str> = real.lines().collect();

    // A timestamp damaged on line 300 (a data line of the excerpt).
    let mut bad = lines.clone();
    let damaged = bad[299].replacen("2022-08-08T", "2022-08-08X", 1);
    bad[299] = &damaged;
    std::fs::write(p.join("bad_ts.txt"), bad.join("\n") + "\n").unwrap();

    // The log cut mid-write inside a condition: the first 200 lines, then line 3
    // (`…|CoolantSystem1_cond|NORMAL||||`) cut after its level.
    let cut = lines[2].split("NORMAL").next().unwrap().to_string() + "NORMAL|";
    let truncated = lines[..200].join("\n") + "\n" + &cut + "\n";
    std::fs::write(p.join("truncated.txt"), truncated).unwrap();

    std::fs::write(p.join("empty.txt"), "").unwrap();
    // A Devices.xml that is not XML: the log itself.
    std::fs::copy(p.join(OKUMA), p.join("not_xml.xml")).unwrap();

    // The UMich excerpt without its Y1 columns (11 of them, fields 12-22).
    let umich = std::fs::read_to_string(p.join(UMICH_LF)).unwrap();
    let no_y: String = umich
        .lines()
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            [&f[..11], &f[22..]].concat().join(",") + "\n"
        })
        .collect();
    std::fs::write(p.join("no_y.csv"), no_y).unwrap();

    let inputs = [
        OKUMA,
        OKUMA_DEV,
        UMICH_LF,
        "bad_ts.txt",
        "truncated.txt",
        "empty.txt",
        "not_xml.xml",
        "no_y.csv",
    ];
    let shdr = |log: &'static str, dev: &'static str, axis: &'static str| {
        [
            "shdr",
            log,
            "--devices",
            dev,
            "--axis",
            axis,
            "--torque-per-load-nm",
            "20",
            "-o",
            "out.csv",
        ]
    };
    expect_bad(
        p,
        &inputs,
        &shdr("bad_ts.txt", OKUMA_DEV, "Z1"),
        "bad_ts.txt:300: bad timestamp `2022-08-08X",
    );
    expect_bad(
        p,
        &inputs,
        &shdr(OKUMA, OKUMA_DEV, "Q9"),
        "no axis `Q9`; axes found: X (Linear, id Lx1), Y (Linear, id LYI1), Z1 (Linear, id Lz1)",
    );
    expect_bad(
        p,
        &inputs,
        &shdr(OKUMA, "not_xml.xml", "Z1"),
        "not_xml.xml: not a readable MTConnect device model",
    );
    expect_bad(
        p,
        &inputs,
        &shdr("truncated.txt", OKUMA_DEV, "Z1"),
        "truncated.txt:201: `CoolantSystem1_cond` (CONDITION) needs 5 fields after the key, \
         the line has 2",
    );
    expect_bad(
        p,
        &inputs,
        &shdr("empty.txt", OKUMA_DEV, "Z1"),
        "empty.txt: the file is empty",
    );
    expect_bad(
        p,
        &inputs,
        &["umich", "no_y.csv", "--axis", "Y", "-o", "out.csv"],
        "no_y.csv: axis `Y`: missing column(s) Y1_ActualPosition, Y1_CurrentFeedback; \
         axes found: X1, Z1",
    );
    expect_bad(
        p,
        &inputs,
        &["umich", "empty.txt", "--axis", "X", "-o", "out.csv"],
        "empty.txt: the file is empty",
    );
    expect_bad(
        p,
        &inputs,
        &["umich", "missing.csv", "--axis", "X", "-o", "out.csv"],
        "missing.csv: cannot read",
    );
}

#[test]
fn list_output_golden() {
    let d = setup(&[OKUMA, OKUMA_DEV, UMICH_CR]);
    let o = import(d.path(), &["shdr", OKUMA, "--devices", OKUMA_DEV, "--list"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    insta::assert_snapshot!("import_shdr_list_okuma", stdout(&o));
    let o = import(d.path(), &["umich", UMICH_CR, "--list"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    insta::assert_snapshot!("import_umich_list", stdout(&o));
}

#[test]
fn import_shdr_help() {
    let d = tempfile::tempdir().unwrap();
    let o = import(d.path(), &["shdr", "--help"]);
    assert_eq!(o.status.code(), Some(0));
    insta::assert_snapshot!("import_shdr_help", stdout(&o));
}
