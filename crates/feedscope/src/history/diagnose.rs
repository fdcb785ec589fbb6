//! Diagnosis in words: which indicators moved and what the papers associate with them.
use super::local::{describe_baseline, DirectionChanges, Extent, ProfileChanges};
use super::{Indicator, IndicatorTrend, Status};
use crate::label::Cause;

/// How an indicator moved: +1 up, −1 down, 0 not at all (status `Ok`).
fn moved(t: &IndicatorTrend) -> i32 {
    if t.status == Status::Ok {
        0
    } else if t.change_sigma >= 0.0 {
        1
    } else {
        -1
    }
}

fn find<'a>(trends: &'a [IndicatorTrend], i: &Indicator) -> Option<&'a IndicatorTrend> {
    trends.iter().find(|t| &t.indicator == i)
}

fn pct(t: &IndicatorTrend) -> String {
    format!("{:+.1} %", t.change_percent)
}

/// A short diagnosis, one sentence per finding, worded as evidence, not certainty.
///
/// Rules (the movement of an indicator is its status not being `Ok`, the sign that of the
/// latest value minus μ₀):
/// - F_s and σ both up: paper 002 associates a larger static friction and a larger viscous
///   coefficient with a worse lubrication condition → evidence of degrading lubrication;
///   one of the two up: weaker evidence of the same; v_s moved: the low-speed (mixed
///   lubrication) regime changed.
/// - Mean friction down over most intervals: paper 000 relates a higher friction to a higher
///   engagement force of balls and races, so a falling level suggests a loss of preload,
///   more so when the ball-refeed components changed too.
/// - A rise confined to one or a few intervals: paper 000 attributes position-dependent
///   friction to non-uniform pitch error (wear where the machine works most) and to
///   misalignment of guides and screw.
/// - Shaft-order components up: pitch error or wear of the screw shaft (paper 000, Group 2).
/// - J moved *and* |J_latest − μ₀| exceeds 3 combined standard errors
///   √(SE_latest² + SE_μ₀²) (SE_μ₀ of the baseline mean, from the SEs stored with the
///   tests): the moving mass changed (fixture, workpiece), not the friction. A J outside a
///   narrow baseline band but within its own uncertainty is measurement scatter, not news.
/// - Then every indicator with a projected threshold crossing.
pub fn diagnose(trends: &[IndicatorTrend]) -> Vec<String> {
    diagnose_with_profiles(trends, None)
}

