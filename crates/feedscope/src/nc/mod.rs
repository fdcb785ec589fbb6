//! Reading single-axis NC programs: the moves and dwells a FANUC or SINUMERIK 840D program
//! commands along one axis, with the program line of each.
//!
//! The reader takes what `feedscope plan` writes ([`crate::plan::gcode`]) and ordinary
//! hand-written programs of the same kind: rapid and linear moves, feeds, dwells, block
//! numbers, comments, units and modes. What it cannot interpret faithfully is an
//! [`NcError`] naming the line and the reason, never skipped: a program that reads is a
//! program whose axis motion is known.
//!
//! # Example
//! ```
//! use feedscope::nc::{NcProgram, NcStep, ParseOptions, StepKind};
//! let text = "%\nO1234 (TEST)\nG21 G90 G94 G61\nN10 G00 Z5.\nN20 G01 Z105. F600\n\
//!             N30 G04 P1500\nN40 G00 Z5.\nM30\n%\n";
//! let prog = NcProgram::parse(text, &ParseOptions::default()).unwrap();
//! assert_eq!(prog.steps.len(), 4);
//! assert!(matches!(prog.steps[1], NcStep::Move { line: 5, block_number: Some(20), .. }));
//! let r = prog.resolve(0.0);
//! assert_eq!(r[1].kind, StepKind::Feed);
//! assert!((r[1].to_mm - 105.0).abs() < 1e-12 && r[1].feed_mm_min == Some(600.0));
//! assert!((r[2].dwell_s - 1.5).abs() < 1e-12);
//! assert_eq!(prog.first_absolute_mm(), Some(5.0));
//! // what cannot be read faithfully is an error naming the line
//! let e = NcProgram::parse("G1 Z10. F100\nM98 P1000\n", &ParseOptions::default()).unwrap_err();
//! assert_eq!(e.to_string(), "program: line 2: M98: subprogram calls are not supported");
//! ```
//!
//! # Dialect
//! Detected from the syntax ([`NcProgram::dialect`]): SINUMERIK when the program has `;`
//! comment lines, `Z=AC(…)`, `Z=IC(…)` or `Z=…`, SINUMERIK keywords (`SOFT`, `MSG(…)`, …),
//! G700/G710, `G4 F`/`G4 S` or a `%_N_` header, or (lacking FANUC-only syntax) G70/G71;
//! FANUC when it has `%` lines, an `O` number, G20/G21/G98/G99, `G04 P/X/U` or M98/M99, and
//! also when nothing tells (the stricter reading, see the decimal point below). Both kinds of
//! syntax in one program is an error. Comments: `( … )` and `; …` in both dialects.
//!
//! # What is read
//! - **Moves**: G0/G00 (rapid), G1/G01 (feed). The motion mode is modal and must be
//!   programmed before the first axis word (the power-on mode is a machine setting). Every
//!   block that commands axis words in G0/G1 is a step, also when it does not move our axis
//!   ([`AxisTarget::Incremental`]`(0.0)`), so that every move of the program is listed.
//! - **Positions**: G90/G91 absolute/incremental (absolute at start, as FANUC mills and
//!   SINUMERIK power on); SINUMERIK `Z=AC(…)`/`Z=IC(…)` per word; with
//!   [`ParseOptions::lathe_incremental_addresses`] the FANUC lathe addresses U, V, W are the
//!   increments of X, Y, Z (G-code system A: then G90, G92 and G94 are the cutting cycles they
//!   are on such a lathe, and G91 does not exist, so all four are errors).
//! - **Units**: FANUC G20/G21 (inch/metric for positions and feeds), SINUMERIK G70/G71
//!   (positions only; the feed stays in the basic system, taken to be metric) and G700/G710
//!   (positions and feeds). Metric at start. Values are returned in mm and mm/min.
//! - **FANUC decimal point**: `Z100` without a point is 0.1 mm on a FANUC control unless
//!   calculator-type input (parameter 3401#0 DPI) is set, so a non-zero axis value without a
//!   point is an error in a FANUC program (write `Z100.`); `F` is not affected. SINUMERIK
//!   reads `Z100` as 100 mm.
//! - **Feed**: F, modal, per minute (G94, or G98 on a FANUC lathe; G98 on a mill only selects
//!   the canned-cycle return level, harmless). G95/G99 (per revolution) and G93 (inverse time)
//!   are errors. A FANUC lathe powers on in feed per revolution, so with
//!   `lathe_incremental_addresses` a feed move before G98 is an error. A feed move before any
//!   F is an error.
//! - **Axis feed** ([`NcStep::Move::feed_mm_min`]): the speed along our axis. F when the
//!   block moves our axis alone; 0 when it moves other axes only; F·|Δaxis|/L with L the path
//!   length over X, Y, Z when the block moves our axis with other linear axes whose travel is
//!   known (absolute positions known from earlier blocks, or increments). It is `None`
//!   (unknown) for rapids and when the travel of another axis is unknown, when a rotary or
//!   additional axis (A, B, C, or U, V, W as axes) moves too, when our axis is not one of X, Y,
//!   Z and another axis moves, and when X moves and may be a diameter (SINUMERIK after `DIAMON`
//!   / `DIAM90`, and FANUC lathes, i.e. `lathe_incremental_addresses`).
//! - **Dwells**: FANUC `G04 P<ms>` (whole milliseconds, no point), `G04 X<s>`/`U<s>` (with a
//!   point); SINUMERIK `G4 F<s>` in a block of its own (`G4 S`, spindle revolutions, is an
//!   error).
//! - **Modes accepted without effect**: exact stop and continuous path (FANUC G09, G61, G62,
//!   G63, G64; SINUMERIK G9, G60, G64, G601-G603, G641-G645, `SOFT`, `BRISK`, `FFWON`, …:
//!   the simulator models exact stop at the end of every block whatever they say), FANUC
//!   look-ahead G05.1/G08 (with their Q/P), planes G17/G18/G19, cancels (G15, G40, G50.1,
//!   G67, G69, G80), FANUC stored stroke check G22/G23, SINUMERIK corner modes G450/G451,
//!   spindle (S, M03-M05, G96/G97, FANUC G50 without axis words), coolant
//!   and other M functions (taken to neither move the axis nor take time), M01 (optional
//!   stop, taken as off), `MSG(…)`, `STOPRE`.
//! - **Setup codes**: T, D, M06, tool length compensation (FANUC G43/G44/G49 with H) and
//!   work offsets (FANUC G54-G59, SINUMERIK G54-G57, G500, G505-G599) are accepted before the
//!   first motion block only; after it they would move or shift the axis by an amount the
//!   reader does not know.
//! - **Arcs** G2/G3 are accepted only when a plane is selected that does not contain our
//!   axis and the block does not program it (no helix); they are steps that do not move the
//!   axis, with axis feed 0.
//! - **Framing**: `%` (before the first block; a `%` after it ends the program), `O1234` on
//!   a line of its own, `N` block numbers (whole numbers), a UTF-8 byte-order mark.
//! - **End**: M30, M2/M02, M17, M99 and SINUMERIK `RET` end the program; lines after the end
//!   are not read (a FANUC file may hold subprograms there, which this reader does not call;
//!   M99 in a main program would restart it on a FANUC control: here it is one pass). A
//!   program without an end ends with its text.
//!
//! # What is refused
//! Loops, conditions and jumps (`WHILE`, `GOTO`, `IF`, `REPEAT`, …), subprogram and macro
//! calls (M98, M97, G65/G66, `CALL`, `L…`, `CYCLE…`), variables and arithmetic (`#`, `[ ]`,
//! R-parameters, `$…`, expressions after `=`), block skip `/`, canned and cutting cycles,
//! threading, cutter compensation, coordinate-system changes (G10, G50/G92 with axes, G52,
//! G53, frames), reference-point moves, G60 on FANUC (single-direction positioning adds an
//! overshoot), M00 (waits for the operator), arcs that move the axis, unknown G codes and
//! words. Bad numbers, missing values, values beyond |position| ≤ 1e5 mm, 0 < feed ≤ 1e6
//! mm/min, 0 ≤ dwell ≤ 1e6 s, lines longer than 4096 characters and text that is not UTF-8
//! are errors with the line.
//!
//! # Errors
//! [`NcError`]: `"{source}: line {line}: {message}"`; line 0 for errors not tied to a line
//! (a file that `feedscope_io::nc::read_program` cannot read, bad [`ParseOptions`]).

