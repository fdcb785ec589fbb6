//! Rough edges met by users (issue #18, items 7 and 8): a report without a baseline says so,
//! missing or unknown databases, machines and axes are explained, foreign files are named,
//! outputs go into folders that do not exist yet, `--effort` errors name the flag, and plots
//! number strokes as the tables do. Real files and the real binary throughout.
use std::path::{Path, PathBuf};
use std::process::Output;

use crate::estimate::{good_long_trace, AXIS};
use crate::history::{axis_file, triangle_trace};
use crate::util::{expect_bad_input, feedscope, run, stderr, stdout};

fn import_data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/import")
        .join(name)
}

/// `feedscope history --db h.db add TRIANGLE --kind triangle --axis axis.toml EXTRA...` in `d`.
fn add_triangle(d: &Path, trace: &Path, extra: &[&str]) -> Output {
    let mut c = feedscope(d);
    c.args(["history", "--db", "h.db", "add", "--kind", "triangle"])
        .args(["--axis", "axis.toml"])
        .arg(trace)
        .args(extra);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    o
}

/// The `y` attribute of the SVG `<text>` element whose content (trimmed) is `label`.
fn text_y(svg: &str, label: &str) -> f64 {
    let element = svg
        .split("<text")
        .skip(1)
        .find(|e| {
            e.split_once('>')
                .is_some_and(|(_, rest)| rest.split("</text>").next().map(str::trim) == Some(label))
        })
        .unwrap_or_else(|| panic!("no text {label:?}"));
    let y = element.find(" y=\"").expect("a y attribute") + 4;
    element[y..y + element[y..].find('"').unwrap()]
        .parse()
        .unwrap()
}

/// One test: no baseline, and the report says so and what is missing, never that nothing
/// changed; with two tests and a baseline of two, the trends have a marker per test, the
/// legend below the plot and the σ floor stated.
#[test]
fn report_says_when_there_is_no_baseline_and_states_the_sigma_floor() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    axis_file(d);
    let t1 = triangle_trace(d, "w1.csv", 1.0, 11);
    add_triangle(d, &t1, &["--time", "2026-01-05T08:00:00Z"]);
    let mut c = feedscope(d);
    c.args(["report", "--db", "h.db", "-o", "r.html"]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    let html = std::fs::read_to_string(d.join("r.html")).unwrap();
    assert!(html.contains("No baseline yet"), "{html}");
    // Five triangle indicators, one test of the five the baseline takes: four more.
    assert!(
        html.contains("the first 5 tests of each indicator and they have only 1 triangle test; 4 more triangle tests are needed"),
        "{html}"
    );
    assert!(!html.contains("No indicator has left its baseline band"));
    assert!(!html.contains("no evidence of"));
    assert!(html.contains("at least 1 % of |μ₀|"), "{html}");

    let t2 = triangle_trace(d, "w2.csv", 1.0, 12);
    add_triangle(d, &t2, &["--time", "2026-01-12T08:00:00Z"]);
    let mut c = feedscope(d);
    c.args([
        "report",
        "--db",
        "h.db",
        "--baseline-tests",
        "2",
        "-o",
        "r2.html",
    ]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    let html = std::fs::read_to_string(d.join("r2.html")).unwrap();
    assert!(!html.contains("No baseline yet"));
    assert!(html.contains("<th>σ floor</th>"));
    assert!(
        html.contains("at least 1 % of |μ₀|") && html.contains("indicators are at the floor"),
        "{html}"
    );
    // The trend of Fs: two markers (one per test), its legend entries below the plot area.
    let fs = html
        .split("<div class=\"trend\">")
        .find(|c| c.contains("static friction Fs ["))
        .expect("a trend chart of Fs");
    assert!(fs.matches("<circle").count() >= 2, "{fs}");
    for entry in ["value (N)", "EWMA (λ 0.2)"] {
        // the report's trend tiles are 400 px high above their legend
        assert!(text_y(fs, entry) > 400.0, "{entry} drawn inside the plot");
    }
}

/// `report` without a database names where it looked and how to make one.
#[test]
fn report_without_a_database_says_where_it_looked() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let mut c = feedscope(d);
    c.env_remove("FEEDSCOPE_DB")
        .args(["report", "-o", "r.html"]);
    let o = run(c);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    for needle in [
        "no database at feedscope.db in ",
        "no --db given and FEEDSCOPE_DB not set",
        "`feedscope history add TRACE --axis AXIS.toml --kind strokes|triangle",
    ] {
        assert!(err.contains(needle), "`{needle}` not in {err}");
    }
    expect_bad_input(
        d,
        &["report", "--db", "old/h.db", "-o", "r.html"],
        &[
            "no database at old/h.db (--db)",
            "feedscope history --db old/h.db add",
        ],
    );
    assert!(!d.join("r.html").exists());
}