/// [`diagnose`], with the position-resolved comparison of the stroke tests
/// ([`super::profile_changes`]) in place of the interval means' "risen locally / in most
/// intervals" rule wherever it compared a test:
///
/// - a flagged local range in the latest test: local wear, with direction, position range,
///   peak, height (N, %), width and the test that first showed it; paper 000 attributes
///   position-dependent friction to non-uniform pitch error (wear where the machine works
///   most) and to misalignment of guides and screw;
/// - a flagged change of the profile's shape over most of the travel: not a local defect;
/// - a flagged rise of the whole-travel level: with F_s and σ up, degrading lubrication (not
///   local wear); without triangle tests, lubrication or preload/seal drag (what tells them
///   apart); a fall: evidence of a loss of preload;
/// - nothing flagged: the profiles stay within their limits at every position;
/// - a direction not yet compared: what its tests allow to know ([`describe_baseline`]).
pub fn diagnose_with_profiles(
    trends: &[IndicatorTrend],
    profiles: Option<&ProfileChanges>,
) -> Vec<String> {
    let compared = profiles.is_some_and(|p| {
        p.directions
            .iter()
            .any(|d| d.tests.iter().any(|t| !t.in_baseline))
    });
    let mut out = Vec::new();
    let fs = find(trends, &Indicator::StaticFriction);
    let sg = find(trends, &Indicator::Viscous);
    let vs = find(trends, &Indicator::StribeckVelocity);
    let fc = find(trends, &Indicator::CoulombFriction);
    let j = find(trends, &Indicator::Inertia);
    let up = |t: Option<&IndicatorTrend>| t.is_some_and(|t| moved(t) > 0);
    match (up(fs), up(sg)) {
        (true, true) => {
            let (fs, sg) = (fs.expect("up"), sg.expect("up"));
            out.push(format!(
                "Static friction Fs ({}) and viscous coefficient σ ({}) have both risen since \
                 the baseline. Paper 002 associates a larger static friction and a larger \
                 viscous coefficient with a worse lubrication condition: this is evidence of \
                 degrading lubrication of screw and guides (check the lubricant supply and \
                 the lubrication interval).",
                pct(fs),
                pct(sg)
            ));
        }
        (true, false) => out.push(format!(
            "Static friction Fs has risen ({}) while σ has not left its band: weaker \
             evidence of a lubrication change (paper 002); contamination or a seal dragging \
             would look similar.",
            pct(fs.expect("up"))
        )),
        (false, true) => out.push(format!(
            "The viscous coefficient σ has risen ({}) while Fs has not: paper 002 reads a \
             larger σ as a worse lubrication condition; a colder or more viscous lubricant \
             would look similar.",
            pct(sg.expect("up"))
        )),
        (false, false) => {}
    }
    if let Some(v) = vs.filter(|t| moved(t) != 0) {
        out.push(format!(
            "The Stribeck velocity vs has changed ({}): the low-speed (mixed lubrication) \
             regime of the contacts behaves differently, which fits a change of lubricant or \
             of its condition.",
            pct(v)
        ));
    }
    if let Some(c) = fc.filter(|t| moved(t) != 0 && !up(fs)) {
        out.push(format!(
            "The Coulomb level Fc has moved ({}) without the static friction: a change of \
             preload or of seal drag is a possible cause.",
            pct(c)
        ));
    }

    let means: Vec<&IndicatorTrend> = trends
        .iter()
        .filter(|t| matches!(t.indicator, Indicator::MeanFriction { .. }))
        .collect();
    let refeed_moved: Vec<&IndicatorTrend> = trends
        .iter()
        .filter(|t| {
            matches!(
                &t.indicator,
                Indicator::Component {
                    cause: Cause::NutRefeed(_) | Cause::GuideRefeed(_),
                    ..
                }
            ) && moved(t) != 0
        })
        .collect();
    if !means.is_empty() {
        let down = means.iter().filter(|t| moved(t) < 0).count();
        let rising: Vec<&&IndicatorTrend> = means.iter().filter(|t| moved(t) > 0).collect();
        if 2 * down > means.len() {
            let mut s = format!(
                "The mean friction has fallen in {down} of {} position intervals. Paper 000 \
                 relates a higher friction to a higher engagement force of balls and races, \
                 so a falling level is evidence of a loss of preload",
                means.len()
            );
            if refeed_moved.is_empty() {
                s.push_str("; the ball-refeed components have not changed, which weakens it.");
            } else {
                s.push_str(&format!(
                    ", supported by changed ball-refeed amplitudes ({}).",
                    refeed_moved
                        .iter()
                        .map(|t| format!("{} {}", t.indicator.label(), pct(t)))
                        .collect::<Vec<_>>()
                        .join(", ")
                ));
            }
            out.push(s);
        } else if compared {
            // The position-resolved comparison below says where and how wide.
        } else if !rising.is_empty() && 3 * rising.len() <= means.len() {
            let where_: Vec<String> = rising
                .iter()
                .map(|t| format!("{} ({})", t.indicator.label(), pct(t)))
                .collect();
            out.push(format!(
                "The mean friction has risen locally: {}. Paper 000 attributes \
                 position-dependent friction to non-uniform pitch error (wear where the \
                 machine works most) and to misalignment of the guides and the screw: \
                 evidence of a local problem there.",
                where_.join(", ")
            ));
        } else if !rising.is_empty() {
            out.push(format!(
                "The mean friction has risen in {} of {} position intervals: a change along \
                 the whole travel, which fits lubrication (see Fs, σ) more than a local \
                 defect.",
                rising.len(),
                means.len()
            ));
        }
    }
    if let Some(p) = profiles {
        out.extend(profile_sentences(
            p,
            up(fs) && up(sg),
            fs.is_some() || sg.is_some(),
        ));
    }
    let shaft: Vec<String> = trends
        .iter()
        .filter(|t| {
            matches!(
                &t.indicator,
                Indicator::Component {
                    cause: Cause::Shaft(_),
                    ..
                }
            ) && moved(t) > 0
        })
        .map(|t| format!("{} {}", t.indicator.label(), pct(t)))
        .collect();
    if !shaft.is_empty() {
        out.push(format!(
            "Components at orders of the shaft revolution have grown ({}): paper 000 links \
             them to pitch errors of the screw, which grow with wear.",
            shaft.join(", ")
        ));
    }
    if let Some(j) = j.filter(|t| moved(t) != 0) {
        match j_change_sigma(j) {
            Some(z) if z.abs() <= J_CHANGE_SIGMA => {}
            z => out.push(format!(
                "The inertia J has changed ({}{}): the moving mass is different (fixture, \
                 workpiece); friction indicators of these tests are comparable with the \
                 earlier ones only with care.",
                pct(j),
                z.map_or(String::new(), |z| format!(
                    ", {:.1} combined standard errors",
                    z.abs()
                ))
            )),
        }
    }
    for t in trends {
        if let Some(p) = &t.projection {
            if moved(t) != 0 || p.days < 90.0 {
                out.push(format!(
                    "At the recent rate, {} will cross {} {} in about {}.",
                    t.indicator.label(),
                    fmt_num(p.threshold),
                    t.indicator.unit(),
                    fmt_days(p.days)
                ));
            }
        }
    }
    if out.is_empty() {
        out.push(
            "No indicator has left its baseline band and no drift is detected: no evidence of \
             a change of condition."
                .to_string(),
        );
    }
    out
}