mod interp;
mod lex;

use serde::{Deserialize, Serialize};

/// Control family: the G-code dialect a program is read in (detected by the reader) or
/// written in ([`crate::plan::gcode`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Dialect {
    /// FANUC 0i / 30i: `%` framing, `O` number, `( )` comments.
    #[default]
    Fanuc,
    /// Siemens SINUMERIK 840D: `;` comments.
    Siemens,
}

/// How to read a program.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ParseOptions {
    /// Address letter of the axis whose motion is read: X, Y, Z, or A, B, C, U, V, W (without
    /// `lathe_incremental_addresses`). Default `'Z'`.
    pub axis_letter: char,
    /// FANUC lathe, G-code system A: U, V, W are the incremental addresses of X, Y, Z, and
    /// G90/G91/G92/G94 are refused (cycles there). Default false (U, V, W are axes of their
    /// own).
    pub lathe_incremental_addresses: bool,
}

impl Default for ParseOptions {
    fn default() -> Self {
        Self {
            axis_letter: 'Z',
            lathe_incremental_addresses: false,
        }
    }
}

/// Where a move goes along the axis.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum AxisTarget {
    /// To this position (mm).
    Absolute(f64),
    /// By this distance (mm), signed.
    Incremental(f64),
}

/// One step of a program along the axis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NcStep {
    /// A motion block (G0 or G1, or an arc in another plane).
    Move {
        /// 1-based line of the block in the text.
        line: usize,
        /// Its `N` number, if any.
        block_number: Option<u64>,
        /// Rapid traverse (G0).
        rapid: bool,
        /// Where the axis goes; `Incremental(0.0)` when the block does not program it.
        target: AxisTarget,
        /// Speed along the axis (mm/min): see the module docs. `None` for rapids and where it
        /// is unknown.
        feed_mm_min: Option<f64>,
    },
    /// A dwell.
    Dwell {
        /// 1-based line of the block.
        line: usize,
        /// Its `N` number, if any.
        block_number: Option<u64>,
        /// Dwell time (s).
        seconds: f64,
    },
}

