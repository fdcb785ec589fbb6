//! SVG plots for people: line charts and heat maps with unit-labelled axes, and the pictures
//! of each use case drawn with them, so that every front end shows the same ones: an
//! estimation's friction along the travel ([`estimate_svg`]), an analysis's IAFV, spectra and
//! components ([`analysis_svgs`]), the torque fit of an identification
//! ([`identification_svg`]), a table's Stribeck fit ([`stribeck_svg`]) and a map's sections,
//! heat maps and mean curves ([`map_svgs`]).
//!
//! plotters is built without system fonts (the `ab_glyph` feature), so the bundled DejaVu Sans
//! is registered once before the first chart.
use std::path::Path;
use std::sync::Once;

use crate::error::AppError;
use crate::estimate::{Estimated, FrictionPlot};
use feedscope::verdict::FrictionSign;
use plotters::prelude::*;

mod analysis;
mod identification;
mod map;
mod stribeck;

pub use analysis::analysis_svgs;
pub use identification::identification_svg;
pub use map::map_svgs;
pub use stribeck::stribeck_svg;

type Result<T, E = AppError> = std::result::Result<T, E>;

static FONT: Once = Once::new();
static FONT_BYTES: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");

fn register_font() {
    FONT.call_once(|| {
        // The font is compiled in, so failure here is a build mistake, not bad input.
        plotters::style::register_font("sans-serif", FontStyle::Normal, FONT_BYTES)
            .map_err(|_| ())
            .expect("bundled DejaVuSans.ttf is a valid font");
    });
}

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Style {
    /// Solid line.
    Line,
    /// Dashed line (fits, limits).
    Dashed,
    /// Small dots (raw samples).
    Points,
    /// Solid line with a marker at every point (one per test in a trend).
    LineMarkers,
    /// Thin solid line in palette colour `colour` (not the series' place): one of many series
    /// of a kind drawn alike, e.g. every forward stroke; give the name to one of them only.
    Thin {
        /// Index into the palette.
        colour: usize,
    },
    /// A level: a solid line in palette colour `colour` with a marker at its middle point, for
    /// a value known only as a mean over a span (its two end points).
    Level {
        /// Index into the palette.
        colour: usize,
    },
}

/// One named series of (x, y) points.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend entry.
    pub name: String,
    /// Points in plot units.
    pub points: Vec<(f64, f64)>,
    /// Drawing style.
    pub style: Style,
}

/// A line chart; axis labels must carry units, e.g. `"position (mm)"`.
#[derive(Debug, Clone)]
pub struct LineChart<'a> {
    /// Title above the plot.
    pub title: &'a str,
    /// X-axis label with unit.
    pub x_label: &'a str,
    /// Y-axis label with unit.
    pub y_label: &'a str,
    /// Series drawn in order, colours from a fixed palette; a series with an empty name has no
    /// legend entry.
    pub series: Vec<Series>,
}

/// A heat map of `z[iy][ix]` over cell centres `x[ix]`, `y[iy]` (both increasing).
#[derive(Debug, Clone)]
pub struct Heatmap<'a> {
    /// Title above the plot.
    pub title: &'a str,
    /// X-axis label with unit.
    pub x_label: &'a str,
    /// Y-axis label with unit.
    pub y_label: &'a str,
    /// Colour-scale label with unit, e.g. `"amplitude (N)"`.
    pub z_label: &'a str,
    /// Cell centres along x.
    pub x: Vec<f64>,
    /// Cell centres along y.
    pub y: Vec<f64>,
    /// Values, one row per y.
    pub z: Vec<Vec<f64>>,
}

const PALETTE: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
];

// Font sizes are given in pt; the SVG gets px at 0.81 of them (15 → 12.1 px): no text is
// smaller than 14 (11.3 px), the size of a plot label on a printed page.
const WIDTH: u32 = 960;
const HEIGHT: u32 = 540;

/// Canvas of a chart shown in a grid of two columns (the report's heat maps and trends), in
/// px: drawn at about the width it is shown at, so that its 12-16 px labels stay that size on
/// screen (a 960 px chart shrunk into a 560 px cell shows them at 7-9 px).
pub const TILE: (u32, u32) = (560, 400);

/// Title size (px) on a canvas `width` px wide: `full` on full-width charts, 17 on tiles,
/// where a long title at full size would run past the edge.
fn caption_px(width: u32, full: u32) -> u32 {
    if width < 800 {
        17
    } else {
        full
    }
}

