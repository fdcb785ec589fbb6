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

/// The component amplitudes of a test history: `amps` (direction, cause, amplitude N), each
/// test scattered by U(−4 %, +4 %) and an estimation error N(0, 0.15 N) (the standard error
/// stored with it), `growth(k, i)` the factor of amplitude `i` at test `k` (0-based).
fn component_series(
    amps: &[(&str, &str, f64)],
    seed: u64,
    tests: usize,
    growth: impl Fn(usize, usize) -> f64,
) -> BTreeMap<String, IndicatorSeries> {
    let mut rng = StdRng::seed_from_u64(seed);
    let e = Normal::new(0.0, 0.15).unwrap();
    let mut series: BTreeMap<String, IndicatorSeries> = BTreeMap::new();
    for k in 0..tests {
        for (i, (dir, cause, a)) in amps.iter().enumerate() {
            let v = a * growth(k, i) * (1.0 + rng.random_range(-0.04..0.04)) + e.sample(&mut rng);
            series
                .entry(format!("amplitude_n/{dir}/{cause}"))
                .or_default()
                .push((
                    k as i64 + 1,
                    Point {
                        time_s: k as f64 * 30.0 * DAY_S,
                        value: v,
                        std_error: Some(0.15),
                    },
                ));
        }
    }
    series
}

/// The first `n` tests of every series.
fn first_tests(
    series: &BTreeMap<String, IndicatorSeries>,
    n: usize,
) -> BTreeMap<String, IndicatorSeries> {
    series
        .iter()
        .map(|(k, v)| (k.clone(), v[..n].to_vec()))
        .collect()
}

const SCREW_COMPONENTS: [(&str, &str, f64); 8] = [
    ("forward", "shaft 1x", 8.0),
    ("backward", "shaft 1x", 18.0),
    ("forward", "shaft 2x", 7.0),
    ("backward", "shaft 2x", 1.5),
    ("forward", "nut ball refeed 1x", 5.0),
    ("backward", "nut ball refeed 1x", 3.0),
    ("forward", "guide ball refeed 1x", 4.0),
    ("backward", "guide ball refeed 2x", 2.0),
];

/// Component amplitudes of an unchanged screw (±4 % between tests, an estimation error of
/// 0.15 N on top, which weighs most at low amplitude) over 30 seeded histories of 12 tests,
/// judged after every test from the 6th as `history trend` would: no component is out of
/// limits or drifting, and no diagnosis sentence speaks of components. Each amplitude's σ is
/// floored at √(SE² + (3 % μ₀)²), the 8 amplitudes are judged as a family (0.1 % false
/// alarms per test for the axis: L = 3.84 instead of 3) and the limits hold the baseline
/// mean's own error (×√(1 + 1/5) for Shewhart, + 1/5 in the EWMA variance, CUSUM not
/// alarming). With independent ±3σ bands and the CUSUM, 10-test histories of 6 amplitudes
/// gave 2 out-of-limits in 720 judgements; these 12-test histories with a family rate of
/// 0.27 % and without the baseline-mean terms gave 1 out-of-limits and 16 drifting in 1680.
#[test]
fn unchanged_component_amplitudes_stay_in_limits() {
    let (mut out_of_limits, mut drifting, mut judged, mut told) = (0, 0, 0, 0);
    for seed in 0..30u64 {
        let series = component_series(&SCREW_COMPONENTS, 3000 + seed, 12, |_, _| 1.0);
        for n in 6..=12 {
            let s = axis_study(&first_tests(&series, n), None, &[], &Default::default()).unwrap();
            for t in &s.trends {
                judged += 1;
                match t.status {
                    feedscope::history::Status::OutOfLimits => out_of_limits += 1,
                    feedscope::history::Status::Drifting => drifting += 1,
                    _ => {}
                }
            }
            told += s
                .diagnosis
                .iter()
                .filter(|d| d.contains("omponent") || d.contains("preload"))
                .count();
        }
    }
    eprintln!(
        "component amplitudes: {out_of_limits} out of limits, {drifting} drifting of {judged} \
         judgements; {told} diagnosis sentences"
    );
    assert_eq!(judged, 30 * 7 * SCREW_COMPONENTS.len());
    assert_eq!((out_of_limits, drifting, told), (0, 0, 0));
}

/// A screw whose forward shaft 1x component grows 10 % a test from the 6th (pitch-error
/// wear), the others unchanged: flagged by the 3rd test of growth (test 8, +30 %, about 8σ of
/// its scatter; measured: test 6 in 3, test 7 in 16, test 8 in 1 of 20 seeded histories),
/// named in the diagnosis as a shaft component, and no other component flagged.
#[test]
fn growing_shaft_component_is_flagged_alone() {
    let mut first_flags = Vec::new();
    for seed in 0..20u64 {
        let series = component_series(&SCREW_COMPONENTS, 4000 + seed, 12, |k, i| {
            if i == 0 && k >= 5 {
                1.0 + 0.10 * (k - 4) as f64
            } else {
                1.0
            }
        });
        let mut first = None;
        for n in 6..=12 {
            let s = axis_study(&first_tests(&series, n), None, &[], &Default::default()).unwrap();
            for t in &s.trends {
                let name = t.indicator.name();
                let flagged = t.status != feedscope::history::Status::Ok;
                if name == "amplitude_n/forward/shaft 1x" {
                    if flagged && first.is_none() {
                        first = Some(n);
                        assert!(
                            s.diagnosis.iter().any(|d| d.contains("shaft revolution")),
                            "{:?}",
                            s.diagnosis
                        );
                    }
                } else {
                    assert!(
                        !flagged,
                        "seed {seed}, {n} tests: {name} {:?} z {} base {:?} points {:?}",
                        t.status,
                        t.change_sigma,
                        t.baseline,
                        t.points.iter().map(|p| p.value).collect::<Vec<_>>()
                    );
                }
            }
        }
        first_flags.push(first.unwrap_or(usize::MAX));
    }
    eprintln!("first flag (test number) of a shaft component growing 10 %/test from test 6: {first_flags:?}");
    assert!(first_flags.iter().all(|&f| f <= 8), "{first_flags:?}");
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
