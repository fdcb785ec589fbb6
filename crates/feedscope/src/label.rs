//! The two labels a fluctuation component carries: the segment of the stroke it was found in
//! and the cause it is given. Both are written as short strings in every file (`all`, `2`,
//! `shaft 1x`, `unresolved`, ...) and are typed everywhere else, so a misspelt label is a
//! compile error instead of a component that silently matches nothing.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// The cause of harmonic h of one mechanism.
type Harmonic = fn(u8) -> Cause;

/// Which part of a stroke a spectrum or component covers.
///
/// Written as `all` for the whole stroke and `1`, `2`, ... for the segments in order of
/// increasing position.
///
/// ```
/// use feedscope::order::Segment;
/// assert_eq!(Segment::Whole.to_string(), "all");
/// assert_eq!("3".parse::<Segment>().unwrap(), Segment::Part(3));
/// assert!("0".parse::<Segment>().is_err()); // segments count from 1
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Segment {
    /// The whole stroke (`all`).
    Whole,
    /// The n-th segment along increasing position, n ≥ 1.
    Part(usize),
}

impl Segment {
    /// `true` for the whole stroke.
    pub fn is_whole(self) -> bool {
        self == Segment::Whole
    }
}

impl fmt::Display for Segment {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Segment::Whole => f.write_str("all"),
            Segment::Part(n) => write!(f, "{n}"),
        }
    }
}

/// A label that is not one of the known forms.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("`{text}` is not a {what} label ({expected})")]
pub struct LabelError {
    /// The text read.
    pub text: String,
    /// `segment`, `cause` or `test kind`.
    pub what: &'static str,
    /// The forms accepted.
    pub expected: &'static str,
}

impl FromStr for Segment {
    type Err = LabelError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        if s == "all" {
            return Ok(Segment::Whole);
        }
        match s.parse::<usize>() {
            Ok(n) if n >= 1 && s.bytes().all(|b| b.is_ascii_digit()) => Ok(Segment::Part(n)),
            _ => Err(LabelError {
                text: s.to_string(),
                what: "segment",
                expected: "`all` or a segment number from 1",
            }),
        }
    }
}

/// The cause given to a significant fluctuation component (paper 000, section 4.1.2 and
/// Eq. 7): the kinematic order it matches, or why it has none.
///
/// Written as `shaft 1x`, `nut ball refeed 2x`, `guide ball refeed 3x`, `declared: TEXT`,
/// `unexplained` or `unresolved`.
///
/// ```
/// use feedscope::order::Cause;
/// let c: Cause = "guide ball refeed 2x".parse().unwrap();
/// assert_eq!(c, Cause::GuideRefeed(2));
/// assert_eq!(Cause::Shaft(1).to_string(), "shaft 1x");
/// assert!(c.is_kinematic());
/// assert!(!Cause::Unresolved.is_kinematic());
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Cause {
    /// Harmonic h of the screw shaft's rotation (pitch errors), h = 1..4.
    Shaft(u8),
    /// Harmonic h of the ball refeeding in the nut (Eq. 7).
    NutRefeed(u8),
    /// Harmonic h of the ball refeeding in the linear guides (Eq. 7).
    GuideRefeed(u8),
    /// An order the user declared in the axis file, with the user's text.
    Declared(String),
    /// Resolved, trusted, and near no kinematic order.
    Unexplained,
    /// Not resolved well enough to be named: the segment spans too few leads, the order is
    /// above the trusted one, or the data verdict withholds causes.
    Unresolved,
}

impl Cause {
    /// `true` when the cause names a mechanism (shaft, nut, guides or a declared order).
    pub fn is_kinematic(&self) -> bool {
        !matches!(self, Cause::Unexplained | Cause::Unresolved)
    }
}

impl fmt::Display for Cause {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Cause::Shaft(h) => write!(f, "shaft {h}x"),
            Cause::NutRefeed(h) => write!(f, "nut ball refeed {h}x"),
            Cause::GuideRefeed(h) => write!(f, "guide ball refeed {h}x"),
            Cause::Declared(text) => write!(f, "declared: {text}"),
            Cause::Unexplained => f.write_str("unexplained"),
            Cause::Unresolved => f.write_str("unresolved"),
        }
    }
}

