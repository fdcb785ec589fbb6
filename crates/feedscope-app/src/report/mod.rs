//! The condition report of an axis: the page model ([`page`]: every chart drawn, every number
//! formatted) and one self-contained HTML file of it ([`render_html`]: plots inline as SVG, no
//! script, no network, from `report.html` with minijinja). The CLI's `feedscope report` writes
//! the file through a [`ReportRequest`]; a server shows the same page.
use feedscope::history::{Extent, Indicator, IndicatorTrend, ProfileChanges, Status, TrendParams};
use feedscope::units::MM_MIN_PER_M_S;
use feedscope_store::{Identified, Store, Stored, TestDetail};
use serde::Serialize;

use crate::error::AppError;
use crate::output::write_atomic;
use crate::plot::{self, Heatmap, LineChart, Series, Style};
use crate::store::{Opener, StoreSpec};
use crate::trend::{AxisTrends, TrendRequest};
use crate::FrontEnd;
use feedscope::study::Curves;

type Result<T, E = AppError> = std::result::Result<T, E>;

const TEMPLATE: &str = include_str!("report.html");

/// A chart of the page: its title and its SVG text.
#[derive(Debug, Clone, Serialize)]
pub struct Chart {
    /// Caption.
    pub title: String,
    /// The SVG document (sized by its container once on the page).
    pub svg: String,
}

/// One indicator's line of the trend table, every number formatted in the indicator's unit
/// (`–` where there is none).
#[derive(Debug, Clone, Serialize)]
pub struct Row {
    /// Indicator key ([`Indicator::name`]).
    pub name: String,
    /// The indicator in words.
    pub label: String,
    /// Its unit.
    pub unit: String,
    /// Tests in its series.
    pub n: usize,
    /// Baseline mean μ₀.
    pub baseline: String,
    /// Baseline σ.
    pub sigma: String,
    /// The σ floor of this indicator (its unit) and whether σ was raised to it.
    pub floor: String,
    /// Lower control limit.
    pub lower: String,
    /// Upper control limit.
    pub upper: String,
    /// Latest value.
    pub latest: String,
    /// Latest change against the baseline (%).
    pub change: String,
    /// EWMA statistic.
    pub ewma: String,
    /// CUSUM statistics.
    pub cusum: String,
    /// The threshold in force, if any.
    pub threshold: String,
    /// When the trend crosses the threshold, if it is projected to.
    pub projection: String,
    /// Status key (`ok`, `drifting`, `out-of-limits`, `threshold-crossed`).
    pub status: String,
    /// CSS class of the status.
    pub css: &'static str,
}

/// One stored test in the page's list.
#[derive(Debug, Clone, Serialize)]
pub struct TestLine {
    /// Test id in the store.
    pub id: i64,
    /// Test time (RFC 3339 UTC).
    pub time: String,
    /// Kind of test.
    pub kind: String,
    /// Source trace.
    pub source: String,
    /// The axis's reference test.
    pub reference: bool,
    /// Its results in one line.
    pub summary: String,
}

/// One identified parameter of the latest triangle test.
#[derive(Debug, Clone, Serialize)]
pub struct Param {
    /// The parameter in words.
    pub name: &'static str,
    /// Value.
    pub value: String,
    /// Standard error (empty where none).
    pub std_error: String,
    /// Unit.
    pub unit: &'static str,
}

