//! Friction-compensation files a controller loads, from [`feedscope::compensation`]:
//!
//! - [`write_tf5200`]: the `frict_comp` block of a Beckhoff TwinCAT CNC (TF5200) axis
//!   compensation list (`# ` comment lines, `key value` lines), to paste into the axis's list;
//! - [`write_sinumerik`]: SINUMERIK 840D conventional friction compensation starting values
//!   (`; ` comment lines, `$MA_NAME[AXIS]=value` lines), to enter and then tune with the
//!   circularity test;
//! - [`write_velocity_table`]: the generic CSV, velocity → friction force, motor torque and
//!   current per direction, for any other control.
//!
//! Every file opens with comment lines stating what it is, where it came from, its units, its
//! sign convention, the velocity range where it is valid and the error of its straight lines
//! against the identified curve; the TF5200 and SINUMERIK files also say what the
//! controller's documentation did not confirm (see the library modules
//! [`feedscope::compensation::tf5200`] and [`feedscope::compensation::sinumerik`]).
//! Numbers are written with fixed decimals so that the files are stable text.

use std::io::Write;

use feedscope::compensation::{
    DriveConversion, FrictionCurve, InterpolationError, SinumerikStartValues, Tf5200Table,
    VelocityTable,
};
use feedscope::units::feed_m_s_to_mm_min;

/// Where the exported values came from, for the header lines.
#[derive(Debug, Clone, Copy)]
pub struct ExportSource<'a> {
    /// The command and its input, e.g. `feedscope fit-stribeck steady.csv`.
    pub source: &'a str,
    /// The axis name of the axis file, if it has one.
    pub axis_name: Option<&'a str>,
}

/// The TF5200 documentation page of P-COMP-00046, the neighbouring pages hold the others.
pub const TF5200_REFERENCE: &str =
    "https://infosys.beckhoff.com/content/1033/tf5200_axis_compensation_parameters/113455883.html";

/// The SINUMERIK function manual section the starting values follow.
pub const SINUMERIK_REFERENCE: &str = "SINUMERIK 840D sl Function Manual Extended Functions, K3 \
    Compensations, Section 4.6 Friction compensation (quadrant error compensation), 03/2013, \
    6FC5397-1BP40-3BA1";

fn mm_min(v_m_s: f64) -> f64 {
    feed_m_s_to_mm_min(v_m_s)
}

fn range_text(c: &FrictionCurve) -> String {
    let (lo, hi) = c.range_m_s();
    format!("{:.3} to {:.3} mm/min", mm_min(lo), mm_min(hi))
}

fn conversion_text(d: &DriveConversion) -> String {
    format!(
        "torque_nm = |F| * lead / (2*pi*efficiency), current_a = torque_nm / torque_constant; \
         lead {} mm, torque constant {} N*m/A, efficiency {}",
        d.lead_m * 1e3,
        d.torque_constant_nm_per_a,
        d.efficiency
    )
}

/// `max X N (Y %) at V mm/min, RMS X N (Y %)` with the force scaled by `per_n` into `unit`
/// when given (e.g. amperes per newton).
fn error_text(e: &InterpolationError, also: Option<(f64, &str)>) -> String {
    let with = |x: f64| match also {
        Some((k, unit)) => format!("{x:.3} N = {:.6} {unit}", x * k),
        None => format!("{x:.3} N"),
    };
    format!(
        "max {} ({:.3} %) at {:.3} mm/min, RMS over ln v {} ({:.3} %)",
        with(e.max_n),
        e.max_pct,
        mm_min(e.max_at_m_s),
        with(e.rms_n),
        e.rms_pct
    )
}

fn source_lines(w: &mut impl Write, prefix: &str, src: &ExportSource) -> std::io::Result<()> {
    writeln!(
        w,
        "{prefix} axis: {}; source: {}",
        src.axis_name.unwrap_or("(unnamed)"),
        src.source
    )
}

