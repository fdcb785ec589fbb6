//! Identify friction and inertia from one triangular-wave test (paper 002), optionally
//! compared with the traditional test: the Stribeck model fitted to the mean friction of
//! constant-speed strokes at several feeds.
//!
//! [`IdentifyRequest`] names the files; [`identify_recordings`] takes traces already held
//! (the Python module's path). Both give an [`Identified`]: the [`IdentifyReport`], which is
//! `ident.json`, and the kernel-averaged series of the fit for plots and arrays. The report's
//! `Display` is its plain-text view.
use feedscope::diag::{Code, Diagnostic};
use std::fmt;
use std::path::PathBuf;

use feedscope::axis::AxisParams;
use feedscope::estimate::EstimateParams;
use feedscope::ident::{
    fit_groups, identify, ForceSide, Group, IdentParams, Identification, TorqueFit, TorqueStdError,
};
use feedscope::trace::EffortKind;
use feedscope::ErrorKind;
use serde::{Deserialize, Serialize};

use crate::recording::{read_recording, Effort};
use crate::{AppError, FrontEnd, Recording};

/// Identify from trace files.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IdentifyRequest {
    /// Trace of the triangular-wave test (CSV or Parquet).
    pub trace: PathBuf,
    /// Axis parameters (TOML or JSON): lead and torque constant; inertia and damping may be
    /// left out (the test identifies them), except with `compare`.
    pub axis: PathBuf,
    /// Trace of constant-feed strokes at several feeds, fitted for comparison.
    pub compare: Option<PathBuf>,
    /// The effort channel of a file that has both current and torque.
    pub effort: Option<Effort>,
    /// Settings of the fit.
    #[serde(flatten)]
    pub options: IdentifyOptions,
}

/// Settings of the identification (the fit's [`IdentParams`]).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct IdentifyOptions {
    /// Settings of the fit (paper 002), as `ident.json` echoes them.
    pub params: IdentParams,
}

impl IdentifyRequest {
    /// Check the request without reading anything.
    ///
    /// # Errors
    /// [`AppError::invalid`] naming the field: an empty path, a setting out of range.
    pub fn validate(&self) -> Result<(), AppError> {
        for (field, p) in [("trace", &self.trace), ("axis", &self.axis)] {
            if p.as_os_str().is_empty() {
                return Err(AppError::invalid(field, format!("`{field}` names no file")));
            }
        }
        if self
            .compare
            .as_ref()
            .is_some_and(|p| p.as_os_str().is_empty())
        {
            return Err(AppError::invalid("compare", "`compare` names no file"));
        }
        self.options.validate()
    }

    /// Read the files and identify.
    ///
    /// # Errors
    /// As [`IdentifyRequest::validate`]; the file readers' errors (naming the file and line);
    /// an axis file without inertia or damping when `compare` is given; the fit's refusal of
    /// a trace that cannot identify the model.
    pub fn run(&self, front: &dyn FrontEnd) -> Result<Identified, AppError> {
        self.validate()?;
        // J and B are what the test identifies: the axis file may leave them out.
        let axis = feedscope_io::axis::load_for_identification(&self.axis)
            .map_err(AppError::from_error)?;
        if self.compare.is_some() {
            needs_dynamics(&axis, Some(&self.axis.display().to_string()), front)?;
        }
        let test = read_recording(&self.trace, self.effort, &axis, front)?;
        let groups = match &self.compare {
            Some(p) => Some(read_recording(p, self.effort, &axis, front)?),
            None => None,
        };
        identify_recordings(&test, groups.as_ref(), &axis, &self.options, front)
    }
}

impl IdentifyOptions {
    /// Check the settings (the fit's own checks, run before any data are read).
    ///
    /// # Errors
    /// [`AppError::invalid`] naming the setting.
    pub fn validate(&self) -> Result<(), AppError> {
        feedscope::ident::check_params(&self.params).map_err(|e| match e {
            feedscope::ident::IdentError::InvalidParam { name, .. } => {
                let reason = e.to_string();
                AppError::invalid(name, reason)
            }
            other => AppError::from_error(other),
        })
    }
}

