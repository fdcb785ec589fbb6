//! The picture of a one-test identification (paper 002): measured and computed motor torque
//! over time, and the rows the fit used.
use feedscope::ident::Identification;

use super::{line_chart_svg, LineChart, Result, Series, Style};

/// Points of one series at most: longer ones are decimated.
const MAX_POINTS: usize = 4000;

/// Measured (kernel-averaged) and computed torque (N·m) over time (s), with the rows used in
/// the fit as points; the title names the axis (`axis_name`, else "axis").
///
/// # Errors
/// A chart that cannot be drawn (no finite value).
pub fn identification_svg(id: &Identification, axis_name: Option<&str>) -> Result<String> {
    let title = format!(
        "Measured and computed motor torque ({})",
        axis_name.unwrap_or("axis")
    );
    let n = id.time_s.len();
    let step = n.div_ceil(MAX_POINTS).max(1);
    let pts = |f: &dyn Fn(usize) -> f64| -> Vec<(f64, f64)> {
        (0..n)
            .step_by(step)
            .map(|k| (id.time_s[k], f(k)))
            .filter(|p| p.1.is_finite())
            .collect()
    };
    let used: Vec<(f64, f64)> = (0..n)
        .step_by(step)
        .filter(|&k| id.used[k])
        .map(|k| (id.time_s[k], id.regressors.torque_nm[k]))
        .collect();
    line_chart_svg(&LineChart {
        title: &title,
        x_label: "time (s)",
        y_label: "torque (N·m)",
        series: vec![
            Series {
                name: "measured (kernel average)".to_string(),
                points: pts(&|k| id.regressors.torque_nm[k]),
                style: Style::Line,
            },
            Series {
                name: "computed, J·θ'' + T_f(v)".to_string(),
                points: pts(&|k| id.computed_torque_nm[k]),
                style: Style::Dashed,
            },
            Series {
                name: "used in the fit".to_string(),
                points: used,
                style: Style::Points,
            },
        ],
    })
}
