//! Lines of NC text into words, without any dialect knowledge: address letters with numbers,
//! SINUMERIK `Z=AC(…)` / `Z=IC(…)` / `Z=…` forms, names of two or more letters (keywords,
//! macro statements) and framing lines (`%`). Comments `( … )` and `; …` are dropped here.
//! Whatever cannot be a word of a plain program (macro variables `#`, brackets, block skip `/`,
//! stray characters) is an error with a message that says why.

/// Longest line read (characters); longer lines are an error, not truncated.
pub(super) const MAX_LINE_CHARS: usize = 4096;

/// Longest number text (sign, digits and point) accepted in one word.
const MAX_NUMBER_CHARS: usize = 32;

/// A number as written: its value and whether it had a decimal point (FANUC reads `Z100`
/// without a point in least input increments, see [`super`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Num {
    pub value: f64,
    pub point: bool,
}

/// How a value was written.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Val {
    /// `Z10.5`
    Plain(Num),
    /// SINUMERIK `Z=10.5`
    Assigned(Num),
    /// SINUMERIK `Z=AC(10.5)`: absolute whatever G90/G91 says
    Ac(Num),
    /// SINUMERIK `Z=IC(10.5)`: incremental whatever G90/G91 says
    Ic(Num),
}

impl Val {
    pub fn num(&self) -> Num {
        match *self {
            Val::Plain(n) | Val::Assigned(n) | Val::Ac(n) | Val::Ic(n) => n,
        }
    }
}

/// One word of a block.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Tok {
    /// An address letter (upper case) with its value.
    Word { letter: char, val: Val },
    /// A name of two or more characters starting with two letters (upper case), e.g. `SOFT`,
    /// `WHILE`, `MSG`; `args` holds the text inside a following `( … )`, `value` a following
    /// `= value`.
    Name {
        name: String,
        args: Option<String>,
        value: Option<Val>,
    },
}

/// A lexed line.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Line {
    /// Nothing but blanks and comments.
    Empty {
        /// The line starts (after blanks) with `;`: a SINUMERIK comment line.
        semicolon_comment: bool,
    },
    /// A line starting with `%` (FANUC tape start/end, SINUMERIK archive header `%_N_…`).
    Percent { rest: String },
    /// A block.
    Block(Vec<Tok>),
}

/// Lex one line (without its line end).
///
/// # Errors
/// A message naming what cannot be read.
pub(super) fn lex_line(text: &str) -> Result<Line, String> {
    let n_chars = text.chars().count();
    if n_chars > MAX_LINE_CHARS {
        return Err(format!(
            "line has {n_chars} characters, more than the {MAX_LINE_CHARS} this reader accepts"
        ));
    }
    let chars: Vec<char> = text.chars().collect();
    let mut i = 0;
    skip_blanks(&chars, &mut i);
    match chars.get(i) {
        Some('%') => {
            return Ok(Line::Percent {
                rest: chars[i + 1..].iter().collect(),
            })
        }
        Some('/') => {
            return Err(
                "block skip `/`: whether the block runs depends on the operator's \
                        block-skip switch; remove the `/` or the block"
                    .to_string(),
            )
        }
        Some(';') => {
            return Ok(Line::Empty {
                semicolon_comment: true,
            })
        }
        _ => {}
    }
    let mut toks = Vec::new();
    while i < chars.len() {
        let c = chars[i];
        match c {
            ' ' | '\t' | '\r' | '\u{c}' => i += 1,
            '(' => {
                // A comment runs to the first `)`; FANUC comments do not nest.
                match chars[i + 1..].iter().position(|&d| d == ')') {
                    Some(k) => i += k + 2,
                    None => return Err("comment `(` without a closing `)`".to_string()),
                }
            }
            ';' => break,
            c if c.is_ascii_alphabetic() => {
                let tok = lex_word(&chars, &mut i)?;
                toks.push(tok);
            }
            '#' => {
                return Err(
                    "macro variable `#`: variables and arithmetic are not supported \
                            (write the values as numbers)"
                        .to_string(),
                )
            }
            '[' | ']' => {
                return Err(format!(
                    "`{c}`: macro arithmetic is not supported (write the values as numbers)"
                ))
            }
            '$' => {
                return Err(
                    "system variable `$…`: variables are not supported (write the values as \
                     numbers)"
                        .to_string(),
                )
            }
            ',' => {
                return Err(
                    "`,`: optional chamfering or corner rounding (`,C` / `,R`) and \
                            other comma forms are not supported"
                        .to_string(),
                )
            }
            '0'..='9' | '+' | '-' | '.' => {
                return Err(format!(
                    "number `{}` without an address letter",
                    number_text(&chars, i)
                ))
            }
            '%' => return Err("`%` inside a block".to_string()),
            '/' => return Err("`/` inside a block (block skip or division)".to_string()),
            other => return Err(format!("unexpected character {}", describe_char(other))),
        }
    }
    if toks.is_empty() {
        Ok(Line::Empty {
            semicolon_comment: false,
        })
    } else {
        Ok(Line::Block(toks))
    }
}

