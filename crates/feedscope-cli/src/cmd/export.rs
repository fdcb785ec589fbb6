//! The flags of `--export tf5200|sinumerik|table` of `feedscope map` and `feedscope
//! fit-stribeck`: friction compensation in the controllers' own files (issue 16, "Out"),
//! made by `feedscope_app::compensation` from the flags' [`ExportOptions`].
use clap::ValueEnum;
use feedscope_app::compensation::{self, ExportOptions};

/// A controller file `--export` writes.
#[derive(Debug, Clone, Copy, ValueEnum, PartialEq, Eq)]
pub enum ExportKind {
    /// Beckhoff TwinCAT CNC (TF5200): the frict_comp block of the axis compensation list.
    Tf5200,
    /// SINUMERIK 840D: conventional friction compensation starting values (MD32490-MD32540).
    Sinumerik,
    /// Generic CSV: velocity -> friction (N), motor torque (N·m) and current (A) per direction.
    Table,
}

impl From<ExportKind> for compensation::ExportKind {
    fn from(k: ExportKind) -> Self {
        match k {
            ExportKind::Tf5200 => Self::Tf5200,
            ExportKind::Sinumerik => Self::Sinumerik,
            ExportKind::Table => Self::Table,
        }
    }
}

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

impl ExportArgs {
    /// The request's export settings (checked by the use case, naming the flag).
    pub fn options(&self) -> ExportOptions {
        ExportOptions {
            kinds: self.export.iter().map(|&k| k.into()).collect(),
            export_points: self.export_points,
            tf5200_out_unit_a: self.tf5200_out_unit_a,
            tf5200_out_unit_nm: self.tf5200_out_unit_nm,
            tf5200_max_points: self.tf5200_max_points,
            sinumerik_axis: self.sinumerik_axis.clone(),
            speed_loop_hz: self.speed_loop_hz,
            circle_radius_mm: self.circle_radius_mm,
            circle_feed_mm_min: self.circle_feed_mm_min,
        }
    }
}
