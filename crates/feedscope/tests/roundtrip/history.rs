//! Issue 11 proof: local wear and lubrication stories on the twin, and false alarms of
//! unchanged histories.
//!
//! The twin here is not the papers' machine: lead 8 mm, table 180 kg, strokes 4 → 92 → 4 mm
//! at 20 mm/min, asynchronous polling every 40 ms (position and effort). Between tests the
//! whole friction level scatters by a factor N(1, 0.4 %) and every component amplitude by
//! U(−4 %, +4 %) (seeded). The wear: a Gaussian bump of σ_w = 6 mm at 56 mm forward and
//! backward, from the third test growing by 4 N a test. The lubrication: from the third test
//! the Stribeck excess grows 7 % and the viscous coefficient 4 % a test (the whole travel).
//!
//! One story goes through the real path (simulate → stroke test → profile comparison); the
//! false-alarm count and the lubrication story use the friction truth sampled on the estimate's
//! grid with white noise (the estimator is not what they test).
use std::collections::BTreeMap;

use feedscope::history::{
    profile_changes, Extent, GridBuilder, GridProfile, LocalParams, Point, ProfileChanges,
    ProfileTest,
};
use feedscope::sim::{
    Bump, DynamicsMode, FrictionModel, FrictionParams, SamplingMode, SimConfig, StrokeConfig,
};
use feedscope::stroke::Direction;
use feedscope::study::{axis_study, stroke_test, IndicatorSeries, StrokeStudyParams};
use rand::{rngs::StdRng, Rng, SeedableRng};
use rand_distr::{Distribution, Normal};

const LEAD_MM: f64 = 8.0;
const FEED_MM_MIN: f64 = 20.0;
const FROM_MM: f64 = 4.0;
const TO_MM: f64 = 92.0;
const WEAR_AT_MM: f64 = 56.0;
const WEAR_WIDTH_MM: f64 = 6.0;
const WEAR_PER_TEST_N: f64 = 4.0;
const DAY_S: f64 = 86_400.0;

/// The twin's axis and sampling (not the papers': see the module docs).
fn machine(seed: u64) -> SimConfig {
    let mut c = SimConfig {
        seed,
        ..SimConfig::default()
    };
    c.axis.name = Some("twin X".into());
    c.axis.lead_mm = LEAD_MM;
    c.axis.table_mass_kg = 180.0;
    c.axis.inertia_kgm2 = 0.0015;
    c.axis.screw_diameter_mm = Some(32.0);
    c.axis.screw_ball_diameter_mm = Some(4.763);
    c.axis.screw_balls_per_turn = Some(16.0);
    c.dynamics.mode = DynamicsMode::Ideal;
    c.sampling.mode = SamplingMode::Asynchronous;
    c.sampling.position.interval_ms = 40.0;
    c.sampling.position.jitter_ms = 1.0;
    c.sampling.effort.interval_ms = 40.0;
    c.sampling.effort.jitter_ms = 1.0;
    c.sampling.effort.start_offset_ms = 20.0;
    c.motion.start_mm = FROM_MM;
    c.motion.strokes = vec![
        StrokeConfig {
            to_mm: TO_MM,
            feed_mm_min: FEED_MM_MIN,
            dwell_s: 1.0,
        },
        StrokeConfig {
            to_mm: FROM_MM,
            feed_mm_min: FEED_MM_MIN,
            dwell_s: 0.0,
        },
    ];
    c
}

#[derive(Clone, Copy)]
enum Story {
    Unchanged,
    Wear,
    Lubrication,
}

/// The friction of test `k` (0-based) of a history: the scatter between tests, and the story's
/// change from the third test on.
fn friction(cfg: &SimConfig, story: Story, seed: u64, k: usize) -> FrictionParams {
    let mut f = FrictionParams::default_for(&cfg.axis);
    let mut rng = StdRng::seed_from_u64(seed.wrapping_mul(7919).wrapping_add(k as u64));
    let level = 1.0 + 0.004 * Normal::new(0.0, 1.0).unwrap().sample(&mut rng);
    for l in [&mut f.forward, &mut f.backward] {
        l.offset_n *= level;
        l.trend_n_per_mm *= level;
        for b in &mut l.bumps {
            b.height_n *= level;
        }
    }
    for c in &mut f.components {
        c.amplitude_n *= 1.0 + rng.random_range(-0.04..0.04);
    }
    let grown = k.saturating_sub(1) as f64;
    match story {
        Story::Unchanged => {}
        Story::Wear => {
            for l in [&mut f.forward, &mut f.backward] {
                l.bumps.push(Bump {
                    center_mm: WEAR_AT_MM,
                    width_mm: WEAR_WIDTH_MM,
                    height_n: WEAR_PER_TEST_N * grown,
                });
            }
        }
        Story::Lubrication => {
            f.velocity.static_excess_n *= 1.0 + 0.07 * grown;
            f.velocity.viscous_n_s_per_m *= 1.0 + 0.04 * grown;
        }
    }
    f
}

