//! Position-resolved change detection: where along the travel the friction of a stroke test
//! has left its baseline, by how much, and whether the change is local or along the whole
//! travel.
//!
//! The interval means of the stroke test (50 mm by default) dilute a narrow change and the
//! IAFV smears it; this detector compares each test's friction with the baseline point by
//! point on a common position grid instead.
//!
//! # The rule
//! For each direction, on a grid of [`GridProfile::step_mm`] (lead/8 by default):
//!
//! 1. s_k(x): test k's friction magnitude |F_f| (N), averaged over its strokes in each grid
//!    cell, then smoothed by a centred moving average over one lead (trapezoidal weights over
//!    lead/step + 1 nodes, so every component of integer order — shaft orders — averages out
//!    exactly).
//! 2. m(x): the baseline profile, the mean of s_b over the baseline tests b (by default the
//!    first 2 stroke tests), or the reference test's s when one is marked.
//! 3. d_k(x) = s_k(x) − m(x); its part common to the whole travel is the robust straight-line
//!    fit a_k + b_k·(m(x) − m̄) (least squares, then again without points beyond 3 robust σ):
//!    an additive shift (lubrication adds the same Stribeck and viscous force everywhere) and
//!    a proportional one (test-to-test level scatter). The local change is
//!    r_k(x) = d_k(x) − a_k − b_k·(m(x) − m̄); the whole-travel change is a_k (N) or
//!    100·a_k/m̄ (%).
//! 4. The baseline's own scatter: the same residuals r_b of the baseline tests about their
//!    own mean give σ_pool = 1.4826·median|r_b(x)|·√(n/(n − 1)) over all baseline tests and
//!    positions; with 3 baseline tests or more also a per-position σ(x) = RMS over ±2 leads of
//!    √(Σ_b r_b(x)²/(n − 1)). σ(x) = max(σ_pool, σ_local(x), 0.1 %·m̄).
//! 5. A position is flagged when |r_k(x)| > K·σ(x)·√(1 + 1/n_m) (K = 6; n_m tests make m, so
//!    the difference of one test from m has that much more variance). Flagged positions of
//!    one sign less than one lead apart form one range; a range covering at least half of the
//!    compared travel is a change of shape [`Extent::WholeTravel`], else [`Extent::Local`].
//! 6. The whole-travel change is flagged when |a_k/m̄| > K_level·σ_a·√(1 + 1/n_m), with σ_a
//!    the sample standard deviation of a_b/m̄ of the baseline tests, floored at 0.5 %
//!    (K_level = 4).
//!
//! A position is compared only where the baseline tests all have data; the first and last
//! half lead of each stroke are not gridded (acceleration transients), and the smoothing
//! takes another half lead at each end.
//!
//! # Limits
//! With 2 baseline tests σ has about (travel/lead) degrees of freedom (pooled over the
//! travel), not per position; a position whose scatter is larger than elsewhere is then not
//! known to be. A change narrower than one lead is diluted by the smoothing (a Gaussian of
//! σ_w keeps about σ_w·√(2π)/lead of its height when σ_w ≪ lead). A change along the whole
//! travel that is exactly proportional to the baseline profile is read as level, not shape.
//!
//! # Reference
//! Paper 000 Section 4.1: friction along the travel, its mean (IAFV) and position-dependent
//! causes (non-uniform pitch error, misalignment).
//!
//! ```
//! use feedscope::history::{profile_changes, GridBuilder, LocalParams, ProfileTest, Extent};
//! use feedscope::stroke::Direction;
//! // 6 tests, 0-200 mm, lead 5 mm; from test 3 a 10 mm-wide bump at 120 mm, +5 N a test
//! let tests: Vec<ProfileTest> = (0..6)
//!     .map(|k| {
//!         let mut g = GridBuilder::new(Direction::Forward, 5.0, 8);
//!         let z: Vec<f64> = (0..4000).map(|i| i as f64 * 0.05e-3).collect();
//!         let f: Vec<f64> = z
//!             .iter()
//!             .enumerate()
//!             .map(|(i, &z)| {
//!                 let x = z * 1e3;
//!                 let bump = 5.0 * (k as f64 - 1.0).max(0.0) * (-0.5 * ((x - 120.0) / 10.0).powi(2)).exp();
//!                 let noise = 0.3 * (((i * 7919 + k * 104_729) % 1000) as f64 / 500.0 - 1.0);
//!                 300.0 + 0.1 * x + bump + noise
//!             })
//!             .collect();
//!         g.add_stroke(&z, &f, 2.5);
//!         ProfileTest { test_id: k as i64 + 1, time_s: k as f64, profiles: vec![g.finish().unwrap()] }
//!     })
//!     .collect();
//! let c = profile_changes(&tests, None, &LocalParams::default()).unwrap();
//! let fwd = &c.directions[0];
//! let first = fwd.first_flag.unwrap();
//! assert_eq!(fwd.tests[first].test_id, 3);
//! let r = &fwd.tests[first].ranges[0];
//! assert_eq!(r.extent, Extent::Local);
//! assert!((r.peak_mm - 120.0).abs() <= 5.0, "{}", r.peak_mm);
//! ```
use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::HistoryError;
use crate::stroke::Direction;