/// Write the TF5200 `frict_comp` block (module docs): comment lines, then `frict_comp.mode 3`,
/// `table_entries`, `scaling_factor` and `table[i].in` / `table[i].out`.
///
/// # Errors
/// I/O errors of the writer.
pub fn write_tf5200<W: Write>(
    t: &Tf5200Table,
    src: &ExportSource,
    mut w: W,
) -> std::io::Result<()> {
    let (size, symbol) = t.params.out_unit.size_and_symbol();
    let first = t.entries.first().map_or(0, |e| e.in_um_s);
    let last = t.entries.last().map_or(0, |e| e.in_um_s);
    let c = "#";
    writeln!(w, "{c} feedscope: friction compensation for the Beckhoff TwinCAT CNC (TF5200), block frict_comp.* of the axis compensation list")?;
    source_lines(&mut w, c, src)?;
    writeln!(
        w,
        "{c} curve: {}; valid {} ({first} to {last} um/s), the measured feeds: no entry lies outside them",
        t.curve.label(),
        range_text(&t.curve)
    )?;
    writeln!(w, "{c} in: commanded velocity in um/s (P-COMP-00046); out: additive motor {} in units of {size} {symbol} (P-COMP-00047: the drive's unit of dig_drv.act_torque, as given on the command line)",
        if symbol == "A" { "current" } else { "torque" })?;
    writeln!(w, "{c} conversion: {}", conversion_text(&t.drive))?;
    writeln!(w, "{c} sign: magnitudes for velocity >= 0; the CNC applies them with the sign of the commanded velocity (assumed: one table per axis, velocities >= 0)")?;
    let per_n = 1.0 / t.n_per_unit() * size;
    writeln!(
        w,
        "{c} interpolation error of these entries (linear between entries, rounded values) against the curve: {}",
        error_text(&t.error, Some((per_n, symbol)))
    )?;
    for (d, e) in &t.direction_errors {
        writeln!(
            w,
            "{c} against the {} curve alone (interpolation and the difference of the directions): {}",
            d.as_str(),
            error_text(e, Some((per_n, symbol)))
        )?;
    }
    writeln!(w, "{c} frict_comp.max_points must be at least {} (P-COMP-00062, configured on the CNC; default 20; cannot change after start-up)", t.params.max_points.max(t.entries.len()))?;
    writeln!(w, "{c} not set here, tune on the machine: frict_comp.position_delay (P-COMP-00043), frict_comp.reversal_lookahead (P-COMP-00044), frict_comp.delay_cycles (P-COMP-00058)")?;
    writeln!(w, "{c} not confirmed by the documentation: the unit of out; linear interpolation between entries; the output below the first and above the last entry; the sign for negative velocities")?;
    writeln!(w, "{c} load: paste into the axis compensation list of this axis (e.g. achskw1.lis), set lr_param.frict_comp 1 (P-AXIS-00522) in its axis parameter list, switch on in the NC program with X[COMP ON FRICT]")?;
    writeln!(
        w,
        "{c} reference: {TF5200_REFERENCE} and the neighbouring P-COMP pages"
    )?;
    writeln!(w, "frict_comp.mode                 3")?;
    writeln!(w, "frict_comp.table_entries        {}", t.entries.len())?;
    writeln!(w, "frict_comp.scaling_factor       {}", t.scaling_factor)?;
    for (i, e) in t.entries.iter().enumerate() {
        let key = format!("frict_comp.table[{i}].in");
        writeln!(w, "{key:<32}{}", e.in_um_s)?;
        let key = format!("frict_comp.table[{i}].out");
        writeln!(w, "{key:<32}{}", e.out)?;
    }
    w.flush()
}