/// The sentences of the position-resolved comparison; `lubrication` when F_s and σ have both
/// risen, `identified` when triangle tests exist at all.
fn profile_sentences(p: &ProfileChanges, lubrication: bool, identified: bool) -> Vec<String> {
    let mut out = Vec::new();
    let k = p.params.k;
    if p.tests == 0 {
        return out;
    }
    for (dir, n) in &p.not_compared {
        out.push(format!(
            "Friction along the travel ({}): {}",
            dir.as_str(),
            describe_baseline(*n, &p.params)
        ));
    }
    let mut quiet = Vec::new();
    for d in &p.directions {
        let dir = d.direction.as_str();
        let Some(last) = d.tests.last() else { continue };
        if last.in_baseline {
            out.push(format!(
                "Friction along the travel ({dir}): {}",
                describe_baseline(d.tests.len(), &p.params)
            ));
            continue;
        }
        let first = |pred: &dyn Fn(&super::TestChange) -> bool| {
            d.tests
                .iter()
                .find(|t| !t.in_baseline && pred(t))
                .map(|t| t.test_id)
        };
        for r in &last.ranges {
            let since = first(&|t| {
                t.ranges.iter().any(|q| {
                    q.start_mm <= r.end_mm + d.lead_mm && q.end_mm >= r.start_mm - d.lead_mm
                })
            })
            .unwrap_or(last.test_id);
            let verb = if r.height_n >= 0.0 { "risen" } else { "fallen" };
            match r.extent {
                Extent::Local => {
                    out.push(format!(
                    "Local wear, {dir}: the friction has {verb} by {:+.1} N ({:+.1} %) at {:.0} \
                     mm (flagged {:.0}-{:.0} mm, about {:.0} mm wide, {:.0}× its scatter), \
                     first flagged in test {since}; elsewhere along the travel it is within its \
                     limits. Paper 000 attributes position-dependent friction to non-uniform \
                     pitch error (wear where the machine works most) and to misalignment of the \
                     guides and the screw: evidence of local wear of screw or guides there.",
                    r.height_n, r.height_percent, r.peak_mm, r.start_mm, r.end_mm, r.width_mm,
                    r.height_sigma
                ))
                }
                Extent::WholeTravel => out.push(format!(
                    "The shape of the {dir} friction profile has changed over most of the \
                     travel ({:.0}-{:.0} mm, {:+.1} N at {:.0} mm), first flagged in test \
                     {since}: not a local defect; a misalignment of guides and screw or a \
                     preload that changes along the travel fits better.",
                    r.start_mm, r.end_mm, r.height_n, r.peak_mm
                )),
            }
        }
        if last.level_flagged {
            let since = first(&|t| t.level_flagged).unwrap_or(last.test_id);
            let what = if last.level_n >= 0.0 {
                if lubrication {
                    "; with Fs and σ up this fits degrading lubrication (everywhere), not local \
                     wear"
                        .to_string()
                } else if identified {
                    "; Fs and σ have not both risen, so a change of preload or seal drag fits \
                     as well as lubrication"
                        .to_string()
                } else {
                    "; this fits lubrication more than a local defect (a triangle test tells it \
                     from preload or seal drag: lubrication raises Fs and σ)"
                        .to_string()
                }
            } else {
                "; a falling level is evidence of a loss of preload (paper 000: friction grows \
                 with the engagement force of balls and races)"
                    .to_string()
            };
            out.push(format!(
                "The {dir} friction has {} along the whole travel by {:+.1} N ({:+.1} %, limit \
                 ±{:.1} %), first flagged in test {since}{what}.",
                if last.level_n >= 0.0 {
                    "risen"
                } else {
                    "fallen"
                },
                last.level_n,
                last.level_percent,
                level_limit_percent(d, p.params.level_k),
            ));
        }
        if last.ranges.is_empty() && !last.level_flagged {
            quiet.push(d);
        }
    }
    if !quiet.is_empty() {
        let words: Vec<String> = quiet
            .iter()
            .map(|d| {
                let n = d.tests.iter().filter(|t| !t.in_baseline).count();
                let earlier = d
                    .first_flag
                    .map(|i| {
                        format!(
                            ", flagged earlier in test {} but not now",
                            d.tests[i].test_id
                        )
                    })
                    .unwrap_or_default();
                format!(
                    "{}: {n} test(s) compared with a baseline of {}, limit ±{:.1} N{earlier}",
                    d.direction.as_str(),
                    d.baseline_ids.len(),
                    median_of(&d.limit_n)
                )
            })
            .collect();
        out.push(format!(
            "The friction along the travel stays within {k}× its baseline scatter at every \
             position in the latest test ({}): no evidence of local wear.",
            words.join("; ")
        ));
    }
    out
}

