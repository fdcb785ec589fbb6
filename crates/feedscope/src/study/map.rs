//! The map study of a test set (paper 000 Section 4.2): friction map F(z, v), Stribeck fits at
//! chosen positions and along the whole mapped travel, non-conventional spans, and the
//! positions and feeds of a compensation table.
use crate::map::{
    build_map, nonconventional_spans, stribeck_profile, DirectionMap, FrictionMap, MapParams,
    NonConventionalSpan, RunFriction, StribeckProfile,
};
use crate::stroke::Direction;

use super::StudyError;

/// Settings of [`map_study`].
#[derive(Debug, Clone, PartialEq)]
pub struct MapStudyParams {
    /// The map and its Stribeck fits (defaults: [`MapParams::default`]).
    pub map: MapParams,
    /// Positions of the Stribeck fits (mm), the same for both directions; `None` (default):
    /// [`default_positions`](Self::default_positions) evenly spaced inside each direction's
    /// mapped span.
    pub positions_mm: Option<Vec<f64>>,
    /// Number of default Stribeck positions: the centres of that many equal parts of the span,
    /// rounded to 1 µm. Default 5.
    pub default_positions: usize,
    /// Position step of the map grid, the compensation table and the Stribeck profile (mm).
    /// Default 1 mm.
    pub position_step_mm: f64,
    /// Feeds of the compensation table (mm/min); `None` (default): the measured feeds.
    pub table_feeds_mm_min: Option<Vec<f64>>,
    /// Allow table feeds outside the measured feeds (the feed polynomial extrapolates).
    /// Default false.
    pub extrapolate: bool,
}

impl Default for MapStudyParams {
    fn default() -> Self {
        Self {
            map: MapParams::default(),
            positions_mm: None,
            default_positions: 5,
            position_step_mm: 1.0,
            table_feeds_mm_min: None,
            extrapolate: false,
        }
    }
}

impl MapStudyParams {
    /// Check the settings of the study (the map's own with [`MapParams::validate`]).
    ///
    /// # Errors
    /// [`StudyError::BadParameter`] for a non-finite position, a step that is not a positive
    /// length, a table feed that is not a positive feed or no default positions;
    /// [`StudyError::Map`] as [`MapParams::validate`].
    pub fn validate(&self) -> Result<(), StudyError> {
        let bad = |name, value, expected| StudyError::BadParameter {
            name,
            value,
            expected,
        };
        if let Some(x) = self.positions_mm.iter().flatten().find(|x| !x.is_finite()) {
            return Err(bad("positions_mm", *x, "finite positions"));
        }
        if !(self.position_step_mm.is_finite() && self.position_step_mm > 0.0) {
            return Err(bad(
                "position_step_mm",
                self.position_step_mm,
                "a positive length",
            ));
        }
        if let Some(x) = self
            .table_feeds_mm_min
            .iter()
            .flatten()
            .find(|x| !(x.is_finite() && **x > 0.0))
        {
            return Err(bad("table_feeds_mm_min", *x, "positive feeds"));
        }
        if self.default_positions == 0 {
            return Err(bad("default_positions", 0.0, "at least 1"));
        }
        self.map.validate()?;
        Ok(())
    }
}

/// Results of a map study; the per-direction vectors follow [`FrictionMap::directions`].
#[derive(Debug, Clone)]
pub struct MapStudy {
    /// The friction map F(z, v).
    pub map: FrictionMap,
    /// Stribeck fits at the chosen positions, one profile per direction.
    pub at_positions: Vec<StribeckProfile>,
    /// Stribeck fits at every position of the map grid, one profile per direction.
    pub profiles: Vec<StribeckProfile>,
    /// Position spans where friction falls with feed although the Stribeck curve rises.
    pub nonconventional: Vec<NonConventionalSpan>,
    /// Positions of the map grid per direction (mm): [`map_grid`] with the study's step.
    pub grids_mm: Vec<Vec<f64>>,
    /// Feeds of the compensation table per direction (mm/min), checked against the measured
    /// feeds unless extrapolation was asked for.
    pub table_feeds_mm_min: Vec<Vec<f64>>,
}