/// Write the SINUMERIK starting values (module docs): `; ` comment lines with the formulas,
/// the quantities and the assumptions, then `$MA_FRICT_COMP_*[axis]=value` lines.
///
/// # Errors
/// I/O errors of the writer.
pub fn write_sinumerik<W: Write>(
    s: &SinumerikStartValues,
    axis_id: &str,
    src: &ExportSource,
    mut w: W,
) -> std::io::Result<()> {
    let c = ";";
    let p = &s.params;
    writeln!(w, "{c} feedscope: SINUMERIK 840D conventional friction compensation (quadrant error compensation), axis {axis_id}")?;
    writeln!(w, "{c} STARTING VALUES ONLY: tune them on the machine with the circularity test (repeat with small changes at the radii and feeds the machine works at) before production")?;
    source_lines(&mut w, c, src)?;
    let fs: Vec<String> = s
        .breakaway_n
        .iter()
        .map(|(d, f)| format!("{} {f:.1} N", d.as_str()))
        .collect();
    let vs: Vec<String> = s
        .stribeck_velocity_m_s
        .iter()
        .map(|(d, v)| format!("{} {:.2} mm/min", d.as_str(), mm_min(*v)))
        .collect();
    writeln!(
        w,
        "{c} from the Stribeck fits: breakaway friction Fs {}; Stribeck velocity vs {}",
        fs.join(", "),
        vs.join(", ")
    )?;
    writeln!(
        w,
        "{c} friction step at a reversal dF = {:.1} N ({}); equivalent mass m_eq = m_t + 4*pi^2*J/p^2 = {:.1} kg",
        s.breakaway_step_n,
        if s.breakaway_n.len() == 1 {
            "2*Fs: one direction measured"
        } else {
            "Fs forward + Fs backward"
        },
        s.equivalent_mass_kg
    )?;
    writeln!(
        w,
        "{c} assumed: speed loop crossover fc = {} Hz, i.e. speed controller P gain Kp = J*2*pi*fc = {:.4} N*m*s/rad on the motor (with the drive's Kp, e.g. SINAMICS p1460: fc = Kp/(2*pi*J)); circularity test radius {} mm at {} mm/min, axis acceleration at the quadrant transition a = v^2/r = {:.4} m/s^2",
        p.speed_loop_hz,
        s.speed_gain_nms_per_rad,
        p.circle_radius_mm,
        p.circle_feed_mm_min,
        s.quadrant_accel_m_s2
    )?;
    writeln!(w, "{c} MD32520 FRICT_COMP_CONST_MAX = dF/(m_eq*2*pi*fc) = {:.3} mm/min: speed setpoint injected at the reversal so that the P part supplies the friction step (unit mm/min assumed for a linear axis)", s.const_max_mm_min)?;
    writeln!(w, "{c} MD32540 FRICT_COMP_TIME = vs/a = {:.4} s: the time the reversal needs to leave the Stribeck region on that circle (name and unit s not confirmed in the documentation found)", s.time_s)?;
    writeln!(w, "{c} MD32510 = 0: constant injection first; the adaptation characteristic (MD32530 FRICT_COMP_CONST_MIN, MD32550/MD32560/MD32570 FRICT_COMP_ACCEL1/2/3) and MD32580 FRICT_COMP_INC_FACTOR are not set: determine them with circularity tests at several accelerations if needed")?;
    writeln!(w, "{c} notation $MA_NAME[axis]=value as in part programs and INI archives: check against an archive of this control before loading; or enter the values on the axis machine data screen")?;
    writeln!(w, "{c} reference: {SINUMERIK_REFERENCE}")?;
    writeln!(w, "$MA_FRICT_COMP_MODE[{axis_id}]=1")?;
    writeln!(w, "$MA_FRICT_COMP_ENABLE[{axis_id}]=1")?;
    writeln!(w, "$MA_FRICT_COMP_ADAPT_ENABLE[{axis_id}]=0")?;
    writeln!(
        w,
        "$MA_FRICT_COMP_CONST_MAX[{axis_id}]={:.3}",
        s.const_max_mm_min
    )?;
    writeln!(w, "$MA_FRICT_COMP_TIME[{axis_id}]={:.4}", s.time_s)?;
    w.flush()
}

/// Write the generic table (module docs): comment lines, then
/// `direction,velocity_mm_min,friction_n,torque_nm,current_a`, one row per point and
/// direction, magnitudes.
///
/// # Errors
/// I/O errors of the writer.
pub fn write_velocity_table<W: Write>(
    t: &VelocityTable,
    src: &ExportSource,
    mut w: W,
) -> std::io::Result<()> {
    let c = "#";
    writeln!(w, "{c} feedscope friction-compensation table: commanded velocity -> friction force and the motor torque and current that overcome it at steady speed; interpolate linearly between rows")?;
    source_lines(&mut w, c, src)?;
    writeln!(w, "{c} units: velocity_mm_min = commanded axis velocity in mm/min; friction_n = friction force at the table in N; torque_nm = motor torque in N*m; current_a = motor current in A")?;
    writeln!(w, "{c} sign: magnitudes per direction; feed forward +value while moving forward (position increasing) and -value backward (friction signed as paper 000 Eq. 5; a positive current pushes the table forward, as in the traces)")?;
    writeln!(w, "{c} conversion: {}", conversion_text(&t.drive))?;
    for d in &t.directions {
        writeln!(
            w,
            "{c} {}; valid {} (the measured feeds; no row outside them); {} points; interpolation error against the curve: {}",
            d.curve.label(),
            range_text(&d.curve),
            d.placed.velocity_m_s.len(),
            error_text(&d.placed.error, None)
        )?;
    }
    writeln!(
        w,
        "direction,velocity_mm_min,friction_n,torque_nm,current_a"
    )?;
    for d in &t.directions {
        let dir = d.curve.direction().map_or("both", |x| x.as_str());
        for (&v, &f) in d.placed.velocity_m_s.iter().zip(&d.placed.friction_n) {
            writeln!(
                w,
                "{dir},{:.6},{f:.6},{:.6},{:.6}",
                mm_min(v),
                t.drive.torque_nm(f),
                t.drive.current_a(f)
            )?;
        }
    }
    w.flush()
}

#[cfg(test)]
mod tests {
    use super::*;
    use feedscope::compensation::{PlacementParams, SinumerikParams, Tf5200OutUnit, Tf5200Params};
    use feedscope::stribeck::StribeckParams;
    use feedscope::stroke::Direction;
    use feedscope::units::feed_mm_min_to_m_s;

