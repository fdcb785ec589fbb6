//! Every input the fuzzer found and that was fixed, replayed: `regressions/<target>/<file>`
//! must now be accepted with a sane result or refused as bad input, within the limits.

use feedscope_fuzz::{run_one, targets, Limits, Outcome};

#[test]
fn found_inputs_stay_fixed() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("regressions");
    let dir = tempfile::tempdir().unwrap();
    let ctx = targets::Ctx {
        dir: dir.path().to_path_buf(),
    };
    let mut replayed = 0;
    let mut failures = Vec::new();
    for t in targets::all() {
        let Ok(entries) = std::fs::read_dir(root.join(t.name)) else {
            continue;
        };
        let mut files: Vec<_> = entries.map(|e| e.unwrap().path()).collect();
        files.sort();
        for f in files {
            let input = std::fs::read(&f).unwrap();
            let run = run_one(&t, &input, &ctx, &Limits::default());
            replayed += 1;
            if let Outcome::Finding(msg) = run.outcome {
                failures.push(format!("{}: {msg}", f.display()));
            }
        }
    }
    assert!(
        replayed > 0,
        "no regression inputs under {}",
        root.display()
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn every_seed_is_accepted() {
    let dir = tempfile::tempdir().unwrap();
    let ctx = targets::Ctx {
        dir: dir.path().to_path_buf(),
    };
    for t in targets::all() {
        for (k, s) in t.seeds().iter().enumerate() {
            let run = run_one(&t, s, &ctx, &Limits::default());
            assert_eq!(run.outcome, Outcome::Accepted, "{} seed {k}", t.name);
        }
    }
}