/// The condition report of one axis: what `report.html` lays out, and what any other front
/// end (a server's axis page) shows, from one source.
#[derive(Debug, Clone, Serialize)]
pub struct Page {
    /// Machine name.
    pub machine: String,
    /// Axis name.
    pub axis: String,
    /// When the page was made (RFC 3339 UTC).
    pub generated: String,
    /// The stored tests, in time order.
    pub tests: Vec<TestLine>,
    /// Time of the first test.
    pub first_time: String,
    /// Time of the last test.
    pub last_time: String,
    /// Indicators per status key, worst first.
    pub counts: Vec<(String, usize)>,
    /// The diagnosis in sentences (or why none can be made).
    pub diagnosis: Vec<String>,
    /// No indicator has a baseline yet.
    pub no_baseline: bool,
    /// The σ floor in words (what it is, its value).
    pub sigma_floor: String,
    /// The indicators that are not ok, worst first.
    pub warnings: Vec<Row>,
    /// The latest stroke test's friction profile with its IAFV.
    pub profile: Option<Chart>,
    /// Which test that is.
    pub profile_test: Option<String>,
    /// The data verdict of that test, in words.
    pub profile_verdict: Option<String>,
    /// Its fluctuation spectra along the travel.
    pub heatmaps: Vec<Chart>,
    /// Position × test maps of the friction change against the profile baseline.
    pub wear_maps: Vec<Chart>,
    /// How to read them and what the comparison found, in words.
    pub wear_notes: Vec<String>,
    /// The identified Stribeck curves of the triangle tests.
    pub stribeck: Option<Chart>,
    /// The latest triangle test's identified parameters.
    pub params: Vec<Param>,
    /// Which test that is.
    pub params_test: Option<String>,
    /// One chart per indicator with its limits.
    pub trend_charts: Vec<Chart>,
    /// The trend table, every indicator.
    pub rows: Vec<Row>,
    /// Mean friction per interval of the latest stroke test.
    pub intervals: Vec<feedscope_store::IntervalRow>,
    /// Its significant whole-stroke components.
    pub components: Vec<feedscope_store::ComponentRow>,
    /// Stored indicators without a trend (no baseline, or unknown to this version).
    pub skipped: Vec<String>,
    /// The feedscope version that made the page.
    pub version: &'static str,
}

fn num(x: f64) -> String {
    if !x.is_finite() {
        "–".into()
    } else if x == 0.0 || (0.1..1e5).contains(&x.abs()) {
        format!("{x:.2}")
    } else {
        format!("{x:.3e}")
    }
}

fn css(s: Status) -> &'static str {
    match s {
        Status::ThresholdCrossed => "alarm",
        Status::OutOfLimits => "alarm",
        Status::Drifting => "warn",
        Status::Ok => "ok",
    }
}

fn row(t: &IndicatorTrend) -> Row {
    let n = t.points.len();
    let last = t.points.last().map_or(f64::NAN, |p| p.value);
    let th = match (t.threshold.lower, t.threshold.upper) {
        (None, None) => "–".to_string(),
        (l, u) => format!(
            "{} … {}",
            l.map_or("".into(), num),
            u.map_or("".into(), num)
        ),
    };
    Row {
        name: t.indicator.name(),
        label: t.indicator.label(),
        unit: t.indicator.unit().into(),
        n,
        baseline: num(t.baseline.mean),
        sigma: num(t.baseline.std),
        floor: format!(
            "{}{}",
            num(sigma_floor_fraction() * t.baseline.mean.abs()),
            if t.baseline.std_floored {
                " (σ raised to it)"
            } else {
                ""
            }
        ),
        lower: num(t.limits.lower),
        upper: num(t.limits.upper),
        latest: num(last),
        change: format!("{:+.1} % ({:+.1} σ)", t.change_percent, t.change_sigma),
        ewma: t.ewma.z.last().map_or("–".into(), |z| num(*z)),
        cusum: format!(
            "{:.1} / {:.1}",
            t.cusum.upper.last().copied().unwrap_or(0.0),
            t.cusum.lower.last().copied().unwrap_or(0.0)
        ),
        threshold: th,
        projection: t.projection.map_or("–".into(), |p| {
            format!("{} in ~{:.0} days", num(p.threshold), p.days)
        }),
        status: t.status.as_str().into(),
        css: css(t.status),
    }
}