    fn curve(dir: Direction, fc: f64) -> FrictionCurve {
        let p = StribeckParams {
            fc_n: fc,
            fs_n: fc + 85.0,
            vs_m_s: feed_mm_min_to_m_s(45.0),
            sigma_n_s_per_m: 7000.0,
            delta: 2.0,
        };
        FrictionCurve::from_params(dir, p, feed_mm_min_to_m_s(9.0), feed_mm_min_to_m_s(900.0))
            .unwrap()
    }

    const SRC: ExportSource = ExportSource {
        source: "test",
        axis_name: Some("Z"),
    };

    /// The block has the documented keys in order, as many entries as it says, ascending
    /// velocities, and only `# ` comments above.
    #[test]
    fn tf5200_block_shape() {
        let (f, b) = (
            curve(Direction::Forward, 260.0),
            curve(Direction::Backward, 310.0),
        );
        let drive = DriveConversion::new(0.01, 1.82, 1.0).unwrap();
        let t = Tf5200Table::build(
            Some(&f),
            Some(&b),
            drive,
            &Tf5200Params::new(12, Tf5200OutUnit::Ampere(0.001)),
            &PlacementParams::default(),
        )
        .unwrap();
        let mut out = Vec::new();
        write_tf5200(&t, &SRC, &mut out).unwrap();
        let text = String::from_utf8(out).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        let body: Vec<&str> = lines
            .iter()
            .copied()
            .filter(|l| !l.starts_with("# "))
            .collect();
        assert!(lines
            .iter()
            .all(|l| !l.starts_with('#') || l.starts_with("# ")));
        assert_eq!(body.len(), 3 + 2 * 12);
        assert_eq!(
            body[0].split_whitespace().collect::<Vec<_>>(),
            ["frict_comp.mode", "3"]
        );
        assert_eq!(
            body[1].split_whitespace().collect::<Vec<_>>(),
            ["frict_comp.table_entries", "12"]
        );
        assert_eq!(
            body[2].split_whitespace().collect::<Vec<_>>(),
            ["frict_comp.scaling_factor", "1000"]
        );
        let ins: Vec<i64> = body[3..]
            .iter()
            .step_by(2)
            .map(|l| l.split_whitespace().nth(1).unwrap().parse().unwrap())
            .collect();
        assert_eq!(ins.len(), 12);
        assert!(ins.windows(2).all(|w| w[1] > w[0]));
        assert!(body[4].starts_with("frict_comp.table[0].out"));
        assert!(text.contains("units of 0.001 A"), "{text}");
    }

    #[test]
    fn sinumerik_lines_and_velocity_table_columns() {
        let (f, b) = (
            curve(Direction::Forward, 260.0),
            curve(Direction::Backward, 310.0),
        );
        let axis = feedscope::sim::SimConfig::default().axis;
        let s =
            SinumerikStartValues::compute(Some(&f), Some(&b), &axis, &SinumerikParams::default())
                .unwrap();
        let mut out = Vec::new();
        write_sinumerik(&s, "AX3", &SRC, &mut out).unwrap();
        let text = String::from_utf8(out).unwrap();
        let md: Vec<&str> = text.lines().filter(|l| !l.starts_with(';')).collect();
        assert_eq!(md[0], "$MA_FRICT_COMP_MODE[AX3]=1");
        assert_eq!(md[3], "$MA_FRICT_COMP_CONST_MAX[AX3]=70.519");
        assert_eq!(md[4], "$MA_FRICT_COMP_TIME[AX3]=0.0270");
        assert!(text.contains("STARTING VALUES ONLY"));

        let drive = DriveConversion::new(0.01, 1.82, 1.0).unwrap();
        let t = VelocityTable::build(&[f, b], drive, 5, &PlacementParams::default()).unwrap();
        let mut out = Vec::new();
        write_velocity_table(&t, &SRC, &mut out).unwrap();
        let text = String::from_utf8(out).unwrap();
        let rows: Vec<&str> = text.lines().filter(|l| !l.starts_with('#')).collect();
        assert_eq!(
            rows[0],
            "direction,velocity_mm_min,friction_n,torque_nm,current_a"
        );
        assert_eq!(rows.len(), 1 + 10);
        assert!(rows[1].starts_with("forward,9.000000,"), "{}", rows[1]);
        assert!(rows[10].starts_with("backward,900.000000,"), "{}", rows[10]);
        // current = friction·p/(2π)/k_e on every row
        for r in &rows[1..] {
            let x: Vec<f64> = r.split(',').skip(1).map(|s| s.parse().unwrap()).collect();
            assert!(
                (x[3] - x[1] * 0.01 / (2.0 * std::f64::consts::PI) / 1.82).abs() < 2e-6,
                "{r}"
            );
        }
    }
}