fn describe_char(c: char) -> String {
    if c.is_control() {
        format!("U+{:04X} (a control character)", c as u32)
    } else {
        format!("`{c}` (U+{:04X})", c as u32)
    }
}

fn skip_blanks(chars: &[char], i: &mut usize) {
    while *i < chars.len() && matches!(chars[*i], ' ' | '\t' | '\r' | '\u{c}') {
        *i += 1;
    }
}

/// The characters that could belong to a number starting at `i` (for messages).
fn number_text(chars: &[char], i: usize) -> String {
    chars[i..]
        .iter()
        .take_while(|c| c.is_ascii_digit() || matches!(c, '+' | '-' | '.'))
        .take(MAX_NUMBER_CHARS + 1)
        .collect()
}

/// An address word, a SINUMERIK assignment form or a name, starting at the letter `chars[*i]`.
fn lex_word(chars: &[char], i: &mut usize) -> Result<Tok, String> {
    let start = *i;
    let letter = chars[start].to_ascii_uppercase();
    // Two letters in a row start a name (keyword, macro statement, subprogram name).
    if chars
        .get(start + 1)
        .is_some_and(|c| c.is_ascii_alphabetic())
    {
        let mut j = start;
        while j < chars.len() && (chars[j].is_ascii_alphanumeric() || chars[j] == '_') {
            j += 1;
        }
        let name: String = chars[start..j]
            .iter()
            .map(|c| c.to_ascii_uppercase())
            .collect();
        // Statements that change the flow or the coordinates are refused here, before the
        // rest of their line (conditions, labels, strings) trips the lexer.
        if let Some(m) = refused_name(&name) {
            return Err(m);
        }
        *i = j;
        let mut args = None;
        let mut value = None;
        // Arguments only right after the name: `SOFT (COMMENT)` is a keyword and a comment.
        if chars.get(*i) == Some(&'(') {
            args = Some(paren_args(chars, i).map_err(|e| format!("{name}(…): {e}"))?);
        } else {
            let mut k = *i;
            skip_blanks(chars, &mut k);
            if chars.get(k) == Some(&'=') {
                *i = k + 1;
                value = Some(assigned_value(chars, i, &name)?);
            }
        }
        return Ok(Tok::Name { name, args, value });
    }
    *i = start + 1;
    skip_blanks(chars, i);
    match chars.get(*i) {
        Some(c) if c.is_ascii_digit() || matches!(c, '+' | '-' | '.') => {
            let num = number(chars, i).map_err(|e| format!("{letter}: {e}"))?;
            let mut k = *i;
            skip_blanks(chars, &mut k);
            if chars.get(k) == Some(&'=') {
                return Err(format!(
                    "`{letter}{}=`: assignment to a parameter (R-parameter or variable) is not \
                     supported (write the values as numbers)",
                    fmt_num(num)
                ));
            }
            Ok(Tok::Word {
                letter,
                val: Val::Plain(num),
            })
        }
        Some('=') => {
            *i += 1;
            let val = assigned_value(chars, i, &letter.to_string())?;
            Ok(Tok::Word { letter, val })
        }
        Some('#') => Err(format!(
            "`{letter}#…`: macro variables are not supported (write the value as a number)"
        )),
        Some('[') => Err(format!(
            "`{letter}[…]`: macro arithmetic is not supported (write the value as a number)"
        )),
        _ => Err(format!("address `{letter}` without a value")),
    }
}

