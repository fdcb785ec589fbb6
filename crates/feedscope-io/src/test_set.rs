//! Test sets of `feedscope map`: the index CSV read from its file (paths relative to its
//! folder), and every run's trace read from its file and estimated.

use std::path::Path;

use feedscope::axis::AxisParams;
use feedscope::estimate::EstimateParams;
use feedscope::map::{estimate_set_with_warnings, MapError, SetEstimate, TestRun, TestSet};
use feedscope::trace::GlitchParams;

use crate::trace::{read_trace_file_with, ReadOptions};

/// Read an index CSV (see [`TestSet::parse_index`]); paths are relative to its folder.
///
/// # Errors
/// [`MapError::Index`] when the file cannot be read (line 0) or is malformed.
pub fn read_index(path: &Path) -> Result<TestSet, MapError> {
    let name = path.display().to_string();
    let text =
        crate::bounded::read_to_string(path, crate::bounded::MAX_CONFIG_BYTES).map_err(|e| {
            MapError::Index {
                source_name: name.clone(),
                line: 0,
                message: format!("cannot read: {e}"),
            }
        })?;
    let base = path.parent().unwrap_or(Path::new(""));
    TestSet::parse_index(&text, base, &name)
}

/// Estimate every run of a test set in parallel, reading each trace with
/// [`read_trace_file_with`] and the position screened at the axis' speed limit
/// ([`GlitchParams::for_axis`]); the glitch warning of a read is kept with its run
/// ([`estimate_set_with_warnings`]). `progress` is called once per finished run (from worker
/// threads).
///
/// Never fails as a whole: a run whose file is missing or malformed, or that has no usable
/// stroke, becomes a [`feedscope::map::RunFailure`] whose error names the file.
pub fn estimate_set(
    set: &TestSet,
    axis: &AxisParams,
    params: &EstimateParams,
    read: &ReadOptions,
    stroke_feed_tolerance: f64,
    progress: &(dyn Fn(&TestRun) + Sync),
) -> SetEstimate {
    // Runs are the parallel unit; parse each file on one thread to avoid nested fan-out.
    let read = ReadOptions {
        threads: 1,
        ..read.clone()
    };
    let glitch = GlitchParams::for_axis(axis);
    estimate_set_with_warnings(
        &set.runs,
        |run| {
            read_trace_file_with(&run.file, &read, &glitch)
                .map(|(t, report)| (t, report.diagnostics()))
                .map_err(|e| e.to_string())
        },
        axis,
        params,
        stroke_feed_tolerance,
        progress,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use feedscope::axis::ConfigFormat;
    use feedscope::diag::Code;

    /// A wide 500 Hz trace: 0 → 20 mm at 600 mm/min and back, with a 5 mm spike at sample 700
    /// (t = 1.4 s, line 702) and a 1e308 at sample 2000 (t = 4 s, line 2002).
    fn spiky_trace() -> String {
        let mut s = String::from("time_s,position_mm,current_a\n");
        for k in 0..2750 {
            let t = k as f64 / 500.0;
            let (mm, dir) = match t {
                t if t < 0.5 => (0.0, 0.0),
                t if t < 2.5 => (10.0 * (t - 0.5), 1.0),
                t if t < 3.0 => (20.0, 0.0),
                t if t < 5.0 => (20.0 - 10.0 * (t - 3.0), -1.0),
                _ => (0.0, 0.0),
            };
            let z = match k {
                700 => format!("{:.4}", mm + 5.0),
                2000 => "1e308".into(),
                _ => format!("{mm:.4}"),
            };
            s.push_str(&format!("{t:.6},{z},{:.6}\n", dir * 0.8));
        }
        s
    }

    #[test]
    fn read_warnings_name_the_run_and_use_the_axis_rapid_rate() {
        let d = tempfile::tempdir().unwrap();
        for name in ["r1.csv", "r2.csv"] {
            std::fs::write(d.path().join(name), spiky_trace()).unwrap();
        }
        let index = d.path().join("index.csv");
        std::fs::write(
            &index,
            "file,feed_mm_min,repeat\nr1.csv,600,1\nr2.csv,600,2\n",
        )
        .unwrap();
        let set = read_index(&index).unwrap();
        let text = "lead_mm = 10\ntable_mass_kg = 300\ninertia_kgm2 = 0.002\n\
                    damping_nms_per_rad = 0\ntorque_constant_nm_per_a = 1.5\n";
        for (rapid, dropped) in [
            ("", "1 position sample"),
            ("rapid_rate_mm_min = 15000\n", "2 position samples"),
        ] {
            let axis =
                AxisParams::parse(&format!("{text}{rapid}"), ConfigFormat::Toml, "a").unwrap();
            let est = estimate_set(
                &set,
                &axis,
                &EstimateParams::default(),
                &ReadOptions::default(),
                0.1,
                &|_| {},
            );
            assert_eq!(est.ok.len(), 2, "{:?}", est.failed);
            let names: Vec<&str> = est.read_warnings.iter().map(|w| w.run.as_str()).collect();
            assert_eq!(names, ["r1.csv", "r2.csv"]);
            let w = &est.read_warnings[0].message;
            assert!(w.contains(dropped) && w.contains("4 s (line 2002)"), "{w}");
            assert_eq!(est.read_warnings[0].code, Code::PositionGlitchesDropped);
            assert_eq!(&est.ok[0].warnings[0].message, w);
            assert_eq!(est.ok[0].warnings[0].code, Code::PositionGlitchesDropped);
        }
    }
}
