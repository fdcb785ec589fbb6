//! What a recording can support: the data verdict, decided once from the samples and what the
//! import learned ([`crate::trace::RecordingFacts`]), and carried to every output.
//!
//! A trace polled every 0.35 s with a whole-percent load reading does not carry a friction
//! profile, let alone the screw's fluctuation orders, even though the spline through it yields
//! a number at every resampled point. The verdict says which of four levels each stroke
//! supports, from least to most ([`Support`]):
//!
//! | level | needs (every condition of the levels below, and) |
//! |---|---|
//! | [`Support::MeanLevel`] | the stroke was estimated: its mean friction and standard error |
//! | [`Support::Profile`] | no process load; ≥ [`PROFILE_MIN_LEADS`] leads of travel; predicted noise floor ≤ [`PROFILE_MAX_FLOOR_FRACTION`] of the mean level |
//! | [`Support::Orders`] | ≥ [`ORDERS_MIN_LEADS`] leads; highest trusted order ≥ [`ORDERS_MIN_ORDER`] (the shaft order) |
//! | [`Support::Causes`] | ≥ [`CAUSES_MIN_LEADS`] leads, so the order resolution 1/L tells neighbouring kinematic orders apart |
//!
//! Why these limits (documented choices, not from a paper):
//! - The profile limit compares the predicted floor (position quanta twice differentiated,
//!   effort noise and effort quantum, inertia residue; see [`crate::estimate::floor`]) with the
//!   stroke's mean friction: a profile whose own noise is a tenth of its level cannot show the
//!   few-percent changes that wear and lubrication make, and its wiggles are the spline
//!   swinging between noisy samples.
//! - Orders need the shaft order (1 cycle per lead) below the highest trusted order
//!   (raw samples per lead / 2.5) and two leads of travel for a spectrum bin at order 0.5.
//! - Causes need four leads: the spectrum's resolution is 1/L orders, and a kinematic cause
//!   is matched within max(1/L, 3 %) of its order; at L < 4 a peak at 1.63 is "shaft 2x".
//! - Process load (a production program's drive load) caps a stroke at its mean level: the
//!   motor force then holds cutting forces, and only its mean, as an upper bound of friction,
//!   is reported.
//!
//! The sign: a drive load that is a magnitude (`effort_signed = false`) gives friction whose
//! sign comes from the direction of motion ([`FrictionSign::FromDirection`]), said so in every
//! output; only a signed current or torque gives friction [`FrictionSign::Signed`] as Eq. 5.

use serde::{Deserialize, Serialize};

use crate::diag::{Code, Diagnostic};

/// Fewest leads of travel for a profile along it.
pub const PROFILE_MIN_LEADS: f64 = 1.0;
/// Largest predicted noise floor (RMS) of a profile, as a fraction of the stroke's |mean|.
pub const PROFILE_MAX_FLOOR_FRACTION: f64 = 0.1;
/// Fewest leads of travel for an order spectrum.
pub const ORDERS_MIN_LEADS: f64 = 2.0;
/// Lowest highest-trusted order for an order spectrum (the shaft order).
pub const ORDERS_MIN_ORDER: f64 = 1.0;
/// Fewest leads of travel (of a stroke or a segment) for a cause label.
pub const CAUSES_MIN_LEADS: f64 = 4.0;

/// What a stroke's data support, from least to most.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Support {
    /// The mean friction of the stroke and its standard error only.
    MeanLevel,
    /// Friction along the travel (its slow profile).
    Profile,
    /// The fluctuation's spectrum in screw orders, up to the stroke's highest trusted order.
    Orders,
    /// Causes (shaft, nut and guide ball refeed) named for the orders.
    Causes,
}

impl Support {
    /// Stable kebab-case name (`mean-level`, `profile`, `orders`, `causes`).
    pub fn as_str(self) -> &'static str {
        match self {
            Self::MeanLevel => "mean-level",
            Self::Profile => "profile",
            Self::Orders => "orders",
            Self::Causes => "causes",
        }
    }

    /// In words, for consoles and reports.
    pub fn describe(self) -> &'static str {
        match self {
            Self::MeanLevel => "mean friction per stroke only",
            Self::Profile => "a friction profile along the travel (no orders)",
            Self::Orders => "a friction profile and its fluctuation orders (no causes)",
            Self::Causes => "a friction profile, fluctuation orders and their causes",
        }
    }

    /// All levels, least first.
    pub const ALL: [Support; 4] = [
        Support::MeanLevel,
        Support::Profile,
        Support::Orders,
        Support::Causes,
    ];
}

/// How the friction's sign was obtained.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum FrictionSign {
    /// From a signed current or torque, as paper 000 Eq. 5.
    Signed,
    /// The effort is a magnitude: friction takes the sign of the direction of motion.
    FromDirection,
}