/// Trend chart: values, baseline, Shewhart and EWMA limits, EWMA, threshold, projection.
fn trend_chart(t: &IndicatorTrend) -> Result<Chart> {
    let t0 = t.points[0].time_s;
    let wk = |s: f64| (s - t0) / (7.0 * 86_400.0);
    let xs: Vec<f64> = t.points.iter().map(|p| wk(p.time_s)).collect();
    let (x0, x1) = (xs[0], *xs.last().expect("non-empty"));
    let flat = |y: f64| vec![(x0, y), (x1, y)];
    let mut series = vec![
        Series {
            name: format!("value ({})", t.indicator.unit()),
            points: xs
                .iter()
                .zip(&t.points)
                .map(|(&x, p)| (x, p.value))
                .collect(),
            // A marker per test: the tests are few and unevenly spaced in time.
            style: Style::LineMarkers,
        },
        Series {
            name: "EWMA (λ 0.2)".into(),
            points: xs.iter().copied().zip(t.ewma.z.iter().copied()).collect(),
            style: Style::Line,
        },
        Series {
            name: "EWMA limits".into(),
            points: xs
                .iter()
                .zip(&t.ewma.limits)
                .map(|(&x, l)| (x, l.upper))
                .collect(),
            style: Style::Dashed,
        },
        Series {
            name: "EWMA lower limit".into(),
            points: xs
                .iter()
                .zip(&t.ewma.limits)
                .map(|(&x, l)| (x, l.lower))
                .collect(),
            style: Style::Dashed,
        },
        Series {
            name: format!("baseline {}", num(t.baseline.mean)),
            points: flat(t.baseline.mean),
            style: Style::Dashed,
        },
        Series {
            name: "±3σ limits".into(),
            points: flat(t.limits.upper),
            style: Style::Dashed,
        },
        Series {
            name: "−3σ".into(),
            points: flat(t.limits.lower),
            style: Style::Dashed,
        },
    ];
    for (v, name) in [
        (t.threshold.upper, "upper threshold"),
        (t.threshold.lower, "lower threshold"),
    ] {
        if let Some(v) = v {
            series.push(Series {
                name: format!("{name} {}", num(v)),
                points: flat(v),
                style: Style::Line,
            });
        }
    }
    if let (Some(p), Some(s)) = (&t.projection, &t.slope) {
        let xe = x1 + p.days / 7.0;
        series.push(Series {
            name: format!("projection: {} in ~{:.0} days", num(p.threshold), p.days),
            points: vec![(x1, s.value_at_last), (xe, p.threshold)],
            style: Style::Dashed,
        });
    }
    let title = format!("{} [{}]", t.indicator.label(), t.status.as_str());
    let y_label = format!("{} ({})", t.indicator.label(), t.indicator.unit());
    // The legend goes below: inside, its corner would hide the newest tests at the right.
    let svg = plot::line_chart_legend_below_svg_sized(
        &LineChart {
            title: &title,
            x_label: "weeks since the first test",
            y_label: &y_label,
            series,
        },
        plot::TILE,
    )?;
    Ok(Chart { title, svg })
}

/// The date part of an RFC 3339 time (the whole text if it is shorter or not ASCII there).
fn date(t: &str) -> &str {
    t.get(..10).unwrap_or(t)
}

/// F(v) = F_c + (F_s − F_c)·exp(−(v/v_s)^δ) + σ·v for v ≥ 0 (paper 002 Eq. 2, force side).
fn stribeck_points(p: &Identified, v_max_mm_min: f64) -> Vec<(f64, f64)> {
    (0..=200)
        .map(|k| {
            let v = v_max_mm_min * k as f64 / 200.0;
            let f = p.fc_n
                + (p.fs_n - p.fc_n) * (-(v / p.vs_mm_min).abs().powf(p.delta)).exp()
                + p.sigma_n_s_per_m * v / MM_MIN_PER_M_S;
            (v, f)
        })
        .collect()
}

fn stribeck_chart(tests: &[TestDetail]) -> Result<Option<Chart>> {
    let ident: Vec<(&TestDetail, &Identified)> = tests
        .iter()
        .filter_map(|t| t.identified.as_ref().map(|p| (t, p)))
        .collect();
    if ident.is_empty() {
        return Ok(None);
    }
    // First, a few in between and the latest: at most 5 curves.
    let n = ident.len();
    let mut pick: Vec<usize> = (0..5).map(|k| k * (n - 1) / 4).collect();
    pick.dedup();
    let v_max = ident
        .iter()
        .map(|(_, p)| p.vs_mm_min)
        .fold(0.0f64, f64::max)
        .mul_add(8.0, 0.0)
        .clamp(100.0, 6000.0);
    let series = pick
        .iter()
        .enumerate()
        .map(|(k, &i)| Series {
            name: format!(
                "test {} ({})",
                ident[i].0.test.id,
                date(&ident[i].0.test.time_utc)
            ),
            points: stribeck_points(ident[i].1, v_max),
            style: if k + 1 == pick.len() {
                Style::Line
            } else {
                Style::Dashed
            },
        })
        .collect();
    let title = "Stribeck curves, first to latest triangle test".to_string();
    let svg = plot::line_chart_svg(&LineChart {
        title: &title,
        x_label: "feed velocity (mm/min)",
        y_label: "friction force F (N)",
        series,
    })?;
    Ok(Some(Chart { title, svg }))
}