/// Why a name (keyword) is refused, if it is: loops, conditions and jumps, calls, frames,
/// definitions.
pub(super) fn refused_name(name: &str) -> Option<String> {
    const LOOPS: &[&str] = &[
        "WHILE", "ENDWHILE", "FOR", "ENDFOR", "LOOP", "ENDLOOP", "REPEAT", "REPEATB", "UNTIL",
        "GOTO", "GOTOF", "GOTOB", "GOTOC", "GOTOS", "IF", "ELSE", "ENDIF", "CASE", "DO", "END",
        "THEN",
    ];
    const CALLS: &[&str] = &["CALL", "PCALL", "MCALL", "EXTCALL", "CALLPATH"];
    const FRAMES: &[&str] = &[
        "TRANS", "ATRANS", "ROT", "AROT", "SCALE", "ASCALE", "MIRROR", "AMIRROR", "SUPA",
    ];
    // FANUC writes `DO1`, `END1`, `GOTO10`.
    let base = name.trim_end_matches(|c: char| c.is_ascii_digit());
    if LOOPS.contains(&base) {
        Some(format!(
            "`{name}`: loops, conditions and jumps are not supported"
        ))
    } else if CALLS.contains(&name) || name.starts_with("CYCLE") {
        Some(format!(
            "`{name}`: subprogram and cycle calls are not supported"
        ))
    } else if FRAMES.contains(&name) {
        Some(format!(
            "`{name}`: frames (shift, rotation, scaling, mirroring) are not supported"
        ))
    } else if matches!(name, "DEF" | "PROC" | "DEFINE") {
        Some(format!(
            "`{name}`: definitions and variables are not supported"
        ))
    } else {
        None
    }
}

/// A number as the text of the original, for messages.
fn fmt_num(n: Num) -> String {
    if n.point {
        format!("{}", n.value)
    } else {
        format!("{}", n.value as i64)
    }
}

/// `[+-]digits[.digits]` (at least one digit, no exponent), at most [`MAX_NUMBER_CHARS`].
fn number(chars: &[char], i: &mut usize) -> Result<Num, String> {
    let start = *i;
    let mut j = start;
    if matches!(chars.get(j), Some('+' | '-')) {
        j += 1;
    }
    let mut digits = 0;
    let mut point = false;
    while j < chars.len() {
        match chars[j] {
            '0'..='9' => digits += 1,
            '.' if !point => point = true,
            '.' => return Err("a number with two decimal points".to_string()),
            _ => break,
        }
        j += 1;
    }
    if digits == 0 {
        return Err(format!(
            "`{}` is not a number",
            chars[start..j].iter().collect::<String>()
        ));
    }
    if j - start > MAX_NUMBER_CHARS {
        return Err(format!(
            "number with more than {MAX_NUMBER_CHARS} characters"
        ));
    }
    if matches!(chars.get(j), Some('+' | '-')) {
        return Err(format!(
            "`{}{}…`: arithmetic is not supported (write the value as a number)",
            chars[start..j].iter().collect::<String>(),
            chars[j]
        ));
    }
    let text: String = chars[start..j].iter().collect();
    // A trailing point ("10.") and a leading one (".5") are valid in G-code; Rust's parser
    // accepts both forms too, and at most 32 characters cannot overflow f64.
    let value: f64 = text
        .parse()
        .map_err(|_| format!("`{text}` is not a number"))?;
    *i = j;
    Ok(Num { value, point })
}

/// After `X=`: a number, `AC(number)` or `IC(number)`.
fn assigned_value(chars: &[char], i: &mut usize, what: &str) -> Result<Val, String> {
    skip_blanks(chars, i);
    let unsupported = || {
        format!(
            "after `{what}=` only a number, AC(number) or IC(number) can be read \
             (expressions, parameters and functions are not supported)"
        )
    };
    match chars.get(*i) {
        Some(c) if c.is_ascii_digit() || matches!(c, '+' | '-' | '.') => {
            let n = number(chars, i).map_err(|e| format!("{what}=: {e}"))?;
            end_of_value(chars, *i).map_err(|_| unsupported())?;
            Ok(Val::Assigned(n))
        }
        Some(c) if c.is_ascii_alphabetic() => {
            let two: String = chars[*i..(*i + 2).min(chars.len())]
                .iter()
                .map(|c| c.to_ascii_uppercase())
                .collect();
            let is_fn = (two == "AC" || two == "IC")
                && !chars
                    .get(*i + 2)
                    .is_some_and(|c| c.is_ascii_alphanumeric() || *c == '_');
            if !is_fn {
                return Err(unsupported());
            }
            *i += 2;
            skip_blanks(chars, i);
            if chars.get(*i) != Some(&'(') {
                return Err(unsupported());
            }
            *i += 1;
            skip_blanks(chars, i);
            let n = number(chars, i).map_err(|_| unsupported())?;
            skip_blanks(chars, i);
            if chars.get(*i) != Some(&')') {
                return Err(unsupported());
            }
            *i += 1;
            end_of_value(chars, *i).map_err(|_| unsupported())?;
            Ok(if two == "AC" { Val::Ac(n) } else { Val::Ic(n) })
        }
        _ => Err(unsupported()),
    }
}

