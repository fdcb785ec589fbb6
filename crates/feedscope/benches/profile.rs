//! Full issue-3 analysis of one 400 mm stroke on the grid lead/1024 (40 961 samples at a 10 mm
//! lead; also 81 921 samples at a 5 mm lead): order scan, automatic breakpoints, C¹ piecewise fit with joint sinusoids, FFS,
//! whole-stroke and segment spectra, peaks and classification.
//!
//! Run: `cargo bench -p feedscope --bench profile`

use std::f64::consts::PI;

use criterion::{criterion_group, criterion_main, Criterion};
use feedscope::axis::{AxisParams, ConfigFormat, DeclaredOrder};
use feedscope::order::SpectrumAnalyzer;
use feedscope::profile::{analyze_stroke, AnalysisParams, Direction, StrokeView};

fn axis(lead_mm: f64) -> AxisParams {
    let text = format!(
        "lead_mm = {lead_mm}\ntable_mass_kg = 425\ninertia_kgm2 = 0.004\n\
         damping_nms_per_rad = 0.002\ntorque_constant_nm_per_a = 1.82\n\
         screw_diameter_mm = 40\nscrew_ball_diameter_mm = 5.6\ncontact_angle_deg = 0\n\
         screw_balls_per_turn = 20\nguide_balls_per_raceway = 19\n"
    );
    let mut a = AxisParams::parse(&text, ConfigFormat::Toml, "bench").expect("axis");
    a.declared_orders.push(DeclaredOrder {
        order: 0.6,
        cause: "rolling-tool mark".into(),
    });
    a
}

/// Mean profile + 9 tones + deterministic pseudo-noise (an LCG, no RNG dependency here).
fn stroke_data(lead_mm: f64) -> (Vec<f64>, Vec<f64>) {
    let tones = [
        (0.6, 4.0, 0.3),
        (1.0, 8.0, 1.1),
        (2.0, 6.0, 2.0),
        (3.0, 3.0, 0.5),
        (4.0, 2.0, 4.0),
        (8.6, 10.0, 1.7),
        (17.2, 4.0, 5.1),
        (9.5, 12.0, 2.9),
        (19.0, 5.0, 0.1),
    ];
    let n = (400.0 / lead_mm * 1024.0) as usize + 1;
    let mut state = 12345u64;
    let mut x = Vec::with_capacity(n);
    let mut y = Vec::with_capacity(n);
    for i in 0..n {
        let p = i as f64 * lead_mm / 1024.0;
        let mut f = 60.0 + 0.05 * p + 15.0 * (-0.5 * ((p - 120.0) / 25.0).powi(2)).exp();
        for (o, a, ph) in tones {
            f += a * (2.0 * PI * o * p / lead_mm + ph).cos();
        }
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        f += ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 10.0;
        x.push(p * 1e-3);
        y.push(f);
    }
    (x, y)
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("profile");
    g.sample_size(20)
        .warm_up_time(std::time::Duration::from_secs(1))
        .measurement_time(std::time::Duration::from_secs(4));
    let params = AnalysisParams::default();
    let mut analyzer = SpectrumAnalyzer::new();
    for lead_mm in [10.0, 5.0] {
        let (x, y) = stroke_data(lead_mm);
        let ax = axis(lead_mm);
        let stroke = StrokeView {
            direction: Direction::Forward,
            position_m: &x,
            friction_n: &y,
            lead_m: lead_mm * 1e-3,
            max_trusted_order: 60.0,
            feed_mm_min: Some(200.0),
        };
        let name = format!("analyze_stroke_400mm_lead{lead_mm}_m1024_n{}", x.len());
        g.bench_function(&name, |b| {
            b.iter(|| analyze_stroke(&stroke, &ax, &params, &mut analyzer).expect("analysis"))
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
