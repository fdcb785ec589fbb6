//! Diagnosis in words: which indicators moved and what the papers associate with them.
use super::{Indicator, IndicatorTrend, Status};

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
/// - J moved: the moving mass changed (fixture, workpiece), not the friction.
/// - Then every indicator with a projected threshold crossing.
pub fn diagnose(trends: &[IndicatorTrend]) -> Vec<String> {
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
            matches!(&t.indicator, Indicator::Component { cause, .. } if cause.contains("refeed"))
                && moved(t) != 0
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
    let shaft: Vec<String> = trends
        .iter()
        .filter(|t| {
            matches!(&t.indicator, Indicator::Component { cause, .. } if cause.contains("shaft"))
                && moved(t) > 0
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
        out.push(format!(
            "The inertia J has changed ({}): the moving mass is different (fixture, \
             workpiece); friction indicators of these tests are comparable with the earlier \
             ones only with care.",
            pct(j)
        ));
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

/// A number with about 3 significant digits.
pub(crate) fn fmt_num(x: f64) -> String {
    if x.abs() >= 100.0 {
        format!("{x:.0}")
    } else if x.abs() >= 1.0 {
        format!("{x:.1}")
    } else {
        format!("{x:.3e}")
    }
}

/// "3 weeks", "5 days", "4 months".
pub(crate) fn fmt_days(d: f64) -> String {
    if d < 14.0 {
        format!("{:.0} days", d.max(1.0))
    } else if d < 90.0 {
        format!("{:.0} weeks", d / 7.0)
    } else {
        format!("{:.0} months", d / 30.4)
    }
}
