//! What a stroke's data verdict ([`crate::verdict`]) withholds from the analyses built on it.
use std::collections::BTreeMap;

use serde::Serialize;

use crate::diag::{Code, Diagnostic};
use crate::estimate::StrokeFriction;
use crate::order::Cause;
use crate::profile::StrokeAnalysis;
use crate::stroke::Direction;
use crate::verdict::Support;

use super::StudyError;

/// A stroke left out of an analysis because its data do not support it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WithheldStroke {
    /// Stroke number (as the estimate numbers them).
    pub stroke: usize,
    /// Direction of travel.
    pub direction: Direction,
    /// What its data support.
    pub support: Support,
    /// Why no more.
    pub reasons: Vec<Diagnostic>,
}

/// The support of a stroke: its verdict's, or [`Support::Causes`] when it was not judged (a
/// friction CSV without its summary; the order analysis keeps its own resolution rules).
pub(crate) fn support_of(s: &StrokeFriction) -> Support {
    s.summary
        .verdict
        .as_ref()
        .map_or(Support::Causes, |v| v.support)
}

/// Split strokes into those that support at least `needed` and those withheld.
pub(crate) fn split(
    strokes: Vec<StrokeFriction>,
    needed: Support,
) -> (Vec<StrokeFriction>, Vec<WithheldStroke>) {
    let mut kept = Vec::with_capacity(strokes.len());
    let mut withheld = Vec::new();
    for s in strokes {
        if support_of(&s) >= needed {
            kept.push(s);
        } else {
            withheld.push(WithheldStroke {
                stroke: s.summary.stroke,
                direction: s.summary.direction,
                support: support_of(&s),
                reasons: s
                    .summary
                    .verdict
                    .as_ref()
                    .map(|v| v.reasons.clone())
                    .unwrap_or_default(),
            });
        }
    }
    (kept, withheld)
}

/// The error when nothing is left: the best level reached and the reasons by code.
pub(crate) fn not_supported(needed: &'static str, withheld: &[WithheldStroke]) -> StudyError {
    let best = withheld
        .iter()
        .map(|w| w.support)
        .max()
        .unwrap_or(Support::MeanLevel);
    let mut by_code: BTreeMap<&str, usize> = BTreeMap::new();
    for r in withheld.iter().flat_map(|w| &w.reasons) {
        *by_code.entry(r.code.as_str()).or_default() += 1;
    }
    StudyError::NotSupported {
        needed,
        strokes: withheld.len(),
        best: best.as_str(),
        reasons: by_code
            .iter()
            .map(|(c, n)| format!("{c} in {n}"))
            .collect::<Vec<_>>()
            .join(", "),
    }
}

/// Withhold from one stroke's analysis what its support does not allow: below
/// [`Support::Orders`] no significant component is kept; below [`Support::Causes`] every
/// component's cause is [`Cause::Unresolved`]. Each withholding is said in the fluctuation warnings.
pub(crate) fn apply(a: &mut StrokeAnalysis, support: Support) {
    let fl = &mut a.fluctuation;
    if support < Support::Orders && !fl.components.is_empty() {
        fl.warnings.push(Diagnostic::new(
            Code::ComponentsWithheld,
            format!(
                "{} significant component(s) withheld: the data verdict of this stroke is \
                 `{}` (no fluctuation orders)",
                fl.components.len(),
                support.as_str()
            ),
        ));
        fl.components.clear();
    } else if support < Support::Causes {
        let mut n = 0;
        for c in &mut fl.components {
            if c.cause != Cause::Unresolved {
                c.cause = Cause::Unresolved;
                c.kinematic_order = None;
                n += 1;
            }
        }
        if n > 0 {
            fl.warnings.push(Diagnostic::new(
                Code::CausesWithheld,
                format!(
                    "{n} component cause(s) withheld (`{}`): the data verdict of \
                     this stroke is `{}` (too few leads to tell kinematic orders apart)",
                    Cause::Unresolved,
                    support.as_str()
                ),
            ));
        }
    }
}