/// Unknown machine or axis: the stored ones are listed, the only one said to be the default;
/// `history add` says which series it started or added to, and where the time came from.
#[test]
fn series_names_are_listed_and_announced() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    axis_file(d);
    let t1 = triangle_trace(d, "w1.csv", 1.0, 21);
    // No --time: the file's modification time, said so; no --machine: the default, named.
    let o = add_triangle(d, &t1, &[]);
    let err = stderr(&o);
    assert!(
        err.contains("started the series of machine \"machine\", axis \"simulated lathe Z\""),
        "{err}"
    );
    assert!(
        err.contains("is the modification time of ") && err.contains("w1.csv (give --time"),
        "{err}"
    );
    let t2 = triangle_trace(d, "w2.csv", 1.0, 22);
    let o = add_triangle(d, &t2, &["--time", "2030-01-01T00:00:00Z"]);
    let err = stderr(&o);
    assert!(
        err.contains(
            "added to the series of machine \"machine\", axis \"simulated lathe Z\" (2 tests now)"
        ),
        "{err}"
    );
    assert!(!err.contains("modification time"), "{err}");

    for cmd in [&["report", "-o", "r.html"][..], &["history", "trend"][..]] {
        let with = |extra: &[&str]| -> Vec<String> {
            let mut a: Vec<String> = cmd.iter().map(|s| s.to_string()).collect();
            a.extend(["--db", "h.db"].map(String::from));
            a.extend(extra.iter().map(|s| s.to_string()));
            a
        };
        let args = with(&["--machine", "lathe 9"]);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        expect_bad_input(
            d,
            &args,
            &[
                "no machine \"lathe 9\"",
                "machines stored: \"machine\" (axes \"simulated lathe Z\" (2 tests))",
                "the only one, the default when --machine is not given",
            ],
        );
        let args = with(&["--axis-name", "X"]);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        expect_bad_input(
            d,
            &args,
            &[
                "machine \"machine\" has no axis \"X\"",
                "axes stored: \"simulated lathe Z\" (2 tests)",
                "the only one, the default when --axis-name is not given",
            ],
        );
    }
    assert!(!d.join("r.html").exists());
}