/// Largest magnitude drawn: beyond it the axis arithmetic (margins, tick steps) overflows,
/// and the plotting library's tick search then never ends.
const MAX_PLOT_MAGNITUDE: f64 = 1e100;

/// Finite extent of the data with a small margin; errors when nothing finite is there or the
/// values are too large to draw. The margin is at least 1e-9 of the values' magnitude, so that
/// tick steps stay above the rounding step of the numbers they label (a range narrower than
/// that never advances and hangs the tick search).
fn extent(values: impl Iterator<Item = f64>) -> Result<(f64, f64)> {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if !lo.is_finite() {
        return Err(AppError::failed("no finite value to plot"));
    }
    let mag = lo.abs().max(hi.abs());
    if mag > MAX_PLOT_MAGNITUDE {
        return Err(AppError::failed(format!(
            "values up to {:.3e} cannot be plotted (at most {MAX_PLOT_MAGNITUDE:e}); the data \
             holds an implausible number",
            if hi.abs() >= lo.abs() { hi } else { lo }
        )));
    }
    let span = hi - lo;
    let pad = if span > 0.0 {
        (0.03 * span).max(1e-9 * mag)
    } else {
        0.5 * mag.max(1.0)
    };
    Ok((lo - pad, hi + pad))
}

fn plot_err<E: std::fmt::Debug>(e: E) -> AppError {
    AppError::failed(format!("drawing the plot failed: {e:?}"))
}

/// Render a line chart to SVG text.
///
/// # Errors
/// When no series holds a finite point, or plotters fails.
pub fn line_chart_svg(chart: &LineChart) -> Result<String> {
    stacked_svg(std::slice::from_ref(chart))
}

/// Render charts stacked vertically (e.g. forward above backward) into one SVG.
///
/// # Errors
/// When a chart holds no finite point, or plotters fails.
pub fn stacked_svg(charts: &[LineChart]) -> Result<String> {
    register_font();
    let n = charts.len().max(1) as u32;
    let height = if n == 1 { HEIGHT } else { 380 * n };
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (WIDTH, height)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        let areas = root.split_evenly((n as usize, 1));
        for (chart, area) in charts.iter().zip(areas.iter()) {
            draw_line_chart(chart, area, true)?;
        }
        root.present().map_err(plot_err)?;
    }
    Ok(svg)
}

/// Render a line chart with its legend below the plot, in two columns, so that no entry hides
/// data: for charts whose newest points are at the right edge (trends), or with many series.
///
/// # Errors
/// When no series holds a finite point, or plotters fails.
pub fn line_chart_legend_below_svg(chart: &LineChart) -> Result<String> {
    line_chart_legend_below_svg_sized(chart, (WIDTH, HEIGHT))
}