impl NcStep {
    /// 1-based line of the block.
    pub fn line(&self) -> usize {
        match self {
            NcStep::Move { line, .. } | NcStep::Dwell { line, .. } => *line,
        }
    }

    /// The block's `N` number, if any.
    pub fn block_number(&self) -> Option<u64> {
        match self {
            NcStep::Move { block_number, .. } | NcStep::Dwell { block_number, .. } => *block_number,
        }
    }
}

/// A program read along one axis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NcProgram {
    /// Moves and dwells in program order.
    pub steps: Vec<NcStep>,
    /// The dialect detected (see the module docs).
    pub dialect: Dialect,
}

/// What a resolved step does.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StepKind {
    /// Rapid traverse (G0).
    Rapid,
    /// Feed move (G1, or an arc in another plane).
    Feed,
    /// Dwell.
    Dwell,
}

/// A step with absolute positions.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResolvedStep {
    /// 1-based line of the block.
    pub line: usize,
    /// Its `N` number, if any.
    pub block_number: Option<u64>,
    /// Rapid, feed or dwell.
    pub kind: StepKind,
    /// Position before the step (mm).
    pub from_mm: f64,
    /// Position after the step (mm); equal to `from_mm` for dwells and for moves that do
    /// not move the axis.
    pub to_mm: f64,
    /// Speed along the axis (mm/min), as [`NcStep::Move::feed_mm_min`]; `None` for dwells.
    pub feed_mm_min: Option<f64>,
    /// Dwell time (s); 0 for moves.
    pub dwell_s: f64,
}