/// The whole-travel limit K_level·σ_a·√(1 + 1/n_m) in percent of m̄.
fn level_limit_percent(d: &DirectionChanges, level_k: f64) -> f64 {
    let n_m = if d.reference_id.is_some() {
        1.0
    } else {
        d.baseline_ids.len() as f64
    };
    100.0 * level_k * d.level_sigma * (1.0 + 1.0 / n_m).sqrt()
}

fn median_of(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    s.get(s.len() / 2).copied().unwrap_or(f64::NAN)
}

/// A J change enters the diagnosis only beyond this many combined standard errors.
const J_CHANGE_SIGMA: f64 = 3.0;

/// The latest J minus the baseline J in units of their combined standard error,
/// (J_latest − μ₀)/√(SE_latest² + SE_μ₀²), or `None` when the series carries no standard
/// errors.
///
/// SE_μ₀ is that of the baseline mean: √(Σ SE_i²)/N over the N points that set it (the first
/// N tests), or the reference test's own SE when the baseline is one reference test (the
/// point whose value is μ₀). J is the one indicator whose week-to-week scatter should be
/// pure measurement noise (the mass does not wear), so its own standard error, not the
/// baseline's scatter alone, says whether a change is real.
pub(crate) fn j_change_sigma(t: &IndicatorTrend) -> Option<f64> {
    let last = t.points.last()?;
    let se_last = last.std_error?;
    let b = &t.baseline;
    let se_base = if b.count <= 1 {
        t.points
            .iter()
            .min_by(|p, q| {
                (p.value - b.mean)
                    .abs()
                    .total_cmp(&(q.value - b.mean).abs())
            })?
            .std_error?
    } else {
        let first = t.points.get(..b.count)?;
        let ss = first
            .iter()
            .map(|p| p.std_error.map(|s| s * s))
            .sum::<Option<f64>>()?;
        ss.sqrt() / b.count as f64
    };
    let se = (se_last * se_last + se_base * se_base).sqrt();
    (se > 0.0).then(|| (last.value - b.mean) / se)
}