impl FromStr for Cause {
    type Err = LabelError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let bad = || LabelError {
            text: s.to_string(),
            what: "cause",
            expected: "`shaft Nx`, `nut ball refeed Nx`, `guide ball refeed Nx`, \
                       `declared: TEXT`, `unexplained` or `unresolved`",
        };
        match s {
            "unexplained" => return Ok(Cause::Unexplained),
            "unresolved" => return Ok(Cause::Unresolved),
            _ => {}
        }
        if let Some(text) = s.strip_prefix("declared: ") {
            return Ok(Cause::Declared(text.to_string()));
        }
        let harmonic = |rest: &str| -> Option<u8> {
            let digits = rest.strip_suffix('x')?;
            if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
                return None;
            }
            digits.parse::<u8>().ok().filter(|h| *h >= 1)
        };
        let kinds: [(&str, Harmonic); 3] = [
            ("shaft ", Cause::Shaft),
            ("nut ball refeed ", Cause::NutRefeed),
            ("guide ball refeed ", Cause::GuideRefeed),
        ];
        for (prefix, make) in kinds {
            if let Some(rest) = s.strip_prefix(prefix) {
                return harmonic(rest).map(make).ok_or_else(bad);
            }
        }
        Err(bad())
    }
}

// Both labels are strings in JSON (and in every file written before they were typed).
macro_rules! serde_as_text {
    ($t:ty) => {
        impl Serialize for $t {
            fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
                s.collect_str(self)
            }
        }
        impl<'de> Deserialize<'de> for $t {
            fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                let text = String::deserialize(d)?;
                text.parse().map_err(serde::de::Error::custom)
            }
        }
    };
}
serde_as_text!(Segment);
serde_as_text!(Cause);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_cause_reads_back_what_it_writes() {
        let all = [
            Cause::Shaft(1),
            Cause::Shaft(4),
            Cause::NutRefeed(2),
            Cause::GuideRefeed(3),
            Cause::Declared("rolling-tool mark: 2x".into()),
            Cause::Declared(String::new()),
            Cause::Unexplained,
            Cause::Unresolved,
        ];
        for c in all {
            let text = c.to_string();
            assert_eq!(text.parse::<Cause>().unwrap(), c, "{text}");
            let json = serde_json::to_string(&c).unwrap();
            assert_eq!(json, format!("\"{text}\""));
            assert_eq!(serde_json::from_str::<Cause>(&json).unwrap(), c);
        }
    }

    #[test]
    fn malformed_causes_are_refused() {
        for bad in [
            "",
            "shaft",
            "shaft x",
            "shaft 0x",
            "shaft 1",
            "shaft -1x",
            "shaft 1x ",
            "Shaft 1x",
            "nut refeed 1x",
            "guide ball refeed 999x",
            "declared:x",
        ] {
            let e = bad.parse::<Cause>().unwrap_err();
            assert_eq!(e.text, bad);
            assert!(e.to_string().contains("cause"), "{e}");
        }
        assert!(serde_json::from_str::<Cause>("\"shaft 1\"").is_err());
    }

    #[test]
    fn segments_read_back_and_refuse_the_rest() {
        for s in [Segment::Whole, Segment::Part(1), Segment::Part(1000)] {
            assert_eq!(s.to_string().parse::<Segment>().unwrap(), s);
            let json = serde_json::to_string(&s).unwrap();
            assert_eq!(serde_json::from_str::<Segment>(&json).unwrap(), s);
        }
        for bad in ["", "0", "-1", "+1", "All", "1.0", " 1"] {
            assert!(bad.parse::<Segment>().is_err(), "{bad}");
        }
        assert!(Segment::Whole < Segment::Part(1));
        assert!(Segment::Part(2) < Segment::Part(10));
    }
}
