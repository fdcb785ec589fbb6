//! `--export tf5200|sinumerik|table` of `feedscope map` and `feedscope fit-stribeck`: friction
//! compensation in the controllers' own files (issue 16, "Out").
use anyhow::{Context, Result};
use clap::ValueEnum;
use feedscope::axis::AxisParams;
use feedscope::compensation::{
    DriveConversion, FrictionCurve, PlacementParams, SinumerikParams, SinumerikStartValues,
    Tf5200OutUnit, Tf5200Params, Tf5200Table, VelocityTable, VELOCITY_TABLE_MAX_POINTS,
};
use feedscope::stroke::Direction;
use feedscope_io::controller_compensation::{
    write_sinumerik, write_tf5200, write_velocity_table, ExportSource,
};

use feedscope_app::AppError;

/// A controller file `--export` writes.
#[derive(Debug, Clone, Copy, ValueEnum, PartialEq, Eq, PartialOrd, Ord)]
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
}

const DEFAULT_POINTS: usize = 20;

/// The flags of `--export`, shared by `map` and `fit-stribeck`.
#[derive(Debug, clap::Args)]
#[command(next_help_heading = "Controller export")]
pub struct ExportArgs {
    /// Controller files to write into the output folder, repeatable or comma-separated:
    /// `tf5200` (frict_comp_tf5200.txt, the frict_comp block of a Beckhoff TwinCAT CNC axis
    /// compensation list), `sinumerik` (frict_comp_sinumerik.txt, SINUMERIK conventional
    /// friction compensation starting values, to tune with the circularity test), `table`
    /// (frict_comp_table.csv, velocity -> friction, motor torque and current per direction).
    #[arg(long, value_enum, value_delimiter = ',')]
    pub export: Vec<ExportKind>,
    /// Points of the exported tables, placed where the curve bends [default: 20; at most
    /// --tf5200-max-points for tf5200, 512 for table].
    #[arg(long)]
    pub export_points: Option<usize>,
    /// Size of one unit of frict_comp.table[i].out in amperes: the drive's unit of
    /// dig_drv.act_torque (e.g. 0.001 for mA). tf5200 needs it or --tf5200-out-unit-nm.
    #[arg(long, conflicts_with = "tf5200_out_unit_nm")]
    pub tf5200_out_unit_a: Option<f64>,
    /// Size of one unit of frict_comp.table[i].out in N·m, for a drive whose act_torque is a
    /// torque.
    #[arg(long)]
    pub tf5200_out_unit_nm: Option<f64>,
    /// frict_comp.max_points configured on the CNC (P-COMP-00062) [default: 20].
    #[arg(long)]
    pub tf5200_max_points: Option<usize>,
    /// Axis identifier of the SINUMERIK machine data lines, e.g. AX3 [default: AX1].
    #[arg(long)]
    pub sinumerik_axis: Option<String>,
    /// Speed-loop crossover frequency (Hz) assumed for the SINUMERIK amplitude; from the
    /// drive's speed controller gain Kp: Kp/(2π·J) [default: 50].
    #[arg(long)]
    pub speed_loop_hz: Option<f64>,
    /// Radius (mm) of the circularity test the SINUMERIK values will be tuned with
    /// [default: 10].
    #[arg(long)]
    pub circle_radius_mm: Option<f64>,
    /// Feed (mm/min) of that circularity test [default: 1000].
    #[arg(long)]
    pub circle_feed_mm_min: Option<f64>,
}

/// The validated export settings.
#[derive(Debug, Clone)]
pub struct ExportConfig {
    /// What to write, each once, in the order tf5200, sinumerik, table.
    pub kinds: Vec<ExportKind>,
    /// Table points.
    pub points: usize,
    /// TF5200 settings when tf5200 is asked for.
    pub tf5200: Option<Tf5200Params>,
    /// SINUMERIK axis identifier and assumptions when sinumerik is asked for.
    pub sinumerik: Option<(String, SinumerikParams)>,
}

impl ExportConfig {
    /// Whether `kind` is to be written.
    pub fn wants(&self, kind: ExportKind) -> bool {
        self.kinds.contains(&kind)
    }
}

fn bad(m: String) -> anyhow::Error {
    AppError::bad_input(m).into()
}

fn positive(flag: &str, v: Option<f64>) -> Result<()> {
    match v {
        Some(x) if !(x.is_finite() && x > 0.0) => {
            Err(bad(format!("{flag} {x}: must be a positive number")))
        }
        _ => Ok(()),
    }
}

