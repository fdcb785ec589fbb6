//! The demo's parts in the application layer (`feedscope_app::demo`): the weekly plan has
//! the tests the demo announces, the friction degrades only after the commissioning weeks, an
//! estimate equal to the truth is no distance from it, and a short weekly history is stored,
//! reported and trended with the static friction rising.
use feedscope::estimate::Direction;
use feedscope::history::Indicator;
use feedscope::sim::{FrictionModel, SimConfig};
use feedscope_app::demo::{self, WeeklyHistory};
use feedscope_app::estimate::FrictionPlot;
use feedscope_app::store::Opener;
use feedscope_app::Quiet;
use feedscope_store::{SqliteStore, Store, TestKind};

#[test]
fn the_weekly_plan_and_the_degrading_friction() {
    // `feedscope demo`: 16 weekly triangle tests, stroke tests in the first 5 weeks, every 3
    // weeks after and in the last.
    let plan = WeeklyHistory::plan(1, 16).unwrap();
    assert_eq!(
        (plan.weeks(), plan.triangle_tests(), plan.stroke_tests()),
        (16, 16, 9)
    );
    let axis = demo::twin(1).axis;
    let steady = demo::week_friction(&axis, 0);
    for w in 1..demo::DRIFT_FROM_WEEK {
        assert_eq!(demo::week_friction(&axis, w), steady, "week {w}");
    }
    // Two weeks into the drift: +14 % static excess, +8 % viscous, −4 % Stribeck velocity;
    // the tolerance is a few ulps of the products.
    let f = demo::week_friction(&axis, demo::DRIFT_FROM_WEEK + 1);
    let rel = |a: f64, b: f64| (a / b - 1.0).abs();
    let (v, v0) = (&f.velocity, &steady.velocity);
    assert!(rel(v.static_excess_n, v0.static_excess_n * 1.14) < 1e-12);
    assert!(rel(v.viscous_n_s_per_m, v0.viscous_n_s_per_m * 1.08) < 1e-12);
    assert!(
        rel(
            v.stribeck_velocity_mm_min,
            v0.stribeck_velocity_mm_min * 0.96
        ) < 1e-12
    );
}

#[test]
fn an_estimate_equal_to_the_truth_is_no_distance_from_it() {
    let d = tempfile::tempdir().unwrap();
    let cfg = SimConfig::default();
    let model = FrictionModel::new(
        cfg.axis.lead_mm,
        feedscope::sim::FrictionParams::default_for(&cfg.axis),
    );
    let feed_mm_min = 100.0;
    let mut plot = FrictionPlot::default();
    plot.forward = vec![vec![(10.0, 0.0), (20.0, 0.0)]];
    plot.backward = vec![vec![(20.0, 0.0), (10.0, 0.0)]];
    let [fwd, bwd] = demo::true_friction(&plot, &model, feed_mm_min);
    assert_eq!(
        (fwd[0].name.as_str(), bwd[0].name.as_str()),
        ("forward (true)", "backward (true)")
    );
    // The friction CSV of `estimate`, its friction the truth's at each row.
    let mut csv = String::from(
        "stroke,direction,position_mm,time_s,velocity_mm_s,accel_mm_s2,current_a,friction_n\n",
    );
    for (series, v_mm_s) in [
        (&fwd[0], feed_mm_min / 60.0),
        (&bwd[0], -feed_mm_min / 60.0),
    ] {
        for &(z_mm, friction_n) in &series.points {
            let dir = if v_mm_s > 0.0 { "forward" } else { "backward" };
            csv.push_str(&format!(
                "0,{dir},{z_mm},0.0,{v_mm_s},0.0,0.0,{friction_n}\n"
            ));
        }
    }
    let path = d.path().join("friction.csv");
    std::fs::write(&path, csv).unwrap();
    let diff = demo::difference_from_truth(&path, &model).unwrap();
    assert_eq!(diff.len(), 2);
    assert_eq!(
        (diff[0].direction, diff[1].direction),
        (Direction::Forward, Direction::Backward)
    );
    for x in &diff {
        assert_eq!(x.points, 2);
        // Written with Rust's shortest round-trip formatting: read back exactly.
        assert!(x.rms_n < 1e-9, "{x:?}");
    }
    std::fs::write(&path, "stroke,direction\n0,forward,ten\n").unwrap();
    let e = demo::difference_from_truth(&path, &model).unwrap_err();
    assert!(e.to_string().contains("line 2"), "{e}");
}

#[test]
fn a_short_weekly_history_is_stored_reported_and_trended() {
    let d = tempfile::tempdir().unwrap();
    let weeks = demo::DRIFT_FROM_WEEK + 2;
    let history = WeeklyHistory::plan(3, weeks).unwrap();
    let t = history.run(d.path(), &Opener::quiet(), &Quiet).unwrap();
    assert_eq!(
        (t.machine.as_str(), t.axis.as_str()),
        (demo::MACHINE, demo::AXIS)
    );
    let store = SqliteStore::open(&d.path().join("history.db")).unwrap();
    let rows = store.list(&Default::default()).unwrap();
    let n = |k| rows.iter().filter(|r| r.kind == k).count();
    assert_eq!(
        (n(TestKind::Triangle), n(TestKind::Strokes)),
        (history.triangle_tests(), history.stroke_tests())
    );
    // Weekly triangles; strokes in the commissioning weeks and the last.
    assert_eq!(
        (n(TestKind::Triangle), n(TestKind::Strokes)),
        (weeks, demo::DRIFT_FROM_WEEK + 1)
    );
    assert_eq!(t.tests.len(), rows.len());
    for f in [
        "report.html",
        "thresholds.toml",
        "weekly/week-01-triangle.csv",
    ] {
        assert!(d.path().join(f).is_file(), "{f}");
    }
    let key: Vec<Indicator> = demo::friction_trends(&t)
        .map(|x| x.indicator.clone())
        .collect();
    assert_eq!(key.len(), 4, "{key:?}");
    let fs = demo::friction_trends(&t)
        .find(|x| x.indicator == Indicator::StaticFriction)
        .unwrap();
    assert!(fs.change_percent > 0.0, "{}", fs.change_percent);
    // A second run starts a fresh history: the same story.
    let again = history.run(d.path(), &Opener::quiet(), &Quiet).unwrap();
    assert_eq!(again.tests.len(), t.tests.len());
    assert_eq!(
        serde_json::to_value(&again.trends).unwrap(),
        serde_json::to_value(&t.trends).unwrap()
    );
}