/// [`line_chart_legend_below_svg`] on a plot of `size` (width, height in px); the legend
/// below adds to the height, in one column on canvases narrower than 800 px.
///
/// # Errors
/// As [`line_chart_legend_below_svg`].
pub fn line_chart_legend_below_svg_sized(chart: &LineChart, size: (u32, u32)) -> Result<String> {
    register_font();
    const ROW: u32 = 22;
    let (width, height) = size;
    let columns = if width >= 800 { 2 } else { 1 };
    let rows = chart.series.len().div_ceil(columns) as u32;
    let legend_height = 12 + ROW * rows;
    let mut svg = String::new();
    {
        let root =
            SVGBackend::with_string(&mut svg, (width, height + legend_height)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        let (plot_area, legend_area) = root.split_vertically(height);
        draw_line_chart(chart, &plot_area, false)?;
        let column_width = (width as i32 - 80) / 2;
        for (k, s) in chart.series.iter().enumerate() {
            let colour = PALETTE[k % PALETTE.len()];
            let (row, column) = (k / columns, k % columns);
            let x = 84 + column as i32 * column_width;
            let y = 6 + row as i32 * ROW as i32 + 8;
            let colour = match s.style {
                Style::Thin { colour } | Style::Level { colour } => PALETTE[colour % PALETTE.len()],
                _ => colour,
            };
            let style = colour.stroke_width(2);
            let segments: Vec<(i32, i32)> = match s.style {
                Style::Dashed => vec![(x, x + 9), (x + 15, x + 24)],
                _ => vec![(x, x + 24)],
            };
            for (a, b) in segments {
                legend_area
                    .draw(&PathElement::new(vec![(a, y), (b, y)], style))
                    .map_err(plot_err)?;
            }
            if matches!(
                s.style,
                Style::LineMarkers | Style::Points | Style::Level { .. }
            ) {
                legend_area
                    .draw(&Circle::new((x + 12, y), 3, colour.filled()))
                    .map_err(plot_err)?;
            }
            legend_area
                .draw(&Text::new(
                    s.name.clone(),
                    (x + 32, y - 8),
                    ("sans-serif", 15).into_font(),
                ))
                .map_err(plot_err)?;
        }
        root.present().map_err(plot_err)?;
    }
    Ok(svg)
}

/// Draw one chart into `area`; with `legend_inside` the legend sits in the upper right, over
/// headroom added above the data.
fn draw_line_chart<DB: DrawingBackend>(
    chart: &LineChart,
    area: &DrawingArea<DB, plotters::coord::Shift>,
    legend_inside: bool,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let (x0, x1) = extent(
        chart
            .series
            .iter()
            .flat_map(|s| s.points.iter().map(|p| p.0)),
    )?;
    let (y0, y1) = extent(
        chart
            .series
            .iter()
            .flat_map(|s| s.points.iter().map(|p| p.1)),
    )?;
    // Headroom above the data for the legend.
    let y1 = if legend_inside {
        y1 + 0.18 * (y1 - y0)
    } else {
        y1
    };
    let mut ctx = ChartBuilder::on(area)
        .caption(
            chart.title,
            ("sans-serif", caption_px(area.dim_in_pixel().0, 20)),
        )
        .margin(12)
        .x_label_area_size(48)
        .y_label_area_size(72)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(plot_err)?;
    ctx.configure_mesh()
        .x_desc(chart.x_label)
        .y_desc(chart.y_label)
        .label_style(("sans-serif", 15))
        .axis_desc_style(("sans-serif", 17))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(plot_err)?;
    for (k, s) in chart.series.iter().enumerate() {
        let colour = match s.style {
            Style::Thin { colour } | Style::Level { colour } => PALETTE[colour % PALETTE.len()],
            _ => PALETTE[k % PALETTE.len()],
        };
        let pts = s
            .points
            .iter()
            .copied()
            .filter(|(x, y)| x.is_finite() && y.is_finite());
        let legend_colour = colour;
        let anno = match s.style {
            Style::Line => ctx
                .draw_series(LineSeries::new(pts, colour.stroke_width(2)))
                .map_err(plot_err)?,
            Style::Dashed => ctx
                .draw_series(DashedLineSeries::new(pts, 8, 5, colour.stroke_width(2)))
                .map_err(plot_err)?,
            Style::Points => ctx
                .draw_series(pts.map(|p| Circle::new(p, 1, colour.mix(0.5).filled())))
                .map_err(plot_err)?,
            Style::LineMarkers => {
                let pts: Vec<(f64, f64)> = pts.collect();
                ctx.draw_series(pts.iter().map(|&p| Circle::new(p, 3, colour.filled())))
                    .map_err(plot_err)?;
                ctx.draw_series(LineSeries::new(pts, colour.stroke_width(2)))
                    .map_err(plot_err)?
            }
            Style::Thin { .. } => ctx
                .draw_series(LineSeries::new(pts, colour.mix(0.8).stroke_width(1)))
                .map_err(plot_err)?,
            Style::Level { .. } => {
                let pts: Vec<(f64, f64)> = pts.collect();
                if let (Some(a), Some(b)) = (pts.first(), pts.last()) {
                    let mid = (0.5 * (a.0 + b.0), 0.5 * (a.1 + b.1));
                    ctx.draw_series(std::iter::once(Circle::new(mid, 3, colour.filled())))
                        .map_err(plot_err)?;
                }
                ctx.draw_series(LineSeries::new(pts, colour.stroke_width(2)))
                    .map_err(plot_err)?
            }
        };
        if s.name.is_empty() {
            continue;
        }
        let anno = anno.label(s.name.as_str());
        if matches!(s.style, Style::Level { .. }) {
            anno.legend(move |(x, y)| {
                EmptyElement::at((x, y))
                    + PathElement::new(vec![(0, 0), (18, 0)], legend_colour.stroke_width(3))
                    + Circle::new((9, 0), 3, legend_colour.filled())
            });
        } else {
            anno.legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 18, y)], legend_colour.stroke_width(3))
            });
        }
    }
    if legend_inside && chart.series.iter().any(|s| !s.name.is_empty()) {
        ctx.configure_series_labels()
            .label_font(("sans-serif", 14))
            .background_style(WHITE.mix(0.85))
            .border_style(RGBColor(180, 180, 180))
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(plot_err)?;
    }
    Ok(())
}