impl MapStudy {
    /// Grid positions (mm) and table feeds (mm/min) of a direction of the map.
    pub fn table_axes(&self, direction: Direction) -> Option<(&[f64], &[f64])> {
        let k = self
            .map
            .directions
            .iter()
            .position(|d| d.direction == direction)?;
        Some((&self.grids_mm[k], &self.table_feeds_mm_min[k]))
    }
}

/// Map a test set: the friction map of its estimated runs ([`build_map`]), the Stribeck fits
/// at the chosen positions and along the grid ([`stribeck_profile`]) and the non-conventional
/// spans ([`nonconventional_spans`]).
///
/// # Errors
/// [`StudyError::BadParameter`] or [`StudyError::Map`] for invalid settings;
/// [`StudyError::Map`] when the runs give no map; [`StudyError::OneFeed`] when a direction
/// was measured at a single feed (a map and a Stribeck curve describe the change with feed);
/// [`StudyError::Position`] for a Stribeck position outside a direction's mapped span;
/// [`StudyError::TableFeed`] for a table feed outside the measured feeds without
/// [`MapStudyParams::extrapolate`].
pub fn map_study(
    runs: &[RunFriction],
    lead_m: f64,
    params: &MapStudyParams,
) -> Result<MapStudy, StudyError> {
    params.validate()?;
    let map = build_map(runs, lead_m, &params.map)?;
    for d in &map.directions {
        if let [one] = d.feeds.as_slice() {
            return Err(StudyError::OneFeed {
                direction: d.direction,
                feed_mm_min: one.feed_mm_min,
            });
        }
    }
    let mut positions = Vec::with_capacity(map.directions.len());
    let mut table_feeds = Vec::with_capacity(map.directions.len());
    let mut grids = Vec::with_capacity(map.directions.len());
    for d in &map.directions {
        let p = params
            .positions_mm
            .clone()
            .unwrap_or_else(|| default_positions(d, params.default_positions));
        for &x in &p {
            d.check_position(x).map_err(StudyError::Position)?;
        }
        positions.push(p);
    }
    for d in &map.directions {
        let feeds = params
            .table_feeds_mm_min
            .clone()
            .unwrap_or_else(|| d.feeds_mm_min());
        for &f in &feeds {
            d.poly_at(f, params.extrapolate)
                .map_err(StudyError::TableFeed)?;
        }
        table_feeds.push(feeds);
        grids.push(map_grid(d, params.position_step_mm));
    }
    let mut at_positions = Vec::with_capacity(map.directions.len());
    let mut profiles = Vec::with_capacity(map.directions.len());
    for ((d, p), g) in map.directions.iter().zip(&positions).zip(&grids) {
        at_positions.push(stribeck_profile(d, p, &params.map)?);
        profiles.push(stribeck_profile(d, g, &params.map)?);
    }
    let nonconventional = profiles.iter().flat_map(nonconventional_spans).collect();
    Ok(MapStudy {
        map,
        at_positions,
        profiles,
        nonconventional,
        grids_mm: grids,
        table_feeds_mm_min: table_feeds,
    })
}

/// The centres of `n` equal parts of a direction's mapped span, rounded to 1 µm so that
/// printed positions read back exactly.
fn default_positions(d: &DirectionMap, n: usize) -> Vec<f64> {
    let round_mm = |x: f64| (x * 1e3).round() / 1e3;
    (0..n)
        .map(|i| round_mm(d.start_mm + (d.end_mm - d.start_mm) * (i as f64 + 0.5) / n as f64))
        .collect()
}

/// Map grid positions (mm): the span's start, the multiples of `step_mm` inside the span
/// (round numbers a control engineer can index), and the span's end.
///
/// # Panics
/// When `step_mm` is not a positive finite length (a programmer's mistake:
/// [`MapStudyParams::validate`] refuses it).
pub fn map_grid(d: &DirectionMap, step_mm: f64) -> Vec<f64> {
    assert!(
        step_mm.is_finite() && step_mm > 0.0,
        "map grid step {step_mm} mm"
    );
    // Multiples closer than 1 nm to an end are the end itself.
    let tol = 1e-6;
    let mut g = vec![d.start_mm];
    let mut k = ((d.start_mm + tol) / step_mm).ceil() as i64;
    loop {
        let z = k as f64 * step_mm;
        if z >= d.end_mm - tol {
            break;
        }
        if z > d.start_mm + tol {
            g.push(z);
        }
        k += 1;
    }
    g.push(d.end_mm);
    g
}
