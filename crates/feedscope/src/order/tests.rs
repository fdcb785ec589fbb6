use super::*;
use rand::{Rng, SeedableRng};
use std::f64::consts::PI;

fn dft_amplitude(x: &[f64], w: &[f64]) -> Vec<f64> {
    let n = x.len();
    let sw: f64 = w.iter().sum();
    (0..=n / 2)
        .map(|k| {
            let (mut re, mut im) = (0.0, 0.0);
            for (i, (v, wi)) in x.iter().zip(w).enumerate() {
                let ph = -2.0 * PI * (k * i % n) as f64 / n as f64;
                re += v * wi * ph.cos();
                im += v * wi * ph.sin();
            }
            let edge = k == 0 || (n.is_multiple_of(2) && k == n / 2);
            (re.hypot(im)) * if edge { 1.0 } else { 2.0 } / sw
        })
        .collect()
}

#[test]
fn fft_amplitude_matches_direct_dft() {
    let mut rng = rand::rngs::StdRng::seed_from_u64(42);
    let mut an = SpectrumAnalyzer::new();
    for n in [17usize, 64, 257, 1000] {
        let x: Vec<f64> = (0..n).map(|_| rng.random_range(-5.0..5.0)).collect();
        for win in [Window::Hann, Window::Rectangular] {
            let mut amp = Vec::new();
            an.amplitude_spectrum(&x, win, &mut amp).unwrap();
            let want = dft_amplitude(&x, &win.coefficients(n));
            assert_eq!(amp.len(), want.len());
            for (a, b) in amp.iter().zip(&want) {
                // Direct DFT rounding grows ~ n·eps·Σ|x|.
                assert!((a - b).abs() < 1e-10, "n {n} {win:?}: {a} vs {b}");
            }
        }
    }
}

#[test]
fn parseval_holds_for_the_single_sided_amplitudes() {
    let mut rng = rand::rngs::StdRng::seed_from_u64(7);
    let mut an = SpectrumAnalyzer::new();
    for n in [100usize, 101] {
        let x: Vec<f64> = (0..n).map(|_| rng.random_range(-3.0..3.0)).collect();
        let mut amp = Vec::new();
        an.amplitude_spectrum(&x, Window::Rectangular, &mut amp)
            .unwrap();
        // mean(x²) = A_0² + Σ A_k²/2 + A_{N/2}² (N even).
        let last = amp.len() - 1;
        let mut s = amp[0] * amp[0];
        for (k, a) in amp.iter().enumerate().skip(1) {
            s += if n % 2 == 0 && k == last {
                a * a
            } else {
                0.5 * a * a
            };
        }
        let ms = x.iter().map(|v| v * v).sum::<f64>() / n as f64;
        assert!((s - ms).abs() < 1e-12 * ms, "n {n}: {s} vs {ms}");
        // Hann: the same identity for the windowed signal, scaled by (Σw/N)².
        an.amplitude_spectrum(&x, Window::Hann, &mut amp).unwrap();
        let w = Window::Hann.coefficients(n);
        let g = w.iter().sum::<f64>() / n as f64;
        let mut s = amp[0] * amp[0];
        for (k, a) in amp.iter().enumerate().skip(1) {
            s += if n % 2 == 0 && k == last {
                a * a
            } else {
                0.5 * a * a
            };
        }
        let ms = x
            .iter()
            .zip(&w)
            .map(|(v, wi)| (v * wi).powi(2))
            .sum::<f64>()
            / n as f64;
        assert!((s * g * g - ms).abs() < 1e-12 * ms, "hann n {n}");
    }
}

#[test]
fn on_bin_sinusoid_reads_its_amplitude_exactly() {
    let n = 4096;
    let mut an = SpectrumAnalyzer::new();
    for (k, a, ph) in [(37usize, 7.5, 0.3), (400, 2.0, 2.0), (3, 11.0, -1.0)] {
        let x: Vec<f64> = (0..n)
            .map(|i| a * (2.0 * PI * (k * i) as f64 / n as f64 + ph).cos())
            .collect();
        let mut amp = Vec::new();
        let corr = an.amplitude_spectrum(&x, Window::Hann, &mut amp).unwrap();
        assert!((corr - 2.0 / (0.5 * n as f64)).abs() < 1e-15);
        // Periodic Hann, coherent gain ½: exact up to rounding.
        assert!((amp[k] - a).abs() < 1e-10 * a, "{} vs {a}", amp[k]);
        // Leakage only into the two neighbours (a/2 each), nothing beyond.
        assert!((amp[k + 1] - 0.5 * a).abs() < 1e-10 * a);
        assert!(amp[k + 3] < 1e-10 * a);
    }
}