/// Normal-consistency factor of the median absolute deviation: σ = 1.4826·MAD for Gaussian
/// data.
const MAD_TO_SIGMA: f64 = 1.4826;

/// One test's friction magnitude along the travel of one direction, on a grid of fixed step
/// aligned at 0 mm: value k sits at (`first_node` + k)·`step_mm`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GridProfile {
    /// Direction of the strokes.
    pub direction: Direction,
    /// Screw lead (mm): the smoothing window of the detector.
    pub lead_mm: f64,
    /// Grid step (mm).
    pub step_mm: f64,
    /// Index of the first node (position = index·`step_mm`).
    pub first_node: i64,
    /// Mean |friction| of the strokes in the cell of each node (N); `None` where no sample
    /// fell.
    pub friction_n: Vec<Option<f64>>,
}

impl GridProfile {
    /// Position of value `k` (mm).
    pub fn position_mm(&self, k: usize) -> f64 {
        (self.first_node + k as i64) as f64 * self.step_mm
    }
}

/// Accumulates the strokes of one direction of one test into a [`GridProfile`].
#[derive(Debug, Clone)]
pub struct GridBuilder {
    direction: Direction,
    lead_mm: f64,
    step_mm: f64,
    /// node → (Σ |F|, samples)
    cells: BTreeMap<i64, (f64, usize)>,
}

impl GridBuilder {
    /// A grid of `cells_per_lead` cells per lead (step = lead/`cells_per_lead`).
    ///
    /// # Panics
    /// When `lead_mm` is not a positive finite length or `cells_per_lead` is 0 (the axis file
    /// and the defaults are validated before).
    pub fn new(direction: Direction, lead_mm: f64, cells_per_lead: u32) -> Self {
        assert!(lead_mm.is_finite() && lead_mm > 0.0 && cells_per_lead > 0);
        Self {
            direction,
            lead_mm,
            step_mm: lead_mm / f64::from(cells_per_lead),
            cells: BTreeMap::new(),
        }
    }

    /// Add one stroke: positions (m) and signed friction (N) of its samples; samples within
    /// `end_margin_mm` of either end of the stroke are left out (acceleration transients).
    pub fn add_stroke(&mut self, position_m: &[f64], friction_n: &[f64], end_margin_mm: f64) {
        let (lo, hi) = position_m
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &z| {
                (a.min(z), b.max(z))
            });
        let (lo, hi) = (lo * 1e3 + end_margin_mm, hi * 1e3 - end_margin_mm);
        for (&z, &f) in position_m.iter().zip(friction_n) {
            let x = z * 1e3;
            if !(x >= lo && x <= hi && f.is_finite()) {
                continue;
            }
            let c = self
                .cells
                .entry((x / self.step_mm).round() as i64)
                .or_default();
            c.0 += f.abs();
            c.1 += 1;
        }
    }

    /// The profile, or `None` when no sample was added.
    pub fn finish(self) -> Option<GridProfile> {
        let (&a, _) = self.cells.first_key_value()?;
        let (&b, _) = self.cells.last_key_value()?;
        let friction_n = (a..=b)
            .map(|k| self.cells.get(&k).map(|&(s, n)| s / n as f64))
            .collect();
        Some(GridProfile {
            direction: self.direction,
            lead_mm: self.lead_mm,
            step_mm: self.step_mm,
            first_node: a,
            friction_n,
        })
    }
}

/// The grid profiles of one stroke test.
#[derive(Debug, Clone, PartialEq)]
pub struct ProfileTest {
    /// The test's id in its store.
    pub test_id: i64,
    /// Test time (s since the Unix epoch).
    pub time_s: f64,
    /// One per direction (a direction may be missing).
    pub profiles: Vec<GridProfile>,
}

/// Options of [`profile_changes`]; the defaults are the rule in the module docs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LocalParams {
    /// Stroke tests in the baseline (the first N of each direction), ≥ 2. Default 2: the
    /// third test is the first compared, so a change that starts early is not absorbed.
    pub baseline_tests: usize,
    /// Flag width K (σ units). Default 6.
    pub k: f64,
    /// Smoothing window (leads). Default 1.
    pub smoothing_leads: f64,
    /// Half-width of the per-position pooling of σ(x) (leads), used with ≥ 3 baseline tests.
    /// Default 2.
    pub local_window_leads: f64,
    /// Floor of σ(x) relative to the mean baseline level m̄. Default 0.001.
    pub min_relative_std: f64,
    /// Flag width of the whole-travel change (σ units). Default 4.
    pub level_k: f64,
    /// Floor of the whole-travel scatter σ_a relative to m̄. Default 0.005 (0.5 %).
    pub min_level_relative_std: f64,
    /// A range covering at least this fraction of the compared travel is a change of the
    /// whole travel. Default 0.5.
    pub whole_travel_fraction: f64,
    /// Flagged runs of one sign closer than this (leads) are one range. Default 1.
    pub merge_gap_leads: f64,
}

