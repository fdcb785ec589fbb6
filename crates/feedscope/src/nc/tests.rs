//! The reader against `plan`'s own G-code, hand-written programs of both dialects, and every
//! refusal with its line.

use super::*;
use crate::plan::gcode::{write_gcode, FanucMachine, GcodeOptions};
use crate::plan::{
    strokes_program, triangle_program, Limits, StrokeTestParams, TestProgram, TriangleParams,
};

fn parse(text: &str) -> NcProgram {
    NcProgram::parse(text, &ParseOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

fn err(text: &str) -> NcError {
    match NcProgram::parse(text, &ParseOptions::default()) {
        Ok(p) => panic!("expected an error, read {p:?}"),
        Err(e) => e,
    }
}

fn lathe() -> ParseOptions {
    ParseOptions {
        lathe_incremental_addresses: true,
        ..ParseOptions::default()
    }
}

/// The moves, feeds and dwells of a planned program as the reader must return them: the
/// approach move to the start and its 1 s settle, then each move and its dwell (none when 0).
/// Positions are written to 0.001 mm, feeds to 0.1 mm/min and FANUC dwells to 1 ms, so the
/// comparison allows half a unit of each.
fn check_round_trip(prog: &TestProgram, opts: &GcodeOptions, parse_opts: &ParseOptions) {
    let text = write_gcode(prog, opts).unwrap();
    let read = NcProgram::parse(&text, parse_opts).unwrap_or_else(|e| panic!("{e}\n{text}"));
    assert_eq!(read.dialect, opts.dialect);
    let approach = prog.moves.iter().map(|m| m.feed_mm_min).fold(0.0, f64::max);
    let mut expect: Vec<(StepKind, f64, Option<f64>, f64)> =
        vec![(StepKind::Feed, prog.start_mm, Some(approach), 0.0)];
    expect.push((StepKind::Dwell, prog.start_mm, None, 1.0));
    for m in &prog.moves {
        expect.push((StepKind::Feed, m.to_mm, Some(m.feed_mm_min), 0.0));
        if m.dwell_s > 0.0 {
            expect.push((StepKind::Dwell, m.to_mm, None, m.dwell_s));
        }
    }
    // From an arbitrary start: every target is absolute.
    let r = read.resolve(-3.0);
    assert_eq!(r.len(), expect.len(), "{text}");
    for (k, (got, (kind, to, feed, dwell))) in r.iter().zip(&expect).enumerate() {
        assert_eq!(got.kind, *kind, "step {k}");
        assert!((got.to_mm - to).abs() <= 5e-4, "step {k}: {got:?} vs {to}");
        match (got.feed_mm_min, feed) {
            (Some(a), Some(b)) => assert!((a - b).abs() <= 0.05, "step {k}: {a} vs {b}"),
            (None, None) => {}
            other => panic!("step {k}: {other:?}"),
        }
        assert!((got.dwell_s - dwell).abs() <= 5e-4, "step {k}");
        if k > 0 {
            assert!((got.from_mm - r[k - 1].to_mm).abs() < 1e-15);
        }
        // the line holds the block that produced the step
        let line = text.lines().nth(got.line - 1).unwrap();
        let dwell_block = line.starts_with("G4 ") || line.starts_with("G04 ");
        assert_eq!(dwell_block, *kind == StepKind::Dwell, "{line}");
    }
    assert_eq!(read.first_absolute_mm(), Some(prog.start_mm));
}

#[test]
fn plan_programs_round_trip_in_every_dialect() {
    let strokes = strokes_program(
        &StrokeTestParams {
            from_mm: 12.5,
            to_mm: 300.25,
            feeds_mm_min: vec![60.0, 612.5, 3000.0],
            repeats: 2,
            dwell_s: 0.75,
            accel_mm_s2: 1500.0,
        },
        &Limits::default(),
    )
    .unwrap();
    let triangle = triangle_program(
        &TriangleParams {
            window_min_mm: 20.0,
            window_max_mm: 140.0,
            feed_max_mm_min: 8000.0,
            ..TriangleParams::default()
        },
        &Limits::default(),
    )
    .unwrap();
    for prog in [&strokes, &triangle] {
        for (dialect, machine) in [
            (Dialect::Fanuc, FanucMachine::Lathe),
            (Dialect::Fanuc, FanucMachine::Mill),
            (Dialect::Siemens, FanucMachine::Lathe),
        ] {
            let opts = GcodeOptions {
                dialect,
                fanuc_machine: machine,
                ..GcodeOptions::default()
            };
            check_round_trip(prog, &opts, &ParseOptions::default());
            if dialect == Dialect::Fanuc && machine == FanucMachine::Lathe {
                check_round_trip(prog, &opts, &lathe());
            }
            // another axis letter
            let opts = GcodeOptions {
                axis_letter: 'X',
                ..opts
            };
            check_round_trip(
                prog,
                &opts,
                &ParseOptions {
                    axis_letter: 'X',
                    ..ParseOptions::default()
                },
            );
        }
    }
}

#[test]
fn hand_written_fanuc_mill() {
    let text = "\u{feff}%\n\
        O0042 (HAND WRITTEN)\n\
        (SETUP)\n\
        G17 G21 G40 G49 G80 G90 G94\n\
        T1 M06\n\
        G54 G43 H1 S1200 M03\n\
        N10 G00 X0 Y0 Z50.\n\
        N20 G01 Z10. F300 M08 ; EOB written as a semicolon\n\
        N30 X40. Y30. Z-30.\n\
        N40 G91 Z5.\n\
        N50 G04 X1.5\n\
        N60 G90 G00 Z100.\n\
        N70 G20 G01 Z3.5 F10.\n\
        N80 G21 G04 P250\n\
        N90 X10.\n\
        M30\n\
        %\n\
        (NOT READ)\n";
    let p = parse(text);
    assert_eq!(p.dialect, Dialect::Fanuc);
    let r = p.resolve(0.0);
    let lines: Vec<usize> = r.iter().map(|s| s.line).collect();
    assert_eq!(lines, vec![7, 8, 9, 10, 11, 12, 13, 14, 15]);
    assert_eq!(r[0].block_number, Some(10));
    assert_eq!(r[0].kind, StepKind::Rapid);
    assert!((r[0].to_mm - 50.0).abs() < 1e-12 && r[0].feed_mm_min.is_none());
    // alone on the axis: the programmed feed
    assert_eq!(r[1].feed_mm_min, Some(300.0));
    // X 0→40, Y 0→30, Z 10→-30: speed along Z = F·40/√(40²+30²+40²)
    let f = r[2].feed_mm_min.unwrap();
    assert!((f - 300.0 * 40.0 / 4100f64.sqrt()).abs() < 1e-9, "{f}");
    assert!((r[2].to_mm + 30.0).abs() < 1e-12);
    // G91 increment
    assert!((r[3].to_mm + 25.0).abs() < 1e-12);
    assert_eq!(r[4].kind, StepKind::Dwell);
    assert!((r[4].dwell_s - 1.5).abs() < 1e-12);
    assert!((r[5].to_mm - 100.0).abs() < 1e-12);
    // inch: 3.5 in, 10 in/min
    assert!((r[6].to_mm - 88.9).abs() < 1e-9);
    assert!((r[6].feed_mm_min.unwrap() - 254.0).abs() < 1e-9);
    assert!((r[7].dwell_s - 0.25).abs() < 1e-12);
    // X only: the axis does not move, speed 0
    assert!((r[8].from_mm - r[8].to_mm).abs() < 1e-15);
    assert_eq!(r[8].feed_mm_min, Some(0.0));
}

#[test]
fn hand_written_siemens() {
    let text = "; hand written\n\
        N5 G17 G71 G90 G94 G64 SOFT\n\
        N10 G0 Z=AC(2)\n\
        N20 G1 Z=IC(-10) F=250 ; comment (with parentheses)\n\
        N30 G91 Z-5 MSG(\"half way; ok\")\n\
        N40 Z=AC(0)\n\
        N50 G4 F2.5\n\
        N60 G70 G90 Z1\n\
        N65 G700 Z2 F10\n\
        N70 G710 G2 X10 Y0 I5 J0\n\
        N80 G1 X20 Z10\n\
        M17\n";
    let p = parse(text);
    assert_eq!(p.dialect, Dialect::Siemens);
    let r = p.resolve(7.0);
    assert_eq!(r[0].kind, StepKind::Rapid);
    assert!((r[0].from_mm - 7.0).abs() < 1e-15 && (r[0].to_mm - 2.0).abs() < 1e-15);
    assert!((r[1].to_mm + 8.0).abs() < 1e-12);
    assert_eq!(r[1].feed_mm_min, Some(250.0));
    assert!((r[2].to_mm + 13.0).abs() < 1e-12);
    assert!((r[3].to_mm).abs() < 1e-15);
    assert!((r[4].dwell_s - 2.5).abs() < 1e-15);
    // G70: inch positions, feed still mm/min; SINUMERIK Z1 = 1 (no decimal-point rule)
    assert!((r[5].to_mm - 25.4).abs() < 1e-12);
    assert_eq!(r[5].feed_mm_min, Some(250.0));
    // G700: feed in inch/min too
    assert!((r[6].to_mm - 50.8).abs() < 1e-12);
    assert!((r[6].feed_mm_min.unwrap() - 254.0).abs() < 1e-9);
    // an arc in the XY plane does not move Z
    assert_eq!(r[7].kind, StepKind::Feed);
    assert!((r[7].to_mm - r[7].from_mm).abs() < 1e-15);
    // X 10 → 20 (known from the arc's end point), Z 50.8 → 10: speed along Z
    let f = r[8].feed_mm_min.unwrap();
    let (dx, dz) = (10.0f64, 10.0f64 - 50.8);
    assert!(
        (f - 254.0 * dz.abs() / f64::hypot(dx, dz)).abs() < 1e-9,
        "{f}"
    );
    assert_eq!(r.len(), 9);
}

#[test]
fn fanuc_lathe_incremental_addresses() {
    let text = "%\nO1\nG21 G98 G61\nT0101\nG00 Z100. X50.\nG01 W-20. F200\nU-2. W-2.\n\
                Z60.\nG04 U0.5\nM30\n%\n";
    let p = NcProgram::parse(text, &lathe()).unwrap();
    let r = p.resolve(0.0);
    assert!((r[1].to_mm - 80.0).abs() < 1e-12);
    assert_eq!(r[1].feed_mm_min, Some(200.0));
    assert!((r[2].to_mm - 78.0).abs() < 1e-12);
    // X may be a diameter on a lathe: the speed along Z is unknown
    assert_eq!(r[2].feed_mm_min, None);
    assert!((r[3].to_mm - 60.0).abs() < 1e-12);
    assert!((r[4].dwell_s - 0.5).abs() < 1e-15);
    // without the option W is an axis of its own: Z does not move, the feed is F (W alone
    // is another axis, so our axis's speed is 0)
    let p = parse(text);
    let r = p.resolve(0.0);
    assert!((r[1].to_mm - 100.0).abs() < 1e-12);
    assert_eq!(r[1].feed_mm_min, Some(0.0));
    // G90 on a system-A lathe is the turning cycle
    let e = NcProgram::parse("G98\nG90 X10. Z5. F100\n", &lathe()).unwrap_err();
    assert_eq!(e.line, 2);
    assert!(e.message.contains("cutting cycle"), "{e}");
    // a lathe starts in feed per revolution
    let e = NcProgram::parse("G01 Z5. F100\n", &lathe()).unwrap_err();
    assert!(e.message.contains("G98"), "{e}");
}

#[test]
fn feed_along_the_axis_is_unknown_when_other_travel_is() {
    // X position unknown before the block: its travel is unknown
    let r = parse("G90 G1 X10. Z5. F100\nX20. Z15.\nG91 A10. Z1.\nG90 Y3. Z2.\n").resolve(0.0);
    assert_eq!(r[0].feed_mm_min, None);
    // now X is known: 10 → 20 with Z 5 → 15
    assert!((r[1].feed_mm_min.unwrap() - 100.0 / 2f64.sqrt()).abs() < 1e-9);
    // a rotary axis in the block
    assert_eq!(r[2].feed_mm_min, None);
    // Y unknown
    assert_eq!(r[3].feed_mm_min, None);
    // the axis's own start is unknown in G90 until its first absolute target
    let r = parse("G90 G1 X0. Y0. F100\nX3. Z4.\nZ1.\nX0. Z5.\n").resolve(0.0);
    assert_eq!(r[1].feed_mm_min, None);
    assert_eq!(r[2].feed_mm_min, Some(100.0));
    assert!((r[3].feed_mm_min.unwrap() - 100.0 * 4.0 / 5.0).abs() < 1e-9);
    // increments are known whatever the start
    let r = parse("G91 G1 X3. Z4. F100\n").resolve(0.0);
    assert!((r[0].feed_mm_min.unwrap() - 80.0).abs() < 1e-9);
    // SINUMERIK DIAMON: X is a diameter
    let r = parse("G90 G1 X0 Y0 Z0 F100\nDIAMON\nG1 X3 Z4\nDIAMOF\nX0 Z8\n").resolve(0.0);
    assert_eq!(r[1].feed_mm_min, None);
    assert!((r[2].feed_mm_min.unwrap() - 80.0).abs() < 1e-9);
}

/// Every refusal names its 1-based line.
#[test]
fn errors_name_the_line_and_the_reason() {
    let cases: &[(&str, usize, &str)] = &[
        ("G1 Z10. F100\nWHILE [#1 LT 3] DO1\n", 2, "loops"),
        ("G1 Z10. F100\nWHILE R1<3\n", 2, "loops"),
        ("G1 Z10. F100\nN20 GOTOF LABEL\n", 2, "jumps"),
        ("G1 Z10. F100\nREPEAT LBL1 P=3\n", 2, "loops"),
        ("G1 Z10. F100\nM98 P1000\n", 2, "subprogram"),
        ("G1 Z10. F100\nCALL \"SUB\"\n", 2, "subprogram"),
        ("G1 Z10. F100\nL100\n", 2, "subprogram"),
        ("G1 Z10. F100\nCYCLE81(10,0,2,-5)\n", 2, "cycle"),
        ("G1 Z10. F100\nR1=5\n", 2, "assignment"),
        ("G1 Z10. F100\nG1 Z=R1\n", 2, "expressions"),
        ("G1 Z10. F100\nG1 Z#100\n", 2, "macro variables"),
        ("G1 Z10. F100\nG1 Z[1.+2.]\n", 2, "arithmetic"),
        (
            "G18\nG1 Z10. F100\nG2 X10. Z20. R5.\n",
            3,
            "contains the axis Z",
        ),
        ("G17\nG1 Z10. F100\nG2 X10. Y0 Z20. R5.\n", 3, "helix"),
        ("G1 Z10. F100\nG2 X10. Y0 R5.\n", 2, "without a plane"),
        ("G1 Z10. F100\nG28 U0 W0\n", 2, "reference"),
        ("G1 Z10. F100\nG81 Z-5. R1. F100\n", 2, "canned cycles"),
        ("G1 Z10. F100\nG41 X5.\n", 2, "compensation"),
        ("G1 Z10. F100\nG95 G1 Z5. F0.1\n", 2, "per revolution"),
        ("G1 Z10. F100\nG99\n", 2, "per revolution"),
        ("G1 Z10. F100\nG93\n", 2, "inverse-time"),
        ("G1 Z10. F100\nG123\n", 2, "not a code"),
        ("G1 Z10. F100\nG60 G0 Z5.\n", 2, "single-direction"),
        ("G1 Z10. F100\nG92 Z0\n", 2, "coordinate system"),
        ("G1 Z10. F100\nM00\n", 2, "operator"),
        ("G1 Z10. F100\nT0202\n", 2, "after the first move"),
        ("G1 Z10. F100\nG55\n", 2, "after the first move"),
        ("G21\nG1 Z10. F100\n/G1 Z5.\n", 3, "block skip"),
        ("G21\nG1 Z10 F100\n", 2, "decimal point"),
        ("G21\nG1 Z10. F100\nG04 X2\n", 3, "decimal point"),
        ("G21\nG1 Z10. F100\nG04 P1.5\n", 3, "whole milliseconds"),
        ("G21\nG1 Z10. F100\nG04\n", 3, "without a time"),
        ("G1 Z10. F100\nG04 Z2.\n", 2, "P (ms) or X/U"),
        ("G21\nG1 Z10. F100\nG04 F2.\n", 3, "mixes"),
        ("G71\nG1 Z10 F100\nG4 S10\n", 3, "spindle revolutions"),
        ("G71\nG1 Z10 F100\nG4 F1 Z3\n", 3, "block of its own"),
        ("G1 Z10.\n", 1, "no F programmed"),
        ("G21\nZ10.\n", 2, "motion code"),
        ("G1 Z10. F0\n", 1, "greater than 0"),
        ("G1 Z10. F-5.\n", 1, "greater than 0"),
        ("G1 Z10. F2000000.\n", 1, "at most"),
        ("G1 Z200000. F100\n", 1, "beyond"),
        ("G20\nG1 Z4000. F100\n", 2, "beyond"),
        ("G91 G1 Z90000. F100\nZ90000.\nZ90000.\n", 3, "add up"),
        ("G4 P2000000000\n", 1, "dwell of"),
        ("G71\nG4 F2000000\n", 2, "dwell of"),
        ("G1 Z10. F100\nN1.5 Z3.\n", 2, "whole number"),
        ("G1 Z10. F100\nN1 N2 Z3.\n", 2, "two block numbers"),
        ("G1 Z10. F100\nZ1. Z2.\n", 2, "twice"),
        ("G1 Z10. F100\nG0 G1 Z2.\n", 2, "two motion"),
        ("G1 Z10. F100\nG4 G1 P10\n", 2, "dwell"),
        ("G1 Z10. F100\nZ1. E2.\n", 2, "thread"),
        ("G1 Z10. F100\nZ1. Q2.\n", 2, "Q outside"),
        ("G1 Z10. F100\nZ1. I2.\n", 2, "outside an arc"),
        ("G1 Z10. F100\nZ1. (OPEN\n", 2, "closing"),
        ("G1 Z10. F100\nZ1.\u{0}\n", 2, "control character"),
        ("O1\nG1 Z10. F100\nZ=IC(1.)\nM30\n", 3, "mixes"),
        ("%\nG1 Z10. F100\n; siemens comment\n", 3, "mixes"),
        ("G71\nG1 Z10 F100\nTRANS Z5\n", 3, "frames"),
        ("G71\nG1 Z10 F100\nFOO\n", 3, "not a word"),
        ("O1\nG21\nG1 Z1. F1.\nO2\n", 4, "second program number"),
        ("O1 G21\n", 1, "alone"),
        ("G1 Z10. F100\nG65 P9000\n", 2, "macro calls"),
        ("G1 Z10. F100\nG1 Z1. H2\n", 2, "H outside"),
        ("G1 Z10. F100\nM99 P10\n", 2, "P outside"),
        ("G1 Z10. F100\nG50 Z0\n", 2, "coordinate system"),
    ];
    for &(text, line, part) in cases {
        let e = err(text);
        assert_eq!(e.line, line, "{text:?}: {e}");
        assert!(
            e.message.contains(part),
            "{text:?}: expected `{part}` in: {e}"
        );
        assert_eq!(
            e.to_string(),
            format!("program: line {line}: {}", e.message)
        );
    }
    // lathe option: U and X both address X
    let e = NcProgram::parse("G98\nG1 X1. U2. F100\n", &lathe()).unwrap_err();
    assert!(e.message.contains("two words for axis X"), "{e}");
    // a long line
    let long = format!("G1 Z1. F100\n({})\n", "A".repeat(5000));
    let e = err(&long);
    assert_eq!(e.line, 2);
    assert!(e.message.contains("4096"), "{e}");
    // bad options are line 0
    for opts in [
        ParseOptions {
            axis_letter: 'F',
            ..ParseOptions::default()
        },
        ParseOptions {
            axis_letter: 'z',
            ..ParseOptions::default()
        },
        ParseOptions {
            axis_letter: 'A',
            lathe_incremental_addresses: true,
        },
    ] {
        let e = NcProgram::parse("G1 Z1. F1\n", &opts).unwrap_err();
        assert_eq!(e.line, 0);
        assert!(e.message.contains("axis_letter"), "{e}");
    }
}

#[test]
fn text_after_the_end_is_not_read() {
    // a subprogram after M30 (never called) with unsupported syntax
    let p = parse("%\nO1\nG21 G1 Z1. F100\nM30\nO2\nWHILE [#1 LT 2] DO1\nM99\n%\n");
    assert_eq!(p.steps.len(), 1);
    // the second % ends a FANUC tape
    let p = parse("%\nG21 G1 Z1. F100\n%\nG1 Z2.\n");
    assert_eq!(p.steps.len(), 1);
    // a program without an end ends with its text; blank and comment lines are fine
    let p = parse("\n(ONLY)\nG21 G1 Z1. F100\n\n");
    assert_eq!(p.steps.len(), 1);
    assert!(parse("").steps.is_empty());
}

#[test]
fn serde_shape_is_snake_case() {
    let p = parse("G21 G0 Z1.\nG1 Z2. F100\nG4 P10\n");
    let json = serde_json::to_string(&p).unwrap();
    assert!(
        json.contains("\"move\"") && json.contains("\"absolute\""),
        "{json}"
    );
    assert!(json.contains("\"dialect\":\"fanuc\""), "{json}");
    let back: NcProgram = serde_json::from_str(&json).unwrap();
    assert_eq!(back, p);
    let r = serde_json::to_string(&p.resolve(0.0)).unwrap();
    assert!(
        r.contains("\"kind\":\"rapid\"") && r.contains("\"kind\":\"dwell\""),
        "{r}"
    );
}

/// A valid program to mutate: both dialects' syntax in separate programs.
const FANUC_SEED: &str = "%\nO1000 (T)\nG21 G98 G61\nN10 G00 Z5.\nN20 G01 Z105.5 F600\n\
                          N30 G04 P1500\nG91 G01 Z-10. F60.\nG04 X0.5\nM30\n%\n";
const SIEMENS_SEED: &str = "; T\nG71 G90 G94 G60\nN10 G0 Z5\nN20 G1 Z=IC(10.5) F600\n\
                            G4 F1.5\nZ=AC(0)\nM30\n";

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(512))]

    /// Any bytes: an error or a program, never a panic; what reads resolves to finite
    /// positions within the limits.
    #[test]
    fn random_bytes_never_panic(bytes in proptest::collection::vec(proptest::num::u8::ANY, 0..400)) {
        if let Ok(p) = NcProgram::parse_bytes(&bytes, "fuzz", &ParseOptions::default()) {
            for s in p.resolve(0.0) {
                proptest::prop_assert!(s.to_mm.is_finite() && s.dwell_s.is_finite());
            }
        }
    }

    /// Programs near valid ones (characters replaced, inserted, deleted): never a panic, and
    /// an error always names a line of the text.
    #[test]
    fn mutated_programs_never_panic(
        siemens in proptest::bool::ANY,
        lathe in proptest::bool::ANY,
        edits in proptest::collection::vec((0usize..200, 0u8..3, proptest::sample::select(
            b"GZXUWFPN.-+=()%;#[]/ 0123456789\nMACI\r\t\xe2".to_vec())), 1..6),
    ) {
        let mut b = if siemens { SIEMENS_SEED } else { FANUC_SEED }.as_bytes().to_vec();
        for (pos, op, ch) in edits {
            let at = pos % (b.len() + 1);
            match op {
                0 if at < b.len() => b[at] = ch,
                1 => b.insert(at, ch),
                _ if at < b.len() => { b.remove(at); }
                _ => {}
            }
        }
        let opts = ParseOptions { lathe_incremental_addresses: lathe, ..ParseOptions::default() };
        match NcProgram::parse_bytes(&b, "fuzz", &opts) {
            Ok(p) => {
                for s in p.resolve(1.0) {
                    proptest::prop_assert!(s.to_mm.abs() <= 3e5);
                    proptest::prop_assert!(s.feed_mm_min.is_none_or(|f| (0.0..=1e6).contains(&f)));
                    proptest::prop_assert!((0.0..=1e6).contains(&s.dwell_s));
                }
            }
            Err(e) => {
                let lines = b.split(|&c| c == b'\n').count();
                proptest::prop_assert!(e.line >= 1 && e.line <= lines, "{e}");
            }
        }
    }
}
