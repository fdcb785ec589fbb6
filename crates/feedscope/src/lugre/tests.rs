//! LuGre against its closed forms (steady state, pre-sliding spring), stability at σ0 = 1e8
//! with large steps against a fine-step reference, and σ0 identification from a simulated
//! reversal.
use super::*;
use crate::units::feed_mm_min_to_m_s;
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

/// Parameters unlike any paper's: F_c 150 N, F_s 210 N, v_s 20 mm/min, σ2 3000 N·s/m.
fn params(sigma0: f64) -> LuGreParams {
    LuGreParams {
        stribeck: StribeckParams {
            fc_n: 150.0,
            fs_n: 210.0,
            vs_m_s: feed_mm_min_to_m_s(20.0),
            sigma_n_s_per_m: 3000.0,
            delta: 2.0,
        },
        sigma0_n_per_m: sigma0,
        sigma1_n_s_per_m: 2.0 * (sigma0 * 300.0f64).sqrt(), // critical-ish for 300 kg
    }
}

fn uniform_time(n: usize, h: f64) -> Vec<f64> {
    (0..n).map(|k| k as f64 * h).collect()
}

#[test]
fn steady_state_matches_g_plus_viscous() {
    let m = LuGre::new(params(3e7)).unwrap();
    for &v in &[1e-5, -1e-5, 3.3e-4, -7e-4, 0.01, -0.05] {
        // run 200 time constants g/(σ0|v|)
        let tau = 210.0 / (3e7 * f64::abs(v));
        let t = uniform_time(2001, tau / 10.0);
        let r = m.simulate(&t, &vec![v; t.len()], 0.0).unwrap();
        let want = m.params().g_n(v) * v.signum() + 3000.0 * v;
        let got = *r.friction_n.last().unwrap();
        // exact step for constant v: only rounding remains (1e-12 relative of ~200 N)
        assert!((got - want).abs() < 1e-9, "v {v}: {got} vs {want}");
        assert!((want - m.params().steady_state_force_n(v)).abs() < 1e-12);
        let z_ss = m.params().steady_state_z_m(v);
        assert!((r.z_m.last().unwrap() - z_ss).abs() < 1e-12 * z_ss.abs().max(1e-12));
        // the Stribeck curve of the static part, signed
        assert!((want - m.params().stribeck.force_n(v)).abs() < 1e-9);
    }
}

/// σ0 = 1e8 N/m with 5 ms steps (up to σ0|v|h/g ≈ 24 at 10 mm/s, where explicit Euler
/// diverges beyond 2) over a sinusoidal velocity with reversals: finite, |z| ≤ F_s/σ0, and
/// within 1 % of F_s of a 1 µs-step reference at the shared samples.
#[test]
fn stiff_sigma0_is_stable_with_large_steps() {
    let m = LuGre::new(params(1e8)).unwrap();
    let v = |t: f64| 0.01 * (2.0 * std::f64::consts::PI * 0.5 * t).sin();
    let coarse_t = uniform_time(801, 5e-3); // 4 s, two periods
    let coarse = m
        .simulate(
            &coarse_t,
            &coarse_t.iter().map(|&t| v(t)).collect::<Vec<_>>(),
            0.0,
        )
        .unwrap();
    let fine_t = uniform_time(4_000_001, 1e-6);
    let fine_v: Vec<f64> = fine_t.iter().map(|&t| v(t)).collect();
    let fine = m.simulate(&fine_t, &fine_v, 0.0).unwrap();
    for (k, (&f, &z)) in coarse.friction_n.iter().zip(&coarse.z_m).enumerate() {
        assert!(
            f.is_finite() && z.abs() <= 210.0 / 1e8 * (1.0 + 1e-12),
            "{k}: {z}"
        );
        let fref = fine.friction_n[k * 5000];
        assert!((f - fref).abs() < 0.01 * 210.0, "sample {k}: {f} vs {fref}");
    }
    // explicit Euler at this step leaves the physical range at once
    let (mut z, h, vv) = (0.0, 5e-3, 0.01);
    for _ in 0..5 {
        z += h * m.params().z_rate_m_s(z, vv);
    }
    assert!(
        z.abs() > 1e3 * 210.0 / 1e8,
        "Euler unexpectedly stable: {z}"
    );
}

