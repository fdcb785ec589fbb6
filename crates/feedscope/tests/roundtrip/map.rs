//! Issue 4 proof (multi-test friction map): simulate a test set of several feeds × repeats with
//! known Stribeck parameters, estimate every run, build the map, fit Stribeck along the travel
//! and compare with the truth `mean_friction_n`.
//!
//! Truth (not any paper's): forward mean level 260 + 0.4·z N with a 25 N bump at 45 mm,
//! backward 310 − 0.3·z N; F_s − F_c = 85 N, v_s = 45 mm/min, σ = 7000 N·s/m (σ·v_max = 105 N
//! at 900 mm/min, 40 % of F_c, so σ is identifiable); ripple 3 N at orders 2 and 3.7. Feeds
//! log-spaced 9-900 mm/min (v_s/5 to 20·v_s), two repeats, strokes 25 → 55 mm.
use feedscope::estimate::{Direction, EstimateParams};
use feedscope::map::{
    build_map, estimate_set_with, stribeck_profile, MapParams, RunFriction, TestRun,
};
use feedscope::sim::{
    Bump, Component, ComponentDirection, DynamicsMode, FrictionParams, MeanLevel, SimConfig,
    SimOutput, StrokeConfig, VelocityTerm,
};
use feedscope::trace::Trace;
use feedscope::units::feed_mm_min_to_m_s;

use crate::util::run;

const FEEDS: [f64; 9] = [9.0, 16.0, 28.0, 50.0, 90.0, 160.0, 285.0, 505.0, 900.0];
const FS_MINUS_FC: f64 = 85.0;
const VS_MM_MIN: f64 = 45.0;
const SIGMA: f64 = 7000.0;

fn friction() -> FrictionParams {
    let comp = |order: f64, phase_deg: f64| Component {
        order,
        amplitude_n: 3.0,
        phase_deg,
        direction: ComponentDirection::Both,
        cause: String::new(),
    };
    FrictionParams {
        sign_smoothing_mm_s: 0.01,
        forward: MeanLevel {
            offset_n: 260.0,
            trend_n_per_mm: 0.4,
            bumps: vec![Bump {
                center_mm: 45.0,
                width_mm: 8.0,
                height_n: 25.0,
            }],
        },
        backward: MeanLevel {
            offset_n: 310.0,
            trend_n_per_mm: -0.3,
            bumps: vec![],
        },
        velocity: VelocityTerm {
            static_excess_n: FS_MINUS_FC,
            stribeck_velocity_mm_min: VS_MM_MIN,
            shape_exponent: 2.0,
            viscous_n_s_per_m: SIGMA,
        },
        components: vec![comp(2.0, 30.0), comp(3.7, 100.0)],
    }
}

/// One run: 25 → 55 mm and back at `feed`, sampled every 20 ms.
fn config(feed: f64, seed: u64) -> SimConfig {
    let mut c = SimConfig {
        seed,
        friction: Some(friction()),
        ..SimConfig::default()
    };
    c.dynamics.mode = DynamicsMode::Ideal;
    c.motion.start_mm = 25.0;
    c.motion.lead_in_s = 0.2;
    c.motion.lead_out_s = 0.2;
    c.motion.strokes = vec![
        StrokeConfig {
            to_mm: 55.0,
            feed_mm_min: feed,
            dwell_s: 0.5,
        },
        StrokeConfig {
            to_mm: 25.0,
            feed_mm_min: feed,
            dwell_s: 0.0,
        },
    ];
    c.sampling.position.interval_ms = 20.0;
    c.sampling.position.jitter_ms = 0.5;
    c.sampling.effort.interval_ms = 20.0;
    c.sampling.effort.jitter_ms = 0.5;
    c.sampling.effort.start_offset_ms = 10.0;
    c.truth.interval_ms = 1000.0;
    c
}

struct Set {
    runs: Vec<TestRun>,
    outs: Vec<SimOutput>,
}