impl FrictionSign {
    /// In words.
    pub fn describe(self) -> &'static str {
        match self {
            Self::Signed => "signed as paper 000 Eq. 5 (from a signed effort)",
            Self::FromDirection => {
                "sign from the direction of motion (the effort is a magnitude; Eq. 5's sign \
                 is not measured)"
            }
        }
    }
}

/// What one stroke's samples show about themselves: the inputs of [`judge_stroke`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StrokeEvidence {
    /// Travel of the estimated stroke in leads.
    pub length_leads: f64,
    /// Highest trusted order (cycles per lead).
    pub max_order: f64,
    /// Predicted noise floor of the friction (N RMS), quanta included.
    pub floor_n: f64,
    /// Mean friction of the stroke (N).
    pub mean_n: f64,
    /// The effort may hold process (cutting) load.
    pub process_load: bool,
}

/// The verdict on one stroke: its level and why it is not higher.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StrokeVerdict {
    /// What the stroke supports.
    pub support: Support,
    /// Why it supports no more (empty at [`Support::Causes`]).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub reasons: Vec<Diagnostic>,
}

/// Judge one stroke (see the module documentation for the rules).
pub fn judge_stroke(e: &StrokeEvidence) -> StrokeVerdict {
    let mut reasons = Vec::new();
    let mut support = Support::Causes;
    let mut cap = |level: Support, code: Code, message: String, reasons: &mut Vec<Diagnostic>| {
        if level < support {
            support = level;
        }
        reasons.push(Diagnostic::new(code, message));
    };
    if e.process_load {
        cap(
            Support::MeanLevel,
            Code::ProcessLoad,
            "the effort may hold process (cutting) load: only the mean motor force, an upper \
             bound of friction, is reported"
                .into(),
            &mut reasons,
        );
    }
    if e.length_leads.is_nan() || e.length_leads < PROFILE_MIN_LEADS {
        cap(
            Support::MeanLevel,
            Code::StrokeTooShort,
            format!(
                "the stroke spans {:.2} leads: a profile needs at least {PROFILE_MIN_LEADS}",
                e.length_leads
            ),
            &mut reasons,
        );
    }
    let limit = PROFILE_MAX_FLOOR_FRACTION * e.mean_n.abs();
    if e.floor_n.is_nan() || e.floor_n > limit {
        cap(
            Support::MeanLevel,
            Code::FloorAboveProfileLimit,
            format!(
                "predicted noise floor {:.1} N RMS is {:.0} % of the mean level {:.1} N: a \
                 profile needs at most {:.0} % (finer effort or position resolution, faster \
                 sampling or a slower feed)",
                e.floor_n,
                100.0 * e.floor_n / e.mean_n.abs().max(1e-12),
                e.mean_n,
                100.0 * PROFILE_MAX_FLOOR_FRACTION
            ),
            &mut reasons,
        );
    }
    if e.length_leads.is_nan() || e.length_leads < ORDERS_MIN_LEADS {
        cap(
            Support::Profile,
            Code::TooFewLeadsForOrders,
            format!(
                "the stroke spans {:.2} leads: an order spectrum needs at least \
                 {ORDERS_MIN_LEADS}",
                e.length_leads
            ),
            &mut reasons,
        );
    }
    if e.max_order.is_nan() || e.max_order < ORDERS_MIN_ORDER {
        cap(
            Support::Profile,
            Code::OrdersNotResolved,
            format!(
                "the highest trusted order is {:.2} (raw samples per lead / 2.5): the shaft \
                 order 1 is not resolved; sample faster or feed slower",
                e.max_order
            ),
            &mut reasons,
        );
    }
    if e.length_leads.is_nan() || e.length_leads < CAUSES_MIN_LEADS {
        cap(
            Support::Orders,
            Code::TooFewLeadsForCauses,
            format!(
                "the stroke spans {:.2} leads: the order resolution {:.2} cannot tell \
                 kinematic causes apart (at least {CAUSES_MIN_LEADS} leads)",
                e.length_leads,
                1.0 / e.length_leads.max(1e-12)
            ),
            &mut reasons,
        );
    }
    // Keep only the reasons that bind: those at or below the level reached.
    reasons.retain(|r| reason_level(r.code) <= support);
    StrokeVerdict { support, reasons }
}

/// The level a reason code caps at (for keeping the binding reasons only).
fn reason_level(code: Code) -> Support {
    match code {
        Code::TooFewLeadsForOrders | Code::OrdersNotResolved => Support::Profile,
        Code::TooFewLeadsForCauses => Support::Orders,
        _ => Support::MeanLevel,
    }
}