fn profile_chart(
    c: &Curves,
    test: &TestDetail,
    changes: Option<&ProfileChanges>,
) -> Result<Option<Chart>> {
    if c.profiles.is_empty() {
        return Ok(None);
    }
    let titles: Vec<String> = c
        .profiles
        .iter()
        .map(|p| {
            format!(
                "Friction and IAFV, {} at {:.0} mm/min (test {}, {})",
                p.direction,
                p.feed_mm_min,
                test.test.id,
                date(&test.test.time_utc)
            )
        })
        .collect();
    // The stroke ends carry acceleration transients of several times the friction: they would
    // set the scale, so points further than 10 robust σ from the IAFV are not drawn.
    let keep: Vec<Vec<bool>> = c
        .profiles
        .iter()
        .map(|p| {
            let mut r: Vec<f64> = p
                .friction_n
                .iter()
                .zip(&p.iafv_n)
                .map(|(f, m)| (f - m).abs())
                .collect();
            let mut sorted = r.clone();
            sorted.sort_by(f64::total_cmp);
            let mad = sorted.get(sorted.len() / 2).copied().unwrap_or(0.0);
            let lim = 10.0 * 1.4826 * mad.max(1e-9);
            r.iter_mut().map(|x| *x <= lim).collect()
        })
        .collect();
    let charts: Vec<LineChart> = c
        .profiles
        .iter()
        .zip(&titles)
        .zip(&keep)
        .map(|((p, title), keep)| LineChart {
            title,
            x_label: "position (mm)",
            y_label: "friction F_f (N)",
            series: {
                let mut v = vec![
                    Series {
                        name: "estimated friction".into(),
                        points: p
                            .position_mm
                            .iter()
                            .zip(&p.friction_n)
                            .zip(keep)
                            .filter(|(_, &k)| k)
                            .map(|((&z, &f), _)| (z, f))
                            .collect(),
                        style: Style::Line,
                    },
                    Series {
                        name: format!(
                            "IAFV, intervals at {:?} mm",
                            p.breaks_mm.iter().map(|b| b.round()).collect::<Vec<_>>()
                        ),
                        points: p
                            .position_mm
                            .iter()
                            .copied()
                            .zip(p.iafv_n.iter().copied())
                            .collect(),
                        style: Style::Line,
                    },
                ];
                v.extend(flagged_series(p, test.test.id, changes));
                v
            },
        })
        .collect();
    Ok(Some(Chart {
        title: "Latest friction profile".into(),
        svg: plot::stacked_svg(&charts)?,
    }))
}

/// The position-resolved comparison on the profile plot of test `id`: its smoothed profile,
/// the baseline profile and each flagged range as a bar above the curves. Friction is drawn
/// signed (backward negative), so the magnitudes of the comparison take the direction's sign.
fn flagged_series(
    p: &feedscope::study::ProfileCurve,
    id: i64,
    changes: Option<&ProfileChanges>,
) -> Vec<Series> {
    let Some(d) = changes.and_then(|c| {
        c.directions
            .iter()
            .find(|d| d.direction.as_str() == p.direction)
    }) else {
        return vec![];
    };
    let Some(t) = d.tests.iter().find(|t| t.test_id == id) else {
        return vec![];
    };
    let sign = if p.direction == "backward" { -1.0 } else { 1.0 };
    let mut v = vec![
        Series {
            name: "baseline profile (smoothed over one lead)".into(),
            points: d
                .position_mm
                .iter()
                .zip(&d.baseline_n)
                .map(|(&x, &m)| (x, sign * m))
                .collect(),
            style: Style::Dashed,
        },
        Series {
            name: "this test (smoothed over one lead)".into(),
            points: d
                .position_mm
                .iter()
                .zip(&d.baseline_n)
                .zip(&t.change_n)
                .filter_map(|((&x, &m), c)| c.map(|c| (x, sign * (m + c))))
                .collect(),
            style: Style::Line,
        },
    ];
    let top = d
        .baseline_n
        .iter()
        .copied()
        .fold(f64::NEG_INFINITY, f64::max);
    for r in &t.ranges {
        // Just above the baseline's highest point, clear of the curves.
        let y = sign * 1.03 * top;
        v.push(Series {
            name: format!(
                "flagged {:.0}-{:.0} mm: {:+.1} N ({:+.1} %) at {:.0} mm, {}",
                r.start_mm,
                r.end_mm,
                r.height_n,
                r.height_percent,
                r.peak_mm,
                match r.extent {
                    Extent::Local => "local",
                    Extent::WholeTravel => "whole travel",
                }
            ),
            points: vec![(r.start_mm, y), (r.end_mm.max(r.start_mm + 0.5), y)],
            style: Style::LineMarkers,
        });
    }
    v
}