fn simulate_set(repeats: u32) -> Set {
    use rayon::prelude::*;
    let runs: Vec<TestRun> = FEEDS
        .iter()
        .flat_map(|&f| {
            (1..=repeats).map(move |r| TestRun {
                name: format!("f{f}_r{r}.csv"),
                file: "".into(),
                feed_mm_min: f,
                repeat: r,
            })
        })
        .collect();
    let outs = runs
        .par_iter()
        .enumerate()
        .map(|(k, r)| run(&config(r.feed_mm_min, 11 + k as u64)))
        .collect();
    Set { runs, outs }
}

fn estimate_all(set: &Set) -> Vec<RunFriction> {
    let axis = &set.outs[0].truth.axis;
    let traces: Vec<&Trace> = set.outs.iter().map(|o| &o.trace).collect();
    let est = estimate_set_with(
        &set.runs,
        |r| {
            let k = set.runs.iter().position(|x| x.name == r.name).unwrap();
            Ok(traces[k].clone())
        },
        axis,
        &EstimateParams::default(),
        MapParams::default().stroke_feed_tolerance,
        &|_| {},
    );
    assert!(est.failed.is_empty(), "{:?}", est.failed);
    est.ok
}

#[test]
fn map_recovers_stribeck_parameters_and_mean_friction() {
    let t0 = std::time::Instant::now();
    let set = simulate_set(2);
    let runs = estimate_all(&set);
    let t1 = t0.elapsed();
    let model = &set.outs[0].truth.friction;
    let lead_m = set.outs[0].truth.axis.lead_m();
    let params = MapParams::default();
    let map = build_map(&runs, lead_m, &params).unwrap();
    assert_eq!(map.directions.len(), 2);
    let mut worst = [0.0f64; 5];
    for d in &map.directions {
        assert_eq!(d.feeds.len(), FEEDS.len());
        assert!(d.feeds.iter().all(|g| g.repeats.len() == 2));
        assert_eq!(d.feed_model.order, 5);
        // The map at the measured feeds against the truth mean friction (no ripple): the
        // piecewise quartics leave part of the 3 N ripple and the quintic in log-feed part of
        // the Stribeck knee; 4 % of the truth bounds both.
        let mut map_err = 0.0f64;
        for &f in &FEEDS {
            let poly = d.poly_at(f, false).unwrap();
            for i in 0..=50 {
                let z = d.start_mm + (d.end_mm - d.start_mm) * i as f64 / 50.0;
                let truth = d.direction.sign()
                    * model.mean_friction_n(d.direction, z * 1e-3, feed_mm_min_to_m_s(f));
                let rel = (poly.value_n(z * 1e-3) - truth).abs() / truth.abs();
                map_err = map_err.max(rel);
            }
        }
        worst[4] = worst[4].max(map_err);
        let positions: Vec<f64> = (0..5)
            .map(|i| d.start_mm + 2.0 + (d.end_mm - d.start_mm - 4.0) * i as f64 / 4.0)
            .collect();
        let prof = stribeck_profile(d, &positions, &params).unwrap();
        for p in &prof.positions {
            let fit = p.fit.as_ref().unwrap();
            let fc_true = model.mean_level_n(d.direction, p.position_mm * 1e-3);
            let e = [
                (fit.params.fc_n - fc_true).abs() / fc_true,
                (fit.params.static_excess_n() - FS_MINUS_FC).abs() / FS_MINUS_FC,
                (fit.params.sigma_n_s_per_m - SIGMA).abs() / SIGMA,
                (fit.vs_mm_min() - VS_MM_MIN).abs() / VS_MM_MIN,
            ];
            eprintln!(
                "{:?} z = {:.1} mm: Fc {:.2} (truth {:.2}), Fs-Fc {:.2}, sigma {:.0}, vs {:.2}; \
                 rel. errors {:.4?}",
                d.direction,
                p.position_mm,
                fit.params.fc_n,
                fc_true,
                fit.params.static_excess_n(),
                fit.params.sigma_n_s_per_m,
                fit.vs_mm_min(),
                e
            );
            for k in 0..4 {
                worst[k] = worst[k].max(e[k]);
            }
            assert!(p.nonconventional.as_ref().unwrap().ranges.is_empty());
        }
    }
    eprintln!(
        "worst relative errors: Fc {:.4}, Fs-Fc {:.4}, sigma {:.4}, vs {:.4}, map {:.4}; \
         simulate+estimate {:.2?}, total {:.2?}",
        worst[0],
        worst[1],
        worst[2],
        worst[3],
        worst[4],
        t1,
        t0.elapsed()
    );
    assert!(worst[0] < 0.02, "Fc");
    assert!(worst[1] < 0.10, "Fs - Fc");
    assert!(worst[2] < 0.05, "sigma");
    assert!(worst[3] < 0.10, "vs");
    assert!(worst[4] < 0.04, "map");
    let _ = Direction::Forward;
}