/// Estimate-level profiles of one test: the truth at the estimate's grid (lead/1024) with
/// white noise of 3 N per point (the estimate's scatter on this twin is of that order),
/// half a lead left out at the stroke ends as the stroke test does.
fn truth_profiles(cfg: &SimConfig, f: FrictionParams, seed: u64) -> Vec<GridProfile> {
    let model = FrictionModel::new(LEAD_MM, f);
    let mut rng = StdRng::seed_from_u64(seed);
    let noise = Normal::new(0.0, 3.0).unwrap();
    let v = FEED_MM_MIN / 60_000.0;
    let n = ((TO_MM - FROM_MM) / LEAD_MM * 1024.0) as usize;
    let z: Vec<f64> = (0..=n)
        .map(|i| (FROM_MM + i as f64 * LEAD_MM / 1024.0) * 1e-3)
        .collect();
    [(Direction::Forward, v), (Direction::Backward, -v)]
        .into_iter()
        .filter_map(|(d, v)| {
            let fr: Vec<f64> = z
                .iter()
                .map(|&z| model.friction_n(z, v) + noise.sample(&mut rng))
                .collect();
            let mut g = GridBuilder::new(d, cfg.axis.lead_mm, 8);
            g.add_stroke(&z, &fr, 0.5 * LEAD_MM);
            g.finish()
        })
        .collect()
}

fn truth_history(story: Story, seed: u64, tests: usize) -> Vec<ProfileTest> {
    let cfg = machine(seed);
    (0..tests)
        .map(|k| ProfileTest {
            test_id: k as i64 + 1,
            time_s: k as f64 * 30.0 * DAY_S,
            profiles: truth_profiles(&cfg, friction(&cfg, story, seed, k), seed * 1000 + k as u64),
        })
        .collect()
}

/// A first flag: the test (1-based), its peak (mm) and extent.
type FirstFlag = Option<(i64, f64, Extent)>;

/// First test (1-based) with a flagged local range, its peak and extent, per direction.
fn first_local(c: &ProfileChanges) -> Vec<(Direction, FirstFlag)> {
    c.directions
        .iter()
        .map(|d| {
            let f = d.tests.iter().find(|t| !t.ranges.is_empty()).map(|t| {
                let r = &t.ranges[0];
                (t.test_id, r.peak_mm, r.extent)
            });
            (d.direction, f)
        })
        .collect()
}

/// Real path: simulate → stroke test (estimate, IAFV, grid) → profile comparison.
#[test]
fn local_wear_through_the_twin_is_flagged_where_and_when_it_grows() {
    let seed = 11;
    let mut tests = Vec::new();
    for k in 0..5 {
        let mut cfg = machine(seed * 100 + k as u64);
        cfg.friction = Some(friction(&cfg, Story::Wear, seed, k));
        let out = feedscope::sim::simulate(&cfg, &mut |_| {}).expect("simulation");
        let st = stroke_test(&out.trace, &out.truth.axis, &StrokeStudyParams::default())
            .expect("stroke test");
        assert_eq!(st.curves.grid.len(), 2, "both directions gridded");
        tests.push(ProfileTest {
            test_id: k as i64 + 1,
            time_s: k as f64 * 30.0 * DAY_S,
            profiles: st.curves.grid,
        });
    }
    let c = profile_changes(&tests, None, &LocalParams::default()).unwrap();
    for d in &c.directions {
        let mut lim = d.limit_n.clone();
        lim.sort_by(f64::total_cmp);
        eprintln!(
            "{:?}: pooled σ {:.3} N, median limit {:.2} N, level σ {:.3} %",
            d.direction,
            d.pooled_sigma_n,
            lim[lim.len() / 2],
            100.0 * d.level_sigma
        );
        for t in &d.tests {
            eprintln!(
                "  test {}: level {:+.2} % {:?}",
                t.test_id,
                t.level_percent,
                t.ranges
                    .iter()
                    .map(|r| (r.start_mm, r.end_mm, r.peak_mm, r.height_n))
                    .collect::<Vec<_>>()
            );
        }
    }
    assert_eq!(c.directions.len(), 2);
    for d in &c.directions {
        // The limit at the wear's position decides when it must be seen: a bump of σ_w = 6 mm
        // keeps ≥ 97 % of its height after smoothing over 8 mm.
        let at = d
            .position_mm
            .iter()
            .position(|&x| (x - WEAR_AT_MM).abs() < 0.5)
            .unwrap();
        let limit = d.limit_n[at];
        let first = d
            .tests
            .iter()
            .find(|t| !t.ranges.is_empty())
            .unwrap_or_else(|| panic!("{:?}: wear not flagged", d.direction));
        let height = WEAR_PER_TEST_N * (first.test_id - 2) as f64;
        assert!(height > 0.8 * limit, "flagged before it exceeded the limit");
        let earlier = WEAR_PER_TEST_N * (first.test_id - 3) as f64;
        assert!(
            earlier < 1.2 * limit,
            "{:?}: {earlier} N exceeded the limit {limit} N in test {} unflagged",
            d.direction,
            first.test_id - 1
        );
        assert_eq!(first.test_id, 3, "{:?}: limit {limit} N", d.direction);
        for t in d.tests.iter().filter(|t| !t.in_baseline) {
            assert!(!t.level_flagged, "{:?} test {}", d.direction, t.test_id);
            for r in &t.ranges {
                assert_eq!(r.extent, Extent::Local, "{r:?}");
                assert!(
                    (r.peak_mm - WEAR_AT_MM).abs() <= LEAD_MM,
                    "{:?} test {}: {r:?}",
                    d.direction,
                    t.test_id
                );
            }
        }
    }
}