impl ExportArgs {
    /// Validate the flags (before any I/O); `None` without `--export`.
    ///
    /// # Errors
    /// Bad input naming the flag: a flag of an export not asked for, fewer than 2 points or
    /// more than the controller holds, tf5200 without the unit of `out`, a value that is not
    /// positive, an axis identifier that is not a name.
    pub fn validate(&self) -> Result<Option<ExportConfig>> {
        let mut kinds = self.export.clone();
        kinds.sort();
        kinds.dedup();
        let has = |k| kinds.contains(&k);
        let given = |flag: &str, set: bool, kind: ExportKind, name: &str| -> Result<()> {
            if set && !has(kind) {
                Err(bad(format!("{flag} is used only with --export {name}")))
            } else {
                Ok(())
            }
        };
        if kinds.is_empty() && self.export_points.is_some() {
            return Err(bad("--export-points is used only with --export".into()));
        }
        given(
            "--tf5200-out-unit-a",
            self.tf5200_out_unit_a.is_some(),
            ExportKind::Tf5200,
            "tf5200",
        )?;
        given(
            "--tf5200-out-unit-nm",
            self.tf5200_out_unit_nm.is_some(),
            ExportKind::Tf5200,
            "tf5200",
        )?;
        given(
            "--tf5200-max-points",
            self.tf5200_max_points.is_some(),
            ExportKind::Tf5200,
            "tf5200",
        )?;
        given(
            "--sinumerik-axis",
            self.sinumerik_axis.is_some(),
            ExportKind::Sinumerik,
            "sinumerik",
        )?;
        given(
            "--speed-loop-hz",
            self.speed_loop_hz.is_some(),
            ExportKind::Sinumerik,
            "sinumerik",
        )?;
        given(
            "--circle-radius-mm",
            self.circle_radius_mm.is_some(),
            ExportKind::Sinumerik,
            "sinumerik",
        )?;
        given(
            "--circle-feed-mm-min",
            self.circle_feed_mm_min.is_some(),
            ExportKind::Sinumerik,
            "sinumerik",
        )?;
        if kinds.is_empty() {
            return Ok(None);
        }
        let points = self.export_points.unwrap_or(DEFAULT_POINTS);
        if points < 2 {
            return Err(bad(format!(
                "--export-points {points}: a table needs at least 2 points"
            )));
        }
        if has(ExportKind::Table) && points > VELOCITY_TABLE_MAX_POINTS {
            return Err(bad(format!(
                "--export-points {points}: the table holds at most {VELOCITY_TABLE_MAX_POINTS} points"
            )));
        }
        let tf5200 = if has(ExportKind::Tf5200) {
            let max_points = self.tf5200_max_points.unwrap_or(DEFAULT_POINTS);
            if !(2..=PlacementParams::default().max_points()).contains(&max_points) {
                return Err(bad(format!(
                    "--tf5200-max-points {max_points}: must lie in 2..={}",
                    PlacementParams::default().max_points()
                )));
            }
            if points > max_points {
                return Err(bad(format!(
                    "--export-points {points} exceeds frict_comp.max_points {max_points} \
                     (P-COMP-00062) of --export tf5200; give --tf5200-max-points if the CNC is \
                     configured for more entries"
                )));
            }
            positive("--tf5200-out-unit-a", self.tf5200_out_unit_a)?;
            positive("--tf5200-out-unit-nm", self.tf5200_out_unit_nm)?;
            let out_unit = match (self.tf5200_out_unit_a, self.tf5200_out_unit_nm) {
                (Some(a), _) => Tf5200OutUnit::Ampere(a),
                (None, Some(t)) => Tf5200OutUnit::NewtonMetre(t),
                (None, None) => {
                    return Err(bad(
                        "--export tf5200 needs the unit of frict_comp.table[i].out, which the \
                         TF5200 documentation leaves to the drive (the unit of \
                         dig_drv.act_torque): give --tf5200-out-unit-a (amperes per unit, e.g. \
                         0.001 for mA) or --tf5200-out-unit-nm"
                            .into(),
                    ))
                }
            };
            Some(Tf5200Params {
                points,
                max_points,
                out_unit,
            })
        } else {
            None
        };
        let sinumerik = if has(ExportKind::Sinumerik) {
            positive("--speed-loop-hz", self.speed_loop_hz)?;
            positive("--circle-radius-mm", self.circle_radius_mm)?;
            positive("--circle-feed-mm-min", self.circle_feed_mm_min)?;
            let axis = self.sinumerik_axis.clone().unwrap_or_else(|| "AX1".into());
            let ok = !axis.is_empty()
                && axis.len() <= 32
                && axis.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
                && axis.starts_with(|c: char| c.is_ascii_alphabetic());
            if !ok {
                return Err(bad(format!(
                    "--sinumerik-axis `{axis}`: expected an axis identifier such as AX1 or Z1 \
                     (letters, digits, underscore; a letter first)"
                )));
            }
            let d = SinumerikParams::default();
            Some((
                axis,
                SinumerikParams {
                    speed_loop_hz: self.speed_loop_hz.unwrap_or(d.speed_loop_hz),
                    circle_radius_mm: self.circle_radius_mm.unwrap_or(d.circle_radius_mm),
                    circle_feed_mm_min: self.circle_feed_mm_min.unwrap_or(d.circle_feed_mm_min),
                },
            ))
        } else {
            None
        };
        Ok(Some(ExportConfig {
            kinds,
            points,
            tf5200,
            sinumerik,
        }))
    }
}