impl Default for LocalParams {
    fn default() -> Self {
        Self {
            baseline_tests: 2,
            k: 6.0,
            smoothing_leads: 1.0,
            local_window_leads: 2.0,
            min_relative_std: 0.001,
            level_k: 4.0,
            min_level_relative_std: 0.005,
            whole_travel_fraction: 0.5,
            merge_gap_leads: 1.0,
        }
    }
}

impl LocalParams {
    fn validate(&self) -> Result<(), HistoryError> {
        let bad = |m: &str| Err(HistoryError::InvalidParams(m.into()));
        if self.baseline_tests < 2 {
            return bad("the profile baseline needs at least 2 tests (their scatter)");
        }
        if !(self.k > 0.0 && self.level_k > 0.0 && self.smoothing_leads > 0.0) {
            return bad("flag widths and the smoothing window must be positive");
        }
        if !(self.local_window_leads >= 0.0
            && self.min_relative_std >= 0.0
            && self.min_level_relative_std >= 0.0
            && self.merge_gap_leads >= 0.0)
        {
            return bad("windows, gaps and σ floors must be ≥ 0");
        }
        if !(self.whole_travel_fraction > 0.0 && self.whole_travel_fraction <= 1.0) {
            return bad("the whole-travel fraction must be in (0, 1]");
        }
        Ok(())
    }
}

/// Whether a flagged range is local or spans the travel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Extent {
    /// Narrower than [`LocalParams::whole_travel_fraction`] of the compared travel.
    Local,
    /// At least that wide: a change of the profile's shape along the travel.
    WholeTravel,
}

/// A flagged position range of one test.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ChangeRange {
    /// First flagged position (mm).
    pub start_mm: f64,
    /// Last flagged position (mm).
    pub end_mm: f64,
    /// Position of the largest |local change| (mm).
    pub peak_mm: f64,
    /// Local change there (N), signed: positive = more friction.
    pub height_n: f64,
    /// The same relative to the baseline profile there (%).
    pub height_percent: f64,
    /// Full width at half height of the local change around the peak (mm).
    pub width_mm: f64,
    /// The height in units of the limit's σ(x)·√(1 + 1/n_m) there.
    pub height_sigma: f64,
    /// Local or along the whole travel.
    pub extent: Extent,
}

/// One test compared with the baseline along the travel of one direction.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TestChange {
    /// The test's id.
    pub test_id: i64,
    /// Test time (s since the Unix epoch).
    pub time_s: f64,
    /// Part of the baseline (or the reference): not flagged.
    pub in_baseline: bool,
    /// d(x) = s(x) − m(x) on [`DirectionChanges::position_mm`] (N); `None` where the test has
    /// no data.
    pub change_n: Vec<Option<f64>>,
    /// The local change r(x) = d(x) minus its whole-travel part (N).
    pub local_n: Vec<Option<f64>>,
    /// Whole-travel change a at the mean level (N).
    pub level_n: f64,
    /// The same relative to m̄ (%).
    pub level_percent: f64,
    /// `true` when the whole-travel change is beyond its limit.
    pub level_flagged: bool,
    /// Flagged ranges of the local change, by position.
    pub ranges: Vec<ChangeRange>,
}

/// The comparison of one direction's tests with their baseline.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DirectionChanges {
    /// Direction.
    pub direction: Direction,
    /// Screw lead (mm).
    pub lead_mm: f64,
    /// Stroke tests with a profile of this direction.
    pub tests_with_profile: usize,
    /// Ids of the tests whose scatter sets σ (the first N).
    pub baseline_ids: Vec<i64>,
    /// Id of the reference test when m(x) is its profile.
    pub reference_id: Option<i64>,
    /// Compared positions (mm): where every baseline test has data.
    pub position_mm: Vec<f64>,
    /// Baseline profile m(x) (N).
    pub baseline_n: Vec<f64>,
    /// σ(x) (N): the per-test scatter at each position after smoothing.
    pub sigma_n: Vec<f64>,
    /// The flag limit K·σ(x)·√(1 + 1/n_m) (N).
    pub limit_n: Vec<f64>,
    /// σ_pool (N).
    pub pooled_sigma_n: f64,
    /// σ_a: scatter of the whole-travel level between baseline tests (fraction of m̄, after
    /// its floor).
    pub level_sigma: f64,
    /// Mean baseline level m̄ (N).
    pub mean_level_n: f64,
    /// Every test of the direction in time order (the baseline ones included).
    pub tests: Vec<TestChange>,
    /// Index in `tests` of the first test with a flagged range or a flagged level.
    pub first_flag: Option<usize>,
}

/// The position-resolved comparison of an axis's stroke tests.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ProfileChanges {
    /// Stroke tests given (with a profile in at least one direction).
    pub tests: usize,
    /// Settings used.
    pub params: LocalParams,
    /// Directions with at least the baseline's tests.
    pub directions: Vec<DirectionChanges>,
    /// Directions with at least one test but not compared, with their number of tests (fewer
    /// than the baseline needs, or a compared span shorter than 3 leads).
    pub not_compared: Vec<(Direction, usize)>,
    /// Tests left out, with the reason (a different grid step than the direction's first).
    pub skipped: Vec<(i64, String)>,
}

