//! Friction compensation in the controllers' own files (issue 16, "Out"): a Beckhoff TF5200
//! `frict_comp` block, SINUMERIK starting values, a generic velocity table, made from the
//! friction curves a map or a Stribeck fit gives.
//!
//! [`ExportOptions`] is what a user asks for; it is flattened into the requests that can
//! export ([`MapRequest`](crate::map::MapRequest),
//! [`FitStribeckRequest`](crate::stribeck::FitStribeckRequest)), whose `run` checks it
//! before anything is read ([`ExportOptions::validate`]) and builds the files after the fit
//! ([`export_files`]). The files are returned, not written, so that a front end puts them in
//! place with the rest of its outputs, or none of them.
//!
//! Units: friction in N, motor torque in N·m, current in A, feeds in mm/min, as the curves
//! carry them (`feedscope::compensation`).
use feedscope::axis::AxisParams;
use feedscope::compensation::{
    DriveConversion, FrictionCurve, PlacementParams, SinumerikParams, SinumerikStartValues,
    Tf5200OutUnit, Tf5200Params, Tf5200Table, VelocityTable, VELOCITY_TABLE_MAX_POINTS,
};
use feedscope::stroke::Direction;
use feedscope_io::controller_compensation::{
    write_sinumerik, write_tf5200, write_velocity_table, ExportSource,
};
use serde::{Deserialize, Serialize};

use crate::output::io_error;
use crate::{AppError, FrontEnd};

/// A controller file an export writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ExportKind {
    /// Beckhoff TwinCAT CNC (TF5200): the frict_comp block of the axis compensation list.
    Tf5200,
    /// SINUMERIK 840D: conventional friction compensation starting values (MD32490-MD32540).
    Sinumerik,
    /// Generic CSV: velocity -> friction (N), motor torque (N·m) and current (A) per direction.
    Table,
}

impl ExportKind {
    /// The file it is written to, in the output folder.
    pub fn file_name(self) -> &'static str {
        match self {
            Self::Tf5200 => "frict_comp_tf5200.txt",
            Self::Sinumerik => "frict_comp_sinumerik.txt",
            Self::Table => "frict_comp_table.csv",
        }
    }

    /// The value's name in requests (and the CLI's `--export`).
    pub fn name(self) -> &'static str {
        match self {
            Self::Tf5200 => "tf5200",
            Self::Sinumerik => "sinumerik",
            Self::Table => "table",
        }
    }
}

/// Table points when `export_points` is not given, and the TF5200 `frict_comp.max_points`
/// when `tf5200_max_points` is not given.
pub const DEFAULT_POINTS: usize = 20;

/// The controller files to write, as a user asks for them; every field is optional and only
/// meaningful with the export it belongs to ([`ExportOptions::validate`] refuses the others).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ExportOptions {
    /// Controller files to write (serde name `export`); empty: no export.
    #[serde(rename = "export")]
    pub kinds: Vec<ExportKind>,
    /// Points of the exported tables, placed where the curve bends (default
    /// [`DEFAULT_POINTS`]; at most `tf5200_max_points` for tf5200,
    /// [`VELOCITY_TABLE_MAX_POINTS`] for table).
    pub export_points: Option<usize>,
    /// Size of one unit of `frict_comp.table[i].out` in amperes (the drive's unit of
    /// `dig_drv.act_torque`, e.g. 0.001 for mA); tf5200 needs it or `tf5200_out_unit_nm`.
    pub tf5200_out_unit_a: Option<f64>,
    /// Size of one unit of `frict_comp.table[i].out` in N·m, for a drive whose `act_torque`
    /// is a torque.
    pub tf5200_out_unit_nm: Option<f64>,
    /// `frict_comp.max_points` configured on the CNC (P-COMP-00062), default
    /// [`DEFAULT_POINTS`].
    pub tf5200_max_points: Option<usize>,
    /// Axis identifier of the SINUMERIK machine data lines (default `AX1`).
    pub sinumerik_axis: Option<String>,
    /// Speed-loop crossover frequency (Hz) assumed for the SINUMERIK amplitude (default 50).
    pub speed_loop_hz: Option<f64>,
    /// Radius (mm) of the circularity test the SINUMERIK values will be tuned with (default
    /// 10).
    pub circle_radius_mm: Option<f64>,
    /// Feed (mm/min) of that circularity test (default 1000).
    pub circle_feed_mm_min: Option<f64>,
}

