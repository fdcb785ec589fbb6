//! The modal interpreter: lexed lines into [`NcStep`]s, with the dialect decided first from
//! the syntax the program uses. Every rule and refusal is listed in the module docs of
//! [`super`].

use super::lex::{lex_line, Line, Num, Tok, Val};
use super::{AxisTarget, Dialect, NcStep, ParseOptions};

/// Largest |position| or |increment| accepted (mm).
const MAX_POSITION_MM: f64 = 1e5;
/// Largest feed accepted (mm/min).
const MAX_FEED_MM_MIN: f64 = 1e6;
/// Largest dwell accepted (s).
const MAX_DWELL_S: f64 = 1e6;
const MM_PER_INCH: f64 = 25.4;

/// An error at a 1-based line (0 = not tied to a line).
pub(super) type LineError = (usize, String);

/// Read the program text into steps; the dialect is detected first.
pub(super) fn interpret(
    text: &str,
    opts: &ParseOptions,
) -> Result<(Vec<NcStep>, Dialect), LineError> {
    let axis = check_options(opts).map_err(|m| (0, m))?;
    let (lines, lex_error) = lex_until_end(text);
    let dialect = detect(&lines)?;
    let mut st = State::new(dialect, opts.lathe_incremental_addresses, axis);
    let mut steps = Vec::new();
    for (no, line) in &lines {
        match line {
            Line::Empty { .. } => {}
            Line::Percent { .. } => {
                // FANUC: the second `%` ends the tape. Before any block it is framing (or a
                // SINUMERIK archive header `%_N_…`).
                if st.blocks_seen {
                    return Ok((steps, dialect));
                }
            }
            Line::Block(toks) => {
                let ended = st.block(toks, *no, &mut steps).map_err(|m| (*no, m))?;
                if ended {
                    return Ok((steps, dialect));
                }
            }
        }
    }
    if let Some(e) = lex_error {
        return Err(e);
    }
    Ok((steps, dialect))
}

/// The axis letter, checked against the options.
fn check_options(opts: &ParseOptions) -> Result<char, String> {
    let a = opts.axis_letter;
    let allowed = if opts.lathe_incremental_addresses {
        "XYZ"
    } else {
        "ABCUVWXYZ"
    };
    if !allowed.contains(a) {
        return Err(format!(
            "option axis_letter = {a:?}: must be one of {} (upper case){}",
            allowed
                .chars()
                .map(String::from)
                .collect::<Vec<_>>()
                .join(", "),
            if opts.lathe_incremental_addresses {
                " with lathe_incremental_addresses, whose U, V, W are the incremental \
                 addresses of X, Y, Z"
            } else {
                ""
            }
        ));
    }
    Ok(a)
}

/// Lex lines up to the end of the program (an end M code or `RET` block, or a `%` after a
/// block), stopping at the first line that cannot be lexed; its error is returned beside the
/// lines before it, to be reported when the interpreter reaches it.
fn lex_until_end(text: &str) -> (Vec<(usize, Line)>, Option<LineError>) {
    let mut out = Vec::new();
    let mut blocks_seen = false;
    for (k, raw) in text.split('\n').enumerate() {
        let no = k + 1;
        let raw = raw.strip_suffix('\r').unwrap_or(raw);
        let line = match lex_line(raw) {
            Ok(l) => l,
            Err(e) => return (out, Some((no, e))),
        };
        let stop = match &line {
            Line::Percent { .. } => blocks_seen,
            Line::Block(toks) => {
                if !toks.iter().all(is_program_number_or_n) {
                    blocks_seen = true;
                }
                toks.iter().any(is_end)
            }
            Line::Empty { .. } => false,
        };
        out.push((no, line));
        if stop {
            break;
        }
    }
    (out, None)
}

fn is_program_number_or_n(t: &Tok) -> bool {
    matches!(
        t,
        Tok::Word {
            letter: 'O' | 'N',
            ..
        }
    )
}

fn is_end(t: &Tok) -> bool {
    match t {
        Tok::Word {
            letter: 'M',
            val: Val::Plain(n),
        } => whole(*n).is_some_and(|m| matches!(m, 2 | 17 | 30 | 99)),
        Tok::Name { name, .. } => name == "RET",
        _ => false,
    }
}

/// Keywords of SINUMERIK that this reader accepts and that mark a program as SINUMERIK.
const SIEMENS_KEYWORDS: &[&str] = &[
    "SOFT", "BRISK", "DRIVE", "FFWON", "FFWOF", "CFC", "CFTCP", "CFIN", "STOPRE", "TRAFOOF",
    "DIAMON", "DIAMOF", "DIAM90", "MSG", "RET",
];

/// G codes (×10) that only FANUC writes, and that only SINUMERIK writes.
const FANUC_ONLY_G: &[u32] = &[200, 210, 980, 990];
const SIEMENS_ONLY_G: &[u32] = &[7000, 7100];
/// G70/G71: SINUMERIK inch/metric, FANUC lathe finishing/roughing cycles.
const SIEMENS_WEAK_G: &[u32] = &[700, 710];