/// One heat map per compared direction: the friction change d(x) = s(x) − m(x) of every
/// stroke test (rows, time order) along the travel (columns).
fn wear_maps(c: &ProfileChanges) -> Result<Vec<Chart>> {
    c.directions
        .iter()
        .filter(|d| d.tests.len() >= 2 && d.position_mm.len() >= 2)
        .map(|d| {
            let title = format!(
                "Friction change along the travel, {}: where is it wearing",
                d.direction.as_str()
            );
            let svg = plot::heatmap_svg_sized(
                &Heatmap {
                    title: &title,
                    x_label: "position (mm)",
                    y_label: "stroke test (in time order)",
                    z_label: "change from baseline (N)",
                    x: d.position_mm.clone(),
                    y: (1..=d.tests.len()).map(|k| k as f64).collect(),
                    z: d.tests
                        .iter()
                        .map(|t| t.change_n.iter().map(|x| x.unwrap_or(f64::NAN)).collect())
                        .collect(),
                },
                plot::TILE,
            )?;
            Ok(Chart { title, svg })
        })
        .collect()
}

/// How to read the maps, then per direction which test is which row and what was flagged.
fn wear_notes(c: &ProfileChanges) -> Vec<String> {
    let mut out = vec![format!(
        "Each row is one stroke test, each column a position; the colour is that test's \
         friction magnitude minus the baseline profile (N, both smoothed over one lead). A \
         local wear shows as a vertical stripe that grows downwards (later tests); a change of \
         the whole travel (lubrication) colours whole rows. A position is flagged when its \
         change, after removing the part common to the whole travel, exceeds {}× the baseline's \
         own test-to-test scatter there.",
        c.params.k
    )];
    for d in &c.directions {
        let rows: Vec<String> = d
            .tests
            .iter()
            .enumerate()
            .map(|(k, t)| {
                format!(
                    "row {} = test {}{}",
                    k + 1,
                    t.test_id,
                    if t.in_baseline { " (baseline)" } else { "" }
                )
            })
            .collect();
        let flagged: Vec<String> = d
            .tests
            .iter()
            .filter(|t| !t.ranges.is_empty())
            .map(|t| {
                format!(
                    "test {}: {}",
                    t.test_id,
                    t.ranges
                        .iter()
                        .map(|r| format!(
                            "{:.0}-{:.0} mm ({:+.1} N)",
                            r.start_mm, r.end_mm, r.height_n
                        ))
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            })
            .collect();
        out.push(format!(
            "{}: {}. Flagged: {}.",
            d.direction.as_str(),
            rows.join(", "),
            if flagged.is_empty() {
                "nothing".to_string()
            } else {
                flagged.join("; ")
            }
        ));
    }
    out
}

fn heatmap_charts(c: &Curves) -> Result<Vec<Chart>> {
    c.heatmaps
        .iter()
        .map(|h| {
            let title = format!("FFS spectra along the travel, {}", h.direction);
            let svg = plot::heatmap_svg_sized(
                &Heatmap {
                    title: &title,
                    x_label: "order (cycles per lead)",
                    y_label: "segment centre position (mm)",
                    z_label: "amplitude (N)",
                    x: h.orders.clone(),
                    y: h.position_mm.clone(),
                    z: h.amplitude_n.clone(),
                },
                plot::TILE,
            )?;
            Ok(Chart { title, svg })
        })
        .collect()
}

/// Make an SVG scale with the page: keep its viewBox, drop the fixed size.
fn responsive(svg: &str) -> String {
    let s = svg.trim_start_matches(|c| c != '<');
    let s = if s.starts_with("<?xml") {
        s.split_once("?>").map_or(s, |x| x.1.trim_start())
    } else {
        s
    };
    s.replacen("<svg ", "<svg class=\"plot\" ", 1)
}

/// The floor of the baseline σ relative to |μ₀|, as the trends of `history trend` and the
/// report use it (the default of [`TrendParams::min_relative_std`]).
fn sigma_floor_fraction() -> f64 {
    TrendParams::default().min_relative_std
}

/// The test kind whose analysis yields an indicator's values.
fn kind_of(name: &str) -> Option<&'static str> {
    Indicator::parse(name).map(|i| match i {
        Indicator::MeanFriction { .. } | Indicator::Component { .. } => "strokes",
        _ => "triangle",
    })
}