/// Export settings checked by [`ExportOptions::validate`].
#[derive(Debug, Clone, PartialEq)]
pub struct ExportPlan {
    /// What to write, each once, in the order tf5200, sinumerik, table.
    pub kinds: Vec<ExportKind>,
    /// Table points.
    pub points: usize,
    /// TF5200 settings when tf5200 is asked for.
    pub tf5200: Option<Tf5200Params>,
    /// SINUMERIK axis identifier and assumptions when sinumerik is asked for.
    pub sinumerik: Option<(String, SinumerikParams)>,
}

impl ExportPlan {
    /// Whether `kind` is to be written.
    pub fn wants(&self, kind: ExportKind) -> bool {
        self.kinds.contains(&kind)
    }
}

impl ExportOptions {
    /// Check the settings before anything is read; `None` when no export is asked for.
    ///
    /// # Errors
    /// [`AppError::invalid`] naming the field as the front end spells it: a setting of an
    /// export not asked for, fewer than 2 points or more than the controller holds, tf5200
    /// without the unit of `out`, a value that is not a positive number, an axis identifier
    /// that is not a name.
    pub fn validate(&self, front: &dyn FrontEnd) -> Result<Option<ExportPlan>, AppError> {
        let name = |f: &str| front.name(f);
        let mut kinds = self.kinds.clone();
        kinds.sort();
        kinds.dedup();
        let has = |k| kinds.contains(&k);
        if kinds.is_empty() && self.export_points.is_some() {
            return Err(AppError::invalid(
                "export_points",
                format!(
                    "{} is used only with {}",
                    name("export_points"),
                    name("export")
                ),
            ));
        }
        // Each setting belongs to one export: given without it, it would be ignored.
        for (field, set, kind) in [
            (
                "tf5200_out_unit_a",
                self.tf5200_out_unit_a.is_some(),
                ExportKind::Tf5200,
            ),
            (
                "tf5200_out_unit_nm",
                self.tf5200_out_unit_nm.is_some(),
                ExportKind::Tf5200,
            ),
            (
                "tf5200_max_points",
                self.tf5200_max_points.is_some(),
                ExportKind::Tf5200,
            ),
            (
                "sinumerik_axis",
                self.sinumerik_axis.is_some(),
                ExportKind::Sinumerik,
            ),
            (
                "speed_loop_hz",
                self.speed_loop_hz.is_some(),
                ExportKind::Sinumerik,
            ),
            (
                "circle_radius_mm",
                self.circle_radius_mm.is_some(),
                ExportKind::Sinumerik,
            ),
            (
                "circle_feed_mm_min",
                self.circle_feed_mm_min.is_some(),
                ExportKind::Sinumerik,
            ),
        ] {
            if set && !has(kind) {
                return Err(AppError::invalid(
                    field,
                    format!(
                        "{} is used only with {}",
                        name(field),
                        front.spell("export", kind.name())
                    ),
                ));
            }
        }
        if kinds.is_empty() {
            return Ok(None);
        }
        let points = self.export_points.unwrap_or(DEFAULT_POINTS);
        if points < 2 {
            return Err(AppError::invalid(
                "export_points",
                format!(
                    "{} {points}: a table needs at least 2 points",
                    name("export_points")
                ),
            ));
        }
        if has(ExportKind::Table) && points > VELOCITY_TABLE_MAX_POINTS {
            return Err(AppError::invalid(
                "export_points",
                format!(
                    "{} {points}: the table holds at most {VELOCITY_TABLE_MAX_POINTS} points",
                    name("export_points")
                ),
            ));
        }
        let tf5200 = if has(ExportKind::Tf5200) {
            Some(self.tf5200_params(points, front)?)
        } else {
            None
        };
        let sinumerik = if has(ExportKind::Sinumerik) {
            Some(self.sinumerik_params(front)?)
        } else {
            None
        };
        Ok(Some(ExportPlan {
            kinds,
            points,
            tf5200,
            sinumerik,
        }))
    }