/// `--compare`/`compare` fits the strokes' mean friction, which needs the axis's inertia and
/// damping (paper 000 Eq. 5).
fn needs_dynamics(
    axis: &AxisParams,
    source: Option<&str>,
    front: &dyn FrontEnd,
) -> Result<(), AppError> {
    if axis.has_dynamics() {
        return Ok(());
    }
    let key = if axis.inertia_kgm2.is_finite() {
        "damping_nms_per_rad"
    } else {
        "inertia_kgm2"
    };
    let what = format!(
        "{} estimates the friction of the constant-speed strokes (paper 000 Eq. 5), which \
         needs key `{key}` in the axis",
        front.name("compare")
    );
    Err(AppError::bad_input(match source {
        Some(file) => format!("{file}: {what} file"),
        None => what,
    })
    .for_field("compare"))
}

/// What an identification gives: the report and the fit's series.
#[derive(Debug, Clone)]
pub struct Identified {
    /// The parameters, standard errors, diagnostics and warnings: `ident.json`.
    pub report: IdentifyReport,
    /// The kernel-averaged series of the fit (times, measured and computed torque, the rows
    /// used), for a plot or arrays.
    pub fit: Identification,
    /// The axis as the identification used it (from the request's file, or the caller's).
    pub axis: AxisParams,
}

/// Identify from traces already held: `test` is the triangular-wave test; `groups`, when
/// given, the constant-speed strokes fitted for comparison.
///
/// # Errors
/// Bad input: the fit's refusal (no reversal, one speed only, too few samples per
/// acceleration phase), an axis without inertia or damping when `groups` is given, a settings
/// error naming the setting.
pub fn identify_recordings(
    test: &Recording<'_>,
    groups: Option<&Recording<'_>>,
    axis: &AxisParams,
    options: &IdentifyOptions,
    front: &dyn FrontEnd,
) -> Result<Identified, AppError> {
    options.validate()?;
    if groups.is_some() {
        needs_dynamics(axis, None, front)?;
    }
    front.stage("identifying");
    let params = &options.params;
    let id = identify(&test.trace, axis, params).map_err(|e| {
        AppError::caused(
            ErrorKind::BadInput,
            format!("identifying from {}", test.source),
            e,
        )
    })?;
    let lead_m = axis.lead_m();
    let mut warnings: Vec<Diagnostic> = test.read_diagnostics();
    warnings.extend(id.warnings.iter().cloned());
    let compare = match groups {
        Some(g) => {
            warnings.extend(g.read_diagnostics());
            let fitted =
                fit_groups(&g.trace, axis, params, &EstimateParams::default()).map_err(|e| {
                    AppError::caused(
                        ErrorKind::BadInput,
                        format!("fitting the constant-speed groups of {}", g.source),
                        e,
                    )
                })?;
            if fitted.fit.vs_at_bound {
                warnings.push(Diagnostic::new(
                    Code::VsAtBound,
                    "groups: the Stribeck velocity ended at a search bound (not resolved by \
                     the feeds of the groups)",
                ));
            }
            let f = &id.fit;
            let pct = |a: f64, b: f64| 100.0 * (a - b) / b;
            Some(Comparison {
                source: g.source.clone(),
                difference_percent: Difference {
                    tc: pct(f.tc_nm, fitted.fit.tc_nm),
                    ts: pct(f.ts_nm, fitted.fit.ts_nm),
                    vs: pct(f.vs_mm_min, fitted.fit.vs_mm_min),
                    sigma: pct(f.sigma_nm_s_per_m, fitted.fit.sigma_nm_s_per_m),
                },
                set: ParamSet::new(&fitted.fit, lead_m),
                groups: fitted.groups,
            })
        }
        None => None,
    };
    let report = IdentifyReport {
        source: test.source.clone(),
        effort: test.trace.effort_kind,
        lead_mm: axis.lead_mm,
        set: ParamSet::new(&id.fit, lead_m),
        samples_total: id.samples_total,
        kernel_half_width_s: id.kernel_half_width_s,
        reversal_guard_s: id.reversal_guard_s,
        sample_interval_s: id.sample_interval_s,
        axis_j_total_kgm2: id.axis_j_total_kgm2,
        params: params.clone(),
        warnings,
        compare,
    };
    Ok(Identified {
        report,
        fit: id,
        axis: axis.clone(),
    })
}