/// Compare every stroke test's friction profile with the baseline, position by position (the
/// rule in docs/history.md and in this module's source).
///
/// `tests` in time order; `reference` the id of a test marked as reference, whose profile then
/// is m(x) (the scatter still comes from the first [`LocalParams::baseline_tests`] tests).
/// A direction with fewer tests than the baseline needs is left out of
/// [`ProfileChanges::directions`] (see [`describe_baseline`] for what is known then).
///
/// # Errors
/// [`HistoryError::InvalidParams`] for parameters out of range; [`HistoryError::NotFinite`]
/// for a non-finite friction or time; [`HistoryError::TimeNotIncreasing`].
pub fn profile_changes(
    tests: &[ProfileTest],
    reference: Option<i64>,
    params: &LocalParams,
) -> Result<ProfileChanges, HistoryError> {
    params.validate()?;
    for (i, w) in tests.windows(2).enumerate() {
        if w[1].time_s < w[0].time_s {
            return Err(HistoryError::TimeNotIncreasing { index: i + 1 });
        }
    }
    for t in tests {
        let bad = !t.time_s.is_finite()
            || t.profiles.iter().any(|p| {
                p.friction_n.iter().flatten().any(|f| !f.is_finite())
                    || !(p.step_mm > 0.0 && p.lead_mm > 0.0)
            });
        if bad {
            return Err(HistoryError::NotFinite { time_s: t.time_s });
        }
    }
    let mut out = ProfileChanges {
        tests: tests.iter().filter(|t| !t.profiles.is_empty()).count(),
        params: params.clone(),
        directions: vec![],
        not_compared: vec![],
        skipped: vec![],
    };
    for dir in [Direction::Forward, Direction::Backward] {
        let mut grid: Option<(f64, f64)> = None;
        let mut set: Vec<(&ProfileTest, &GridProfile)> = Vec::new();
        for t in tests {
            let Some(p) = t.profiles.iter().find(|p| p.direction == dir) else {
                continue;
            };
            let (step, lead) = *grid.get_or_insert((p.step_mm, p.lead_mm));
            // Same grid to a part in 10⁹: the step is lead/8 of the same axis file.
            if (p.step_mm - step).abs() > 1e-9 * step || (p.lead_mm - lead).abs() > 1e-9 * lead {
                out.skipped.push((
                    t.test_id,
                    format!(
                        "{} profile on a {} mm grid (lead {} mm), the first test's is {} mm \
                         (lead {} mm)",
                        dir.as_str(),
                        p.step_mm,
                        p.lead_mm,
                        step,
                        lead
                    ),
                ));
                continue;
            }
            set.push((t, p));
        }
        match compare_direction(dir, &set, reference, params) {
            Some(d) => out.directions.push(d),
            None if !set.is_empty() => out.not_compared.push((dir, set.len())),
            None => {}
        }
    }
    Ok(out)
}