    fn tf5200_params(&self, points: usize, front: &dyn FrontEnd) -> Result<Tf5200Params, AppError> {
        let name = |f: &str| front.name(f);
        let max_points = self.tf5200_max_points.unwrap_or(DEFAULT_POINTS);
        let most = PlacementParams::default().max_points();
        if !(2..=most).contains(&max_points) {
            return Err(AppError::invalid(
                "tf5200_max_points",
                format!(
                    "{} {max_points}: must lie in 2..={most}",
                    name("tf5200_max_points")
                ),
            ));
        }
        if points > max_points {
            return Err(AppError::invalid(
                "export_points",
                format!(
                    "{} {points} exceeds frict_comp.max_points {max_points} (P-COMP-00062) of \
                     {}; give {} if the CNC is configured for more entries",
                    name("export_points"),
                    front.spell("export", ExportKind::Tf5200.name()),
                    name("tf5200_max_points")
                ),
            ));
        }
        positive("tf5200_out_unit_a", self.tf5200_out_unit_a, front)?;
        positive("tf5200_out_unit_nm", self.tf5200_out_unit_nm, front)?;
        let out_unit = match (self.tf5200_out_unit_a, self.tf5200_out_unit_nm) {
            (Some(a), _) => Tf5200OutUnit::Ampere(a),
            (None, Some(t)) => Tf5200OutUnit::NewtonMetre(t),
            (None, None) => {
                return Err(AppError::invalid(
                    "tf5200_out_unit_a",
                    format!(
                        "{} needs the unit of frict_comp.table[i].out, which the TF5200 \
                         documentation leaves to the drive (the unit of dig_drv.act_torque): \
                         give {} (amperes per unit, e.g. 0.001 for mA) or {}",
                        front.spell("export", ExportKind::Tf5200.name()),
                        name("tf5200_out_unit_a"),
                        name("tf5200_out_unit_nm")
                    ),
                ))
            }
        };
        Ok(Tf5200Params {
            points,
            max_points,
            out_unit,
        })
    }

    fn sinumerik_params(
        &self,
        front: &dyn FrontEnd,
    ) -> Result<(String, SinumerikParams), AppError> {
        positive("speed_loop_hz", self.speed_loop_hz, front)?;
        positive("circle_radius_mm", self.circle_radius_mm, front)?;
        positive("circle_feed_mm_min", self.circle_feed_mm_min, front)?;
        let axis = self.sinumerik_axis.clone().unwrap_or_else(|| "AX1".into());
        // What the machine data lines take as an axis identifier.
        let ok = !axis.is_empty()
            && axis.len() <= 32
            && axis.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
            && axis.starts_with(|c: char| c.is_ascii_alphabetic());
        if !ok {
            return Err(AppError::invalid(
                "sinumerik_axis",
                format!(
                    "{} `{axis}`: expected an axis identifier such as AX1 or Z1 (letters, \
                     digits, underscore; a letter first)",
                    front.name("sinumerik_axis")
                ),
            ));
        }
        let d = SinumerikParams::default();
        Ok((
            axis,
            SinumerikParams {
                speed_loop_hz: self.speed_loop_hz.unwrap_or(d.speed_loop_hz),
                circle_radius_mm: self.circle_radius_mm.unwrap_or(d.circle_radius_mm),
                circle_feed_mm_min: self.circle_feed_mm_min.unwrap_or(d.circle_feed_mm_min),
            },
        ))
    }
}

/// Refuse a given value that is not a finite number above 0.
fn positive(field: &'static str, v: Option<f64>, front: &dyn FrontEnd) -> Result<(), AppError> {
    match v {
        Some(x) if !(x.is_finite() && x > 0.0) => Err(AppError::invalid(
            field,
            format!("{} {x}: must be a positive number", front.name(field)),
        )),
        _ => Ok(()),
    }
}

/// One exported file, ready for the front end's output set.
#[derive(Debug, Clone, Serialize)]
pub struct ExportFile {
    /// File name in the output folder ([`ExportKind::file_name`]).
    pub name: &'static str,
    /// Its content.
    #[serde(skip)]
    pub bytes: Vec<u8>,
    /// One line for people: what it holds and the error of its table against the curve.
    pub summary: String,
}

