//! The picture of a steady-speed table's Stribeck fit (paper 000 Eq. 9): the table's points
//! and the fitted curve of each direction, friction (N) against feed (mm/min).
use feedscope::stribeck::{FrictionModel, M_S_PER_MM_MIN};

use super::{line_chart_svg, LineChart, Result, Series, Style};
use crate::stribeck::StribeckReport;

/// Points of each fitted curve: this many steps spaced linearly and as many logarithmically.
const CURVE_STEPS: usize = 200;

/// Per direction the table's points and the reported curve (the Stribeck fit, or the
/// Coulomb + viscous line where the table did not determine one).
///
/// # Errors
/// A chart that cannot be drawn (no finite value).
pub fn stribeck_svg(report: &StribeckReport) -> Result<String> {
    let mut series = Vec::new();
    for d in &report.directions {
        let pts: Vec<(f64, f64)> = d
            .data
            .iter()
            .map(|p| (p.feed_mm_min, p.friction_n))
            .collect();
        // The shared point style is a faint dot meant for dense samples; a dashed line
        // through the (feed-sorted) points keeps a few table rows visible.
        series.push(Series {
            name: format!("{} data", d.direction),
            points: pts,
            style: Style::Dashed,
        });
        let p = d.curve;
        // Linear and logarithmic spacing together: the hump sits at the low end.
        let (lo, hi) = (d.feed_min_mm_min, d.feed_max_mm_min);
        let mut feeds: Vec<f64> = (0..=CURVE_STEPS)
            .flat_map(|k| {
                let s = k as f64 / CURVE_STEPS as f64;
                [lo + (hi - lo) * s, lo * (hi / lo).powf(s)]
            })
            .collect();
        feeds.sort_by(f64::total_cmp);
        let curve = feeds
            .into_iter()
            .map(|f| (f, p.magnitude_n(f * M_S_PER_MM_MIN)))
            .collect();
        let fitted = if d.model == FrictionModel::Stribeck.code() {
            "Stribeck fit"
        } else {
            "Coulomb + viscous fit"
        };
        series.push(Series {
            name: format!("{} {fitted}", d.direction),
            points: curve,
            style: Style::Line,
        });
    }
    line_chart_svg(&LineChart {
        title: "Friction against feed (steady speed) and Stribeck fit",
        x_label: "feed (mm/min)",
        y_label: "friction (N)",
        series,
    })
}