/// Render a heat map to SVG text, with a colour bar labelled `z_label`.
///
/// # Errors
/// When the grid is empty or ragged, or holds no finite value.
pub fn heatmap_svg(map: &Heatmap) -> Result<String> {
    heatmap_svg_sized(map, (WIDTH, HEIGHT))
}

/// [`heatmap_svg`] on a canvas of `size` (width, height in px).
///
/// # Errors
/// As [`heatmap_svg`].
pub fn heatmap_svg_sized(map: &Heatmap, size: (u32, u32)) -> Result<String> {
    register_font();
    let (width, height) = size;
    let (nx, ny) = (map.x.len(), map.y.len());
    if nx == 0 || ny == 0 || map.z.len() != ny || map.z.iter().any(|r| r.len() != nx) {
        return Err(AppError::failed(
            "heat map grid is empty or its rows do not match the axes",
        ));
    }
    let edges = |c: &[f64]| -> Vec<f64> {
        // Cell edges halfway between centres; the outer cells mirror their inner neighbour.
        let n = c.len();
        if n == 1 {
            return vec![c[0] - 0.5, c[0] + 0.5];
        }
        let mut e = Vec::with_capacity(n + 1);
        e.push(c[0] - 0.5 * (c[1] - c[0]));
        for k in 1..n {
            e.push(0.5 * (c[k - 1] + c[k]));
        }
        e.push(c[n - 1] + 0.5 * (c[n - 1] - c[n - 2]));
        e
    };
    let (xe, ye) = (edges(&map.x), edges(&map.y));
    let (z0, z1) = extent(map.z.iter().flatten().copied())?;
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (width, height)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        let (main, bar) = root.split_horizontally(width - 110);
        let mut ctx = ChartBuilder::on(&main)
            .caption(map.title, ("sans-serif", caption_px(width, 22)))
            .margin(12)
            .x_label_area_size(48)
            .y_label_area_size(72)
            .build_cartesian_2d(xe[0]..xe[nx], ye[0]..ye[ny])
            .map_err(plot_err)?;
        ctx.configure_mesh()
            .disable_mesh()
            .x_desc(map.x_label)
            .y_desc(map.y_label)
            .label_style(("sans-serif", 15))
            .axis_desc_style(("sans-serif", 17))
            .draw()
            .map_err(plot_err)?;
        let colour = |v: f64| ViridisRGB::get_color_normalized(v, z0, z1);
        ctx.draw_series((0..ny).flat_map(|iy| {
            let (xe, ye) = (&xe, &ye);
            (0..nx).filter_map(move |ix| {
                let v = map.z[iy][ix];
                v.is_finite().then(|| {
                    Rectangle::new(
                        [(xe[ix], ye[iy]), (xe[ix + 1], ye[iy + 1])],
                        colour(v).filled(),
                    )
                })
            })
        }))
        .map_err(plot_err)?;
        // Colour bar.
        let mut cb = ChartBuilder::on(&bar)
            .margin_top(46)
            .margin_bottom(60)
            .margin_right(8)
            .y_label_area_size(62)
            .build_cartesian_2d(0.0..1.0, z0..z1)
            .map_err(plot_err)?;
        cb.configure_mesh()
            .disable_mesh()
            .disable_x_axis()
            .y_desc(map.z_label)
            .label_style(("sans-serif", 14))
            .axis_desc_style(("sans-serif", 15))
            .draw()
            .map_err(plot_err)?;
        let steps = 64;
        cb.draw_series((0..steps).map(|k| {
            let a = z0 + (z1 - z0) * k as f64 / steps as f64;
            let b = z0 + (z1 - z0) * (k + 1) as f64 / steps as f64;
            Rectangle::new([(0.0, a), (1.0, b)], colour(0.5 * (a + b)).filled())
        }))
        .map_err(plot_err)?;
        root.present().map_err(plot_err)?;
    }
    Ok(svg)
}

/// Write SVG text to `path`, atomically ([`crate::output::write_atomic`]).
///
/// # Errors
/// I/O errors, with the path in the message.
pub fn write_svg(path: &Path, svg: &str) -> Result<()> {
    crate::output::write_atomic(path, svg.as_bytes())
}

