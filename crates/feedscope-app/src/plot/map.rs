//! The pictures of a friction map (paper 000, Section 4.2): friction against feed at the
//! chosen positions with the Stribeck fit and the map's section (Fig. 14), the map F(z, v)
//! of each direction as a heat map, the repeats of one feed with their mean (Fig. 11) and the
//! mean curves of several feeds (Fig. 12).
use feedscope::map::{DirectionMap, FeedGroup};
use feedscope::profile::PiecewisePoly;
use feedscope::stribeck::{FrictionModel, M_S_PER_MM_MIN};
use feedscope::study::{map_grid, MapStudy};

use super::{heatmap_svg, stacked_svg, Heatmap, LineChart, Result, Series, Style};
use crate::AppError;

/// `n` feeds from `lo` to `hi` (mm/min), evenly spaced in log-feed.
fn log_feeds(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| lo * (hi / lo).powf(i as f64 / (n - 1) as f64))
        .collect()
}

/// The measured feed of `d` nearest `plot_feed_mm_min` (default: the slowest).
fn nearest_feed(d: &DirectionMap, plot_feed_mm_min: Option<f64>) -> &FeedGroup {
    let target = plot_feed_mm_min.unwrap_or(d.feeds[0].feed_mm_min);
    d.feeds
        .iter()
        .min_by(|a, b| {
            (a.feed_mm_min - target)
                .abs()
                .total_cmp(&(b.feed_mm_min - target).abs())
        })
        .expect("a mapped direction has a feed group")
}

