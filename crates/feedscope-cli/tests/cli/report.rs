//! `feedscope report` and the demo's history: a drifting history gives warnings, a diagnosis
//! of lubrication and a self-contained HTML report with every section.
use crate::history::{axis_file, triangle_trace};
use crate::util::{feedscope, run, stderr, stdout};

/// Seven weekly triangle tests, the last two with a clearly higher static friction.
#[test]
fn report_of_a_drifting_axis() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    axis_file(d);
    let scales = [1.0, 1.0, 1.0, 1.0, 1.0, 1.5, 1.8];
    for (w, s) in scales.iter().enumerate() {
        let t = triangle_trace(d, &format!("w{w}.csv"), *s, 10 + w as u64);
        let mut c = feedscope(d);
        c.args([
            "history",
            "--db",
            "h.db",
            "add",
            "--kind",
            "triangle",
            "--axis",
            "axis.toml",
        ])
        .arg(&t)
        .args(["--time", &format!("2026-01-{:02}T08:00:00Z", 5 + w)]);
        let o = run(c);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    std::fs::write(d.join("th.toml"), "[thresholds]\nfs_n = { upper = 900 }\n").unwrap();
    let mut c = feedscope(d);
    c.args([
        "history",
        "--db",
        "h.db",
        "trend",
        "--thresholds",
        "th.toml",
        "--fail-on-warning",
    ]);
    let o = run(c);
    assert_eq!(o.status.code(), Some(1), "{}\n{}", stdout(&o), stderr(&o));
    // A finding, not a failure: a status line naming the indicators, no `error:`.
    let err = stderr(&o);
    assert!(
        err.starts_with("attention: ") && !err.contains("error:"),
        "{err}"
    );
    assert!(err.contains("fs_n"), "{err}");
    let text = stdout(&o);
    assert!(text.contains("fs_n"), "{text}");
    assert!(text.contains("lubrication"), "{text}");

    let mut c = feedscope(d);
    c.args([
        "report",
        "--db",
        "h.db",
        "--thresholds",
        "th.toml",
        "-o",
        "r.html",
    ]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    let html = std::fs::read_to_string(d.join("r.html")).unwrap();
    for id in [
        "summary",
        "diagnosis",
        "profile",
        "spectra",
        "stribeck",
        "trends",
        "tables",
    ] {
        assert!(
            html.contains(&format!("<section id=\"{id}\""))
                || html.contains(&format!("id=\"{id}\"")),
            "{id}"
        );
    }
    assert!(
        html.matches("<svg").count() >= 6,
        "trend charts and the Stribeck curves"
    );
    text_is_legible(&html);
    // self-contained: no external resource
    for bad in ["<script", "src=\"http", "href=\"http", "<link"] {
        assert!(!html.contains(bad), "{bad}");
    }

    // a thresholds file with an unknown indicator is bad input
    std::fs::write(
        d.join("bad.toml"),
        "[thresholds]\nfriction = { upper = 1 }\n",
    )
    .unwrap();
    let mut c = feedscope(d);
    c.args([
        "report",
        "--db",
        "h.db",
        "--thresholds",
        "bad.toml",
        "-o",
        "x.html",
    ]);
    assert_eq!(run(c).status.code(), Some(2));
}

#[test]
fn report_without_database_is_bad_input() {
    let tmp = tempfile::tempdir().unwrap();
    let mut c = feedscope(tmp.path());
    c.args(["report", "--db", "none.db"]);
    let o = run(c);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(!tmp.path().join("none.db").exists());
}

#[test]
fn report_help() {
    let d = tempfile::tempdir().unwrap();
    let mut c = feedscope(d.path());
    c.args(["report", "--help"]);
    let o = run(c);
    assert!(o.status.success());
    insta::assert_snapshot!("report_help", stdout(&o));
}

#[test]
fn thresholds_from_the_axis_file_are_used() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    axis_file(d);
    // The same axis with an alarm level every test crosses (fs_n is ~ hundreds of N).
    let mut axis = std::fs::read_to_string(d.join("axis.toml")).unwrap();
    axis.push_str("\n[thresholds]\nfs_n = { upper = 1.0 }\n");
    std::fs::write(d.join("axis.toml"), axis).unwrap();
    for w in 0..3 {
        let t = triangle_trace(d, &format!("w{w}.csv"), 1.0, 40 + w as u64);
        let mut c = feedscope(d);
        c.args([
            "history",
            "--db",
            "h.db",
            "add",
            "--kind",
            "triangle",
            "--axis",
            "axis.toml",
        ])
        .arg(&t)
        .args(["--time", &format!("2026-02-{:02}T08:00:00Z", 2 + 7 * w)]);
        let o = run(c);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let mut c = feedscope(d);
    c.args([
        "history",
        "--db",
        "h.db",
        "trend",
        "--baseline-tests",
        "2",
        "--format",
        "json",
    ]);
    let o = run(c);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    let fs = v["trends"]
        .as_array()
        .unwrap()
        .iter()
        .find(|t| t["indicator"]["kind"] == "static_friction")
        .unwrap_or_else(|| panic!("no static-friction trend in {v}"));
    assert_eq!(fs["threshold"]["upper"].as_f64(), Some(1.0), "{fs}");
}

/// The plots' text as a reader sees it: each chart in a two-column grid is drawn about as wide
/// as its cell (560 px in the 1200 px page), so that no label is shrunk; every label is at
/// least 11 px (the 7-9 px of a 960 px chart shrunk into a cell were hard to read).
fn text_is_legible(html: &str) {
    let mut in_grid = 0;
    for (k, piece) in html
        .split("<svg class=\"plot\" width=\"")
        .enumerate()
        .skip(1)
    {
        let width: u32 = piece.split('"').next().unwrap().parse().unwrap();
        let before = html
            .split("<svg class=\"plot\" width=\"")
            .take(k)
            .collect::<String>();
        let grid = before.rfind("<div class=\"grid\">") > before.rfind("</div></div>");
        if grid {
            in_grid += 1;
            assert!(width <= 560, "chart {k} in a grid is {width} px wide");
        }
        let svg = &piece[..piece.find("</svg>").unwrap()];
        for size in svg.split("font-size=\"").skip(1) {
            let px: f64 = size.split('"').next().unwrap().parse().unwrap();
            assert!(px >= 11.0, "chart {k}: text of {px} px");
        }
    }
    assert!(in_grid >= 4, "only {in_grid} charts in grids");
}