fn compare_direction(
    dir: Direction,
    set: &[(&ProfileTest, &GridProfile)],
    reference: Option<i64>,
    params: &LocalParams,
) -> Option<DirectionChanges> {
    let nb = params.baseline_tests;
    if set.len() < nb {
        return None;
    }
    let (step, lead) = (set[0].1.step_mm, set[0].1.lead_mm);
    let per_lead = (lead / step).round().max(1.0) as usize;
    // Common node range of all tests.
    let lo = set.iter().map(|(_, p)| p.first_node).min()?;
    let hi = set
        .iter()
        .map(|(_, p)| p.first_node + p.friction_n.len() as i64 - 1)
        .max()?;
    let len = (hi - lo + 1) as usize;
    let half = ((params.smoothing_leads * per_lead as f64) / 2.0)
        .round()
        .max(1.0) as usize;
    let smoothed: Vec<Vec<Option<f64>>> = set
        .iter()
        .map(|(_, p)| {
            let mut v = vec![None; len];
            let off = (p.first_node - lo) as usize;
            v[off..off + p.friction_n.len()].copy_from_slice(&p.friction_n);
            smooth(&v, half)
        })
        .collect();
    let base: Vec<usize> = (0..nb).collect();
    let ref_idx = reference.and_then(|r| set.iter().position(|(t, _)| t.test_id == r));
    // Compared nodes: every baseline test (and the reference) has a smoothed value.
    let nodes: Vec<usize> = (0..len)
        .filter(|&j| {
            base.iter()
                .chain(ref_idx.iter())
                .all(|&b| smoothed[b][j].is_some())
        })
        .collect();
    if nodes.len() < 3 * per_lead {
        return None;
    }
    // Each test on the compared nodes.
    let cols: Vec<Vec<Option<f64>>> = smoothed
        .iter()
        .map(|v| nodes.iter().map(|&j| v[j]).collect())
        .collect();
    let at = |k: usize| -> &[Option<f64>] { &cols[k] };
    let base_mean: Vec<f64> = (0..nodes.len())
        .map(|i| base.iter().map(|&b| at(b)[i].unwrap_or(0.0)).sum::<f64>() / nb as f64)
        .collect();
    let (m, n_m) = match ref_idx {
        Some(r) => (at(r).iter().map(|x| x.unwrap_or(0.0)).collect(), 1usize),
        None => (base_mean.clone(), nb),
    };
    let mbar = m.iter().sum::<f64>() / m.len() as f64;
    // Scatter of the baseline tests about their own mean, whole-travel part removed.
    let mut resid: Vec<Vec<f64>> = Vec::with_capacity(nb);
    let mut levels = Vec::with_capacity(nb);
    for &b in &base {
        let d: Vec<Option<f64>> = at(b)
            .iter()
            .zip(&base_mean)
            .map(|(s, mb)| s.map(|s| s - mb))
            .collect();
        let (a, r) = split_level(&d, &base_mean);
        levels.push(a / mbar);
        resid.push(r.into_iter().map(|x| x.unwrap_or(0.0)).collect());
    }
    let dof = (nb - 1) as f64;
    let corr = (nb as f64 / dof).sqrt();
    let mut all: Vec<f64> = resid.iter().flatten().map(|x| x.abs()).collect();
    let pooled = MAD_TO_SIGMA * median(&mut all) * corr;
    let floor = params.min_relative_std * mbar.abs();
    let w = (params.local_window_leads * per_lead as f64).round() as usize;
    let var_at: Vec<f64> = (0..nodes.len())
        .map(|i| resid.iter().map(|r| r[i] * r[i]).sum::<f64>() / dof)
        .collect();
    let sigma: Vec<f64> = (0..nodes.len())
        .map(|i| {
            let local = if nb >= 3 {
                let (a, b) = (i.saturating_sub(w), (i + w).min(nodes.len() - 1));
                (var_at[a..=b].iter().sum::<f64>() / (b - a + 1) as f64).sqrt()
            } else {
                0.0
            };
            pooled.max(local).max(floor).max(f64::MIN_POSITIVE)
        })
        .collect();
    let inflate = (1.0 + 1.0 / n_m as f64).sqrt();
    let limit: Vec<f64> = sigma.iter().map(|s| params.k * s * inflate).collect();
    let level_sigma = (levels.iter().map(|a| a * a).sum::<f64>() / dof)
        .sqrt()
        .max(params.min_level_relative_std)
        .max(f64::MIN_POSITIVE);
    let position_mm: Vec<f64> = nodes
        .iter()
        .map(|&j| (lo + j as i64) as f64 * step)
        .collect();
    let travel = position_mm.last()? - position_mm[0];
    let gap = (params.merge_gap_leads * per_lead as f64).round() as usize;
    let mut tests = Vec::with_capacity(set.len());
    let mut first_flag = None;
    for (k, (t, _)) in set.iter().enumerate() {
        let in_baseline = k < nb || Some(k) == ref_idx;
        let d: Vec<Option<f64>> = at(k)
            .iter()
            .zip(&m)
            .map(|(s, m)| s.map(|s| s - m))
            .collect();
        let (a, r) = split_level(&d, &m);
        let level_flagged =
            !in_baseline && (a / mbar).abs() > params.level_k * level_sigma * inflate;
        let ranges = if in_baseline {
            vec![]
        } else {
            flag_ranges(&r, &limit, &m, &position_mm, step, gap, travel, params)
        };
        if first_flag.is_none() && (level_flagged || !ranges.is_empty()) {
            first_flag = Some(k);
        }
        tests.push(TestChange {
            test_id: t.test_id,
            time_s: t.time_s,
            in_baseline,
            change_n: d,
            local_n: r,
            level_n: a,
            level_percent: 100.0 * a / mbar,
            level_flagged,
            ranges,
        });
    }
    Some(DirectionChanges {
        direction: dir,
        lead_mm: lead,
        tests_with_profile: set.len(),
        baseline_ids: base.iter().map(|&b| set[b].0.test_id).collect(),
        reference_id: ref_idx.map(|r| set[r].0.test_id),
        position_mm,
        baseline_n: m,
        sigma_n: sigma,
        limit_n: limit,
        pooled_sigma_n: pooled,
        level_sigma,
        mean_level_n: mbar,
        tests,
        first_flag,
    })
}

/// Centred moving average over 2·`half` steps with trapezoidal end weights (one lead when
/// 2·`half` = cells per lead); `None` where any node of the window is missing.
fn smooth(v: &[Option<f64>], half: usize) -> Vec<Option<f64>> {
    let n = v.len();
    (0..n)
        .map(|j| {
            if j < half || j + half >= n {
                return None;
            }
            let window = &v[j - half..=j + half];
            let mut s = 0.0;
            for (k, x) in window.iter().enumerate() {
                // Trapezoidal ends: the window spans 2·half steps, not 2·half + 1 nodes.
                let w = if k == 0 || k == 2 * half { 0.5 } else { 1.0 };
                s += w * (*x)?;
            }
            Some(s / (2 * half) as f64)
        })
        .collect()
}