/// Up to this many strokes of a direction are each drawn in a colour of their own and named
/// in the legend ([`friction_svg`]); more are drawn thin in one colour per kind, with one
/// legend entry per kind that counts them.
pub const PLOT_NAMED_STROKES: usize = 6;

/// Friction vs position: one panel per direction, with optional extra series (e.g. the
/// truth) per direction. Every stroke is drawn: a profile as a line, a stroke whose data
/// support only its mean level as a flat segment at that level with a marker at its middle.
/// Up to [`PLOT_NAMED_STROKES`] strokes a panel are named one by one; more are drawn thin,
/// in the direction's colour, and the legend counts them.
pub fn friction_svg(
    plot: &FrictionPlot,
    title: &str,
    mut extra_forward: Vec<Series>,
    mut extra_backward: Vec<Series>,
) -> Result<String> {
    let mut charts_series = Vec::new();
    for (d, (label, strokes, extra)) in [
        ("forward", &plot.forward, &mut extra_forward),
        ("backward", &plot.backward, &mut extra_backward),
    ]
    .into_iter()
    .enumerate()
    {
        if strokes.is_empty() {
            continue;
        }
        let (numbers, flat) = (&plot.numbers[d], &plot.mean_only[d]);
        let is_flat = |k: usize| flat.get(k).copied().unwrap_or(false);
        let mut series: Vec<Series> = if strokes.len() <= PLOT_NAMED_STROKES {
            strokes
                .iter()
                .enumerate()
                .map(|(k, pts)| Series {
                    // Numbered as in the console table and the CSV, not within the plot.
                    name: match (strokes.len() > 1, is_flat(k)) {
                        (_, true) => format!(
                            "{label} stroke {}: mean level only (no profile supported)",
                            numbers[k]
                        ),
                        (true, false) => format!("{label} stroke {}", numbers[k]),
                        (false, false) => {
                            format!("{label} stroke {} (estimated)", numbers[k])
                        }
                    },
                    points: pts.clone(),
                    style: if is_flat(k) {
                        Style::Level { colour: k }
                    } else {
                        Style::Line
                    },
                })
                .collect()
        } else {
            let n_flat = (0..strokes.len()).filter(|&k| is_flat(k)).count();
            let n_profile = strokes.len() - n_flat;
            let (mut named_profile, mut named_flat) = (false, false);
            strokes
                .iter()
                .enumerate()
                .map(|(k, pts)| {
                    let (name, style) = if is_flat(k) {
                        let name = (!std::mem::replace(&mut named_flat, true)).then(|| {
                            format!(
                                "{label}: {n_flat} of {} strokes, mean level only (no \
                                 profile supported)",
                                strokes.len()
                            )
                        });
                        (name, Style::Level { colour: d + 2 })
                    } else {
                        let name = (!std::mem::replace(&mut named_profile, true)).then(|| {
                            format!(
                                "{label}: {n_profile} of {} strokes, friction along the \
                                 travel",
                                strokes.len()
                            )
                        });
                        (name, Style::Thin { colour: d })
                    };
                    Series {
                        name: name.unwrap_or_default(),
                        points: pts.clone(),
                        style,
                    }
                })
                .collect()
        };
        series.append(extra);
        charts_series.push((label, series));
    }
    let titles: Vec<String> = charts_series
        .iter()
        .map(|(label, _)| format!("{title}: {label}"))
        .collect();
    let charts: Vec<LineChart> = charts_series
        .into_iter()
        .zip(&titles)
        .map(|((_, series), t)| LineChart {
            title: t,
            x_label: "position (mm)",
            y_label: if plot.sign_from_direction {
                "friction F_f (N, sign from the direction of motion)"
            } else {
                "friction F_f (N, signed as Eq. 5)"
            },
            series,
        })
        .collect();
    stacked_svg(&charts)
}