/// Every SVG of a map as (file name, content), in this order: `friction_vs_feed.svg` (one
/// chart per direction and chosen position, feeds as log10 of mm/min), `map_<direction>.svg`
/// (friction in N over position in mm and log10 feed), `iafv_repeats.svg` (the repeats of
/// the feed nearest `plot_feed_mm_min`, default the slowest, and their PPOCM) and
/// `mvoiaf.svg` (the PPOCM of up to 8 feeds).
///
/// # Errors
/// A chart that cannot be drawn (no finite value); the map refusing a feed inside its
/// measured ones (a bug, reported rather than a panic).
pub fn map_svgs(study: &MapStudy, plot_feed_mm_min: Option<f64>) -> Result<Vec<(String, String)>> {
    let (map, at) = (&study.map, &study.at_positions);
    let mut out = Vec::new();
    // Friction vs feed at the chosen positions: PPOCM points, Stribeck fit, map section (Fig. 14).
    let mut titles = Vec::new();
    for p in at {
        for q in &p.positions {
            titles.push(format!(
                "{} at {:.3} mm: friction vs feed",
                p.direction.as_str(),
                q.position_mm
            ));
        }
    }
    let mut charts = Vec::new();
    let mut t = titles.iter();
    for p in at {
        let d = map
            .direction(p.direction)
            .expect("the Stribeck fits are of mapped directions");
        let fine = log_feeds(
            d.feed_model.feed_min_mm_min,
            d.feed_model.feed_max_mm_min,
            120,
        );
        for q in &p.positions {
            let mut series = vec![Series {
                name: "PPOCM at the measured feeds (joined)".into(),
                points: p
                    .feeds_mm_min
                    .iter()
                    .map(|f| f.log10())
                    .zip(q.friction_n.iter().copied())
                    .collect(),
                // Joined: the chart draws points as 1 px dots, invisible for a few feeds.
                style: Style::Dashed,
            }];
            if let Some(f) = &q.fit {
                series.push(Series {
                    name: match f.model {
                        FrictionModel::Stribeck => "Stribeck fit (Eq. 9)".into(),
                        m => format!("{m} fit"),
                    },
                    points: fine
                        .iter()
                        .map(|&x| (x.log10(), f.magnitude_n(x * M_S_PER_MM_MIN)))
                        .collect(),
                    style: Style::Line,
                });
            }
            series.push(Series {
                name: "map section (Eq. 8)".into(),
                points: fine
                    .iter()
                    .filter_map(|&x| {
                        d.friction_n(q.position_mm, x, false)
                            .ok()
                            .map(|v| (x.log10(), v.abs()))
                    })
                    .collect(),
                style: Style::Line,
            });
            charts.push(LineChart {
                title: t.next().expect("a title per position"),
                // Feeds are log-spaced and the chart axes linear: plot log10 of the feed.
                x_label: "log10 of feed (feed in mm/min)",
                y_label: "friction magnitude (N)",
                series,
            });
        }
    }
    out.push(("friction_vs_feed.svg".to_string(), stacked_svg(&charts)?));

    for (d, zs) in map.directions.iter().zip(&study.grids_mm) {
        let feeds = log_feeds(
            d.feed_model.feed_min_mm_min,
            d.feed_model
                .feed_max_mm_min
                .max(d.feed_model.feed_min_mm_min * 1.0001),
            40,
        );
        // Two feeds at least (the study refuses one), so the log-spaced feeds lie inside the
        // measured ones; an error here is a bug, reported rather than a panic.
        let z: Vec<Vec<f64>> = feeds
            .iter()
            .map(|&f| {
                let p = d.poly_at(f, false).map_err(AppError::from_error)?;
                Ok(zs.iter().map(|&x| p.value_n(x * 1e-3)).collect())
            })
            .collect::<Result<_>>()?;
        let dir = d.direction.as_str();
        let title = format!("friction map F(z, v), {dir} (signed)");
        out.push((
            format!("map_{dir}.svg"),
            heatmap_svg(&Heatmap {
                title: &title,
                x_label: "position (mm)",
                y_label: "log10 of feed (feed in mm/min)",
                z_label: "friction (N)",
                x: zs.clone(),
                y: feeds.iter().map(|f| f.log10()).collect(),
                z,
            })?,
        ));
    }

    // Repeats and their mean at one feed (Fig. 11); mean curves of several feeds (Fig. 12).
    let t11: Vec<String> = map
        .directions
        .iter()
        .map(|d| {
            format!(
                "{} at {} mm/min: IAFV of the repeats and their PPOCM",
                d.direction.as_str(),
                nearest_feed(d, plot_feed_mm_min).feed_mm_min
            )
        })
        .collect();
    let t12: Vec<String> = map
        .directions
        .iter()
        .map(|d| {
            format!(
                "{}: mean friction (PPOCM) along the travel per feed",
                d.direction.as_str()
            )
        })
        .collect();
    let mut c11 = Vec::new();
    let mut c12 = Vec::new();
    for (k, d) in map.directions.iter().enumerate() {
        let zs = map_grid(d, (d.end_mm - d.start_mm) / 200.0);
        let curve = |p: &PiecewisePoly| -> Vec<(f64, f64)> {
            zs.iter().map(|&x| (x, p.value_n(x * 1e-3))).collect()
        };
        let g = nearest_feed(d, plot_feed_mm_min);
        let mut s: Vec<Series> = g
            .repeats
            .iter()
            .map(|r| Series {
                name: format!("{} (repeat {})", r.run, r.repeat),
                points: curve(&r.poly),
                style: Style::Line,
            })
            .collect();
        s.push(Series {
            name: "PPOCM (mean)".into(),
            points: curve(&g.ppocm),
            style: Style::Dashed,
        });
        c11.push(LineChart {
            title: &t11[k],
            x_label: "position (mm)",
            y_label: "friction (N)",
            series: s,
        });
        // Up to 8 feeds, the slowest and the fastest among them.
        let n = d.feeds.len();
        let pick: Vec<usize> = if n <= 8 {
            (0..n).collect()
        } else {
            (0..8).map(|i| (i * (n - 1) + 3) / 7).collect()
        };
        c12.push(LineChart {
            title: &t12[k],
            x_label: "position (mm)",
            y_label: "friction (N)",
            series: pick
                .iter()
                .map(|&i| Series {
                    name: format!("{} mm/min", d.feeds[i].feed_mm_min),
                    points: curve(&d.feeds[i].ppocm),
                    style: Style::Line,
                })
                .collect(),
        });
    }
    out.push(("iafv_repeats.svg".to_string(), stacked_svg(&c11)?));
    out.push(("mvoiaf.svg".to_string(), stacked_svg(&c12)?));
    Ok(out)
}