/// Through files: an index with relative paths, one malformed trace and one missing file. The
/// two failures are reported by name and the other runs still map; identical simulations
/// (same seed) give repeats whose PPOCM equals each of them.
#[test]
fn failed_runs_are_named_and_the_rest_map_from_files() {
    use feedscope_io::test_set::{estimate_set, read_index};
    use feedscope_io::trace::{write_csv, Layout, ReadOptions};
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("traces")).unwrap();
    let mut index = String::from("file,feed_mm_min,repeat,comment\n");
    let mut axis = None;
    for f in [16.0, 90.0, 505.0] {
        // Same seed for both repeats: identical traces.
        let out = run(&config(f, 7));
        for r in 1..=2 {
            let name = format!("traces/f{f}_r{r}.csv");
            write_csv(
                &out.trace,
                std::fs::File::create(dir.path().join(&name)).unwrap(),
                Layout::Long,
            )
            .unwrap();
            index.push_str(&format!("{name},{f},{r},ok\n"));
        }
        axis = Some(out.truth.axis);
    }
    std::fs::write(
        dir.path().join("traces/broken.csv"),
        "time_s,channel,value\n0,position_mm,1\n0.1,position_mm,oops\n",
    )
    .unwrap();
    index.push_str("traces/broken.csv,90,3,malformed\ntraces/gone.csv,505,3,missing\n");
    let index_path = dir.path().join("index.csv");
    std::fs::write(&index_path, index).unwrap();
    let axis = axis.unwrap();

    let set = read_index(&index_path).unwrap();
    assert_eq!(set.runs.len(), 8);
    let est = estimate_set(
        &set,
        &axis,
        &EstimateParams::default(),
        &ReadOptions::default(),
        MapParams::default().stroke_feed_tolerance,
        &|_| {},
    );
    let failed: Vec<&str> = est.failed.iter().map(|f| f.run.name.as_str()).collect();
    assert_eq!(failed, ["traces/broken.csv", "traces/gone.csv"]);
    assert!(
        est.failed[0].error.contains("broken.csv"),
        "{}",
        est.failed[0].error
    );
    assert!(
        est.failed[1].error.contains("gone.csv"),
        "{}",
        est.failed[1].error
    );
    assert_eq!(est.ok.len(), 6);
    let map = build_map(&est.ok, axis.lead_m(), &MapParams::default()).unwrap();
    for d in &map.directions {
        assert_eq!(d.feeds.len(), 3);
        // Three feeds: feed polynomial of order 3 − 2 = 1.
        assert_eq!(d.feed_model.order, 1);
        for g in &d.feeds {
            assert_eq!(g.repeats.len(), 2);
            for r in &g.repeats {
                for (a, b) in r
                    .poly
                    .coeffs_n
                    .iter()
                    .flatten()
                    .zip(g.ppocm.coeffs_n.iter().flatten())
                {
                    // Identical data: the mean of two equal numbers is exact to one rounding.
                    assert!((a - b).abs() <= 1e-12 * b.abs().max(1.0));
                }
            }
            assert!(g.repeatability.iter().all(|r| r.max_spread_n < 1e-9));
        }
    }
}