/// What the exports are made from: per measured direction, the curve the tables follow and
/// the Stribeck curve the SINUMERIK values need (the same curves for a Stribeck fit).
#[derive(Debug, Clone, Copy)]
pub struct ExportCurves<'a> {
    /// Curves of the tables (tf5200, table), forward first.
    pub table: &'a [FrictionCurve],
    /// Stribeck curves (sinumerik), forward first.
    pub stribeck: &'a [FrictionCurve],
}

fn of(curves: &[FrictionCurve], d: Direction) -> Option<&FrictionCurve> {
    curves.iter().find(|c| c.direction() == Some(d))
}

/// Build every file `plan` asks for from `curves`; nothing is written here.
///
/// `drive` converts friction (N) into motor torque (N·m) and current (A); `axis` gives the
/// masses of the SINUMERIK amplitude; `source` names the origin in the files' headers.
///
/// # Errors
/// Bad input naming the export: a curve the output cannot use (a fit that did not converge,
/// a reduced model for sinumerik, directions that share no feeds, an `out` unit too coarse),
/// an axis without the keys a conversion needs.
pub fn export_files(
    plan: &ExportPlan,
    curves: &ExportCurves,
    axis: &AxisParams,
    drive: DriveConversion,
    source: &ExportSource,
    front: &dyn FrontEnd,
) -> Result<Vec<ExportFile>, AppError> {
    let placement = PlacementParams::default();
    let export = |kind: ExportKind| front.spell("export", kind.name());
    // Writing into memory fails only if the writer has a bug.
    let writing = |kind: ExportKind| move |e| io_error(format!("writing {}", kind.file_name()), e);
    let mut files = Vec::new();
    let amps_per_n = drive.current_a(1.0);
    if let Some(p) = &plan.tf5200 {
        let kind = ExportKind::Tf5200;
        let t = Tf5200Table::build(
            of(curves.table, Direction::Forward),
            of(curves.table, Direction::Backward),
            drive,
            p,
            &placement,
        )
        .map_err(|e| AppError::within(export(kind), e))?;
        let mut bytes = Vec::new();
        write_tf5200(&t, source, &mut bytes).map_err(writing(kind))?;
        files.push(ExportFile {
            name: kind.file_name(),
            bytes,
            summary: format!(
                "{} entries on the {}, error of the rounded table max {:.3} N = {:.4} A ({:.3} %), RMS {:.3} N ({:.3} %)",
                t.entries.len(),
                t.curve.label(),
                t.error.max_n,
                t.error.max_n * amps_per_n,
                t.error.max_pct,
                t.error.rms_n,
                t.error.rms_pct
            ),
        });
    }
    if let Some((axis_id, p)) = &plan.sinumerik {
        let kind = ExportKind::Sinumerik;
        let s = SinumerikStartValues::compute(
            of(curves.stribeck, Direction::Forward),
            of(curves.stribeck, Direction::Backward),
            axis,
            p,
        )
        .map_err(|e| AppError::within(export(kind), e))?;
        let mut bytes = Vec::new();
        write_sinumerik(&s, axis_id, source, &mut bytes).map_err(writing(kind))?;
        files.push(ExportFile {
            name: kind.file_name(),
            bytes,
            summary: format!(
                "STARTING VALUES (tune with the circularity test): MD32520 {:.3} mm/min, MD32540 {:.4} s",
                s.const_max_mm_min, s.time_s
            ),
        });
    }
    if plan.wants(ExportKind::Table) {
        let kind = ExportKind::Table;
        let t = VelocityTable::build(curves.table, drive, plan.points, &placement)
            .map_err(|e| AppError::within(export(kind), e))?;
        let mut bytes = Vec::new();
        write_velocity_table(&t, source, &mut bytes).map_err(writing(kind))?;
        let errs: Vec<String> = t
            .directions
            .iter()
            .map(|d| {
                format!(
                    "{} max {:.3} N ({:.3} %), RMS {:.3} N",
                    d.curve.direction().map_or("both", |x| x.as_str()),
                    d.placed.error.max_n,
                    d.placed.error.max_pct,
                    d.placed.error.rms_n
                )
            })
            .collect();
        files.push(ExportFile {
            name: kind.file_name(),
            bytes,
            summary: format!(
                "{} points per direction, error {}",
                plan.points,
                errs.join("; ")
            ),
        });
    }
    Ok(files)
}