/// A number with about 3 significant digits.
pub(crate) fn fmt_num(x: f64) -> String {
    if x.abs() >= 1e6 {
        format!("{x:.4e}")
    } else if x.abs() >= 100.0 {
        format!("{x:.0}")
    } else if x.abs() >= 1.0 {
        format!("{x:.1}")
    } else {
        format!("{x:.3e}")
    }
}

/// "3 weeks", "5 days", "4 months", "3 years"; beyond a century a straight line says
/// nothing of a machine: "more than 100 years".
pub(crate) fn fmt_days(d: f64) -> String {
    if d < 14.0 {
        format!("{:.0} days", d.max(1.0))
    } else if d < 90.0 {
        format!("{:.0} weeks", d / 7.0)
    } else if d < 730.5 {
        format!("{:.0} months", d / 30.4)
    } else if d <= 36_525.0 {
        format!("{:.0} years", d / 365.25)
    } else {
        "more than 100 years".to_string()
    }
}

#[cfg(test)]
mod format_tests {
    use super::*;

    #[test]
    fn numbers_and_spans_stay_short() {
        assert_eq!(fmt_num(4e102), "4.0000e102");
        assert_eq!(fmt_num(480.0), "480");
        assert_eq!(fmt_days(3.0), "3 days");
        assert_eq!(fmt_days(400.0), "13 months");
        assert_eq!(fmt_days(1000.0), "3 years");
        assert_eq!(fmt_days(1.6e101 * 30.4), "more than 100 years");
        assert_eq!(fmt_days(f64::INFINITY), "more than 100 years");
    }
}

#[cfg(test)]
mod j_tests {
    use super::*;
    use crate::history::{assess, Point, Threshold, TrendParams};

    /// J series of 8 weekly tests with standard error `se` each; the last value `last`.
    fn j_trend(values: &[f64], se: Option<f64>) -> IndicatorTrend {
        let pts: Vec<Point> = values
            .iter()
            .enumerate()
            .map(|(i, &v)| Point {
                time_s: i as f64 * 7.0 * 86_400.0,
                value: v,
                std_error: se,
            })
            .collect();
        let params = TrendParams {
            // no σ floor: the baseline band is the scatter of the first five tests alone
            min_relative_std: 0.0,
            ..TrendParams::default()
        };
        assess(&Indicator::Inertia, &pts, &params, &Threshold::default()).unwrap()
    }

    fn says_j(d: &[String]) -> bool {
        d.iter().any(|s| s.contains("inertia J"))
    }

    /// Five nearly identical baseline values make a band narrower than J's own standard error:
    /// a last value 0.3 % off is out of that band but within 3 combined SEs (0.2 % each):
    /// no J finding. The same change with SEs of 0.02 % is 13.7 SEs: reported, with the
    /// number. Without SEs the status alone decides, as before.
    #[test]
    fn j_change_is_reported_only_beyond_its_uncertainty() {
        let base = [5.600e-3, 5.6005e-3, 5.5995e-3, 5.6002e-3, 5.5998e-3];
        let mut vals = base.to_vec();
        vals.extend([5.601e-3, 5.599e-3, 5.6168e-3]);
        let t = j_trend(&vals, Some(0.002 * 5.6e-3));
        assert_ne!(
            t.status,
            crate::history::Status::Ok,
            "out of the narrow band"
        );
        let z = j_change_sigma(&t).unwrap();
        // Δ = 0.0168e-3; SE = 0.0112e-3·√(1 + 1/5)
        assert!((z - 0.0168 / (0.0112 * 1.2f64.sqrt())).abs() < 1e-6, "{z}");
        assert!(!says_j(&diagnose(&[t])));

        let t = j_trend(&vals, Some(0.0002 * 5.6e-3));
        let d = diagnose(&[t]);
        assert!(
            d.iter()
                .any(|s| s.contains("inertia J") && s.contains("13.7 combined")),
            "{d:?}"
        );

        let t = j_trend(&vals, None);
        assert!(j_change_sigma(&t).is_none());
        assert!(says_j(&diagnose(&[t])));
    }
}