/// From rest, a displacement x ≪ x_c = g/σ0 gives F ≈ σ0·x (+ (σ1 + σ2)·v). At constant v
/// (g constant) the closed form is z = x_c·(1 − e^{−x/x_c}), F = σ0·z + σ1·v·(1 − z/x_c) + σ2·v;
/// the simulation matches it to rounding, and the slope between x = 1e-4·x_c and 1e-3·x_c is
/// σ0 up to the curvature (x/x_c ≈ 5.5e-4) and the damping term's decay (σ1·v/(σ0·x_c)).
#[test]
fn presliding_slope_is_sigma0() {
    for sigma0 in [1e6, 3e7, 1e8] {
        let m = LuGre::new(params(sigma0)).unwrap();
        let prm = m.params();
        let v = 1e-6;
        let g = prm.g_n(v);
        let xc = g / sigma0;
        // travel 1e-3·x_c in 1000 steps
        let h = 1e-3 * xc / v / 1000.0;
        let t = uniform_time(1001, h);
        let r = m.simulate(&t, &vec![v; 1001], 0.0).unwrap();
        for k in [100, 1000] {
            let x = r.displacement_m[k];
            let z = xc * (1.0 - (-x / xc).exp());
            let f = sigma0 * z + prm.sigma1_n_s_per_m * v * (1.0 - z / xc) + 3000.0 * v;
            assert!(
                (r.friction_n[k] - f).abs() < 1e-9 * f.abs().max(1e-3),
                "{k}"
            );
        }
        let (x1, x2) = (r.displacement_m[100], r.displacement_m[1000]);
        let slope = (r.friction_n[1000] - r.friction_n[100]) / (x2 - x1);
        let bound = (x1 + x2) / (2.0 * xc) + prm.sigma1_n_s_per_m * v / (sigma0 * xc);
        assert!(
            (slope / sigma0 - 1.0).abs() < 1.1 * bound && bound < 3e-3,
            "σ0 {sigma0}: slope {slope}, bound {bound}"
        );
    }
}

/// A slow reversal (−1 → +1 mm/min through a 0.2 s ramp) simulated at σ0 = 2.7e7 N/m, 1 kHz;
/// friction against the travel since the zero crossing recovers σ0 within 10 % with 0.2 N of
/// noise, with g fitted or given, and the standard error covers the error.
#[test]
fn identification_recovers_sigma0_from_a_reversal() {
    let sigma0 = 2.7e7;
    let m = LuGre::new(params(sigma0)).unwrap();
    let v0 = feed_mm_min_to_m_s(1.0);
    let t = uniform_time(8001, 1e-3);
    let vel: Vec<f64> = t
        .iter()
        .map(|&t| v0 * ((t - 1.0) / 0.1).clamp(-1.0, 1.0))
        .collect();
    let z0 = m.params().steady_state_z_m(-v0);
    let r = m.simulate(&t, &vel, z0).unwrap();
    // reversal at t = 1 s (sample 1000)
    let k0 = 1000;
    let x: Vec<f64> = r.displacement_m[k0..]
        .iter()
        .map(|x| x - r.displacement_m[k0])
        .collect();
    let mut rng = rand::rngs::StdRng::seed_from_u64(9);
    let noise = Normal::new(0.0, 0.2).unwrap();
    let f: Vec<f64> = r.friction_n[k0..]
        .iter()
        .map(|f| f + noise.sample(&mut rng))
        .collect();
    let fit = identify_presliding(&x, &f, &PreSlidingParams::default()).unwrap();
    let err = fit.sigma0_n_per_m / sigma0 - 1.0;
    eprintln!(
        "σ0 {:.4e} ({:+.2} %), SE {:?}, g {:.2} N, F0 {:.2} N, x_c {:.3} µm",
        fit.sigma0_n_per_m,
        100.0 * err,
        fit.sigma0_std_error_n_per_m,
        fit.level_n,
        fit.start_force_n,
        fit.presliding_length_m * 1e6
    );
    assert!(err.abs() < 0.10, "{fit:?}");
    let se = fit.sigma0_std_error_n_per_m.unwrap();
    assert!(
        (fit.sigma0_n_per_m - sigma0).abs() < 3.0 * se + 0.02 * sigma0,
        "{se}"
    );
    // g ≈ g(v0) = 209.85 N, F0 ≈ −g
    assert!((fit.level_n - m.params().g_n(v0)).abs() < 2.0);
    // with g known from the Stribeck fit
    let known = PreSlidingParams {
        level_n: Some(m.params().g_n(v0)),
    };
    let fit2 = identify_presliding(&x, &f, &known).unwrap();
    assert!(
        (fit2.sigma0_n_per_m / sigma0 - 1.0).abs() < 0.10,
        "{fit2:?}"
    );
}