/// A whole number written without a point.
fn whole(n: Num) -> Option<u64> {
    (!n.point && n.value >= 0.0 && n.value <= 9e15 && n.value.fract() == 0.0)
        .then_some(n.value as u64)
}

fn g_code(n: Num) -> Option<u32> {
    let c = n.value * 10.0;
    let r = c.round();
    ((0.0..=99_999.0).contains(&r) && (c - r).abs() < 1e-6).then_some(r as u32)
}

/// Which dialect: SINUMERIK if the program uses syntax only SINUMERIK has (`;` comment
/// lines, `Z=AC(…)`/`IC(…)`/`Z=…`, its keywords, G700/G710, `G4 F`/`G4 S`, `%_N_` headers)
/// or, lacking any FANUC-only syntax, G70/G71; otherwise FANUC (`%` lines, `O` numbers,
/// G20/G21/G98/G99, `G04 P/X/U`, M98/M99, or nothing either way). Both kinds of syntax in one
/// program is an error.
fn detect(lines: &[(usize, Line)]) -> Result<Dialect, LineError> {
    let mut fanuc: Option<(usize, String)> = None;
    let mut siemens: Option<(usize, String)> = None;
    let mut siemens_weak = false;
    for (no, line) in lines {
        let mut f = |what: String| {
            if fanuc.is_none() {
                fanuc = Some((*no, what));
            }
        };
        let mut s_found: Option<String> = None;
        match line {
            Line::Empty {
                semicolon_comment: true,
            } => s_found = Some("a `;` comment line".into()),
            Line::Empty { .. } => {}
            Line::Percent { rest } => {
                if rest.trim_start().starts_with("_N_") {
                    s_found = Some("a `%_N_` header".into());
                } else if rest.trim().is_empty() {
                    f("a `%` line".into());
                }
            }
            Line::Block(toks) => {
                let has_g4 = toks.iter().any(|t| {
                    matches!(t, Tok::Word { letter: 'G', val: Val::Plain(n) } if g_code(*n) == Some(40))
                });
                for t in toks {
                    match t {
                        Tok::Word { letter, val } => {
                            if !matches!(val, Val::Plain(_)) {
                                s_found = Some(format!("`{letter}=`"));
                                continue;
                            }
                            let n = val.num();
                            match letter {
                                'O' => f("an `O` program number".into()),
                                'G' => {
                                    if let Some(c) = g_code(n) {
                                        if FANUC_ONLY_G.contains(&c) {
                                            f(format!("G{}", c / 10));
                                        } else if SIEMENS_ONLY_G.contains(&c) {
                                            s_found = Some(format!("G{}", c / 10));
                                        } else if SIEMENS_WEAK_G.contains(&c) {
                                            siemens_weak = true;
                                        }
                                    }
                                }
                                'M' if matches!(whole(n), Some(98 | 99)) => {
                                    f(format!("M{}", n.value))
                                }
                                'P' | 'X' | 'U' if has_g4 => f(format!("G04 {letter}")),
                                'F' | 'S' if has_g4 => s_found = Some(format!("G4 {letter}")),
                                _ => {}
                            }
                        }
                        Tok::Name { name, value, .. } => {
                            if value.is_some() || SIEMENS_KEYWORDS.contains(&name.as_str()) {
                                s_found = Some(format!("`{name}`"));
                            }
                        }
                    }
                }
            }
        }
        if let Some(s) = s_found {
            if siemens.is_none() {
                siemens = Some((*no, s));
            }
        }
        if let (Some((lf, wf)), Some((ls, ws))) = (&fanuc, &siemens) {
            return Err((
                (*lf).max(*ls),
                format!(
                    "the program mixes FANUC syntax ({wf} on line {lf}) and SINUMERIK syntax \
                     ({ws} on line {ls}); this reader takes one dialect per program"
                ),
            ));
        }
    }
    Ok(if siemens.is_some() || (siemens_weak && fanuc.is_none()) {
        Dialect::Siemens
    } else {
        Dialect::Fanuc
    })
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Motion {
    Rapid,
    Linear,
    Arc,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Plane {
    Xy,
    Zx,
    Yz,
}

impl Plane {
    fn contains(self, axis: char) -> bool {
        match self {
            Plane::Xy => matches!(axis, 'X' | 'Y'),
            Plane::Zx => matches!(axis, 'Z' | 'X'),
            Plane::Yz => matches!(axis, 'Y' | 'Z'),
        }
    }
    fn name(self) -> &'static str {
        match self {
            Plane::Xy => "XY plane (G17)",
            Plane::Zx => "ZX plane (G18)",
            Plane::Yz => "YZ plane (G19)",
        }
    }
}

/// What a G code does here.
enum GAct {
    Motion(Motion),
    Dwell,
    Plane(Plane),
    Units {
        inch: bool,
        inch_feed: bool,
    },
    Distance {
        absolute: bool,
    },
    FeedPerMinute,
    Ignore,
    /// Tool length compensation, work offsets: accepted before the first move only.
    Setup,
    /// Accepted without axis words (spindle clamp, scaling cancel); with them, the message.
    IfNoAxisWords(&'static str),
    /// FANUC look-ahead / AI contour control on or off (takes P or Q).
    LookAhead,
    Refuse(String),
}

fn fanuc_g(c: u32, lathe: bool) -> GAct {
    let cycle = "canned cycles are not supported (write the moves as G00/G01 blocks)";
    match c {
        0 => GAct::Motion(Motion::Rapid),
        10 => GAct::Motion(Motion::Linear),
        20 | 30 => GAct::Motion(Motion::Arc),
        40 => GAct::Dwell,
        51 | 80 => GAct::LookAhead,
        90 | 150 | 220 | 230 | 400 | 501 | 610 | 620 | 630 | 640 | 670 | 690 | 800 | 960 | 970 => {
            GAct::Ignore
        }
        170 => GAct::Plane(Plane::Xy),
        180 => GAct::Plane(Plane::Zx),
        190 => GAct::Plane(Plane::Yz),
        200 => GAct::Units {
            inch: true,
            inch_feed: true,
        },
        210 => GAct::Units {
            inch: false,
            inch_feed: false,
        },
        250 | 260 => GAct::IfNoAxisWords(
            "G25/G26 with axis words: not the spindle-speed fluctuation check this reader \
             accepts",
        ),
        430 | 440 | 490 | 540 | 550 | 560 | 570 | 580 | 590 => GAct::Setup,
        500 => GAct::IfNoAxisWords(
            "G50 with axis words sets the coordinate system, which shifts every later \
             position by an amount this reader does not know",
        ),
        900 | 910 | 920 | 940 if lathe => GAct::Refuse(match c {
            900 => "G90 on a FANUC lathe (G-code system A) is the outer-diameter cutting \
                    cycle, not absolute mode; cycles are not supported"
                .into(),
            910 => "G91 does not exist in lathe G-code system A (incremental moves use U, V, \
                    W)"
            .into(),
            920 => "G92 on a FANUC lathe (G-code system A) is the threading cycle; cycles \
                    are not supported"
                .into(),
            _ => "G94 on a FANUC lathe (G-code system A) is the end-face cutting cycle \
                  (feed per minute is G98); cycles are not supported"
                .into(),
        }),
        900 => GAct::Distance { absolute: true },
        910 => GAct::Distance { absolute: false },
        920 => GAct::IfNoAxisWords(
            "G92 with axis words sets the coordinate system, which shifts every later \
             position by an amount this reader does not know",
        ),
        940 | 980 => GAct::FeedPerMinute,
        100 => GAct::Refuse(
            "G10: programmable data input (offsets, parameters) is not supported".into(),
        ),
        160 => GAct::Refuse("G16: polar coordinates are not supported".into()),
        270 | 280 | 290 | 300 | 301 => GAct::Refuse(format!(
            "G{}: reference-position moves go to machine positions this reader does not know",
            fmt_g(c)
        )),
        310 => {
            GAct::Refuse("G31: skip function (the move ends at a signal) is not supported".into())
        }
        320 | 330 | 340 => GAct::Refuse("threading (feed per revolution) is not supported".into()),
        410 | 420 => GAct::Refuse(
            "cutter radius compensation (G41/G42) changes the path by the tool radius; not \
             supported"
                .into(),
        ),
        510 | 511 => GAct::Refuse("scaling and mirroring (G51/G51.1) are not supported".into()),
        520 => GAct::Refuse(
            "G52: a local coordinate system shifts the positions; not supported".into(),
        ),
        530 => GAct::Refuse("G53: machine coordinates are not supported".into()),
        541 => GAct::Refuse("G54.1: extended work offsets (with P) are not supported".into()),
        600 => GAct::Refuse(
            "G60 on a FANUC control is single-direction positioning, which adds an overshoot \
             and return to positioning moves; not supported (exact stop is G61, or G09 per \
             block)"
                .into(),
        ),
        650 | 660 => GAct::Refuse("macro calls (G65/G66) are not supported".into()),
        680 => GAct::Refuse("G68: coordinate rotation is not supported".into()),
        700..=890 => GAct::Refuse(format!("G{}: {cycle}", fmt_g(c))),
        930 => GAct::Refuse("G93: inverse-time feed is not supported".into()),
        950 => GAct::Refuse("G95: feed per revolution is not supported (use G94 or G98)".into()),
        990 => GAct::Refuse(
            "G99: feed per revolution (FANUC lathe) is not supported (use G98); on a mill \
             G99 selects the canned-cycle R-level return, and canned cycles are not \
             supported either"
                .into(),
        ),
        _ => GAct::Refuse(format!(
            "G{}: not a code this reader knows, and it may change the motion",
            fmt_g(c)
        )),
    }
}

fn siemens_g(c: u32) -> GAct {
    match c {
        0 => GAct::Motion(Motion::Rapid),
        10 => GAct::Motion(Motion::Linear),
        20 | 30 => GAct::Motion(Motion::Arc),
        40 => GAct::Dwell,
        90 | 400 | 600 | 640 | 960 | 970 | 4500 | 4510 | 6010 | 6020 | 6030 | 6410..=6450 => {
            GAct::Ignore
        }
        170 => GAct::Plane(Plane::Xy),
        180 => GAct::Plane(Plane::Zx),
        190 => GAct::Plane(Plane::Yz),
        // G70/G71 set the unit of geometry only; the feed stays in the basic system (taken
        // to be metric), G700/G710 set both.
        700 => GAct::Units {
            inch: true,
            inch_feed: false,
        },
        710 | 7100 => GAct::Units {
            inch: false,
            inch_feed: false,
        },
        7000 => GAct::Units {
            inch: true,
            inch_feed: true,
        },
        250 | 260 => GAct::IfNoAxisWords(
            "G25/G26 with axis words set programmable working-area limits; not supported",
        ),
        540 | 550 | 560 | 570 | 5000 | 5050..=5990 => GAct::Setup,
        900 => GAct::Distance { absolute: true },
        910 => GAct::Distance { absolute: false },
        940 => GAct::FeedPerMinute,
        410 | 420 => GAct::Refuse(
            "cutter radius compensation (G41/G42) changes the path by the tool radius; not \
             supported"
                .into(),
        ),
        530 | 1530 => GAct::Refuse(format!(
            "G{}: suppressing frames (machine coordinates) is not supported",
            fmt_g(c)
        )),
        580 | 590 => GAct::Refuse(format!(
            "G{}: programmable offsets shift the positions; not supported",
            fmt_g(c)
        )),
        330 | 3310 | 3320 | 340 | 350 => {
            GAct::Refuse("threading and tapping are not supported".into())
        }
        740 | 750 => GAct::Refuse(
            "reference-point and fixed-point approach (G74/G75) go to machine positions this \
             reader does not know"
                .into(),
        ),
        930 => GAct::Refuse("G93: inverse-time feed is not supported".into()),
        950 => GAct::Refuse("G95: feed per revolution is not supported (use G94)".into()),
        _ => GAct::Refuse(format!(
            "G{}: not a code this reader knows, and it may change the motion",
            fmt_g(c)
        )),
    }
}

fn fmt_g(c: u32) -> String {
    if c.is_multiple_of(10) {
        format!("{}", c / 10)
    } else {
        format!("{}.{}", c / 10, c % 10)
    }
}

/// Position of the programmed axis as far as the program tells.
#[derive(Debug, Clone, Copy)]
enum AxisPos {
    /// Known absolute position (mm).
    Known(f64),
    /// Unknown absolute position; this far from the (unknown) start (mm).
    FromStart(f64),
}

/// The modal state.
struct State {
    dialect: Dialect,
    lathe: bool,
    axis: char,
    motion: Option<Motion>,
    absolute: bool,
    inch: bool,
    inch_feed: bool,
    /// Feed per minute programmed explicitly (a FANUC lathe powers on in feed per
    /// revolution).
    feed_per_minute_explicit: bool,
    feed_mm_min: Option<f64>,
    plane: Option<Plane>,
    /// SINUMERIK DIAMON / DIAM90: X is a diameter.
    diameter: bool,
    /// An axis has been commanded to move: tool and offset changes are refused from here.
    moved: bool,
    blocks_seen: bool,
    pos: AxisPos,
    /// Absolute X, Y, Z where known (mm).
    linear: [Option<f64>; 3],
}

/// One axis word after interpretation.
struct AxisWord {
    /// The axis it moves (X, Y, Z, or the letter itself for others).
    axis: char,
    /// Absolute target or increment (mm, or degrees for rotary axes).
    target: AxisTarget,
}

fn linear_index(axis: char) -> Option<usize> {
    match axis {
        'X' => Some(0),
        'Y' => Some(1),
        'Z' => Some(2),
        _ => None,
    }
}

impl State {
    fn new(dialect: Dialect, lathe: bool, axis: char) -> Self {
        Self {
            dialect,
            lathe,
            axis,
            motion: None,
            absolute: true,
            inch: false,
            inch_feed: false,
            feed_per_minute_explicit: false,
            feed_mm_min: None,
            plane: None,
            diameter: false,
            moved: false,
            blocks_seen: false,
            pos: AxisPos::FromStart(0.0),
            linear: [None; 3],
        }
    }

    fn fanuc(&self) -> bool {
        self.dialect == Dialect::Fanuc
    }

    /// A length or angle word in mm (or degrees): the FANUC decimal-point rule, inch, range.
    fn length(&self, letter: char, val: Val, linear: bool) -> Result<f64, String> {
        let n = self.plain_or_siemens(letter, val)?;
        if self.fanuc() && !n.point && n.value != 0.0 {
            let v = n.value as i64;
            return Err(format!(
                "`{letter}{v}` has no decimal point: a FANUC control reads it in least input \
                 increments ({letter}{v} = {} mm with the usual 0.001 mm) unless \
                 calculator-type input is set (parameter 3401#0 DPI); write `{letter}{v}.`",
                n.value * 1e-3
            ));
        }
        let mm = if linear && self.inch {
            n.value * MM_PER_INCH
        } else {
            n.value
        };
        if mm.is_nan() || mm.abs() > MAX_POSITION_MM {
            return Err(format!(
                "{letter}: |{mm}| mm is beyond the {MAX_POSITION_MM:.0e} mm this reader accepts"
            ));
        }
        Ok(mm)
    }

    /// The number of a word; SINUMERIK `=` forms are refused in a FANUC program.
    fn plain_or_siemens(&self, letter: char, val: Val) -> Result<Num, String> {
        if self.fanuc() && !matches!(val, Val::Plain(_)) {
            return Err(format!(
                "`{letter}=…`: SINUMERIK syntax in a program read as FANUC"
            ));
        }
        Ok(val.num())
    }

    /// An integer word (N, M, FANUC P) without a point.
    fn integer(&self, letter: char, val: Val, max: f64) -> Result<u64, String> {
        let n = self.plain_or_siemens(letter, val)?;
        if n.point || n.value < 0.0 || n.value > max || n.value.fract() != 0.0 {
            return Err(format!(
                "{letter}{}: must be a whole number from 0 to {max} without a decimal point",
                n.value
            ));
        }
        Ok(n.value as u64)
    }

    /// Interpret one block; `true` when it ends the program.
    fn block(
        &mut self,
        toks: &[Tok],
        line: usize,
        steps: &mut Vec<NcStep>,
    ) -> Result<bool, String> {
        // Sort the words.
        let mut n_word: Option<u64> = None;
        let mut o_word = false;
        let mut gs: Vec<GAct> = Vec::new();
        let mut g_codes: Vec<u32> = Vec::new();
        let mut ms: Vec<u64> = Vec::new();
        let mut single: Vec<(char, Val)> = Vec::new();
        let mut names: Vec<(String, bool, bool)> = Vec::new();
        for t in toks {
            match t {
                Tok::Word { letter: 'N', val } => {
                    if n_word.is_some() {
                        return Err("two block numbers N in one block".into());
                    }
                    n_word = Some(self.integer('N', *val, 9e15)?);
                }
                Tok::Word { letter: 'O', val } => {
                    self.integer('O', *val, 99_999_999.0)?;
                    o_word = true;
                }
                Tok::Word { letter: 'G', val } => {
                    let n = self.plain_or_siemens('G', *val)?;
                    let c = g_code(n)
                        .filter(|_| n.value >= 0.0)
                        .ok_or_else(|| format!("G{}: not a G code", n.value))?;
                    g_codes.push(c);
                    gs.push(match self.dialect {
                        Dialect::Fanuc => fanuc_g(c, self.lathe),
                        Dialect::Siemens => siemens_g(c),
                    });
                }
                Tok::Word { letter: 'M', val } => ms.push(self.integer('M', *val, 99_999.0)?),
                Tok::Word { letter, val } => {
                    if single.iter().any(|(l, _)| l == letter) {
                        return Err(format!("address {letter} twice in one block"));
                    }
                    single.push((*letter, *val));
                }
                Tok::Name { name, args, value } => {
                    names.push((name.clone(), args.is_some(), value.is_some()))
                }
            }
        }
        if o_word {
            if self.blocks_seen {
                return Err(
                    "a second program number O: this reader reads one program per \
                            file (subprograms are not called)"
                        .into(),
                );
            }
            if toks.len() > 1 + usize::from(n_word.is_some()) {
                return Err("the program number O must stand alone on its line".into());
            }
            return Ok(false);
        }
        // As in `lex_until_end`: a line of block numbers only does not start the program.
        if !toks.iter().all(is_program_number_or_n) {
            self.blocks_seen = true;
        }
        let word = |l: char| single.iter().find(|(c, _)| *c == l).map(|(_, v)| *v);

        // Names: SINUMERIK keywords, or refusals.
        let mut ends = false;
        let mut arc_names = false;
        for (name, has_args, has_value) in &names {
            match self.name(name, *has_args, *has_value)? {
                NameAct::Ignore => {}
                NameAct::End => ends = true,
                NameAct::ArcParameter => arc_names = true,
            }
        }

        // G codes in the order written; one motion code and one dwell at most.
        let mut motion_here: Option<Motion> = None;
        let mut dwell = false;
        let mut setup: Option<String> = None;
        let mut look_ahead = false;
        let mut if_no_axis: Option<&'static str> = None;
        for (act, c) in gs.into_iter().zip(&g_codes) {
            match act {
                GAct::Motion(m) => {
                    if motion_here.is_some() {
                        return Err("two motion G codes in one block".into());
                    }
                    motion_here = Some(m);
                }
                GAct::Dwell => dwell = true,
                GAct::Plane(p) => self.plane = Some(p),
                GAct::Units { inch, inch_feed } => {
                    self.inch = inch;
                    self.inch_feed = inch_feed;
                }
                GAct::Distance { absolute } => self.absolute = absolute,
                GAct::FeedPerMinute => self.feed_per_minute_explicit = true,
                GAct::Ignore => {}
                GAct::Setup => setup = Some(format!("G{}", fmt_g(*c))),
                GAct::IfNoAxisWords(m) => if_no_axis = Some(m),
                GAct::LookAhead => look_ahead = true,
                GAct::Refuse(m) => return Err(m),
            }
        }
        if dwell && motion_here.is_some() {
            return Err("a dwell G4 and a motion G code in one block".into());
        }

        // M codes.
        for &m in &ms {
            match m {
                0 => {
                    return Err(
                        "M00: program stop waits for the operator for an unknown time \
                                (use a dwell, G04/G4, instead)"
                            .into(),
                    )
                }
                2 | 17 | 30 | 99 => ends = true,
                6 => setup = Some("M06".into()),
                97 | 98 | 198 => {
                    return Err(format!("M{m}: subprogram calls are not supported"));
                }
                // M01 optional stop (taken as off), spindle, coolant and machine functions:
                // no motion of the axis.
                _ => {}
            }
        }

        // Words other than axes.
        for (letter, _) in &single {
            match letter {
                'T' | 'D' => {
                    setup.get_or_insert_with(|| letter.to_string());
                }
                'H' if setup.is_some() => {}
                'H' => {
                    return Err(
                        "H outside tool length compensation (G43/G44): not supported".into(),
                    )
                }
                'L' => {
                    return Err(
                        "L: a subprogram call or repeat count; subprograms are not supported"
                            .into(),
                    )
                }
                'E' => return Err("E: thread lead and similar are not supported".into()),
                _ => {}
            }
        }
        if let Some(what) = setup {
            if self.moved {
                return Err(format!(
                    "{what} after the first move: tool changes and offset changes move or \
                     shift the axis by an amount this reader does not know (they are \
                     accepted before the first motion block only)"
                ));
            }
        }

        if dwell {
            self.dwell(&single, line, n_word, steps)?;
            return Ok(ends);
        }

        // Feed.
        if let Some(v) = word('F') {
            let n = self.plain_or_siemens('F', v)?;
            let f = if self.inch_feed {
                n.value * MM_PER_INCH
            } else {
                n.value
            };
            if !(f > 0.0 && f <= MAX_FEED_MM_MIN) {
                return Err(format!(
                    "F{}: the feed must be greater than 0 and at most {MAX_FEED_MM_MIN:.0e} \
                     mm/min",
                    n.value
                ));
            }
            self.feed_mm_min = Some(f);
        }
        if let Some(v) = word('S') {
            self.plain_or_siemens('S', v)?;
        }

        if let Some(m) = motion_here {
            self.motion = Some(m);
        }

        // Axis words.
        let mut axes: Vec<AxisWord> = Vec::new();
        for (letter, val) in &single {
            let (axis, forced_inc) = match letter {
                'U' if self.lathe => ('X', true),
                'V' if self.lathe => ('Y', true),
                'W' if self.lathe => ('Z', true),
                'A' | 'B' | 'C' | 'U' | 'V' | 'W' | 'X' | 'Y' | 'Z' => (*letter, false),
                _ => continue,
            };
            if axes.iter().any(|a| a.axis == axis) {
                return Err(format!("two words for axis {axis} in one block"));
            }
            let linear = linear_index(axis).is_some();
            let v = self.length(*letter, *val, linear)?;
            let absolute = match val {
                Val::Ac(_) => true,
                Val::Ic(_) => false,
                _ => self.absolute && !forced_inc,
            };
            axes.push(AxisWord {
                axis,
                target: if absolute {
                    AxisTarget::Absolute(v)
                } else {
                    AxisTarget::Incremental(v)
                },
            });
        }
        if let Some(m) = if_no_axis {
            if !axes.is_empty() {
                return Err(m.into());
            }
        }

        let arc_words = ['I', 'J', 'K', 'R']
            .into_iter()
            .filter(|l| word(*l).is_some())
            .collect::<Vec<_>>();
        let arc_params = !arc_words.is_empty() || arc_names;
        // A full circle (centre words, no end point) moves the plane's axes too.
        let moves = !axes.is_empty() || (arc_params && self.motion == Some(Motion::Arc));
        let motion = if moves { self.motion } else { None };
        if arc_params && self.motion != Some(Motion::Arc) {
            let mut listed: Vec<String> = arc_words.iter().map(|c| c.to_string()).collect();
            if arc_names {
                listed.push("CR/AR".into());
            }
            return Err(format!(
                "{}: arc or cycle parameters outside an arc (G2/G3) are not supported",
                listed.join(", ")
            ));
        }
        for l in ['P', 'Q'] {
            if word(l).is_some() && !look_ahead {
                return Err(format!(
                    "{l} outside a dwell: subprogram, cycle or offset numbers are not supported"
                ));
            }
        }

        let Some(motion) = motion else {
            if !axes.is_empty() {
                return Err(
                    "axis words before any motion code (G0/G1): the power-on motion \
                            mode is a machine setting; program G0 or G1"
                        .into(),
                );
            }
            return Ok(ends);
        };
        if motion != Motion::Rapid {
            if self.feed_mm_min.is_none() {
                return Err("a feed move without a feed: no F programmed yet".into());
            }
            if self.lathe && !self.feed_per_minute_explicit {
                return Err(
                    "a FANUC lathe powers on in feed per revolution (G99); program G98 \
                            (feed per minute) before the first feed move"
                        .into(),
                );
            }
        }
        if motion == Motion::Arc {
            self.arc_check(&axes)?;
        }
        self.moved = true;
        let step = self.motion_step(motion, &axes, line, n_word)?;
        steps.push(step);
        Ok(ends)
    }

    /// An arc may not move the axis: the plane must be known and not contain it, and the
    /// block must not program it (helix).
    fn arc_check(&self, axes: &[AxisWord]) -> Result<(), String> {
        let Some(plane) = self.plane else {
            return Err(
                "an arc (G2/G3) without a plane selected (G17/G18/G19): the default \
                        plane is a machine setting, so whether the arc moves the axis is \
                        unknown"
                    .into(),
            );
        };
        if plane.contains(self.axis) {
            return Err(format!(
                "an arc (G2/G3) in the {}, which contains the axis {}: arcs that move the \
                 axis are not supported",
                plane.name(),
                self.axis
            ));
        }
        if axes.iter().any(|a| a.axis == self.axis) {
            return Err(format!(
                "a helix (G2/G3 with {}): arcs that move the axis are not supported",
                self.axis
            ));
        }
        Ok(())
    }

    fn motion_step(
        &mut self,
        motion: Motion,
        axes: &[AxisWord],
        line: usize,
        block_number: Option<u64>,
    ) -> Result<NcStep, String> {
        let ours = axes.iter().find(|a| a.axis == self.axis);
        let target = ours.map_or(AxisTarget::Incremental(0.0), |a| a.target);
        // Travel of our axis in this block, where the program tells it.
        let delta = match target {
            AxisTarget::Incremental(d) => Some(d),
            AxisTarget::Absolute(a) => match self.pos {
                AxisPos::Known(c) => Some(a - c),
                AxisPos::FromStart(_) => None,
            },
        };
        let feed = match motion {
            Motion::Rapid => None,
            Motion::Arc => Some(0.0),
            Motion::Linear => {
                let f = self.feed_mm_min.unwrap_or(0.0);
                let others: Vec<&AxisWord> = axes.iter().filter(|a| a.axis != self.axis).collect();
                if others.is_empty() {
                    Some(f)
                } else if ours.is_none() {
                    Some(0.0)
                } else {
                    self.axis_speed(f, delta, &others)
                }
            }
        };
        // Update the positions.
        let mut next = self.pos;
        if ours.is_some() {
            next = match (target, self.pos) {
                (AxisTarget::Absolute(a), _) => AxisPos::Known(a),
                (AxisTarget::Incremental(d), AxisPos::Known(c)) => AxisPos::Known(c + d),
                (AxisTarget::Incremental(d), AxisPos::FromStart(o)) => AxisPos::FromStart(o + d),
            };
            match next {
                AxisPos::Known(z) if z.abs() > MAX_POSITION_MM => {
                    return Err(format!(
                        "the axis reaches {z} mm, beyond the {MAX_POSITION_MM:.0e} mm this \
                         reader accepts"
                    ))
                }
                AxisPos::FromStart(o) if o.abs() > 2.0 * MAX_POSITION_MM => {
                    return Err(format!(
                        "incremental moves add up to {o} mm, beyond twice the \
                         {MAX_POSITION_MM:.0e} mm this reader accepts"
                    ))
                }
                _ => {}
            }
        }
        self.pos = next;
        for a in axes {
            if let Some(k) = linear_index(a.axis) {
                self.linear[k] = match a.target {
                    AxisTarget::Absolute(v) => Some(v),
                    AxisTarget::Incremental(d) => self.linear[k].map(|c| c + d),
                };
            }
        }
        if let Some(k) = linear_index(self.axis) {
            if let AxisPos::Known(z) = self.pos {
                self.linear[k] = Some(z);
            }
        }
        Ok(NcStep::Move {
            line,
            block_number,
            rapid: motion == Motion::Rapid,
            target,
            feed_mm_min: feed,
        })
    }

    /// Speed along the axis in a G1 block that also moves `others`: F·|Δaxis|/path length
    /// over X, Y, Z when every travel is known; `None` otherwise (other kinds of axis, X as
    /// a diameter, unknown positions).
    fn axis_speed(&self, f: f64, delta: Option<f64>, others: &[&AxisWord]) -> Option<f64> {
        linear_index(self.axis)?;
        let dz = delta?;
        let mut sum = dz * dz;
        for a in others {
            let k = linear_index(a.axis)?;
            if a.axis == 'X' && (self.lathe || self.diameter) {
                return None;
            }
            let d = match a.target {
                AxisTarget::Incremental(d) => d,
                AxisTarget::Absolute(v) => v - self.linear[k]?,
            };
            sum += d * d;
        }
        let len = sum.sqrt();
        Some(if len > 0.0 { f * dz.abs() / len } else { f })
    }

    fn dwell(
        &mut self,
        single: &[(char, Val)],
        line: usize,
        block_number: Option<u64>,
        steps: &mut Vec<NcStep>,
    ) -> Result<(), String> {
        let mut seconds: Option<f64> = None;
        for &(letter, val) in single {
            let s = match (self.dialect, letter) {
                (Dialect::Fanuc, 'P') => {
                    let n = self.plain_or_siemens('P', val)?;
                    if n.point || n.value.fract() != 0.0 {
                        return Err(format!(
                            "G04 P{}: P counts whole milliseconds, without a decimal point",
                            n.value
                        ));
                    }
                    n.value * 1e-3
                }
                (Dialect::Fanuc, 'X' | 'U') => {
                    let n = self.plain_or_siemens(letter, val)?;
                    if !n.point && n.value != 0.0 {
                        return Err(format!(
                            "G04 {letter}{}: without a decimal point a FANUC control reads \
                             the time in least increments (ms) unless calculator-type input \
                             is set; write {letter}{}. for seconds or P for milliseconds",
                            n.value, n.value
                        ));
                    }
                    n.value
                }
                (Dialect::Siemens, 'F') => val.num().value,
                (Dialect::Siemens, 'S') => {
                    return Err(
                        "G4 S: a dwell in spindle revolutions is not supported (use \
                                G4 F in seconds)"
                            .into(),
                    )
                }
                (_, 'S' | 'T' | 'D' | 'H') => continue,
                (Dialect::Fanuc, l) => {
                    return Err(format!(
                        "{l} in a G04 block: a FANUC dwell takes P (ms) or X/U (s) only"
                    ))
                }
                (Dialect::Siemens, l) => {
                    return Err(format!(
                        "{l} in a G4 block: a SINUMERIK dwell takes F (s) only, in a block \
                         of its own"
                    ))
                }
            };
            if seconds.is_some() {
                return Err("two dwell times in one block".into());
            }
            if !(0.0..=MAX_DWELL_S).contains(&s) {
                return Err(format!(
                    "dwell of {s} s: must be from 0 to {MAX_DWELL_S:.0e} s"
                ));
            }
            seconds = Some(s);
        }
        let Some(seconds) = seconds else {
            return Err(match self.dialect {
                Dialect::Fanuc => "G04 without a time (P in ms, or X/U in s)".into(),
                Dialect::Siemens => "G4 without a time (F in s)".into(),
            });
        };
        steps.push(NcStep::Dwell {
            line,
            block_number,
            seconds,
        });
        Ok(())
    }

    fn name(&mut self, name: &str, has_args: bool, has_value: bool) -> Result<NameAct, String> {
        if let Some(m) = super::lex::refused_name(name) {
            return Err(m);
        }
        if self.fanuc() {
            return Err(format!(
                "`{name}`: not a word of a plain FANUC program (macro statements are not \
                 supported)"
            ));
        }
        if has_value {
            return if matches!(name, "CR" | "AR") {
                Ok(NameAct::ArcParameter)
            } else {
                Err(format!(
                    "`{name}=`: assignments to variables are not supported"
                ))
            };
        }
        match name {
            "MSG" if has_args => Ok(NameAct::Ignore),
            "SOFT" | "BRISK" | "DRIVE" | "FFWON" | "FFWOF" | "CFC" | "CFTCP" | "CFIN"
            | "STOPRE" | "TRAFOOF" | "DIAMOF"
                if !has_args =>
            {
                if name == "DIAMOF" {
                    self.diameter = false;
                }
                Ok(NameAct::Ignore)
            }
            "DIAMON" | "DIAM90" if !has_args => {
                self.diameter = true;
                Ok(NameAct::Ignore)
            }
            "RET" if !has_args => Ok(NameAct::End),
            _ => Err(format!(
                "`{name}`: not a word this reader knows (a subprogram call, cycle or \
                 keyword?)"
            )),
        }
    }
}

enum NameAct {
    Ignore,
    End,
    ArcParameter,
}