/// 24 seeded unchanged histories of 10 tests: no flag at any position or level.
#[test]
fn unchanged_histories_raise_no_profile_flag() {
    let mut flagged = 0;
    let mut compared = 0;
    for seed in 0..24 {
        let h = truth_history(Story::Unchanged, 500 + seed, 10);
        let c = profile_changes(&h, None, &LocalParams::default()).unwrap();
        for d in &c.directions {
            compared += d.tests.iter().filter(|t| !t.in_baseline).count();
            flagged += d.first_flag.is_some() as usize;
        }
    }
    eprintln!("false alarms: {flagged} of 48 direction histories ({compared} tests compared)");
    assert_eq!(compared, 24 * 2 * 8);
    assert_eq!(flagged, 0);
}

/// The wear story at estimate level over several seeds: first flag in test 3 at 56 ± 8 mm.
#[test]
fn wear_story_first_flag_test_and_position() {
    for seed in 0..6 {
        let h = truth_history(Story::Wear, 900 + seed, 10);
        let c = profile_changes(&h, None, &LocalParams::default()).unwrap();
        for (dir, f) in first_local(&c) {
            let (test, peak, extent) = f.unwrap_or_else(|| panic!("seed {seed} {dir:?}"));
            assert_eq!(test, 3, "seed {seed} {dir:?}");
            assert!((peak - WEAR_AT_MM).abs() <= LEAD_MM, "{peak}");
            assert_eq!(extent, Extent::Local);
        }
    }
}

/// Lubrication degrading everywhere, with the triangle tests' Fs and σ rising: the diagnosis
/// calls it lubrication along the whole travel, never local wear.
#[test]
fn lubrication_story_is_called_lubrication_not_local_wear() {
    let seed = 77;
    let n = 12;
    let profiles = truth_history(Story::Lubrication, seed, n);
    let cfg = machine(seed);
    let mut series: BTreeMap<String, IndicatorSeries> = BTreeMap::new();
    let mut rng = StdRng::seed_from_u64(seed);
    let e = Normal::new(0.0, 1.0).unwrap();
    for (k, p) in profiles.iter().enumerate() {
        let f = friction(&cfg, Story::Lubrication, seed, k);
        let pt = |v: f64, se: f64| Point {
            time_s: p.time_s,
            value: v,
            std_error: Some(se),
        };
        // Fs = Coulomb level + Stribeck excess, σ as simulated, each with an identification
        // error of about 0.5 %
        let fs = 275.0 + f.velocity.static_excess_n;
        let sg = f.velocity.viscous_n_s_per_m;
        series.entry("fs_n".into()).or_default().push((
            p.test_id,
            pt(fs * (1.0 + 0.005 * e.sample(&mut rng)), 0.005 * fs),
        ));
        series.entry("sigma_n_s_per_m".into()).or_default().push((
            p.test_id,
            pt(sg * (1.0 + 0.005 * e.sample(&mut rng)), 0.005 * sg),
        ));
    }
    let study = axis_study(&series, None, &profiles, &Default::default()).unwrap();
    let text = study.diagnosis.join("\n");
    eprintln!("{text}");
    let c = study.profiles.as_ref().unwrap();
    for d in &c.directions {
        assert!(
            d.tests.iter().all(|t| t.ranges.is_empty()),
            "{:?}: {:?}",
            d.direction,
            d.tests.iter().map(|t| &t.ranges).collect::<Vec<_>>()
        );
        assert!(d.tests.last().unwrap().level_flagged);
    }
    assert!(text.contains("degrading lubrication"), "{text}");
    assert!(text.contains("along the whole travel"), "{text}");
    assert!(!text.contains("Local wear"), "{text}");
}