#[test]
fn unidentifiable_data_say_so() {
    let sigma0 = 2.7e7;
    let p = params(sigma0);
    let g = p.g_n(0.0);
    let xc = g / sigma0;
    let curve = |x: f64| g - 2.0 * g * (-x / xc).exp();
    // travel only to 0.2·x_c: linear range
    let x: Vec<f64> = (0..50).map(|k| 0.2 * xc * k as f64 / 49.0).collect();
    let f: Vec<f64> = x.iter().map(|&x| curve(x)).collect();
    let e = identify_presliding(&x, &f, &PreSlidingParams::default()).unwrap_err();
    assert!(
        matches!(
            e,
            LuGreError::NotIdentifiable(NotIdentifiable::TooShort { .. })
        ),
        "{e}"
    );
    assert!(e.to_string().contains("not identifiable"), "{e}");
    // data start 5·x_c after the reversal: already sliding
    let x: Vec<f64> = (0..50).map(|k| xc * (5.0 + k as f64)).collect();
    let f: Vec<f64> = x.iter().map(|&x| curve(x)).collect();
    let e = identify_presliding(&x, &f, &PreSlidingParams::default()).unwrap_err();
    assert!(matches!(e, LuGreError::NotIdentifiable(_)), "{e}");
    // bad input
    assert!(matches!(
        identify_presliding(&[0.0, f64::NAN, 1.0, 2.0], &[0.0; 4], &Default::default()),
        Err(LuGreError::NonFinite { .. })
    ));
    assert!(matches!(
        identify_presliding(&[0.0, -1.0, 1.0, 2.0], &[0.0; 4], &Default::default()),
        Err(LuGreError::BadParameter { .. })
    ));
}

#[test]
fn bad_parameters_and_inputs_are_errors() {
    let mut p = params(1e7);
    p.stribeck.fc_n = 0.0;
    assert!(LuGre::new(p).is_err());
    let mut p = params(1e7);
    p.sigma0_n_per_m = f64::INFINITY;
    assert!(LuGre::new(p).is_err());
    let m = LuGre::new(params(1e7)).unwrap();
    assert!(matches!(
        m.simulate(&[0.0, 0.0], &[0.0, 0.0], 0.0),
        Err(LuGreError::TimeNotIncreasing { index: 1, .. })
    ));
    assert!(matches!(
        m.simulate(&[0.0, 1.0], &[0.0, f64::NAN], 0.0),
        Err(LuGreError::NonFinite { .. })
    ));
    assert!(matches!(
        m.simulate(&[0.0, 1.0], &[0.0], 0.0),
        Err(LuGreError::LengthMismatch { .. })
    ));
}
