//! G-code for a [`TestProgram`]: FANUC (0i/30i) and Siemens SINUMERIK 840D.
//!
//! Every number has fixed decimals (positions 0.001 mm, feeds 0.1 mm/min, Siemens dwell
//! 0.001 s, FANUC dwell whole milliseconds), never an exponent. Metric input is selected
//! explicitly (FANUC `G21`, Siemens `G71`) and exact stop is modal (FANUC `G61`, Siemens
//! `G60`), so every block ends at rest as the planner's timing assumes.
//!
//! # FANUC feed-per-minute and absolute mode
//! On a FANUC **lathe** (T series, G-code system A, the default) feed per minute is `G98`,
//! and `G90`/`G94` are the outer-diameter and end-face *cutting cycles*, so they must not be
//! written: coordinates are absolute by address (`Z`; `W` would be incremental). On a
//! **mill** (M series) feed per minute is `G94` and absolute mode `G90`. The machine type is an
//! option ([`FanucMachine`]); the default is the lathe because writing its preparatory codes
//! on a mill is harmless (`G98` there selects the canned-cycle return level), while the mill's
//! `G90 G94` on a lathe would start cutting cycles.
//!
//! # Dwell
//! FANUC `G04 P…` in milliseconds (P takes no decimal point); Siemens `G4 F…` in seconds,
//! in a block of its own.

use std::fmt::Write as _;

use serde::{Deserialize, Serialize};

use super::{PlanError, TestKind, TestProgram};

pub use crate::nc::Dialect;
use crate::sim::RampShape;
use crate::units::s_to_min;

/// FANUC machine type, which decides the feed-per-minute code (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FanucMachine {
    /// Lathe, G-code system A: `G98`, no `G90`.
    #[default]
    Lathe,
    /// Machining centre / mill: `G90 G94`.
    Mill,
}

/// How to write the program.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GcodeOptions {
    /// Control family. Default FANUC.
    pub dialect: Dialect,
    /// FANUC machine type. Default lathe.
    pub fanuc_machine: FanucMachine,
    /// Axis address letter, `A`-`Z`. Default `Z`.
    pub axis_letter: char,
    /// FANUC program number (1-9999). Default 1000.
    pub program_number: u32,
    /// Sampling interval of the acquisition, for the expected sample counts (s). Default
    /// 0.072 (paper 000's asynchronous FOCAS reads).
    pub sample_interval_s: f64,
    /// Feed of the first move to the start position (mm/min). `None` (default) = the
    /// highest feed of the program.
    pub approach_feed_mm_min: Option<f64>,
}

impl Default for GcodeOptions {
    fn default() -> Self {
        Self {
            dialect: Dialect::Fanuc,
            fanuc_machine: FanucMachine::Lathe,
            axis_letter: 'Z',
            program_number: 1000,
            sample_interval_s: 0.072,
            approach_feed_mm_min: None,
        }
    }
}

/// A number with `decimals` fixed decimals, never `-0.000` and never an exponent.
pub fn fixed(v: f64, decimals: usize) -> String {
    let s = format!("{v:.decimals$}");
    if s.starts_with('-') && s[1..].chars().all(|c| c == '0' || c == '.') {
        s[1..].to_string()
    } else {
        s
    }
}

/// Header lines: what the program is for, travel, feeds, run time, sample counts.
pub fn header_lines(prog: &TestProgram, opts: &GcodeOptions) -> Vec<String> {
    let l = opts.axis_letter;
    let (lo, hi) = prog.span_mm();
    let t = prog.run_time_s();
    let feeds: Vec<String> = prog.feeds_mm_min().iter().map(|f| fixed(*f, 1)).collect();
    let mut h = vec![match prog.kind {
        TestKind::Strokes => {
            "FEEDSCOPE IDLE STROKE TEST (PAPER 000 SECTION 2) - FRICTION ALONG THE TRAVEL"
                .to_string()
        }
        TestKind::Triangle => "FEEDSCOPE TRIANGULAR WAVE TEST (PAPER 002 EQ. 8) - ONE-TEST \
                               IDENTIFICATION OF J, FC, FS, VS, SIGMA"
            .to_string(),
    }];
    h.push(format!(
        "IDLE AXIS {l}, NO CUTTING. TRAVEL {l}{} TO {l}{} MM",
        fixed(lo, 3),
        fixed(hi, 3)
    ));
    h.push(format!("FEEDS MM/MIN {}", feeds.join(" ")));
    h.push(format!(
        "MOVES {}, EXPECTED RUN TIME {} S = {} MIN AT ACCEL {} MM/S2",
        prog.moves.len(),
        fixed(t, 1),
        fixed(s_to_min(t), 2),
        fixed(prog.accel_mm_s2, 0)
    ));
    h.push(match (prog.ramp, prog.jerk_mm_s3) {
        (RampShape::JerkLimited, Some(j)) => {
            format!("RAMPS JERK-LIMITED, JERK {} MM/S3", fixed(j, 0))
        }
        (RampShape::Bell, _) => "RAMPS BELL-SHAPED".to_string(),
        _ => "RAMPS TRAPEZOID, CONSTANT ACCELERATION".to_string(),
    });
    h.push(format!(
        "EXPECTED SAMPLES PER CHANNEL {} AT {} MS",
        prog.expected_samples(opts.sample_interval_s),
        fixed(opts.sample_interval_s * 1e3, 3)
    ));
    h.push(format!(
        "FIRST BLOCK MOVES TO {l}{} AND SETTLES 1 S, NOT IN THE RUN TIME",
        fixed(prog.start_mm, 3)
    ));
    h.extend(prog.notes.iter().cloned());
    h
}