/// One exported file, ready for the command's output set.
pub struct ExportFile {
    /// File name in the output folder.
    pub name: &'static str,
    /// Its content.
    pub bytes: Vec<u8>,
    /// One line for stderr: what it holds and its error.
    pub summary: String,
}

/// What the exports are made from: per measured direction, the curve the tables follow and
/// the Stribeck curve the SINUMERIK values need (the same for `fit-stribeck`).
pub struct ExportCurves<'a> {
    /// Curves of the tables (tf5200, table), forward first.
    pub table: &'a [FrictionCurve],
    /// Stribeck curves (sinumerik), forward first.
    pub stribeck: &'a [FrictionCurve],
}

fn of(curves: &[FrictionCurve], d: Direction) -> Option<&FrictionCurve> {
    curves.iter().find(|c| c.direction() == Some(d))
}

/// Build every file asked for; nothing is written here (the caller adds them to its output
/// set, all or nothing).
///
/// # Errors
/// Bad input (exit 2) naming the export: a curve the output cannot use (a fit that did not
/// converge, a reduced model for sinumerik, directions that share no feeds, an `out` unit too
/// coarse), an axis without the keys a conversion needs.
pub fn build(
    cfg: &ExportConfig,
    curves: &ExportCurves,
    axis: &AxisParams,
    drive: DriveConversion,
    src: &ExportSource,
) -> Result<Vec<ExportFile>> {
    let placement = PlacementParams::default();
    let mut files = Vec::new();
    let amps_per_n = drive.current_a(1.0);
    if let Some(p) = &cfg.tf5200 {
        let t = Tf5200Table::build(
            of(curves.table, Direction::Forward),
            of(curves.table, Direction::Backward),
            drive,
            p,
            &placement,
        )
        .context("--export tf5200")?;
        let mut bytes = Vec::new();
        write_tf5200(&t, src, &mut bytes)?;
        files.push(ExportFile {
            name: ExportKind::Tf5200.file_name(),
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
    if let Some((axis_id, p)) = &cfg.sinumerik {
        let s = SinumerikStartValues::compute(
            of(curves.stribeck, Direction::Forward),
            of(curves.stribeck, Direction::Backward),
            axis,
            p,
        )
        .context("--export sinumerik")?;
        let mut bytes = Vec::new();
        write_sinumerik(&s, axis_id, src, &mut bytes)?;
        files.push(ExportFile {
            name: ExportKind::Sinumerik.file_name(),
            bytes,
            summary: format!(
                "STARTING VALUES (tune with the circularity test): MD32520 {:.3} mm/min, MD32540 {:.4} s",
                s.const_max_mm_min, s.time_s
            ),
        });
    }
    if cfg.wants(ExportKind::Table) {
        let t = VelocityTable::build(curves.table, drive, cfg.points, &placement)
            .context("--export table")?;
        let mut bytes = Vec::new();
        write_velocity_table(&t, src, &mut bytes)?;
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
            name: ExportKind::Table.file_name(),
            bytes,
            summary: format!(
                "{} points per direction, error {}",
                cfg.points,
                errs.join("; ")
            ),
        });
    }
    Ok(files)
}