/// Issue 34 item 11: `report` and `history trend` without `--machine` use the only machine
/// in the store, whatever its name; among several they name them and ask for one.
#[test]
fn the_only_machine_is_the_default_of_report_and_trend() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    axis_file(d);
    for (k, week) in ["2030-01-01T00:00:00Z", "2030-01-08T00:00:00Z"]
        .iter()
        .enumerate()
    {
        let t = triangle_trace(d, &format!("m{k}.csv"), 1.0, 31 + k as u64);
        let o = add_triangle(d, &t, &["--machine", "mill 7", "--time", week]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let mut c = feedscope(d);
    c.args(["history", "--db", "h.db", "trend"]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).starts_with("mill 7 simulated lathe Z: 2 tests"),
        "{}",
        stdout(&o)
    );
    let mut c = feedscope(d);
    c.args(["report", "--db", "h.db", "-o", "r.html"]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(std::fs::read_to_string(d.join("r.html"))
        .unwrap()
        .contains("mill 7"));
    std::fs::remove_file(d.join("r.html")).unwrap();

    let t = triangle_trace(d, "l.csv", 1.0, 35);
    let o = add_triangle(
        d,
        &t,
        &["--machine", "lathe 2", "--time", "2030-01-02T00:00:00Z"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    for cmd in [
        &["report", "--db", "h.db", "-o", "r.html"][..],
        &["history", "--db", "h.db", "trend"][..],
    ] {
        expect_bad_input(
            d,
            cmd,
            &["several machines (\"lathe 2\", \"mill 7\"): choose one with --machine"],
        );
    }
    assert!(!d.join("r.html").exists());
}

/// A semicolon CSV, a raw SHDR log and a raw UMich CSV given to `estimate` are named as such,
/// with the import command for the last two; `import shdr` on a trace CSV says it is no SHDR.
#[test]
fn foreign_files_are_named() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    std::fs::write(d.join("axis.toml"), AXIS).unwrap();
    // As a spreadsheet in a decimal-comma locale saves the good trace.
    let semi: String = good_long_trace()
        .lines()
        .map(|l| l.replace(',', ";").replace('.', ",") + "\n")
        .collect();
    std::fs::write(d.join("semi.csv"), semi).unwrap();
    let est = |f: &str| ["estimate", f, "--axis", "axis.toml", "-o", "f.csv"].map(String::from);
    let bad = |args: [String; 6], needles: &[&str]| {
        let a: Vec<&str> = args.iter().map(String::as_str).collect();
        expect_bad_input(d, &a, needles);
    };
    bad(
        est("semi.csv"),
        &[
            "semi.csv:2:",
            "separated by `;`",
            "decimal mark is a comma",
            "`0.036,current_a,0.842`",
        ],
    );
    for f in [
        "okuma_head640.txt",
        "umich_experiment_01_head120.csv",
        "okuma_Devices.xml",
    ] {
        std::fs::copy(import_data(f), d.join(f)).unwrap();
    }
    bad(
        est("okuma_head640.txt"),
        &[
            "okuma_head640.txt:1:",
            "MTConnect SHDR log",
            "feedscope import shdr",
        ],
    );
    bad(
        est("umich_experiment_01_head120.csv"),
        &[
            "umich_experiment_01_head120.csv:1:",
            "UMich SMART CNC mill CSV",
            "feedscope import umich",
        ],
    );
    std::fs::write(d.join("trace.csv"), good_long_trace()).unwrap();
    expect_bad_input(
        d,
        &[
            "import",
            "shdr",
            "trace.csv",
            "--devices",
            "okuma_Devices.xml",
            "--axis",
            "Z1",
            "--torque-per-load-nm",
            "20",
            "-o",
            "z.csv",
        ],
        &[
            "trace.csv:2: not an MTConnect SHDR log",
            "`timestamp|key|value|…`",
            "looks like CSV",
        ],
    );
    assert!(!d.join("f.csv").exists() && !d.join("z.csv").exists());
}

/// `-o` into folders that do not exist: made, for every command writing a file; a folder
/// given as the output file and a database in a missing folder are named.
#[test]
fn outputs_go_into_missing_folders() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    std::fs::write(d.join("axis.toml"), AXIS).unwrap();
    std::fs::write(d.join("trace.csv"), good_long_trace()).unwrap();
    std::fs::copy(
        import_data("umich_experiment_01_head120.csv"),
        d.join("umich.csv"),
    )
    .unwrap();
    let runs: [&[&str]; 4] = [
        &[
            "estimate",
            "trace.csv",
            "--axis",
            "axis.toml",
            "-o",
            "a/b/f.csv",
        ],
        &[
            "import",
            "umich",
            "umich.csv",
            "--axis",
            "X",
            "-o",
            "c/x.csv",
        ],
        &[
            "plan",
            "strokes",
            "--axis",
            "axis.toml",
            "--feeds",
            "100",
            "--from",
            "0",
            "--to",
            "50",
            "-o",
            "e/p.nc",
        ],
        &[
            "estimate",
            "trace.csv",
            "--axis",
            "axis.toml",
            "-o",
            "g.csv",
            "--summary",
            "h/s.json",
        ],
    ];
    for args in runs {
        let mut c = feedscope(d);
        c.args(args);
        let o = run(c);
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    }
    for f in [
        "a/b/f.csv",
        "a/b/f.json",
        "a/b/f.svg",
        "c/x.csv",
        "e/p.nc",
        "h/s.json",
    ] {
        assert!(d.join(f).is_file(), "{f}");
    }
    std::fs::create_dir(d.join("dir")).unwrap();
    expect_bad_input(
        d,
        &["estimate", "trace.csv", "--axis", "axis.toml", "-o", "dir"],
        &["dir is a folder; the output must be a file name"],
    );
    expect_bad_input(
        d,
        &[
            "history",
            "--db",
            "no/such/h.db",
            "add",
            "trace.csv",
            "--axis",
            "axis.toml",
            "--kind",
            "strokes",
        ],
        &["no/such/h.db: the folder no/such does not exist"],
    );
    assert!(!d.join("no").exists());
}

/// `--effort` errors name the flag: a channel asked for and absent, and a file with both.
#[test]
fn effort_errors_name_the_flag() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    std::fs::write(d.join("axis.toml"), AXIS).unwrap();
    std::fs::write(d.join("trace.csv"), good_long_trace()).unwrap();
    for cmd in ["estimate", "identify"] {
        expect_bad_input(
            d,
            &[
                cmd,
                "trace.csv",
                "--axis",
                "axis.toml",
                "-o",
                "o.json",
                "--effort",
                "torque",
            ],
            &["--effort torque: trace.csv: no `torque_nm` samples found"],
        );
    }
    let mut both = String::from("time_s,position_mm,current_a,torque_nm\n");
    for k in 0..100 {
        both.push_str(&format!("{},{},0.3,0.5\n", k as f64 * 0.07, k));
    }
    std::fs::write(d.join("both.csv"), both).unwrap();
    expect_bad_input(
        d,
        &["estimate", "both.csv", "--axis", "axis.toml", "-o", "o.csv"],
        &[
            "both.csv: both `current_a` and `torque_nm`",
            "--effort current or --effort torque",
        ],
    );
}