/// Split d(x) into its whole-travel part a + b·(m(x) − m̄) (robust line fit on m) and the
/// rest; returns a (the shift at m̄, N) and the rest (None where d is None).
fn split_level(d: &[Option<f64>], m: &[f64]) -> (f64, Vec<Option<f64>>) {
    let pts: Vec<(f64, f64)> = d
        .iter()
        .zip(m)
        .filter_map(|(d, &m)| d.map(|d| (m, d)))
        .collect();
    if pts.is_empty() {
        return (0.0, vec![None; d.len()]);
    }
    let mbar = m.iter().sum::<f64>() / m.len() as f64;
    let fit = |keep: &dyn Fn(f64, f64) -> bool| -> (f64, f64) {
        let sel: Vec<(f64, f64)> = pts
            .iter()
            .copied()
            .filter(|&(x, y)| keep(x, y))
            .map(|(x, y)| (x - mbar, y))
            .collect();
        let n = sel.len().max(1) as f64;
        let xm = sel.iter().map(|p| p.0).sum::<f64>() / n;
        let ym = sel.iter().map(|p| p.1).sum::<f64>() / n;
        let sxx: f64 = sel.iter().map(|p| (p.0 - xm).powi(2)).sum();
        let sxy: f64 = sel.iter().map(|p| (p.0 - xm) * (p.1 - ym)).sum();
        // A flat baseline (spread of m below 1e-9 of its level) leaves the slope undefined:
        // the whole-travel part is then the shift alone.
        let b = if sxx > 1e-18 * n * mbar * mbar {
            sxy / sxx
        } else {
            0.0
        };
        (ym - b * xm, b)
    };
    // Start from the pure shift (the median of d, no slope): a local change then stands out
    // in the residuals instead of tilting the line; then refit without the points beyond
    // 3 robust σ of the current line until the kept set no longer changes.
    let mut dv: Vec<f64> = pts.iter().map(|p| p.1).collect();
    let (mut a, mut b) = (median(&mut dv), 0.0);
    let mut kept: Vec<bool> = vec![];
    for _ in 0..20 {
        let mut r: Vec<f64> = pts
            .iter()
            .map(|&(x, y)| (y - a - b * (x - mbar)).abs())
            .collect();
        let cut = 3.0 * MAD_TO_SIGMA * median(&mut r.clone());
        if cut <= 0.0 {
            break;
        }
        let now: Vec<bool> = r.iter_mut().map(|x| *x <= cut).collect();
        if now == kept {
            break;
        }
        let (a0, b0) = (a, b);
        (a, b) = fit(&|x, y| (y - a0 - b0 * (x - mbar)).abs() <= cut);
        kept = now;
    }
    let rest = d
        .iter()
        .zip(m)
        .map(|(d, &m)| d.map(|d| d - a - b * (m - mbar)))
        .collect();
    (a, rest)
}

/// Median of the values (reorders them); 0 for none.
fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

#[allow(clippy::too_many_arguments)]
fn flag_ranges(
    r: &[Option<f64>],
    limit: &[f64],
    m: &[f64],
    pos: &[f64],
    step: f64,
    gap: usize,
    travel: f64,
    params: &LocalParams,
) -> Vec<ChangeRange> {
    // sign of each flagged node, 0 = not flagged
    let sign: Vec<i8> = r
        .iter()
        .zip(limit)
        .map(|(x, l)| match x {
            Some(x) if x.abs() > *l => {
                if *x > 0.0 {
                    1
                } else {
                    -1
                }
            }
            _ => 0,
        })
        .collect();
    // runs (start, end, sign), merged across gaps ≤ `gap` nodes of the same sign
    let mut runs: Vec<(usize, usize, i8)> = Vec::new();
    for (i, &s) in sign.iter().enumerate() {
        if s == 0 {
            continue;
        }
        match runs.last_mut() {
            Some(last) if last.2 == s && i - last.1 <= gap + 1 => last.1 = i,
            _ => runs.push((i, i, s)),
        }
    }
    runs.into_iter()
        .map(|(a, b, _)| {
            let peak = (a..=b)
                .max_by(|&i, &j| {
                    let v = |k: usize| r[k].map_or(0.0, f64::abs);
                    v(i).total_cmp(&v(j))
                })
                .unwrap_or(a);
            let h = r[peak].unwrap_or(0.0);
            let half_h = 0.5 * h.abs();
            let above = |k: usize| r[k].is_some_and(|x| x * h.signum() >= half_h);
            let (mut wa, mut wb) = (peak, peak);
            while wa > 0 && above(wa - 1) {
                wa -= 1;
            }
            while wb + 1 < r.len() && above(wb + 1) {
                wb += 1;
            }
            let span = pos[b] - pos[a];
            ChangeRange {
                start_mm: pos[a],
                end_mm: pos[b],
                peak_mm: pos[peak],
                height_n: h,
                height_percent: 100.0 * h / m[peak],
                width_mm: (pos[wb] - pos[wa]).max(step),
                height_sigma: h.abs() / (limit[peak] / params.k),
                extent: if travel > 0.0 && span >= params.whole_travel_fraction * travel {
                    Extent::WholeTravel
                } else {
                    Extent::Local
                },
            }
        })
        .collect()
}

