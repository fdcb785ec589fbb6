//! One-test identification (paper 002) on the twin, repeated over seeds like weekly tests:
//! the joint fit's J is within 1 % and scatters as its reported standard error says.
//!
//! Measured figures are printed (`cargo test --release -p feedscope --test roundtrip --
//! ident --nocapture`) and quoted in docs/identification.md.
use std::f64::consts::PI;

use feedscope::ident::{identify, IdentParams, Identification};
use feedscope::plan::{triangle_program, Limits, TestProgram, TriangleParams};
use feedscope::sim::{
    simulate_profile, Component, ComponentDirection, DynamicsMode, FrictionParams, MeanLevel,
    SamplingMode, SimConfig, VelocityTerm,
};
use feedscope::trace::EffortKind;
use rayon::prelude::*;

/// One machine of the twin: mechanics, friction, the test and the sampling.
struct Machine {
    name: &'static str,
    lead_mm: f64,
    table_mass_kg: f64,
    motor_inertia_kgm2: f64,
    damping_nms_per_rad: f64,
    fc_n: f64,
    fs_n: f64,
    vs_mm_min: f64,
    sigma_n_s_per_m: f64,
    rate_hz: f64,
    quantum_mm: f64,
    torque_noise_nm: f64,
    triangle: TriangleParams,
}

/// Paper 002's test (Section 3.2): lead 16 mm, 0.12 m of travel, 8 feeds up to 10 m/min,
/// position and torque sampled together at 83.33 Hz; 1 µm position quantum, torque noise
/// 0.025 N·m. The mass and friction are ours (the paper gives F_s = F_c = 4.45 N·m).
fn paper_002() -> Machine {
    Machine {
        name: "paper 002 motion, 83.33 Hz",
        lead_mm: 16.0,
        table_mass_kg: 400.0,
        motor_inertia_kgm2: 0.003,
        damping_nms_per_rad: 0.002,
        fc_n: 1200.0,
        fs_n: 1500.0,
        vs_mm_min: 60.0,
        sigma_n_s_per_m: 4000.0,
        rate_hz: 83.33,
        quantum_mm: 1e-3,
        torque_noise_nm: 0.025,
        triangle: TriangleParams {
            window_min_mm: 20.0,
            window_max_mm: 140.0,
            feed_max_mm_min: 10_000.0,
            levels: 8,
            min_cruise_s: 1.0,
            vs_guess_mm_min: 60.0,
            ..TriangleParams::default()
        },
    }
}

/// A machine unlike the paper's: lead 5 mm, 120 kg, a light motor, 250 Hz sampling, 0.5 µm
/// quantum, 0.01 N·m torque noise, feeds up to 4 m/min at 600 mm/s².
fn small_mill() -> Machine {
    Machine {
        name: "lead 5 mm, 120 kg, 250 Hz",
        lead_mm: 5.0,
        table_mass_kg: 120.0,
        motor_inertia_kgm2: 0.0008,
        damping_nms_per_rad: 0.0005,
        fc_n: 300.0,
        fs_n: 420.0,
        vs_mm_min: 30.0,
        sigma_n_s_per_m: 1500.0,
        rate_hz: 250.0,
        quantum_mm: 5e-4,
        torque_noise_nm: 0.01,
        triangle: TriangleParams {
            window_min_mm: 10.0,
            window_max_mm: 90.0,
            feed_max_mm_min: 4000.0,
            levels: 7,
            min_cruise_s: 1.0,
            vs_guess_mm_min: 30.0,
            accel_mm_s2: 600.0,
            ..TriangleParams::default()
        },
    }
}

impl Machine {
    fn config(&self, seed: u64) -> SimConfig {
        let mut c = SimConfig {
            seed,
            ..SimConfig::default()
        };
        c.axis.lead_mm = self.lead_mm;
        c.axis.table_mass_kg = self.table_mass_kg;
        c.axis.inertia_kgm2 = self.motor_inertia_kgm2;
        c.axis.damping_nms_per_rad = self.damping_nms_per_rad;
        c.axis.travel_min_mm = Some(0.0);
        c.axis.travel_max_mm = Some(450.0);
        let level = MeanLevel {
            offset_n: self.fc_n,
            trend_n_per_mm: 0.0,
            bumps: vec![],
        };
        // The small fixed ripple along the travel (the same every week): 1 % of F_c at
        // screw order 1 and 0.5 % at order 2.6; paper 002's model has no such term.
        let ripple = |order: f64, amplitude_n: f64, phase_deg: f64| Component {
            order,
            amplitude_n,
            phase_deg,
            direction: ComponentDirection::Both,
            cause: "fixed ripple".into(),
        };
        c.friction = Some(FrictionParams {
            sign_smoothing_mm_s: 0.01,
            forward: level.clone(),
            backward: level,
            velocity: VelocityTerm {
                static_excess_n: self.fs_n - self.fc_n,
                stribeck_velocity_mm_min: self.vs_mm_min,
                shape_exponent: 2.0,
                viscous_n_s_per_m: self.sigma_n_s_per_m,
            },
            components: vec![
                ripple(1.0, 0.01 * self.fc_n, 30.0),
                ripple(2.6, 0.005 * self.fc_n, 200.0),
            ],
        });
        c.dynamics.mode = DynamicsMode::Servo;
        c.motion.acceleration_mm_s2 = self.triangle.accel_mm_s2;
        c.sampling.mode = SamplingMode::Synchronous;
        c.sampling.synchronous_rate_hz = self.rate_hz;
        c.sampling.effort_kind = EffortKind::TorqueNm;
        c.sampling.position.quantum_mm = self.quantum_mm;
        c.sampling.effort.torque_noise_std_nm = self.torque_noise_nm;
        c.sampling.effort.torque_quantum_nm = 0.001;
        c
    }

