//! The whole analysis a drive file asks for (its `[sweep]` and `[ripple]` tables), in the
//! user units of the file: positions in mm, feed rates in mm/min.

use serde::{Deserialize, Serialize};

use super::config::RippleParams;
use super::contact::JointState;
use super::modal::{DriveModel, ModalResult};
use super::ripple::find_resonances;
pub use super::ripple::Resonance;
use super::DynamicsError;
use crate::units::M_S_PER_MM_MIN;

/// Frequencies and joint state at one feed rate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FeedPoint {
    /// Feed rate (mm/min).
    pub feed_mm_min: f64,
    /// Lowest natural frequencies (Hz), ascending.
    pub frequencies_hz: Vec<f64>,
    /// Joint loads and stiffnesses (SI).
    pub joints: JointState,
}

/// Natural frequencies against feed rate at one nut position.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FeedSweep {
    /// Nut position y from the rear bearing (mm).
    pub position_mm: f64,
    /// One point per feed rate, ascending, the first at rest.
    pub points: Vec<FeedPoint>,
}

/// Frequencies at one nut position.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PositionPoint {
    /// Nut position y from the rear bearing (mm).
    pub position_mm: f64,
    /// Lowest natural frequencies (Hz), ascending.
    pub frequencies_hz: Vec<f64>,
}

/// Natural frequencies against nut position at one feed rate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PositionSweep {
    /// Feed rate (mm/min).
    pub feed_mm_min: f64,
    /// One point per position, ascending.
    pub points: Vec<PositionPoint>,
}

/// A support bearing unit whose axial load reaches zero.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct UnloadEvent {
    /// Which unit: `"rear"` for positive feed (the front unit unloads at the same negative
    /// feed rate).
    pub bearing: String,
    /// Feed rate at which f(v) = 2·Fas (mm/min); 0 means as soon as the table moves.
    pub feed_mm_min: f64,
    /// Screw pretension Fas (N).
    pub pretension_n: f64,
    /// Lowest natural frequency just below the unload feed rate (Hz).
    pub first_before_hz: f64,
    /// Lowest natural frequency just above it (Hz).
    pub first_after_hz: f64,
}

/// Everything `feedscope dynamics` reports.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DynamicsReport {
    /// The drive's name from the file.
    pub name: Option<String>,
    /// Nut position of the feed sweep (mm).
    pub position_mm: f64,
    /// Lowest natural frequency at rest, f(v) = 0 (Hz): the paper's 108 Hz figure.
    pub static_first_hz: f64,
    /// Lowest natural frequency just after breakaway, f(0⁺) = F_s (Hz): the paper's 117.5 Hz.
    pub breakaway_first_hz: f64,
    /// Highest lowest-frequency over the feed sweep (Hz).
    pub peak_first_hz: f64,
    /// Feed rate of that peak (mm/min).
    pub peak_feed_mm_min: f64,
    /// Where the rear bearing unit unloads, if below 100 m/s.
    pub bearing_unload: Option<UnloadEvent>,
    /// Modes at rest at the feed-sweep position, with shapes (SI).
    pub static_modes: ModalResult,
    /// Mode shapes against feed and position: at the feed-sweep position for each feed of
    /// `sweep.position_feeds_mm_min`, then at the first and last position of the position
    /// sweep for each of those feeds. Each result names its position and feed (SI).
    pub mode_shapes: Vec<ModalResult>,
    /// Frequencies against feed rate.
    pub feed_sweep: FeedSweep,
    /// Frequencies against position, one sweep per requested feed rate.
    pub position_sweeps: Vec<PositionSweep>,
    /// The ripple settings used.
    pub ripple: RippleParams,
    /// Screw lead (mm), for drawing the ripple lines f_T = N_P·P_n·v/(60·p).
    pub lead_mm: f64,
    /// Resonance risks on the feed sweep, ascending in feed rate.
    pub resonances: Vec<Resonance>,
}

/// `n` evenly spaced values from `a` to `b` inclusive.
fn linspace(a: f64, b: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| a + (b - a) * i as f64 / (n - 1).max(1) as f64)
        .collect()
}