/// A program that cannot be read faithfully, with the line (1-based; 0 when not tied to a
/// line).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{source_name}: line {line}: {message}")]
pub struct NcError {
    /// File name, config key or `program`.
    pub source_name: String,
    /// 1-based line; 0 for errors of the whole file or of the options.
    pub line: usize,
    /// What is wrong.
    pub message: String,
}

impl NcError {
    /// What the error means to a caller: always [`BadInput`](crate::ErrorKind::BadInput): the NC program cannot be read.
    pub fn kind(&self) -> crate::ErrorKind {
        use crate::ErrorKind;
        ErrorKind::BadInput
    }
}

impl NcProgram {
    /// Read a program from text (errors name the source `program`).
    ///
    /// # Errors
    /// [`NcError`] naming the line: see the module docs.
    pub fn parse(text: &str, opts: &ParseOptions) -> Result<NcProgram, NcError> {
        Self::parse_named(text, "program", opts)
    }

    /// [`NcProgram::parse`] with errors naming `source_name` (a file name, a config key).
    ///
    /// # Errors
    /// [`NcError`] naming the line.
    pub fn parse_named(
        text: &str,
        source_name: &str,
        opts: &ParseOptions,
    ) -> Result<NcProgram, NcError> {
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        interp::interpret(text, opts)
            .map(|(steps, dialect)| NcProgram { steps, dialect })
            .map_err(|(line, message)| NcError {
                source_name: source_name.to_string(),
                line,
                message,
            })
    }

    /// Read a program from bytes, which must be UTF-8 (an error names the line of the first
    /// invalid byte).
    ///
    /// # Errors
    /// [`NcError`] naming the line.
    pub fn parse_bytes(
        bytes: &[u8],
        source_name: &str,
        opts: &ParseOptions,
    ) -> Result<NcProgram, NcError> {
        match std::str::from_utf8(bytes) {
            Ok(text) => Self::parse_named(text, source_name, opts),
            Err(e) => {
                let good = &bytes[..e.valid_up_to()];
                let line = 1 + good.iter().filter(|&&b| b == b'\n').count();
                let column = 1 + good.iter().rev().take_while(|&&b| b != b'\n').count();
                Err(NcError {
                    source_name: source_name.to_string(),
                    line,
                    message: format!(
                        "not UTF-8 text (byte 0x{:02X} at byte column {column}); save the \
                         program as UTF-8 or ASCII",
                        bytes[e.valid_up_to()]
                    ),
                })
            }
        }
    }

    /// Absolute positions from a start position (mm): one entry per step, moves that do not
    /// move the axis kept with `from_mm == to_mm`.
    pub fn resolve(&self, start_mm: f64) -> Vec<ResolvedStep> {
        let mut z = start_mm;
        self.steps
            .iter()
            .map(|s| match *s {
                NcStep::Move {
                    line,
                    block_number,
                    rapid,
                    target,
                    feed_mm_min,
                } => {
                    let from = z;
                    z = match target {
                        AxisTarget::Absolute(a) => a,
                        AxisTarget::Incremental(d) => z + d,
                    };
                    ResolvedStep {
                        line,
                        block_number,
                        kind: if rapid {
                            StepKind::Rapid
                        } else {
                            StepKind::Feed
                        },
                        from_mm: from,
                        to_mm: z,
                        feed_mm_min,
                        dwell_s: 0.0,
                    }
                }
                NcStep::Dwell {
                    line,
                    block_number,
                    seconds,
                } => ResolvedStep {
                    line,
                    block_number,
                    kind: StepKind::Dwell,
                    from_mm: z,
                    to_mm: z,
                    feed_mm_min: None,
                    dwell_s: seconds,
                },
            })
            .collect()
    }

    /// The first absolute target (mm), if any: where a G90 program puts the axis first, which
    /// lets a caller infer the start of the program.
    pub fn first_absolute_mm(&self) -> Option<f64> {
        self.steps.iter().find_map(|s| match s {
            NcStep::Move {
                target: AxisTarget::Absolute(a),
                ..
            } => Some(*a),
            _ => None,
        })
    }
}

#[cfg(test)]
mod tests;
