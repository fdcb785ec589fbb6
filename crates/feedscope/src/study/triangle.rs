//! The triangle test (paper 002): one-test identification → condition indicators.
use crate::axis::AxisParams;
use crate::history::Indicator;
use crate::ident::{identify, IdentParams, Identification};
use crate::trace::Trace;

use super::{IndicatorValue, StudyError};

/// Settings of [`triangle_test`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TriangleStudyParams {
    /// The identification (defaults: [`IdentParams::default`]).
    pub ident: IdentParams,
}

/// Results of a triangle test.
#[derive(Debug, Clone, PartialEq)]
pub struct TriangleTest {
    /// The identification, motor and table side, with its diagnostics.
    pub identification: Identification,
    /// F_s, F_c, σ, v_s and J with their standard errors, in that order.
    pub indicators: Vec<IndicatorValue>,
}

/// Identify the friction and inertia of an axis from its triangular-wave test and turn them
/// into the condition indicators [`Indicator::StaticFriction`], [`Indicator::CoulombFriction`],
/// [`Indicator::Viscous`], [`Indicator::StribeckVelocity`] and [`Indicator::Inertia`] (table
/// side, with standard errors).
///
/// # Errors
/// [`StudyError::Identify`] when the trace does not identify the parameters.
pub fn triangle_test(
    trace: &Trace,
    axis: &AxisParams,
    params: &TriangleStudyParams,
) -> Result<TriangleTest, StudyError> {
    let identification = identify(trace, axis, &params.ident)?;
    let indicators = triangle_indicators(&identification);
    Ok(TriangleTest {
        identification,
        indicators,
    })
}

/// The five indicators of an identification.
pub(crate) fn triangle_indicators(id: &Identification) -> Vec<IndicatorValue> {
    let (f, s, force) = (&id.fit, &id.fit.std_error, &id.force);
    vec![
        IndicatorValue::new(Indicator::StaticFriction, force.fs_n, Some(force.fs_std_n)),
        IndicatorValue::new(Indicator::CoulombFriction, force.fc_n, Some(force.fc_std_n)),
        IndicatorValue::new(
            Indicator::Viscous,
            force.sigma_n_s_per_m,
            Some(force.sigma_std_n_s_per_m),
        ),
        IndicatorValue::new(
            Indicator::StribeckVelocity,
            force.vs_mm_min,
            Some(s.vs_mm_min),
        ),
        IndicatorValue::new(Indicator::Inertia, f.j_total_kgm2, Some(s.j_total_kgm2)),
    ]
}