/// What is known about the position-resolved comparison of one direction, in words:
/// after 0, 1 or 2 tests (no comparison yet: what the next test brings) or the outcome.
pub fn describe_baseline(tests_with_profile: usize, params: &LocalParams) -> String {
    let nb = params.baseline_tests;
    match tests_with_profile {
        0 => "No stroke test with a friction profile on the position grid is stored (tests \
              stored by an older feedscope have none): the friction along the travel cannot \
              be compared yet."
            .to_string(),
        1 => format!(
            "One stroke test: its friction profile is the reference shape along the travel, \
             but the scatter between tests is not known, so no position can be judged yet; \
             with {nb} tests the baseline and its scatter are known and the next test is the \
             first compared position by position."
        ),
        n if n < nb => format!(
            "{n} stroke tests: the profile baseline needs {nb}; {} more before positions can \
             be compared.",
            nb - n
        ),
        _ => format!(
            "{tests_with_profile} stroke tests: the baseline profile and its scatter are \
             known; the next stroke test is the first compared position by position."
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{rngs::StdRng, SeedableRng};
    use rand_distr::{Distribution, Normal};

    /// Synthetic test: 0-200 mm, lead 5 mm, a level with a trend, shaft-order 1 and a
    /// non-integer order with scattered amplitudes, level scatter, white noise, optional
    /// Gaussian bump and additive shift.
    fn synth(seed: u64, bump: Option<(f64, f64, f64)>, shift_n: f64) -> GridProfile {
        let mut rng = StdRng::seed_from_u64(seed);
        let n01 = Normal::new(0.0, 1.0).unwrap();
        let level = 1.0 + 0.003 * n01.sample(&mut rng);
        let a1 = 8.0 * (1.0 + 0.03 * n01.sample(&mut rng));
        let a2 = 4.0 * (1.0 + 0.03 * n01.sample(&mut rng));
        let z: Vec<f64> = (0..8000).map(|i| i as f64 * 0.025e-3).collect();
        let f: Vec<f64> = z
            .iter()
            .map(|&z| {
                let x = z * 1e3;
                let tau = std::f64::consts::TAU;
                let mut f = level * (280.0 + 0.2 * x)
                    + a1 * (tau * x / 5.0).sin()
                    + a2 * (tau * 8.116 * x / 5.0 + 1.0).sin()
                    + shift_n
                    + 3.0 * n01.sample(&mut rng);
                if let Some((c, w, h)) = bump {
                    f += h * (-0.5 * ((x - c) / w).powi(2)).exp();
                }
                f
            })
            .collect();
        let mut g = GridBuilder::new(Direction::Forward, 5.0, 8);
        g.add_stroke(&z, &f, 2.5);
        g.finish().unwrap()
    }

    fn history(
        seed: u64,
        n: usize,
        f: impl Fn(usize) -> (Option<(f64, f64, f64)>, f64),
    ) -> Vec<ProfileTest> {
        (0..n)
            .map(|k| {
                let (bump, shift) = f(k);
                ProfileTest {
                    test_id: k as i64 + 1,
                    time_s: k as f64 * 86_400.0,
                    profiles: vec![synth(seed * 100 + k as u64, bump, shift)],
                }
            })
            .collect()
    }

    #[test]
    fn smoothing_over_one_lead_removes_integer_orders_exactly() {
        let v: Vec<Option<f64>> = (0..40)
            .map(|i| Some(10.0 + 3.0 * (std::f64::consts::TAU * i as f64 / 8.0 + 0.3).sin()))
            .collect();
        let s = smooth(&v, 4);
        assert!(s[..4].iter().all(Option::is_none));
        for x in s[4..36].iter() {
            // a sum of 8 samples of one period cancels to rounding (a few ulps of 10)
            assert!((x.unwrap() - 10.0).abs() < 1e-12, "{x:?}");
        }
        let mut with_gap = v.clone();
        with_gap[20] = None;
        let s = smooth(&with_gap, 4);
        assert!(s[16..=24].iter().all(Option::is_none) && s[15].is_some());
    }

    #[test]
    fn level_split_removes_shift_and_scale_but_not_a_bump() {
        let m: Vec<f64> = (0..100).map(|i| 250.0 + i as f64).collect();
        let d: Vec<Option<f64>> = m
            .iter()
            .enumerate()
            .map(|(i, &m)| {
                let bump = if (40..45).contains(&i) { 20.0 } else { 0.0 };
                Some(7.0 + 0.01 * (m - 299.5) + bump)
            })
            .collect();
        let (a, r) = split_level(&d, &m);
        // exact data: the robust refit without the bump recovers the line to rounding
        assert!((a - 7.0).abs() < 1e-9, "{a}");
        for (i, x) in r.iter().enumerate() {
            let want = if (40..45).contains(&i) { 20.0 } else { 0.0 };
            assert!((x.unwrap() - want).abs() < 1e-9, "{i}: {x:?}");
        }
    }

    #[test]
    fn a_growing_bump_is_found_where_and_when_it_exceeds_the_limit() {
        // +2.5 N per test from test 3 (σ_w = 10 mm at 140 mm): the smoothed noise σ is about
        // 3 N/√(cells·samples) ≈ 0.1 N and the level scatter is removed, so the limit is ~1 N
        let tests = history(7, 8, |k| {
            (Some((140.0, 10.0, 2.5 * (k as f64 - 1.0).max(0.0))), 0.0)
        });
        let c = profile_changes(&tests, None, &LocalParams::default()).unwrap();
        let d = &c.directions[0];
        assert_eq!(d.baseline_ids, vec![1, 2]);
        let first = d.first_flag.expect("flagged");
        assert_eq!(d.tests[first].test_id, 3, "{:?}", d.tests[first]);
        let limit_at_peak = d.limit_n[d
            .position_mm
            .iter()
            .position(|&x| (x - 140.0).abs() < 0.1)
            .unwrap()];
        assert!(limit_at_peak < 2.5, "{limit_at_peak}");
        for t in &d.tests[first..] {
            assert!(!t.level_flagged, "{}", t.level_percent);
            assert_eq!(t.ranges.len(), 1, "{:?}", t.ranges);
            let r = &t.ranges[0];
            assert_eq!(r.extent, Extent::Local);
            assert!((r.peak_mm - 140.0).abs() <= 5.0, "{r:?}");
            assert!(r.start_mm > 100.0 && r.end_mm < 180.0, "{r:?}");
        }
        let last = &d.tests[7].ranges[0];
        // 15 N bump smoothed over one lead (5 mm ≪ 2.355·10 mm FWHM keeps ~99 %)
        assert!((last.height_n - 15.0).abs() < 1.0, "{last:?}");
        assert!((last.width_mm - 23.5).abs() < 3.0, "{last:?}");
    }

    #[test]
    fn unchanged_histories_raise_no_flag() {
        let mut flags = 0;
        for seed in 0..30 {
            let tests = history(1000 + seed, 10, |_| (None, 0.0));
            let c = profile_changes(&tests, None, &LocalParams::default()).unwrap();
            flags += c.directions[0].first_flag.is_some() as usize;
        }
        assert_eq!(flags, 0);
    }

    #[test]
    fn an_additive_rise_everywhere_is_level_not_local() {
        let tests = history(3, 8, |k| (None, 4.0 * (k as f64 - 1.0).max(0.0)));
        let c = profile_changes(&tests, None, &LocalParams::default()).unwrap();
        let d = &c.directions[0];
        for t in &d.tests[2..] {
            assert!(t.ranges.is_empty(), "{:?}", t.ranges);
        }
        // The limit is K_level·σ_a·√(1 + 1/2) of m̄ (≥ 0.5 % × 4 × √1.5 = 2.45 %); the shift
        // 4·(k − 1) N of test k must be flagged once clearly beyond it and not while clearly
        // within (±15 %: the fitted level scatters by the 0.3 % level noise).
        let limit = 4.0 * d.level_sigma * 1.5f64.sqrt() * d.mean_level_n;
        assert!(limit >= 0.0245 * d.mean_level_n * 0.999);
        for (k, t) in d.tests.iter().enumerate().skip(2) {
            let shift = 4.0 * (k as f64 - 1.0);
            if shift > 1.15 * limit {
                assert!(t.level_flagged, "test {}: {shift} N, limit {limit}", k + 1);
            } else if shift < 0.85 * limit {
                assert!(!t.level_flagged, "test {}: {shift} N, limit {limit}", k + 1);
            }
        }
        assert!(d.first_flag.is_some());
        // 24 N, give or take the level scatter of test 8 and of the baseline mean:
        // 0.3 % of ~300 N·√(1 + 1/2) ≈ 1.1 N, so 4 N is 3.6 σ
        assert!(
            (d.tests[7].level_n - 24.0).abs() < 4.0,
            "{}",
            d.tests[7].level_n
        );
    }

    #[test]
    fn reference_profile_and_early_history_words() {
        let tests = history(5, 5, |k| (None, if k >= 3 { 30.0 } else { 0.0 }));
        // the reference is test 4 (after the change): later tests compare with it
        let c = profile_changes(&tests, Some(4), &LocalParams::default()).unwrap();
        let d = &c.directions[0];
        assert_eq!(d.reference_id, Some(4));
        assert!(d.tests[3].in_baseline);
        assert!(!d.tests[4].level_flagged, "{}", d.tests[4].level_percent);
        assert!(d.tests[2].level_flagged, "{}", d.tests[2].level_percent);
        // one test: no direction compared, and the words say what is known
        let c = profile_changes(&tests[..1], None, &LocalParams::default()).unwrap();
        assert!(c.directions.is_empty());
        let p = LocalParams::default();
        assert!(describe_baseline(1, &p).contains("scatter between tests is not known"));
        assert!(describe_baseline(2, &p).contains("next stroke test is the first compared"));
        let bad = LocalParams {
            baseline_tests: 1,
            ..p
        };
        assert!(matches!(
            profile_changes(&tests, None, &bad),
            Err(HistoryError::InvalidParams(_))
        ));
    }
}