/// What the indicators without a baseline would need: per test kind, how many of its
/// indicators have none, how many tests they have and how many more a baseline of
/// `baseline_tests` needs. Empty when every indicator has one.
fn missing_baselines(
    store: &dyn Store,
    t: &AxisTrends,
    baseline_tests: usize,
) -> Result<Vec<String>> {
    if t.skipped.is_empty() {
        return Ok(vec![]);
    }
    // The baseline takes the first N tests of each indicator, and at least 2 for a scatter.
    let need = baseline_tests.max(2);
    let series = store
        .series(&t.machine, &t.axis)
        .map_err(AppError::from_error)?;
    let mut out = Vec::new();
    for (kind, test_word) in [("strokes", "stroke test"), ("triangle", "triangle test")] {
        let names: Vec<&String> = t
            .skipped
            .iter()
            .filter(|n| kind_of(n) == Some(kind))
            .collect();
        if names.is_empty() {
            continue;
        }
        let have = names
            .iter()
            .map(|n| series.get(*n).map_or(0, Vec::len))
            .max()
            .unwrap_or(0);
        let more = need.saturating_sub(have);
        let plural = |n: usize| if n == 1 { "" } else { "s" };
        out.push(format!(
            "{} indicator{} of {test_word}s ha{} no baseline: the baseline is the mean and \
             scatter of the first {need} tests of each indicator and {} only {have} \
             {test_word}{}; {more} more {test_word}{} needed.",
            names.len(),
            plural(names.len()),
            if names.len() == 1 { "s" } else { "ve" },
            if names.len() == 1 {
                "it has"
            } else {
                "they have"
            },
            plural(have),
            if more == 1 { " is" } else { "s are" },
        ));
    }
    let unknown = t.skipped.iter().filter(|n| kind_of(n).is_none()).count();
    if unknown > 0 {
        out.push(format!(
            "{unknown} stored indicator(s) are not known to this version of feedscope and are \
             not trended."
        ));
    }
    Ok(out)
}