/// FANUC comments may not hold parentheses and older controls want upper case.
fn fanuc_comment(text: &str) -> String {
    let t: String = text
        .to_uppercase()
        .chars()
        .map(|c| match c {
            'A'..='Z' | '0'..='9' | ' ' | '.' | ',' | '-' | '+' | '=' | '/' | '*' => c,
            _ => ' ',
        })
        .collect();
    format!("({})", t.split_whitespace().collect::<Vec<_>>().join(" "))
}

/// Write the program as G-code text (lines end in `\n`).
///
/// # Errors
/// [`PlanError::InvalidValue`] for an axis letter outside `A`-`Z`, a FANUC program number
/// outside 1-9999 or a non-positive sampling interval.
pub fn write_gcode(prog: &TestProgram, opts: &GcodeOptions) -> Result<String, PlanError> {
    let l = opts.axis_letter;
    if !l.is_ascii_uppercase() {
        return Err(PlanError::InvalidValue {
            name: "axis_letter",
            value: l as u32 as f64,
            reason: "must be one upper-case letter A-Z",
        });
    }
    if opts.dialect == Dialect::Fanuc && !(1..=9999).contains(&opts.program_number) {
        return Err(PlanError::InvalidValue {
            name: "program_number",
            value: opts.program_number as f64,
            reason: "a FANUC program number is 1-9999",
        });
    }
    if !(opts.sample_interval_s.is_finite() && opts.sample_interval_s > 0.0) {
        return Err(PlanError::InvalidValue {
            name: "sample_interval_s",
            value: opts.sample_interval_s,
            reason: "must be finite and > 0",
        });
    }
    let approach = opts
        .approach_feed_mm_min
        .unwrap_or_else(|| prog.moves.iter().map(|m| m.feed_mm_min).fold(0.0, f64::max));
    let header = header_lines(prog, opts);
    let mut o = String::new();
    let mut line = |s: &str| {
        o.push_str(s);
        o.push('\n');
    };
    match opts.dialect {
        Dialect::Fanuc => {
            line("%");
            line(&format!(
                "O{:04} {}",
                opts.program_number,
                fanuc_comment("FEEDSCOPE")
            ));
            for h in &header {
                line(&fanuc_comment(h));
            }
            line(match opts.fanuc_machine {
                FanucMachine::Lathe => "G21 G98 G61",
                FanucMachine::Mill => "G21 G90 G94 G61",
            });
        }
        Dialect::Siemens => {
            for h in &header {
                line(&format!("; {h}"));
            }
            line("G71 G90 G94 G60");
        }
    }
    let block = |to: f64, feed: f64, dwell: f64, o: &mut dyn FnMut(&str)| {
        let mut b = String::new();
        // Writing into a String cannot fail.
        let _ = write!(b, "G01 {l}{} F{}", fixed(to, 3), fixed(feed, 1));
        o(&b);
        if dwell > 0.0 {
            match opts.dialect {
                Dialect::Fanuc => o(&format!("G04 P{}", (dwell * 1e3).round() as u64)),
                Dialect::Siemens => o(&format!("G4 F{}", fixed(dwell, 3))),
            }
        }
    };
    // Approach move, then a 1 s settle before the test proper.
    block(prog.start_mm, approach, 1.0, &mut line);
    for m in &prog.moves {
        block(m.to_mm, m.feed_mm_min, m.dwell_s, &mut line);
    }
    line("M30");
    if opts.dialect == Dialect::Fanuc {
        line("%");
    }
    Ok(o)
}