/// The picture of an estimation: friction along the travel of every stroke
/// ([`friction_svg`]), titled with the axis's name and what the data support, and when the
/// effort is a magnitude, that the sign comes from the direction of motion.
///
/// # Errors
/// As [`friction_svg`].
pub fn estimate_svg(estimated: &Estimated) -> Result<String> {
    let report = &estimated.report;
    let name = report.axis.name.as_deref().unwrap_or("axis");
    let v = &report.verdict;
    friction_svg(
        &estimated.plot,
        &format!(
            "Friction along the travel ({name}); data support: {}{}",
            v.support.as_str(),
            if v.friction_sign == FrictionSign::FromDirection {
                "; sign from direction"
            } else {
                ""
            }
        ),
        vec![],
        vec![],
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_chart_renders_labels() {
        let svg = line_chart_svg(&LineChart {
            title: "t",
            x_label: "position (mm)",
            y_label: "friction (N)",
            series: vec![
                Series {
                    name: "forward".into(),
                    points: vec![(0.0, 1.0), (1.0, 2.0), (2.0, f64::NAN)],
                    style: Style::Line,
                },
                Series {
                    name: "fit".into(),
                    points: vec![(0.0, 1.5), (2.0, 1.5)],
                    style: Style::Dashed,
                },
            ],
        })
        .unwrap();
        assert!(svg.contains("position (mm)") && svg.contains("friction (N)"));
        assert!(svg.contains("forward"));
    }

    /// The legend below the plot: every entry is drawn, markers mark each point, and the plot
    /// area keeps no headroom for a legend inside it.
    #[test]
    fn legend_below_lists_every_series_and_marks_points() {
        let chart = LineChart {
            title: "t",
            x_label: "weeks since the first test",
            y_label: "Fs (N)",
            series: vec![
                Series {
                    name: "value (N)".into(),
                    points: vec![(0.0, 1.0), (1.0, 2.0), (2.0, 3.0)],
                    style: Style::LineMarkers,
                },
                Series {
                    name: "baseline 1.00".into(),
                    points: vec![(0.0, 1.0), (2.0, 1.0)],
                    style: Style::Dashed,
                },
                Series {
                    name: "third entry".into(),
                    points: vec![(0.0, 2.0), (2.0, 2.0)],
                    style: Style::Line,
                },
            ],
        };
        let below = line_chart_legend_below_svg(&chart).unwrap();
        for name in ["value (N)", "baseline 1.00", "third entry"] {
            assert!(below.contains(name), "{name}");
        }
        // 3 markers on the data and 1 in the legend.
        assert_eq!(below.matches("<circle").count(), 4, "{below}");
        let inside = line_chart_svg(&chart).unwrap();
        assert_eq!(inside.matches("<circle").count(), 3);
    }

    #[test]
    fn heatmap_renders_and_rejects_ragged() {
        let ok = heatmap_svg(&Heatmap {
            title: "h",
            x_label: "order (cycles/rev)",
            y_label: "position (mm)",
            z_label: "amplitude (N)",
            x: vec![0.0, 1.0, 2.0],
            y: vec![10.0, 20.0],
            z: vec![vec![0.0, 1.0, 2.0], vec![3.0, 4.0, 5.0]],
        })
        .unwrap();
        assert!(ok.contains("amplitude (N)"));
        let bad = heatmap_svg(&Heatmap {
            title: "h",
            x_label: "x",
            y_label: "y",
            z_label: "z",
            x: vec![0.0, 1.0],
            y: vec![0.0],
            z: vec![vec![0.0]],
        });
        assert!(bad.is_err());
    }

    /// Found by fuzzing: a value of 1.797e308 overflowed the margins and hung the tick search;
    /// a range far below the values' rounding step did the same.
    #[test]
    fn huge_values_are_an_error_and_narrow_ranges_render() {
        let chart = |ys: [f64; 2]| LineChart {
            title: "t",
            x_label: "position (mm)",
            y_label: "friction (N)",
            series: vec![Series {
                name: String::new(),
                points: vec![(0.0, ys[0]), (1.0, ys[1])],
                style: Style::Line,
            }],
        };
        let err = line_chart_svg(&chart([1.797e308, 0.0])).unwrap_err();
        assert!(format!("{err:#}").contains("cannot be plotted"), "{err:#}");
        assert!(line_chart_svg(&chart([-1e200, 0.0])).is_err());
        for ys in [[1e20, 1e20 + 4096.0], [5.0, 5.0], [0.0, 0.0], [1e99, -1e99]] {
            let svg = line_chart_svg(&chart(ys)).unwrap();
            assert!(svg.contains("friction (N)"), "{ys:?}");
        }
    }

    #[test]
    fn nothing_finite_is_an_error() {
        let r = line_chart_svg(&LineChart {
            title: "t",
            x_label: "x",
            y_label: "y",
            series: vec![Series {
                name: String::new(),
                points: vec![(f64::NAN, 1.0)],
                style: Style::Points,
            }],
        });
        assert!(r.is_err());
    }
}