/// A value must be followed by a blank, a comment, the end of the line or the next address.
fn end_of_value(chars: &[char], i: usize) -> Result<(), ()> {
    match chars.get(i) {
        None => Ok(()),
        Some(' ' | '\t' | '\r' | '\u{c}' | ';' | '(') => Ok(()),
        Some(c) if c.is_ascii_alphabetic() => Ok(()),
        _ => Err(()),
    }
}

/// The text inside `( … )` starting at `chars[*i] == '('`, honouring `"…"` strings.
fn paren_args(chars: &[char], i: &mut usize) -> Result<String, String> {
    let start = *i + 1;
    let mut depth = 0usize;
    let mut in_string = false;
    let mut j = *i;
    while j < chars.len() {
        let c = chars[j];
        if in_string {
            if c == '"' {
                in_string = false;
            }
        } else {
            match c {
                '"' => in_string = true,
                '(' => depth += 1,
                ')' => {
                    depth -= 1;
                    if depth == 0 {
                        *i = j + 1;
                        return Ok(chars[start..j].iter().collect());
                    }
                }
                _ => {}
            }
        }
        j += 1;
    }
    Err("`(` without a closing `)`".to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn words(text: &str) -> Vec<Tok> {
        match lex_line(text).unwrap() {
            Line::Block(t) => t,
            other => panic!("{other:?}"),
        }
    }

    fn plain(letter: char, value: f64, point: bool) -> Tok {
        Tok::Word {
            letter,
            val: Val::Plain(Num { value, point }),
        }
    }

    #[test]
    fn words_without_spaces_and_with_comments() {
        assert_eq!(
            words("N10G01Z-10.5F100(FEED);rest"),
            vec![
                plain('N', 10.0, false),
                plain('G', 1.0, false),
                plain('Z', -10.5, true),
                plain('F', 100.0, false),
            ]
        );
        assert_eq!(words("g1 z.5")[1], plain('Z', 0.5, true));
        assert_eq!(words("G 01 Z10.")[1], plain('Z', 10.0, true));
    }

    #[test]
    fn siemens_forms() {
        let t = words("G1 Z=IC(-5) X=AC( 2.5 ) Y=3 SOFT MSG(\"A (B) ;\")");
        assert_eq!(
            t[1],
            Tok::Word {
                letter: 'Z',
                val: Val::Ic(Num {
                    value: -5.0,
                    point: false
                })
            }
        );
        assert!(matches!(
            t[2],
            Tok::Word {
                val: Val::Ac(_),
                ..
            }
        ));
        assert!(matches!(
            t[3],
            Tok::Word {
                val: Val::Assigned(_),
                ..
            }
        ));
        assert_eq!(
            t[4],
            Tok::Name {
                name: "SOFT".into(),
                args: None,
                value: None
            }
        );
        assert!(matches!(&t[5], Tok::Name { args: Some(a), .. } if a == "\"A (B) ;\""));
    }

    #[test]
    fn lines_that_are_not_blocks() {
        assert_eq!(
            lex_line("  ; a comment").unwrap(),
            Line::Empty {
                semicolon_comment: true
            }
        );
        assert_eq!(
            lex_line("(ONLY A COMMENT)").unwrap(),
            Line::Empty {
                semicolon_comment: false
            }
        );
        assert!(matches!(lex_line("%").unwrap(), Line::Percent { .. }));
    }

    #[test]
    fn errors_say_why() {
        for (text, part) in [
            ("G1 Z#100", "macro variables"),
            ("G1 Z[1+2]", "arithmetic"),
            ("/G1 Z1.", "block skip"),
            ("G1 Z1.2.3", "two decimal points"),
            ("G1 Z=R1", "only a number"),
            ("G1 Z=IC(R1)", "only a number"),
            ("R1=5", "assignment"),
            ("G1 Z", "without a value"),
            ("(OPEN", "without a closing"),
            ("G1 10.", "without an address"),
            ("G1 Z1.,C2.", "chamfering"),
            ("G1 Z1-2", "arithmetic"),
            ("G1 Z=5+2", "arithmetic"),
            ("G1 Z1\u{7}", "control character"),
        ] {
            let e = lex_line(text).unwrap_err();
            assert!(e.contains(part), "{text}: {e}");
        }
        let long = format!("G1 Z1. {}", " ".repeat(MAX_LINE_CHARS));
        assert!(lex_line(&long).unwrap_err().contains("4096"));
        let digits = format!("G1 Z{}", "1".repeat(40));
        assert!(lex_line(&digits).unwrap_err().contains("more than 32"));
    }
}
