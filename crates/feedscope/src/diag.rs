//! Diagnostics: what a result wants its reader to know, as data.
//!
//! Every warning, note and data-verdict reason of every crate has one [`Code`] from the
//! catalogue below: a stable kebab-case identifier (never renamed once published, so that
//! scripts and a server can act on it) with its explanation, and a [`Diagnostic`] pairs it with
//! the message for people, which states the numbers of the case at hand. Typed warnings that
//! carry their data as fields ([`FitWarning`](crate::stribeck::FitWarning), the
//! [`Undetermined`](crate::stribeck::Undetermined) reason of a refused model) take their code
//! from the same catalogue. `docs/diagnostics.md` is generated from it ([`catalogue_markdown`];
//! a test keeps the file current). Serialised as `{"code": ..., "message": ...}`.
//!
//! ```
//! use feedscope::diag::{Code, Diagnostic};
//! let d = Diagnostic::new(Code::EffortUnsigned, "the effort is a magnitude");
//! assert_eq!(serde_json::to_string(&d).unwrap(),
//!            r#"{"code":"effort-unsigned","message":"the effort is a magnitude"}"#);
//! assert_eq!(d.to_string(), "the effort is a magnitude");
//! assert!(Code::EffortUnsigned.explanation().starts_with("The effort is a magnitude"));
//! // Older files stored the message alone; a newer feedscope may know more codes.
//! let old: Diagnostic = serde_json::from_str(r#""a warning""#).unwrap();
//! assert_eq!((old.code, old.message.as_str()), (Code::Uncoded, "a warning"));
//! let newer: Diagnostic =
//!     serde_json::from_str(r#"{"code":"from-the-future","message":"m"}"#).unwrap();
//! assert_eq!(newer.code, Code::Unknown);
//! ```
use std::fmt;