    fn program(&self) -> TestProgram {
        triangle_program(&self.triangle, &Limits::default()).expect("triangle program")
    }

    /// True J_total = J_m + m_t·(p/2π)² (kg·m²) and motor-side F_c, F_s, σ (bearing damping
    /// in σ, as the model lumps it).
    fn truth(&self) -> [f64; 4] {
        let p = self.lead_mm * 1e-3;
        let k = p / (2.0 * PI);
        let b_eq = self.damping_nms_per_rad / (k * k);
        [
            self.motor_inertia_kgm2 + self.table_mass_kg * k * k,
            self.fc_n * k,
            self.fs_n * k,
            (self.sigma_n_s_per_m + b_eq) * k,
        ]
    }

    fn run(&self, seed: u64) -> Identification {
        let c = self.config(seed);
        let out = simulate_profile(&c, &self.program(), &mut |_| {}).expect("simulation");
        identify(&out.trace, &c.axis, &IdentParams::default()).expect("identification")
    }
}

/// Relative errors (estimate/truth − 1) of J, F_c, F_s, σ and the relative SE of J.
struct Week {
    err: [f64; 4],
    j_se_rel: f64,
}

fn weeks(m: &Machine, seeds: u64) -> Vec<Week> {
    let truth = m.truth();
    (0..seeds)
        .into_par_iter()
        .map(|s| {
            let id = m.run(1000 + s);
            let f = &id.fit;
            let est = [f.j_total_kgm2, f.tc_nm, f.ts_nm, f.sigma_nm_s_per_m];
            Week {
                err: std::array::from_fn(|i| est[i] / truth[i] - 1.0),
                j_se_rel: f.std_error.j_total_kgm2 / truth[0],
            }
        })
        .collect()
}

fn mean_std(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let m = x.iter().sum::<f64>() / n;
    let v = x.iter().map(|y| (y - m).powi(2)).sum::<f64>() / (n - 1.0);
    (m, v.sqrt())
}

/// The acceptance of issue #11 on one machine: over `seeds` weekly repeats, |mean J error|
/// < 1 %, the scatter of J within a factor 2 of the mean reported SE, and the friction
/// parameters within 2 % on average (the fixed ripple is not in the model).
fn check_machine(m: &Machine, seeds: u64) {
    let w = weeks(m, seeds);
    let col = |i: usize| w.iter().map(|x| x.err[i]).collect::<Vec<_>>();
    let (j_mean, j_std) = mean_std(&col(0));
    let se = w.iter().map(|x| x.j_se_rel).sum::<f64>() / w.len() as f64;
    let (fc, _) = mean_std(&col(1));
    let (fs, fs_std) = mean_std(&col(2));
    let (sg, sg_std) = mean_std(&col(3));
    eprintln!(
        "{}: {seeds} seeds, J error {:+.3} % ± {:.3} % (std), mean reported SE {:.3} %, \
         ratio {:.2}; Fc {:+.2} %, Fs {:+.2} % ± {:.2} %, sigma {:+.2} % ± {:.2} %",
        m.name,
        100.0 * j_mean,
        100.0 * j_std,
        100.0 * se,
        j_std / se,
        100.0 * fc,
        100.0 * fs,
        100.0 * fs_std,
        100.0 * sg,
        100.0 * sg_std
    );
    assert!(j_mean.abs() < 0.01, "{}: mean J error {j_mean}", m.name);
    // Every single week within 1 % too: the false J alarms of issue #11 came from single
    // weeks off by 10-15 %.
    for (k, x) in w.iter().enumerate() {
        assert!(
            x.err[0].abs() < 0.01,
            "{}: week {k} J error {}",
            m.name,
            x.err[0]
        );
    }
    // The std of J estimated from n seeds has a relative uncertainty of about 1/√(2(n−1))
    // (16 % at n = 20); a factor 2 either way is far outside that, so a wrong SE formula
    // (e.g. ignoring the kernel's correlation, a factor ~1.5-3, or the old n/n_eff
    // inflation) fails.
    assert!(
        (0.5..2.0).contains(&(j_std / se)),
        "{}: J scatter {j_std} vs reported SE {se}",
        m.name
    );
    for (name, e) in [("Fc", fc), ("Fs", fs), ("sigma", sg)] {
        assert!(e.abs() < 0.02, "{}: mean {name} error {e}", m.name);
    }
}

#[test]
fn ident_paper_002_twin_j_within_1_percent_and_scatter_matches_se() {
    check_machine(&paper_002(), 24);
}

#[test]
fn ident_unlike_machine_j_within_1_percent_and_scatter_matches_se() {
    check_machine(&small_mill(), 20);
}