/// The verdict on a whole recording.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DataVerdict {
    /// The most any stroke supports.
    pub support: Support,
    /// Strokes per level, least first (`mean-level`, `profile`, `orders`, `causes`).
    pub strokes_per_level: [usize; 4],
    /// How the friction's sign was obtained.
    pub friction_sign: FrictionSign,
    /// What limits the whole recording (unsigned or quantised effort, process load, pieced
    /// recordings), besides each stroke's own reasons.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub reasons: Vec<Diagnostic>,
}

impl DataVerdict {
    /// Summarise per-stroke verdicts with the recording's own reasons.
    pub fn from_strokes<'a>(
        strokes: impl IntoIterator<Item = &'a StrokeVerdict>,
        friction_sign: FrictionSign,
        reasons: Vec<Diagnostic>,
    ) -> Self {
        let mut counts = [0usize; 4];
        let mut best = None;
        for v in strokes {
            counts[v.support as usize] += 1;
            best = best.max(Some(v.support));
        }
        Self {
            support: best.unwrap_or(Support::MeanLevel),
            strokes_per_level: counts,
            friction_sign,
            reasons,
        }
    }

    /// One line for a console: the best level and how many strokes reach each.
    pub fn headline(&self) -> String {
        let counts: Vec<String> = Support::ALL
            .iter()
            .zip(self.strokes_per_level)
            .filter(|(_, n)| *n > 0)
            .map(|(s, n)| format!("{n} {}", s.as_str()))
            .collect();
        format!(
            "data verdict: {} (strokes: {}); friction {}",
            self.support.describe(),
            counts.join(", "),
            self.friction_sign.describe()
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ev(length_leads: f64, max_order: f64, floor_n: f64) -> StrokeEvidence {
        StrokeEvidence {
            length_leads,
            max_order,
            floor_n,
            mean_n: 100.0,
            process_load: false,
        }
    }

    #[test]
    fn levels_switch_at_the_documented_limits() {
        assert_eq!(judge_stroke(&ev(30.0, 20.0, 1.0)).support, Support::Causes);
        assert!(judge_stroke(&ev(30.0, 20.0, 1.0)).reasons.is_empty());
        // floor at 10 % of the mean is a profile, just above is not
        assert_eq!(judge_stroke(&ev(30.0, 20.0, 10.0)).support, Support::Causes);
        let v = judge_stroke(&ev(30.0, 20.0, 10.01));
        assert_eq!(v.support, Support::MeanLevel);
        assert_eq!(v.reasons[0].code, Code::FloorAboveProfileLimit);
        assert_eq!(judge_stroke(&ev(3.99, 20.0, 1.0)).support, Support::Orders);
        assert_eq!(judge_stroke(&ev(4.0, 20.0, 1.0)).support, Support::Causes);
        assert_eq!(judge_stroke(&ev(1.99, 20.0, 1.0)).support, Support::Profile);
        assert_eq!(judge_stroke(&ev(30.0, 0.99, 1.0)).support, Support::Profile);
        assert_eq!(
            judge_stroke(&ev(0.99, 20.0, 1.0)).support,
            Support::MeanLevel
        );
        assert_eq!(
            judge_stroke(&ev(f64::NAN, 20.0, 1.0)).support,
            Support::MeanLevel
        );
        let mut p = ev(30.0, 20.0, 1.0);
        p.process_load = true;
        let v = judge_stroke(&p);
        assert_eq!(v.support, Support::MeanLevel);
        assert_eq!(v.reasons.len(), 1);
        assert_eq!(v.reasons[0].code, Code::ProcessLoad);
    }

    #[test]
    fn only_binding_reasons_are_kept() {
        // Too short for causes and orders unresolved: the binding limit is the order one.
        let v = judge_stroke(&ev(3.0, 0.5, 1.0));
        assert_eq!(v.support, Support::Profile);
        let codes: Vec<Code> = v.reasons.iter().map(|r| r.code).collect();
        assert_eq!(codes, [Code::OrdersNotResolved]);
    }

    #[test]
    fn recording_verdict_counts_and_takes_the_best() {
        let a = judge_stroke(&ev(30.0, 20.0, 50.0));
        let b = judge_stroke(&ev(3.0, 20.0, 1.0));
        let d = DataVerdict::from_strokes([&a, &b, &a], FrictionSign::FromDirection, vec![]);
        assert_eq!(d.support, Support::Orders);
        assert_eq!(d.strokes_per_level, [2, 0, 1, 0]);
        let h = d.headline();
        assert!(h.contains("2 mean-level, 1 orders"), "{h}");
        assert!(h.contains("sign from the direction"), "{h}");
    }
}