use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// Defines [`Code`] from sections of `/// explanation` + `Variant = "code"` entries, so that
/// the enum's documentation, [`Code::explanation`] and `docs/diagnostics.md` are one text.
macro_rules! catalogue {
    ($( $section:literal { $( $(#[doc = $doc:literal])+ $variant:ident = $code:literal, )+ } )+) => {
        /// The stable code of a diagnostic: every warning, note and verdict reason feedscope
        /// gives. Serialised as its kebab-case [`Code::as_str`].
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
        #[non_exhaustive]
        pub enum Code {
            $( $( $(#[doc = $doc])+ $variant, )+ )+
            /// A diagnostic read from a file written before codes existed, which stored the
            /// message alone (`uncoded`).
            Uncoded,
            /// A code this version does not know, read from a file a newer feedscope wrote
            /// (`unknown`); its message is kept.
            Unknown,
        }

        impl Code {
            /// Every code a diagnostic is given, in catalogue order (not [`Code::Uncoded`]
            /// and [`Code::Unknown`], which only reading gives).
            pub const ALL: &'static [Code] = &[ $( $( Code::$variant, )+ )+ ];

            /// The stable kebab-case identifier.
            pub fn as_str(self) -> &'static str {
                match self {
                    $( $( Code::$variant => $code, )+ )+
                    Code::Uncoded => "uncoded",
                    Code::Unknown => "unknown",
                }
            }

            /// The code's explanation as written in the catalogue (one line per source line).
            fn doc(self) -> &'static str {
                match self {
                    $( $( Code::$variant => concat!($($doc, "\n"),+), )+ )+
                    Code::Uncoded => " Read from a file that stored the message alone.\n",
                    Code::Unknown => " A code a newer feedscope wrote; this version does not know it.\n",
                }
            }

            /// Where the diagnostic arises (a section of the catalogue).
            pub fn section(self) -> &'static str {
                match self {
                    $( $( Code::$variant => $section, )+ )+
                    Code::Uncoded | Code::Unknown => "Reading stored results",
                }
            }
        }
    };
}

catalogue! {
    "Reading recordings" {
        /// The position never changes in the trace: there are no strokes to estimate friction
        /// from. Record while the axis moves (check the position channel is the axis's).
        PositionNeverMoves = "position-never-moves",
        /// The effort is zero in every sample: the channel is not the drive's current or torque,
        /// or the control did not record it.
        EffortAllZero = "effort-all-zero",
        /// The median sampling interval is too long for the friction's ripple along the travel:
        /// only each stroke's mean friction can be estimated. A faster recording (a servo trace
        /// instead of polled values) resolves the profile and its orders.
        SlowSampling = "slow-sampling",
        /// A channel declares a unit that differs from the one given on the command line; the
        /// given one was used. Check which is right.
        UnitOverridden = "unit-overridden",
        /// A channel declares a scaling: its values are taken as exported. Export with the
        /// scaling applied, or check that the values are in the declared unit.
        ScaledChannel = "scaled-channel",
        /// A data frame of the recording does not hold a selected signal: no samples come from
        /// that frame.
        SignalMissingInFrame = "signal-missing-in-frame",
        /// Samples carrying the control's invalid mark were dropped (they are not values).
        InvalidSamplesDropped = "invalid-samples-dropped",
        /// The recording declares more samples than its records hold: samples may be missing.
        DatapointCountMismatch = "datapoint-count-mismatch",
        /// Gaps in a channel are not a whole number of its sampling interval: they are left as
        /// gaps, not filled.
        IrregularGaps = "irregular-gaps",
        /// The control reports samples it lost (data drop-outs) during the recording.
        DropOuts = "drop-outs",
        /// The values carry three significant figures only: large positions are coarsely
        /// quantised, which limits what the trace supports.
        ThreeSignificantFigures = "three-significant-figures",
        /// The chosen current column is not the torque-producing current (it stays near a
        /// constant whatever the axis does); choose the feedback current.
        OutputCurrentNotTorque = "output-current-not-torque",
        /// The position declares no units and is taken in the standard's unit (millimetres for
        /// MTConnect POSITION).
        PositionUnitsAssumed = "position-units-assumed",
        /// The load is reported in whole percent: the torque is quantised in steps of 1 % of its
        /// scale, which enters every standard error.
        LoadWholePercent = "load-whole-percent",
        /// The load is never negative: the drive reports a magnitude, so the sign of the torque
        /// (and of friction on backward strokes) is lost; friction takes the sign of the motion.
        LoadUnsigned = "load-unsigned",
        /// The trace is pieced together from several recordings (time jumps back); samples are
        /// put in time order with gaps between the recordings.
        PiecedRecording = "pieced-recording",
        /// Recordings of one log overlap in time and their samples interleave: check the trace
        /// before estimating.
        RecordingsInterleave = "recordings-interleave",
        /// The first line of the log is long before this axis's first sample (a state dump?);
        /// `--time-origin trace` starts the trace at its first sample.
        FirstLineLongBefore = "first-line-long-before",
        /// Position samples that jump further than the axis can move between two samples
        /// (a glitch of the control or the log) were dropped on reading; the message names the
        /// first ones.
        PositionGlitchesDropped = "position-glitches-dropped",
        /// Effort samples far outside the drive's range (a glitch) were dropped on reading; the
        /// message names the first ones.
        EffortGlitchesDropped = "effort-glitches-dropped",
        /// The file's last line has no line end: it may have been cut off while being written
        /// or copied; it was read as it stands, and the recording may end early.
        LastLineUnterminated = "last-line-unterminated",
    }
    "Estimating friction" {
        /// Friction comes out pushing the table along in both directions only because the axis
        /// file's motor damping takes more than the drive's whole force off it: the damping is
        /// far too large, and every friction value is wrong until it is corrected (or set to 0).
        DampingExceedsDriveForce = "damping-exceeds-drive-force",
        /// Friction comes out pushing the table along in both directions: the effort's sign
        /// convention is reversed against the position (or the axis file's torque constant has
        /// the wrong sign). Every friction value has the wrong sign until it is corrected.
        EffortSignReversed = "effort-sign-reversed",
        /// The effort is a magnitude: friction takes the sign of the direction of motion, and a
        /// force that assists the motion (gravity on a vertical axis) cannot be told apart.
        EffortUnsigned = "effort-unsigned",
        /// The effort is never negative and backward strokes have positive friction: the effort
        /// may be a magnitude; say so (`--effort-sign magnitude`) or import it with
        /// `feedscope import`, which records it.
        EffortMaybeUnsigned = "effort-maybe-unsigned",
        /// The effort is recorded in steps (quantised): its rounding enters every standard
        /// error.
        EffortQuantised = "effort-quantised",
        /// The effort may hold process (cutting) load, from the recording's own marks or a
        /// turning spindle: only each stroke's mean motor force, an upper bound of friction, is
        /// reported.
        ProcessLoad = "process-load",
        /// The position spline is not monotone somewhere in a stroke (noisy or coarsely
        /// quantised position at a low feed); the time at a position took the nearest solution.
        PositionNotMonotone = "position-not-monotone",
        /// A stroke's mean friction lies within a few standard errors of zero: the effort varies
        /// along it far more than friction does (process load, or too few samples for its
        /// noise), so the stroke does not resolve its friction.
        MeanNotResolved = "mean-not-resolved",
        /// Too few raw samples per screw lead: the fluctuation above the trusted order cannot be
        /// trusted. Sample faster or feed slower (the message gives the feed for 8 samples per
        /// lead).
        FewSamplesPerLead = "few-samples-per-lead",
        /// The position is smoothed below an order of interest: the table acceleration of higher
        /// orders is not resolved, so their amplitudes lack the inertia term. Finer position
        /// quanta, faster sampling or a slower feed resolve more.
        PositionSmoothedBelowOrder = "position-smoothed-below-order",
        /// The predicted noise floor (position quantisation, effort noise, inertia) is large
        /// against the friction's variation: the profile is only good to about twice the floor.
        NoiseFloorHigh = "noise-floor-high",
        /// The feed changed inside a stroke faster than the position smoothing resolves: the
        /// friction within a stated reach of each change is off; the rest is not affected.
        FeedChangeUnresolved = "feed-change-unresolved",
        /// The feed varied by more than a quarter of its mean along a stroke (an override
        /// turned, a modulated feed): the mean profile mixes the friction of these feeds where
        /// friction depends on the feed; the orders are not affected.
        FeedVariesAlongStroke = "feed-varies-along-stroke",
        /// Without a rapid rate in the axis file, the much faster moves were taken for rapids
        /// and left out; set `rapid_rate_mm_min` (or give the program) to be sure.
        RapidsInferred = "rapids-inferred",
        /// A measuring move ran at a feed more than 5 % from the one its program block
        /// programs (a feed override?).
        FeedNotAsProgrammed = "feed-not-as-programmed",
        /// Moves of the trace match no block of the program: they are taken for jogging and
        /// left out.
        MovesNotInProgram = "moves-not-in-program",
        /// Programmed moves were not found in the trace (the recording starts late or ends
        /// early, or the program is not the one that ran).
        BlocksNotFound = "blocks-not-found",
        /// A stroke was found but not estimated; the message says why.
        StrokeSkipped = "stroke-skipped",
        /// A stroke of a test-set run ran at a feed other than the one the index gives for
        /// the run, and was left out of the friction map.
        StrokeOffFeed = "stroke-off-feed",
    }
    "Fluctuation orders" {
        /// Segments too short for a spectrum (fewer than 16 samples) were skipped.
        SegmentsSkipped = "segments-skipped",
        /// Significant components were left without a cause: their segment spans too few leads
        /// (order resolution coarser than 0.5) or their order is above the trusted order.
        ComponentsUnresolved = "components-unresolved",
        /// The highest kinematic order of the drive (from the axis file's geometry) is above
        /// the highest trusted order: sample faster or feed slower (the message says by how
        /// much) so that it is resolved without aliasing.
        KinematicOrderAboveTrusted = "kinematic-order-above-trusted",
        /// Significant components above the trusted order are flagged untrusted: they may be
        /// aliases of higher orders.
        ComponentsAboveTrusted = "components-above-trusted",
        /// Significant components are withheld because the stroke's data verdict is below
        /// `orders`.
        ComponentsWithheld = "components-withheld",
        /// Component causes are withheld because the stroke's data verdict is below `causes`
        /// (too few leads to tell kinematic orders apart).
        CausesWithheld = "causes-withheld",
    }
    "Data verdict" {
        /// The stroke spans too few leads for a friction profile: its mean level only.
        StrokeTooShort = "stroke-too-short",
        /// The predicted noise floor is too large a part of the mean level for a profile:
        /// finer effort or position resolution, faster sampling or a slower feed.
        FloorAboveProfileLimit = "floor-above-profile-limit",
        /// The stroke spans too few leads for an order spectrum: a profile only.
        TooFewLeadsForOrders = "too-few-leads-for-orders",
        /// The highest trusted order is below the shaft order 1: orders are not resolved;
        /// sample faster or feed slower.
        OrdersNotResolved = "orders-not-resolved",
        /// The stroke spans too few leads for an order resolution that tells kinematic causes
        /// apart: orders without causes.
        TooFewLeadsForCauses = "too-few-leads-for-causes",
    }
    "Identification" {
        /// The identified Stribeck velocity ended at a bound of its search: the test does not
        /// resolve it; slower or faster levels are needed.
        VsAtBound = "vs-at-bound",
        /// The identified static torque is below the Coulomb torque: no Stribeck drop was
        /// found, and v_s is meaningless.
        NoStribeckDrop = "no-stribeck-drop",
        /// A parameter's standard error is above half its value (the inertia J with too little
        /// acceleration, or v_s): it is poorly identified.
        PoorlyIdentified = "poorly-identified",
        /// The trace is sampled coarsely: the inertia rests on few accelerating rows; its
        /// standard error says how well.
        CoarseSampling = "coarse-sampling",
        /// Position and effort have different timestamps: the effort was interpolated to the
        /// position times.
        EffortInterpolated = "effort-interpolated",
    }
    "Friction fits" {
        /// No more points than parameters: no residual degrees of freedom, so no standard
        /// errors.
        FewPoints = "few-points",
        /// The slowest point is at or above twice the Stribeck velocity: v_s and F_s − F_c are
        /// poorly identified. Add slower feeds.
        NoDataBelowTwiceVs = "no-data-below-twice-vs",
        /// Every point is far above the Stribeck velocity, where the Stribeck term vanishes: the
        /// data cannot see v_s or F_s at all.
        AllSpeedsFarAboveVs = "all-speeds-far-above-vs",
        /// The fastest point is below three times the Stribeck velocity: F_c and σ are
        /// confounded with the Stribeck term. Add faster feeds.
        NoDataAboveThreeVs = "no-data-above-three-vs",
        /// A standard error exceeds its parameter's value: the parameter is not
        /// distinguishable from zero.
        StdErrorExceedsValue = "std-error-exceeds-value",
        /// A parameter ended on a bound of the search (e.g. σ = 0).
        AtBound = "at-bound",
        /// The column-scaled Jacobian is ill conditioned: parameters trade off against each
        /// other (a warning on an accepted fit, or why a model was refused).
        IllConditioned = "ill-conditioned",
        /// The refinement stopped at its iteration limit.
        NotConverged = "not-converged",
        /// A model was refused: too few distinct feeds for its parameters.
        TooFewFeeds = "too-few-feeds",
        /// A model was refused: its Jacobian is singular (parameters not identifiable).
        SingularJacobian = "singular-jacobian",
        /// A model was refused: the fit gave a number that is not finite.
        NonFinite = "non-finite",
        /// A model was refused: a parameter is many times the largest friction measured.
        AbsurdMagnitude = "absurd-magnitude",
        /// A model was refused: a parameter's uncertainty is absurdly large.
        AbsurdUncertainty = "absurd-uncertainty",
        /// A model was refused: the Stribeck velocity lies far outside the measured speeds, so
        /// the hump is not in the data.
        VsOutsideData = "vs-outside-data",
        /// A model was refused: the static friction is below the Coulomb level by more than its
        /// standard error; a falling curve is not a Stribeck hump.
        StaticBelowCoulomb = "static-below-coulomb",
    }
    "Reading results" {
        /// A friction CSV has no summary JSON beside it: the aliasing limit of its strokes is
        /// unknown.
        NoSummary = "no-summary",
    }
}

impl Code {
    /// The explanation of the code: what it means and what to do (one paragraph).
    pub fn explanation(self) -> String {
        self.doc()
            .lines()
            .map(str::trim)
            .filter(|l| !l.is_empty())
            .collect::<Vec<_>>()
            .join(" ")
    }

    /// The code named `s`; [`Code::Unknown`] for a name this version does not know.
    pub fn parse(s: &str) -> Self {
        match s {
            "uncoded" => Self::Uncoded,
            _ => Self::ALL
                .iter()
                .copied()
                .find(|c| c.as_str() == s)
                .unwrap_or(Self::Unknown),
        }
    }
}

impl fmt::Display for Code {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

impl Serialize for Code {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.as_str())
    }
}

impl<'de> Deserialize<'de> for Code {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = std::borrow::Cow::<'de, str>::deserialize(d)?;
        Ok(Self::parse(&s))
    }
}

/// `docs/diagnostics.md`: every code by section with its explanation.
pub fn catalogue_markdown() -> String {
    let mut out = String::from(
        "# Diagnostics\n\n\
         <!-- Generated from `feedscope::diag::Code` (crates/feedscope/src/diag.rs); do not \
         edit. `FEEDSCOPE_BLESS=1 cargo test -p feedscope --test diagnostics_doc` rewrites it. \
         -->\n\n\
         Every warning, note and data-verdict reason feedscope gives carries one of these \
         codes. In JSON outputs a diagnostic is `{\"code\": ..., \"message\": ...}`: the code \
         is stable (scripts may act on it), the message states the numbers of the case. Fit \
         warnings and refused models carry their data as fields beside the code.\n",
    );
    let mut section = "";
    for c in Code::ALL {
        if c.section() != section {
            section = c.section();
            out.push_str(&format!(
                "\n## {section}\n\n| code | meaning |\n|---|---|\n"
            ));
        }
        out.push_str(&format!(
            "| `{}` | {} |\n",
            c.as_str(),
            c.explanation().replace('|', "\\|")
        ));
    }
    out
}

/// One diagnostic: a stable code and a message. Reads `{code, message}`, or a bare string (the
/// form files written before codes existed; its code is [`Code::Uncoded`]).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(from = "Stored")]
pub struct Diagnostic {
    /// Stable code, e.g. [`Code::FewSamplesPerLead`] (`few-samples-per-lead`).
    pub code: Code,
    /// What a person reads: the numbers of this case.
    pub message: String,
}

impl Diagnostic {
    /// A diagnostic with `code` and `message`.
    pub fn new(code: Code, message: impl Into<String>) -> Self {
        Self {
            code,
            message: message.into(),
        }
    }
}

/// What a file may hold for a diagnostic.
#[derive(Deserialize)]
#[serde(untagged)]
enum Stored {
    Coded { code: Code, message: String },
    Text(String),
}

impl From<Stored> for Diagnostic {
    fn from(s: Stored) -> Self {
        match s {
            Stored::Coded { code, message } => Self { code, message },
            Stored::Text(message) => Self {
                code: Code::Uncoded,
                message,
            },
        }
    }
}

impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_are_unique_kebab_case_and_explained() {
        let mut seen = std::collections::BTreeSet::new();
        for c in Code::ALL {
            let s = c.as_str();
            assert!(seen.insert(s), "{s} twice");
            assert!(
                s.split('-').all(|w| !w.is_empty()
                    && w.bytes()
                        .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit())),
                "{s} is not kebab-case"
            );
            assert_eq!(Code::parse(s), *c);
            assert!(c.explanation().len() > 30, "{s} has no real explanation");
            assert!(c.explanation().ends_with('.'), "{s}: {}", c.explanation());
        }
        assert!(!seen.contains("uncoded") && !seen.contains("unknown"));
    }

    #[test]
    fn a_code_round_trips_through_json() {
        for c in Code::ALL {
            let j = serde_json::to_string(c).unwrap();
            assert_eq!(j, format!("\"{}\"", c.as_str()));
            assert_eq!(serde_json::from_str::<Code>(&j).unwrap(), *c);
        }
    }
}