/// The plot's legend numbers strokes as the console table does (from 0, over both
/// directions), not 1.. within each direction's panel.
#[test]
fn plot_legend_numbers_strokes_as_the_table() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    std::fs::write(d.join("axis.toml"), AXIS).unwrap();
    std::fs::write(d.join("trace.csv"), good_long_trace()).unwrap();
    let mut c = feedscope(d);
    c.args([
        "estimate",
        "trace.csv",
        "--axis",
        "axis.toml",
        "-o",
        "f.csv",
    ]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    // The table's first column is the stroke number, its second the direction.
    let table = stdout(&o);
    let number = |dir: &str| -> String {
        let rows: Vec<&str> = table
            .lines()
            .filter(|l| l.split_whitespace().nth(1) == Some(dir))
            .filter_map(|l| l.split_whitespace().next())
            .collect();
        assert_eq!(rows.len(), 1, "{table}");
        rows[0].to_string()
    };
    let (fwd, bwd) = (number("forward"), number("backward"));
    // The table counts strokes from 0 over both directions (here 0 forward, 1 backward); the
    // plot counted from 1 within each panel, or not at all for a panel's only stroke.
    assert_eq!((fwd.as_str(), bwd.as_str()), ("0", "1"), "{table}");
    let svg = std::fs::read_to_string(d.join("f.svg")).unwrap();
    for (dir, n) in [("forward", fwd), ("backward", bwd)] {
        let entry = format!("{dir} stroke {n} (estimated)");
        assert!(text_y(&svg, &entry) > 0.0, "{entry}");
    }
}