/// The result of an identification: `ident.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct IdentifyReport {
    /// The test trace's source.
    pub source: String,
    /// The effort channel fitted.
    pub effort: EffortKind,
    /// Screw lead (mm).
    pub lead_mm: f64,
    /// The parameters, their standard errors, the force side and the fit's diagnostics.
    #[serde(flatten)]
    pub set: ParamSet,
    /// Samples of the trace.
    pub samples_total: usize,
    /// Half-width of the averaging kernel used (s).
    pub kernel_half_width_s: f64,
    /// Guard around slow samples and reversals used (s).
    pub reversal_guard_s: f64,
    /// Median sampling interval of the trace (s).
    pub sample_interval_s: f64,
    /// J_total the axis file predicts (motor + screw + table, kg·m²), for comparison; `None`
    /// when the file gives no `inertia_kgm2`.
    pub axis_j_total_kgm2: Option<f64>,
    /// The settings of the fit.
    pub params: IdentParams,
    /// What the result does not support, or what the readers dropped.
    pub warnings: Vec<Diagnostic>,
    /// The comparison with the constant-speed groups, when asked for.
    pub compare: Option<Comparison>,
}

/// Motor-side parameters of a fit (paper 002 Eq. 1-2).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Motor {
    /// Total inertia seen by the motor, J (kg·m²).
    pub j_total_kgm2: f64,
    /// Coulomb friction torque T_c (N·m).
    pub tc_nm: f64,
    /// Static (breakaway) friction torque T_s (N·m).
    pub ts_nm: f64,
    /// Stribeck velocity v_s (mm/min).
    pub vs_mm_min: f64,
    /// Viscous coefficient σ (N·m per m/s of table speed).
    pub sigma_nm_s_per_m: f64,
    /// Constant torque T_0 (N·m).
    pub offset_nm: f64,
    /// Stribeck shape exponent δ (held fixed).
    pub delta: f64,
}

/// How well a fit is determined.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Diagnostics {
    /// RMS of the torque residual (N·m).
    pub residual_rms_nm: f64,
    /// Condition number of the linear part.
    pub condition_number: f64,
    /// Evaluations of the v_s search.
    pub iterations: usize,
    /// Rows used in the fit.
    pub samples_used: usize,
    /// Whether v_s ended at a bound of its search (not resolved).
    pub vs_at_bound: bool,
}

/// One fit's parameters as `ident.json` holds them.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ParamSet {
    /// Motor side.
    pub motor: Motor,
    /// Standard errors of the motor-side parameters (same units).
    pub std_error: TorqueStdError,
    /// Force side, F = 2π·T/p.
    pub force: ForceSide,
    /// How well the fit is determined.
    pub diagnostics: Diagnostics,
}

impl ParamSet {
    /// The set of a fit, with the force side for a screw of lead `lead_m` (m).
    pub fn new(f: &TorqueFit, lead_m: f64) -> Self {
        Self {
            motor: Motor {
                j_total_kgm2: f.j_total_kgm2,
                tc_nm: f.tc_nm,
                ts_nm: f.ts_nm,
                vs_mm_min: f.vs_mm_min,
                sigma_nm_s_per_m: f.sigma_nm_s_per_m,
                offset_nm: f.offset_nm,
                delta: f.delta,
            },
            std_error: f.std_error.clone(),
            force: ForceSide::from_fit(f, lead_m),
            diagnostics: Diagnostics {
                residual_rms_nm: f.residual_rms_nm,
                condition_number: f.condition_number,
                iterations: f.iterations,
                samples_used: f.samples_used,
                vs_at_bound: f.vs_at_bound,
            },
        }
    }
}

/// The traditional test's fit beside the one-test identification.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Comparison {
    /// The groups trace's source.
    pub source: String,
    /// The constant-speed groups: feed and mean friction of each.
    pub groups: Vec<Group>,
    /// The model fitted to the groups.
    #[serde(flatten)]
    pub set: ParamSet,
    /// (one test − groups) / groups, in percent.
    pub difference_percent: Difference,
}

/// Relative differences of the friction parameters (%).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Difference {
    /// Of T_c.
    pub tc: f64,
    /// Of T_s.
    pub ts: f64,
    /// Of v_s.
    pub vs: f64,
    /// Of σ.
    pub sigma: f64,
}