/// The report page of an axis whose trends took their baseline from the first
/// `baseline_tests` tests of each indicator: every chart drawn, every number formatted, ready
/// for [`render_html`] or for a front end that lays it out itself (a server's axis page).
///
/// # Errors
/// The store's errors; stored curves that do not read; a chart that cannot be drawn.
pub fn page(store: &dyn Store, t: &AxisTrends, baseline_tests: usize) -> Result<Page> {
    let details: Vec<TestDetail> = t
        .tests
        .iter()
        .map(|x| store.get(x.id))
        .collect::<Result<_, _>>()
        .map_err(AppError::from_error)?;
    let latest_strokes = details
        .iter()
        .rev()
        .find(|d| d.test.kind == feedscope_store::TestKind::Strokes);
    let curves: Option<(Curves, &TestDetail)> = match latest_strokes {
        Some(d) => store
            .curves(d.test.id)
            .map_err(AppError::from_error)?
            .map(|c| match c {
                Stored::Read(c) => Ok((c, d)),
                Stored::Unread { reason, .. } => {
                    Err(crate::trend::unread_curves(d.test.id, &reason))
                }
            })
            .transpose()?,
        None => None,
    };
    let (profile, heatmaps) = match &curves {
        Some((c, d)) => (
            profile_chart(c, d, t.profiles.as_ref())?,
            heatmap_charts(c)?,
        ),
        None => (None, vec![]),
    };
    let latest_ident = details.iter().rev().find(|d| d.identified.is_some());
    let params = latest_ident
        .and_then(|d| d.identified.as_ref())
        .map(|p| {
            vec![
                Param {
                    name: "static friction Fs",
                    value: num(p.fs_n),
                    std_error: num(p.fs_std_n),
                    unit: "N",
                },
                Param {
                    name: "Coulomb friction Fc",
                    value: num(p.fc_n),
                    std_error: num(p.fc_std_n),
                    unit: "N",
                },
                Param {
                    name: "viscous coefficient σ",
                    value: num(p.sigma_n_s_per_m),
                    std_error: num(p.sigma_std_n_s_per_m),
                    unit: "N·s/m",
                },
                Param {
                    name: "Stribeck velocity vs",
                    value: num(p.vs_mm_min),
                    std_error: num(p.vs_std_mm_min),
                    unit: "mm/min",
                },
                Param {
                    name: "inertia J",
                    value: num(p.j_total_kgm2),
                    std_error: num(p.j_std_kgm2),
                    unit: "kg·m²",
                },
                Param {
                    name: "residual RMS",
                    value: num(p.residual_rms_nm),
                    std_error: "".into(),
                    unit: "N·m",
                },
            ]
        })
        .unwrap_or_default();
    let mut trend_charts = Vec::new();
    for tr in &t.trends {
        trend_charts.push(trend_chart(tr)?);
    }
    let rows: Vec<Row> = t.trends.iter().map(row).collect();
    let mut warnings: Vec<(Status, Row)> = t
        .trends
        .iter()
        .filter(|x| x.status != Status::Ok)
        .map(|x| (x.status, row(x)))
        .collect();
    warnings.sort_by_key(|w| w.0);
    let mut counts = Vec::new();
    for s in [
        Status::ThresholdCrossed,
        Status::OutOfLimits,
        Status::Drifting,
        Status::Ok,
    ] {
        let n = t.trends.iter().filter(|x| x.status == s).count();
        counts.push((s.as_str().to_string(), n));
    }
    let tests: Vec<TestLine> = details
        .iter()
        .map(|d| TestLine {
            id: d.test.id,
            time: d.test.time_utc.clone(),
            kind: d.test.kind.to_string(),
            source: d.test.source.clone(),
            reference: d.test.reference,
            summary: match &d.identified {
                Some(p) => format!(
                    "Fs {} N, Fc {} N, σ {} N·s/m, vs {} mm/min",
                    num(p.fs_n),
                    num(p.fc_n),
                    num(p.sigma_n_s_per_m),
                    num(p.vs_mm_min)
                ),
                None => format!(
                    "{} intervals, {} components",
                    d.intervals.len(),
                    d.components.iter().filter(|c| c.segment.is_whole()).count()
                ),
            },
        })
        .collect();
    let missing = missing_baselines(store, t, baseline_tests)?;
    let no_baseline = t.trends.is_empty();
    let diagnosis: Vec<String> = if no_baseline {
        // The study's "no evidence of a change" would be read as a clean bill of health: with
        // no baseline there is no evidence either way.
        let mut d = vec![format!(
            "No baseline yet, so nothing can be said about a change of condition: {} test{} \
             stored for this axis.",
            t.tests.len(),
            if t.tests.len() == 1 { " is" } else { "s are" }
        )];
        d.extend(missing);
        d
    } else {
        t.diagnosis.iter().cloned().chain(missing).collect()
    };
    let floor = sigma_floor_fraction();
    let n_floored = t.trends.iter().filter(|x| x.baseline.std_floored).count();
    let mut sigma_floor = format!(
        "σ floor: the σ of each baseline is at least {} % of |μ₀| (in the indicator's unit; \
         column \"σ floor\"), so that tests which happen to repeat a value do not make every \
         later wobble an alarm",
        100.0 * floor
    );
    sigma_floor.push_str(&if no_baseline {
        ".".to_string()
    } else {
        format!(
            "; {n_floored} of {} indicators are at the floor.",
            t.trends.len()
        )
    });
    let mut chart = |c: Chart| Chart {
        title: c.title,
        svg: responsive(&c.svg),
    };
    let ctx = Page {
        machine: t.machine.clone(),
        axis: t.axis.clone(),
        generated: feedscope_store::time::format_rfc3339(feedscope_store::time::now_s()),
        first_time: t
            .tests
            .first()
            .map_or(String::new(), |x| x.time_utc.clone()),
        last_time: t.tests.last().map_or(String::new(), |x| x.time_utc.clone()),
        tests,
        counts,
        diagnosis,
        no_baseline,
        sigma_floor,
        warnings: warnings.into_iter().map(|w| w.1).collect(),
        profile_test: curves
            .as_ref()
            .map(|(_, d)| format!("test {} ({})", d.test.id, d.test.time_utc)),
        profile_verdict: curves
            .as_ref()
            .and_then(|(c, _)| c.verdict.as_ref())
            .map(|v| v.headline()),
        profile: profile.map(&mut chart),
        heatmaps: heatmaps.into_iter().map(&mut chart).collect(),
        wear_maps: match &t.profiles {
            Some(p) => wear_maps(p)?.into_iter().map(&mut chart).collect(),
            None => vec![],
        },
        wear_notes: t.profiles.as_ref().map(wear_notes).unwrap_or_default(),
        stribeck: stribeck_chart(&details)?.map(&mut chart),
        params,
        params_test: latest_ident.map(|d| format!("test {} ({})", d.test.id, d.test.time_utc)),
        trend_charts: trend_charts.into_iter().map(&mut chart).collect(),
        rows,
        intervals: latest_strokes
            .map(|d| d.intervals.clone())
            .unwrap_or_default(),
        components: latest_strokes
            .map(|d| {
                d.components
                    .iter()
                    .filter(|c| c.segment.is_whole())
                    .cloned()
                    .collect()
            })
            .unwrap_or_default(),
        skipped: t.skipped.clone(),
        version: env!("CARGO_PKG_VERSION"),
    };
    Ok(ctx)
}

