//! The plain-text view of a map, shared by the front ends: what was mapped, the Stribeck
//! fits at the chosen positions and the non-conventional spans ([`Display`](fmt::Display) of
//! [`Mapped`]), and the remarks beside it ([`Mapped::remarks`]): the model of each direction,
//! the models refused and why, every fit warning.
use std::fmt;

use feedscope::map::{StribeckAtPosition, StribeckProfile};
use feedscope::stribeck::{FrictionModel, Reduction, M_S_PER_MM_MIN};

use super::Mapped;
use crate::stribeck::advice;

impl fmt::Display for Mapped {
    /// Runs mapped and failed; per direction the span (mm), intervals, feeds (mm/min), feed
    /// polynomial and its misfit (N), worst repeatability (N); the Stribeck fit at every
    /// chosen position (Fc, Fs − Fc in N, vs in mm/min, σ in N·s/m, residual RMS in N); the
    /// non-conventional spans.
    fn fmt(&self, o: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = &self.report.summary;
        let (at, spans) = (&self.study.at_positions, &self.study.nonconventional);
        writeln!(o, "{}: {} of {} runs mapped", s.index, s.runs_ok, s.runs)?;
        for f in &s.failed {
            writeln!(o, "  failed: {} ({})", f.file, f.error)?;
        }
        for d in &s.directions {
            writeln!(
                o,
                "{:?}: {:.3}-{:.3} mm, {} intervals, {} feeds {:.4}-{:.4} mm/min, feed polynomial order {} (misfit RMS {:.3} N, max {:.3} N), worst repeatability std {}",
                d.direction,
                d.start_mm,
                d.end_mm,
                d.orders.len(),
                d.feeds_mm_min.len(),
                d.feeds_mm_min.first().copied().unwrap_or(f64::NAN),
                d.feeds_mm_min.last().copied().unwrap_or(f64::NAN),
                d.feed_order,
                d.feed_misfit_rms_n,
                d.feed_misfit_max_n,
                d.worst_repeatability_std_n
                    .map_or("n/a (one repeat)".to_string(), |v| format!("{v:.3} N"))
            )?;
        }
        writeln!(
            o,
            "Stribeck fits (Eq. 9; coulomb-viscous where the feeds do not determine one, see stderr):"
        )?;
        writeln!(
            o,
            "  direction  position_mm  model                 Fc_N    Fs-Fc_N   vs_mm_min   sigma_Ns/m  rms_N  warnings"
        )?;
        let cell = |x: Option<f64>, w: usize, prec: usize| {
            x.map_or_else(|| format!("{:>w$}", "-"), |v| format!("{v:w$.prec$}"))
        };
        for p in at {
            let dir = p.direction.as_str();
            for q in &p.positions {
                match &q.fit {
                    Some(f) => {
                        let hump = f.model == FrictionModel::Stribeck;
                        writeln!(
                            o,
                            "  {:9}  {:11.3}  {:15}  {:9.2}  {}  {}  {}  {:5.2}  {}",
                            dir,
                            q.position_mm,
                            f.model.code(),
                            f.params.fc_n,
                            cell(hump.then(|| f.params.static_excess_n()), 9, 2),
                            cell(f.vs_m_s().map(|v| v / M_S_PER_MM_MIN), 10, 2),
                            cell(f.sigma_n_s_per_m(), 11, 1),
                            f.residual_rms_n,
                            f.warnings.len()
                        )?;
                    }
                    None => writeln!(
                        o,
                        "  {:9}  {:11.3}  fit failed: {}",
                        dir,
                        q.position_mm,
                        q.error.clone().unwrap_or_default()
                    )?,
                }
            }
        }
        if spans.is_empty() {
            writeln!(
                o,
                "no non-conventional behaviour (friction falling with feed where Stribeck rises)"
            )?;
        }
        for span in spans {
            writeln!(
                o,
                "non-conventional {}: positions {:.3}-{:.3} mm, friction falls between {:.3} and {:.3} mm/min (excess drop up to {:.2} N)",
                span.direction.as_str(),
                span.from_position_mm,
                span.to_position_mm,
                span.from_feed_mm_min,
                span.to_feed_mm_min,
                span.max_excess_drop_n
            )?;
        }
        Ok(())
    }
}

impl Mapped {
    /// The remarks beside the text view (the CLI's stderr), one line each, per direction: the
    /// model at the chosen positions (once, `(every position)`, when it and its reasons are
    /// the same everywhere), the richer models refused with their reasons and what to measure
    /// ([`advice`]), then every fit warning (`warning: forward at 35.000 mm: ...`).
    pub fn remarks(&self) -> Vec<String> {
        let mut lines = Vec::new();
        for p in &self.study.at_positions {
            models(p, &mut lines);
        }
        lines
    }
}

/// The remarks of one direction's fits ([`Mapped::remarks`]).
fn models(p: &StribeckProfile, lines: &mut Vec<String>) {
    let dir = p.direction.as_str();
    let key = |q: &StribeckAtPosition| {
        q.fit.as_ref().map(|f| {
            let reasons: Vec<String> = f.reductions.iter().map(|r| r.to_string()).collect();
            (f.model, reasons)
        })
    };
    let first = p.positions.first().and_then(key);
    let same = p.positions.iter().all(|q| key(q) == first);
    let mut describe = |where_: &str, model: FrictionModel, reductions: &[Reduction]| {
        lines.push(format!("{dir}{where_}: model {model}"));
        for r in reductions {
            lines.push(format!("  {r}"));
        }
        if let Some(r) = reductions.last() {
            // The map fits δ = 2: no free δ to advise on.
            lines.push(format!("  {}", advice(r.code(), None)));
        }
    };
    match (&first, same) {
        (Some(_), true) => {
            let f = p.positions[0]
                .fit
                .as_ref()
                .expect("the first position's fit");
            describe(" (every position)", f.model, &f.reductions);
        }
        _ => {
            for q in &p.positions {
                if let Some(f) = &q.fit {
                    describe(
                        &format!(" at {:.3} mm", q.position_mm),
                        f.model,
                        &f.reductions,
                    );
                }
            }
        }
    }
    for q in &p.positions {
        for w in q.fit.iter().flat_map(|f| &f.warnings) {
            lines.push(format!("warning: {dir} at {:.3} mm: {w}", q.position_mm));
        }
    }
}