/// Component amplitudes of an unchanged screw (the twin's scatter: ±4 % between tests, and an
/// estimation error of 0.15 N on top, which weighs most at low amplitude) over 24 seeded
/// histories of 10 tests: judged after every test as `history trend` would, `out of limits`
/// stays at the nominal rate of a ±3σ band whose σ is the amplitudes' true scatter (0.27 % of
/// judgements for Gaussian errors; measured: 2 of 720), not the systematic alarms of a 1 %
/// floor; drifting signals (EWMA, CUSUM) are bounded too.
#[test]
fn unchanged_component_amplitudes_stay_in_limits() {
    let amps = [
        ("forward", "shaft 1x", 8.0),
        ("backward", "shaft 1x", 18.0),
        ("forward", "shaft 2x", 7.0),
        ("forward", "nut ball refeed 1x", 5.0),
        ("forward", "guide ball refeed 1x", 4.0),
        ("backward", "guide ball refeed 2x", 2.0),
    ];
    let (mut out_of_limits, mut drifting, mut judged) = (0, 0, 0);
    for seed in 0..24u64 {
        let mut rng = StdRng::seed_from_u64(3000 + seed);
        let e = Normal::new(0.0, 0.15).unwrap();
        let mut series: BTreeMap<String, IndicatorSeries> = BTreeMap::new();
        for k in 0..10 {
            for (dir, cause, a) in amps {
                let v = a * (1.0 + rng.random_range(-0.04..0.04)) + e.sample(&mut rng);
                series
                    .entry(format!("amplitude_n/{dir}/{cause}"))
                    .or_default()
                    .push((
                        k + 1,
                        Point {
                            time_s: k as f64 * 30.0 * DAY_S,
                            value: v,
                            std_error: Some(0.15),
                        },
                    ));
            }
        }
        for n in 6..=10 {
            let prefix: BTreeMap<String, IndicatorSeries> = series
                .iter()
                .map(|(k, v)| (k.clone(), v[..n].to_vec()))
                .collect();
            let s = axis_study(&prefix, None, &[], &Default::default()).unwrap();
            for t in &s.trends {
                judged += 1;
                match t.status {
                    feedscope::history::Status::OutOfLimits => out_of_limits += 1,
                    feedscope::history::Status::Drifting => drifting += 1,
                    _ => {}
                }
            }
        }
    }
    eprintln!(
        "component amplitudes: {out_of_limits} out of limits, {drifting} drifting of {judged} \
         judgements"
    );
    assert_eq!(judged, 24 * 5 * amps.len());
    // ≤ 0.5 %: twice the nominal 0.27 % of a ±3σ band, the slack for σ's own estimate
    assert!(out_of_limits * 200 <= judged, "{out_of_limits} of {judged}");
    // EWMA and CUSUM are meant to be sensitive; on unchanged data they may still signal
    // rarely: at most 1 % of the judgements.
    assert!(drifting * 100 <= judged, "{drifting} of {judged}");
}

/// A heavier fixture from test 6 (J +8 %), friction unchanged: the diagnosis names the mass
/// change and finds neither local wear nor lubrication.
#[test]
fn mass_change_is_told_apart_from_wear_and_lubrication() {
    let seed = 41;
    let profiles = truth_history(Story::Unchanged, seed, 10);
    let mut rng = StdRng::seed_from_u64(seed);
    let e = Normal::new(0.0, 1.0).unwrap();
    let mut series: BTreeMap<String, IndicatorSeries> = BTreeMap::new();
    for (k, p) in profiles.iter().enumerate() {
        let j = 2.1e-3 * if k >= 5 { 1.08 } else { 1.0 };
        let mut pt = |v: f64, rel: f64| Point {
            time_s: p.time_s,
            value: v * (1.0 + rel * e.sample(&mut rng)),
            std_error: Some(rel * v),
        };
        let (jv, fs, sg) = (pt(j, 0.002), pt(350.0, 0.005), pt(2000.0, 0.005));
        for (name, v) in [("j_total_kgm2", jv), ("fs_n", fs), ("sigma_n_s_per_m", sg)] {
            series.entry(name.into()).or_default().push((p.test_id, v));
        }
    }
    let study = axis_study(&series, None, &profiles, &Default::default()).unwrap();
    let text = study.diagnosis.join("\n");
    eprintln!("{text}");
    assert!(text.contains("inertia J has changed"), "{text}");
    assert!(text.contains("no evidence of local wear"), "{text}");
    assert!(
        !text.contains("Local wear") && !text.contains("lubrication"),
        "{text}"
    );
}