impl fmt::Display for IdentifyReport {
    /// The report's plain-text view shared by the front ends: the fit's diagnostics, the
    /// motor-side parameters with their standard errors (beside the groups' with a
    /// comparison), the force side, the inertia the axis file predicts, the differences to
    /// the groups in percent and every warning.
    fn fmt(&self, w: &mut fmt::Formatter<'_>) -> fmt::Result {
        let m = &self.set.motor;
        let s = &self.set.std_error;
        let f = &self.set.force;
        writeln!(w, "one-test identification (paper 002) of {}", self.source)?;
        writeln!(
            w,
            "  samples {} used of {}, residual RMS {:.4} N·m, condition {:.1}, {} evaluations",
            self.set.diagnostics.samples_used,
            self.samples_total,
            self.set.diagnostics.residual_rms_nm,
            self.set.diagnostics.condition_number,
            self.set.diagnostics.iterations
        )?;
        let rows: [(&str, f64, f64, &str); 6] = [
            ("J total", m.j_total_kgm2, s.j_total_kgm2, "kg·m²"),
            ("Tc", m.tc_nm, s.tc_nm, "N·m"),
            ("Ts", m.ts_nm, s.ts_nm, "N·m"),
            ("vs", m.vs_mm_min, s.vs_mm_min, "mm/min"),
            ("sigma", m.sigma_nm_s_per_m, s.sigma_nm_s_per_m, "N·m·s/m"),
            ("T0", m.offset_nm, s.offset_nm, "N·m"),
        ];
        let cmp = self.compare.as_ref();
        match cmp {
            Some(_) => writeln!(
                w,
                "  {:<8} {:>14} {:>12} {:>14} {:>12}  unit",
                "", "one test", "± 1σ", "groups", "± 1σ"
            )?,
            None => writeln!(w, "  {:<8} {:>14} {:>12}  unit", "", "value", "± 1σ")?,
        }
        for (k, (name, v, e, unit)) in rows.iter().enumerate() {
            match cmp {
                // The groups' fit has no inertia: J is the one test's alone.
                Some(_) if k == 0 => writeln!(
                    w,
                    "  {name:<8} {v:>14.6} {e:>12.6} {:>14} {:>12}  {unit}",
                    "-", "-"
                )?,
                Some(c) => {
                    let cm = &c.set.motor;
                    let cs = &c.set.std_error;
                    let (gv, ge) = [
                        (cm.j_total_kgm2, cs.j_total_kgm2),
                        (cm.tc_nm, cs.tc_nm),
                        (cm.ts_nm, cs.ts_nm),
                        (cm.vs_mm_min, cs.vs_mm_min),
                        (cm.sigma_nm_s_per_m, cs.sigma_nm_s_per_m),
                        (cm.offset_nm, cs.offset_nm),
                    ][k];
                    writeln!(
                        w,
                        "  {name:<8} {v:>14.6} {e:>12.6} {gv:>14.6} {ge:>12.6}  {unit}"
                    )?;
                }
                None => writeln!(w, "  {name:<8} {v:>14.6} {e:>12.6}  {unit}")?,
            }
        }
        writeln!(
            w,
            "  force side (F = 2π·T/p): Fc {:.2} N, Fs {:.2} N, sigma {:.1} N·s/m, \
             equivalent mass {:.1} kg",
            f.fc_n, f.fs_n, f.sigma_n_s_per_m, f.equivalent_mass_kg
        )?;
        match self.axis_j_total_kgm2 {
            Some(j) => writeln!(w, "  the axis file predicts J total {j:.6} kg·m²")?,
            None => writeln!(w, "  the axis file gives no inertia: J is the test's alone")?,
        }
        if let Some(c) = cmp {
            let d = &c.difference_percent;
            writeln!(
                w,
                "  one test vs {} groups: Tc {:+.1} %, Ts {:+.1} %, vs {:+.1} %, sigma {:+.1} %",
                c.groups.len(),
                d.tc,
                d.ts,
                d.vs,
                d.sigma
            )?;
        }
        for warn in &self.warnings {
            writeln!(w, "  warning: {warn}")?;
        }
        Ok(())
    }
}
