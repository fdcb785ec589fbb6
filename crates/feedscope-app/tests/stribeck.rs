//! `fit-stribeck` through the application layer: a table file and the same table parsed give
//! one report, a known curve comes back, and settings are named in errors.
use feedscope::stribeck::DeltaMode;
use feedscope_app::stribeck::{fit_table, FitStribeckOptions, FitStribeckRequest};
use feedscope_app::{FrontEnd, Quiet};
use feedscope_io::stribeck_table;

/// F(v) = Fc + (Fs − Fc)·exp(−(v/vs)²) + σ·v at 14 feeds per direction, the backward curve
/// 10 % higher: a machine with a Coulomb level of 140 N, unlike the papers' drives.
fn table() -> String {
    let (fc, fs, vs_mm_min, sigma) = (140.0, 205.0, 45.0, 900.0);
    let mut text = String::from("feed_mm_min,force_n,direction\n");
    for k in 0..14 {
        let f = 5.0 * 1.6f64.powi(k);
        let v = f / 60_000.0;
        let force = fc + (fs - fc) * (-(f / vs_mm_min).powi(2)).exp() + sigma * v;
        text.push_str(&format!(
            "{f},{force},forward\n{f},{},backward\n",
            1.1 * force
        ));
    }
    text
}

#[test]
fn a_known_curve_comes_back_from_a_file_and_from_memory_alike() {
    let d = tempfile::tempdir().unwrap();
    let path = d.path().join("steady.csv");
    std::fs::write(&path, table()).unwrap();
    let request = FitStribeckRequest {
        table: path.clone(),
        ..FitStribeckRequest::default()
    };
    let from_file = request.run(&Quiet).unwrap();
    let options = FitStribeckOptions::default();
    let parsed = stribeck_table::parse(
        &table(),
        &path.display().to_string(),
        &options.table_options(None),
    )
    .unwrap();
    let in_memory =
        fit_table(&parsed, &path.display().to_string(), None, &options, &Quiet).unwrap();
    assert_eq!(from_file.report, in_memory.report);
    let [fwd, bwd] = &from_file.report.directions[..] else {
        panic!("two directions expected");
    };
    for (d, scale) in [(fwd, 1.0), (bwd, 1.1)] {
        let p = &d.params;
        let near = |got: Option<f64>, want: f64| {
            let got = got.unwrap();
            assert!(
                (got - want).abs() < 1e-3 * want.abs(),
                "{} {got} vs {want}",
                d.direction
            );
        };
        assert_eq!(d.model, "stribeck");
        near(Some(p.fc_n), 140.0 * scale);
        near(p.fs_n, 205.0 * scale);
        near(p.vs_mm_min, 45.0);
        near(p.sigma_n_s_per_m, 900.0 * scale);
    }
    assert_eq!(from_file.fits.len(), 2);
}

struct Flags;
impl FrontEnd for Flags {
    fn name(&self, field: &str) -> String {
        format!("--{}", field.replace('_', "-"))
    }
}

#[test]
fn settings_are_named_as_the_front_end_spells_them() {
    let bad_noise = FitStribeckOptions {
        noise_n: Some(-1.0),
        ..FitStribeckOptions::default()
    };
    let e = bad_noise.validate(&Flags).unwrap_err();
    assert_eq!(e.field(), Some("noise_n"));
    assert_eq!(e.to_string(), "--noise-n must be >= 0, got -1");
    let bad_delta = FitStribeckOptions {
        delta: DeltaMode::Fixed(0.0),
        ..FitStribeckOptions::default()
    };
    assert_eq!(
        bad_delta.validate(&Quiet).unwrap_err().field(),
        Some("delta")
    );
    let mut axis = feedscope::sim::SimConfig::default().axis;
    axis.lead_mm = 10.0;
    let lead = FitStribeckOptions {
        lead_mm: Some(12.0),
        ..FitStribeckOptions::default()
    };
    let e = lead.lead_mm(Some((&axis, "a.toml")), &Flags).unwrap_err();
    assert_eq!(e.field(), Some("lead_mm"));
    assert_eq!(
        e.to_string(),
        "--lead-mm 12 disagrees with lead_mm = 10 of a.toml"
    );
    assert_eq!(lead.lead_mm(None, &Flags).unwrap(), Some(12.0));
    // A request body: unknown keys refused, δ "free" or {"fixed": x}.
    let r: FitStribeckRequest =
        serde_json::from_str(r#"{"table": "t.csv", "delta": "free", "efficiency": 0.9}"#).unwrap();
    assert_eq!(r.options.delta, DeltaMode::Free);
    assert!(serde_json::from_str::<FitStribeckRequest>(r#"{"table": "t.csv", "eta": 1}"#).is_err());
}

/// The plain-text view: a row per direction under the header, and beside it the model, the
/// models refused with what to measure (δ free needing one feed more, spelled as the front
/// end spells it) and the warnings.
#[test]
fn the_text_view_and_its_remarks_say_the_model_and_what_to_measure() {
    let d = tempfile::tempdir().unwrap();
    let path = d.path().join("steady.csv");
    std::fs::write(&path, table()).unwrap();
    let known = FitStribeckRequest {
        table: path.clone(),
        ..FitStribeckRequest::default()
    }
    .run(&Quiet)
    .unwrap()
    .report;
    let text = known.to_string();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 3, "{text}");
    assert!(lines[0].starts_with("direction points") && lines[0].ends_with("rms (N)"));
    assert!(lines[1].starts_with("forward"), "{text}");
    assert!(lines[2].starts_with("backward"), "{text}");
    let remarks = known.remarks(&Quiet);
    assert!(remarks[0].starts_with("forward: model "), "{remarks:?}");
    assert!(remarks.iter().all(|r| !r.contains("for a Stribeck curve")));

    // Three feeds: too few for a Stribeck curve (4, or 5 with δ free).
    std::fs::write(
        &path,
        "feed_mm_min,force_n\n50,300\n200,310\n800,330\n-50,-300\n-200,-310\n-800,-330\n",
    )
    .unwrap();
    struct Spell;
    impl FrontEnd for Spell {
        fn spell(&self, field: &str, value: &str) -> String {
            format!("<{field}={value}>")
        }
    }
    for (delta, advice) in [
        (
            DeltaMode::Free,
            "  for a Stribeck curve, measure at least 4 distinct feeds per direction (5 with \
             <delta=free>), several of them below the expected Stribeck velocity",
        ),
        (
            DeltaMode::Fixed(2.0),
            "  for a Stribeck curve, measure at least 4 distinct feeds per direction, several \
             of them below the expected Stribeck velocity",
        ),
    ] {
        let report = FitStribeckRequest {
            table: path.clone(),
            options: FitStribeckOptions {
                delta,
                ..FitStribeckOptions::default()
            },
            ..FitStribeckRequest::default()
        }
        .run(&Spell)
        .unwrap()
        .report;
        assert_eq!(report.directions[0].model, "coulomb-viscous");
        let remarks = report.remarks(&Spell);
        assert_eq!(
            remarks[0],
            "forward: model Coulomb + viscous (F = Fc + sigma*v)"
        );
        assert!(remarks.iter().any(|r| r == advice), "{remarks:#?}");
    }
}