/// Run the sweeps and the resonance search of the model's configuration.
///
/// # Errors
/// As [`DriveModel::at_position`] (not expected for a validated configuration).
pub fn analyse(model: &DriveModel) -> Result<DynamicsReport, DynamicsError> {
    let cfg = model.config();
    let sw = &cfg.sweep;
    let n_modes = sw.modes;
    let y = sw.position_mm / 1000.0;
    let plan = model.at_position(y)?;

    let feeds = linspace(0.0, sw.feed_max_mm_min, sw.feed_points);
    let feeds_si: Vec<f64> = feeds.iter().map(|v| v * M_S_PER_MM_MIN).collect();
    let freqs = model.sweep_feed(y, &feeds_si, n_modes)?;
    let feed_sweep = FeedSweep {
        position_mm: sw.position_mm,
        points: feeds
            .iter()
            .zip(&freqs)
            .map(|(&v, f)| FeedPoint {
                feed_mm_min: v,
                frequencies_hz: f.clone(),
                joints: model.joints(v * M_S_PER_MM_MIN),
            })
            .collect(),
    };

    let static_modes = plan.modes(0.0, n_modes);
    let static_first_hz = static_modes.modes[0].frequency_hz;
    // f(0⁺): the friction has reached F_s; 1e-9 m/s is far below any Stribeck velocity.
    let breakaway_first_hz = plan.frequencies_hz(1e-9, 1)[0];
    let (peak_feed_mm_min, peak_first_hz) =
        feeds
            .iter()
            .zip(&freqs)
            .map(|(&v, f)| (v, f[0]))
            .fold(
                (0.0, f64::NEG_INFINITY),
                |a, b| if b.1 > a.1 { b } else { a },
            );

    let bearing_unload = model.bearing_unload_feed_m_s().map(|v| {
        // ±1e-6 relative either side of the root to see the step in stiffness.
        let below = (v * (1.0 - 1e-6)).max(1e-9);
        let above = v * (1.0 + 1e-6) + 1e-9;
        UnloadEvent {
            bearing: "rear".to_owned(),
            feed_mm_min: v / M_S_PER_MM_MIN,
            pretension_n: cfg.bearings.screw_pretension_kn * 1e3,
            first_before_hz: plan.frequencies_hz(below, 1)[0],
            first_after_hz: plan.frequencies_hz(above, 1)[0],
        }
    });

    let positions = linspace(sw.position_min_mm, sw.position_max_mm, sw.position_points);
    let positions_si: Vec<f64> = positions.iter().map(|p| p / 1000.0).collect();
    let mut position_sweeps = Vec::with_capacity(sw.position_feeds_mm_min.len());
    for &v in &sw.position_feeds_mm_min {
        let grid = model.sweep_grid(&positions_si, &[v * M_S_PER_MM_MIN], n_modes)?;
        position_sweeps.push(PositionSweep {
            feed_mm_min: v,
            points: positions
                .iter()
                .zip(grid)
                .map(|(&p, mut f)| PositionPoint {
                    position_mm: p,
                    frequencies_hz: f.swap_remove(0),
                })
                .collect(),
        });
    }

    let mut mode_shapes = Vec::new();
    for y_mm in [sw.position_mm, sw.position_min_mm, sw.position_max_mm] {
        let p = model.at_position(y_mm / 1000.0)?;
        for &v in &sw.position_feeds_mm_min {
            mode_shapes.push(p.modes(v * M_S_PER_MM_MIN, n_modes));
        }
    }

    let resonances = find_resonances(&plan, &feeds, &freqs, &cfg.ripple, cfg.screw.lead_mm);

    Ok(DynamicsReport {
        name: cfg.name.clone(),
        position_mm: sw.position_mm,
        static_first_hz,
        breakaway_first_hz,
        peak_first_hz,
        peak_feed_mm_min,
        bearing_unload,
        static_modes,
        mode_shapes,
        feed_sweep,
        position_sweeps,
        ripple: cfg.ripple.clone(),
        lead_mm: cfg.screw.lead_mm,
        resonances,
    })
}