/// The report page as self-contained HTML (plots inline as SVG, no script, no network).
///
/// # Errors
/// A template that does not render (a build mistake: the template is compiled in).
pub fn render_html(page: &Page) -> Result<String> {
    let internal = |what: &str, e: minijinja::Error| {
        AppError::caused(feedscope::ErrorKind::Internal, what.to_string(), e)
    };
    let mut env = minijinja::Environment::new();
    env.add_template("report.html", TEMPLATE)
        .map_err(|e| internal("the report template", e))?;
    env.get_template("report.html")
        .and_then(|tpl| tpl.render(minijinja::value::Serde(page)))
        .map_err(|e| internal("rendering the report", e))
}

/// [`page`] rendered by [`render_html`]: the condition report of an axis as one HTML file.
///
/// # Errors
/// As [`page`] and [`render_html`].
pub fn render(store: &dyn Store, t: &AxisTrends, baseline_tests: usize) -> Result<String> {
    render_html(&page(store, t, baseline_tests)?)
}

/// Write the condition report of one axis of a history store (`feedscope report`).
#[derive(Debug, Clone, Default, PartialEq, serde::Deserialize, Serialize)]
#[serde(default, deny_unknown_fields)]
pub struct ReportRequest {
    /// The axis and the trend's settings (baseline, detectors, thresholds file), as
    /// `history trend` takes them; a key of its own (`"trend": {...}`), since serde cannot
    /// refuse unknown keys through a flattened struct.
    pub trend: TrendRequest,
    /// The HTML file to write (whole or not at all).
    pub output: std::path::PathBuf,
}

impl ReportRequest {
    /// Check the settings and read the thresholds file, open the store `spec` (an SQLite file
    /// must exist: a report never makes an empty database), make the axis's trend, render the
    /// page and write it to `output`.
    ///
    /// # Errors
    /// As [`TrendRequest::run`]; bad input when `output` is empty or the SQLite file is
    /// missing; the page's drawing errors; I/O errors writing `output` (nothing is left there).
    pub fn run(&self, spec: &StoreSpec, opener: &Opener, front: &dyn FrontEnd) -> Result<()> {
        if self.output.as_os_str().is_empty() {
            return Err(AppError::invalid(
                "output",
                format!("{} must name the HTML file to write", front.name("output")),
            ));
        }
        let options = &self.trend.options;
        options.validate(front)?;
        let from_file = options.file_thresholds()?;
        if let Some(db) = spec.sqlite_path() {
            if !db.exists() {
                return Err(AppError::bad_input(format!(
                    "no database at {}",
                    db.display()
                )));
            }
        }
        let store = opener.open(spec)?;
        let t = self.trend.trend(&*store, from_file, front)?;
        let html = render(&*store, &t, options.baseline_tests)?;
        write_atomic(&self.output, html.as_bytes())
    }
}
