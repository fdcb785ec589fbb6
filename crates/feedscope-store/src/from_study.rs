//! The rows of an analysed test: from the library's workflow results
//! ([`feedscope::study`]) to what the store keeps.
use feedscope::axis::AxisParams;
use feedscope::ident::Identification;
use feedscope::study::{IndicatorValue, IntervalMean, StrokeComponent, TestAnalysis};
use sha2::{Digest, Sha256};

use crate::{ComponentRow, Identified, IndicatorRow, IntervalRow, NewTest};

impl From<&IndicatorValue> for IndicatorRow {
    fn from(v: &IndicatorValue) -> Self {
        IndicatorRow {
            name: v.indicator.name(),
            value: v.value,
            std_error: v.std_error.filter(|s| s.is_finite()),
            unit: v.indicator.unit().to_string(),
        }
    }
}

impl From<&IntervalMean> for IntervalRow {
    fn from(i: &IntervalMean) -> Self {
        IntervalRow {
            direction: i.direction.as_str().into(),
            start_mm: i.start_mm,
            end_mm: i.end_mm,
            mean_n: i.mean_n,
            std_n: i.std_n,
            samples: i.samples as i64,
        }
    }
}

impl From<&StrokeComponent> for ComponentRow {
    fn from(s: &StrokeComponent) -> Self {
        let c = &s.component;
        ComponentRow {
            direction: s.direction.as_str().to_string(),
            segment: c.segment,
            position_mm: c.position_mm,
            order: c.order,
            amplitude_n: c.amplitude_n,
            floor_n: c.floor_n,
            cause: c.cause.clone(),
            trusted: c.trusted,
        }
    }
}

impl From<&Identification> for Identified {
    fn from(id: &Identification) -> Self {
        let (f, s, force) = (&id.fit, &id.fit.std_error, &id.force);
        Identified {
            j_total_kgm2: f.j_total_kgm2,
            j_std_kgm2: s.j_total_kgm2,
            fc_n: force.fc_n,
            fc_std_n: force.fc_std_n,
            fs_n: force.fs_n,
            fs_std_n: force.fs_std_n,
            sigma_n_s_per_m: force.sigma_n_s_per_m,
            sigma_std_n_s_per_m: force.sigma_std_n_s_per_m,
            vs_mm_min: force.vs_mm_min,
            vs_std_mm_min: s.vs_mm_min,
            delta: f.delta,
            offset_n: force.offset_n,
            residual_rms_nm: f.residual_rms_nm,
            samples_used: f.samples_used as i64,
        }
    }
}

/// SHA-256 of a trace file's bytes in lower-case hex: [`NewTest::content_sha256`], the key by
/// which the same trace is recognised when added again.
pub fn content_sha256(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .map(|x| format!("{x:02x}"))
        .collect()
}

impl NewTest {
    /// The rows of an analysed test: its kind, axis parameters, content hash, results and
    /// report curves. Who, where and when (machine, axis name, time, source, program,
    /// reference, compensation) are left empty for the caller to fill.
    pub fn from_analysis(analysis: &TestAnalysis, axis: &AxisParams, trace_bytes: &[u8]) -> Self {
        let mut t = NewTest {
            machine: String::new(),
            axis: String::new(),
            axis_params: axis.clone().into(),
            time_utc: String::new(),
            time_s: 0.0,
            kind: analysis.kind(),
            source: String::new(),
            content_sha256: content_sha256(trace_bytes),
            program: None,
            reference: false,
            compensation_ref: None,
            identified: None,
            intervals: vec![],
            components: vec![],
            indicators: analysis
                .indicators()
                .iter()
                .map(IndicatorRow::from)
                .collect(),
            curves: None,
        };
        match analysis {
            TestAnalysis::Triangle(tri) => {
                t.identified = Some(Identified::from(&tri.identification));
            }
            TestAnalysis::Strokes(s) => {
                t.intervals = s.intervals.iter().map(IntervalRow::from).collect();
                t.components = s.components.iter().map(ComponentRow::from).collect();
                t.curves = Some(s.curves.clone().into());
            }
        }
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use feedscope::history::Indicator;
    use feedscope::stroke::Direction;

    #[test]
    fn rows_keep_keys_units_and_drop_non_finite_errors() {
        let v = IndicatorValue {
            indicator: Indicator::MeanFriction {
                direction: Direction::Backward,
                start_mm: 0.0,
                end_mm: 50.0,
            },
            value: 310.0,
            std_error: Some(f64::NAN),
        };
        let r = IndicatorRow::from(&v);
        assert_eq!(r.name, v.indicator.name());
        assert_eq!(r.unit, "N");
        assert_eq!(r.std_error, None);
        assert_eq!(
            content_sha256(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
    }
}