#[test]
fn off_bin_peak_refinement_is_accurate() {
    // 40 leads at 256 samples per lead; tones off-bin by up to ½ bin.
    let du = 1.0 / 256.0;
    let n = 40 * 256;
    let mut an = SpectrumAnalyzer::new();
    for (f, a) in [
        (0.6137, 4.0),
        (8.6, 10.0),
        (9.5123, 3.0),
        (19.0, 5.0),
        (2.0125, 6.0),
    ] {
        let x: Vec<f64> = (0..n)
            .map(|i| a * (2.0 * PI * f * i as f64 * du + 0.7).cos())
            .collect();
        let mut amp = Vec::new();
        an.amplitude_spectrum(&x, Window::Hann, &mut amp).unwrap();
        let p = find_peaks(&an, Window::Hann, &x, &amp, du, &PeakParams::default());
        assert_eq!(p.len(), 1, "{f}: {p:?}");
        // Grandke's interpolation is exact for one tone; the negative-frequency image
        // biases it slightly at low orders.
        assert!((p[0].order - f).abs() < 2e-4, "{f}: {}", p[0].order);
        assert!(
            (p[0].amplitude_n - a).abs() < 1e-3 * a,
            "{f}: {}",
            p[0].amplitude_n
        );
    }
}

#[test]
fn segment_bounds_follow_the_paper_layout() {
    let b = segment_bounds(&[0.0, 85.0, 150.0, 410.0], 10.0, &SegmentSpec::default()).unwrap();
    let counts: Vec<usize> = [(0.0, 85.0), (85.0, 150.0), (150.0, 410.0)]
        .iter()
        .map(|(a, c)| b.iter().filter(|s| s.0 >= *a && s.1 <= *c).count())
        .collect();
    assert_eq!(counts, vec![2, 2, 5]);
    let b = segment_bounds(&[0.0, 400.0], 10.0, &SegmentSpec::Count { count: 4 }).unwrap();
    assert_eq!(b.len(), 4);
    assert!((b[3].0 - 300.0).abs() < 1e-12);
    assert!(segment_bounds(&[0.0, 400.0], 10.0, &SegmentSpec::Count { count: 0 }).is_err());
    assert!(segment_bounds(
        &[0.0, 400.0],
        10.0,
        &SegmentSpec::LengthMm {
            length_mm: f64::NAN
        }
    )
    .is_err());
}

#[test]
fn classification_uses_resolution_or_relative_tolerance() {
    let k = vec![
        KinematicOrder {
            order: 1.0,
            cause: "shaft 1x".parse().unwrap(),
        },
        KinematicOrder {
            order: 8.6,
            cause: "nut ball refeed 1x".parse().unwrap(),
        },
        KinematicOrder {
            order: 9.5,
            cause: "guide ball refeed 1x".parse().unwrap(),
        },
    ];
    assert_eq!(
        classify(1.02, 0.025, 0.03, &k).unwrap().cause.to_string(),
        "shaft 1x"
    );
    assert!(classify(1.05, 0.025, 0.03, &k).is_none());
    assert!(classify(1.2, 0.25, 0.03, &k).is_some()); // coarse segment resolution
    assert_eq!(
        classify(8.8, 0.025, 0.03, &k).unwrap().cause.to_string(),
        "nut ball refeed 1x"
    );
    assert_eq!(
        classify(9.3, 0.025, 0.03, &k).unwrap().cause.to_string(),
        "guide ball refeed 1x"
    );
    assert!(classify(9.05, 0.025, 0.03, &k).is_none());
}

#[test]
fn spectrum_rejects_bad_samples() {
    let mut an = SpectrumAnalyzer::new();
    let mut amp = Vec::new();
    assert!(matches!(
        an.amplitude_spectrum(&[1.0, 2.0], Window::Hann, &mut amp),
        Err(OrderError::TooFewSamples { .. })
    ));
    assert!(matches!(
        an.amplitude_spectrum(&[1.0, 2.0, f64::INFINITY, 0.0], Window::Hann, &mut amp),
        Err(OrderError::NonFinite { index: 2 })
    ));
}
