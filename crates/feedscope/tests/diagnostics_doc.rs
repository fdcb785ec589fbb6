//! `docs/diagnostics.md` is generated from the catalogue of diagnostic codes and must match it,
//! so that the published list never drifts from what the code gives.
//! `FEEDSCOPE_BLESS=1 cargo test -p feedscope --test diagnostics_doc` rewrites the file.

use std::path::Path;

#[test]
fn docs_diagnostics_md_is_the_catalogue() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/diagnostics.md");
    let want = feedscope::diag::catalogue_markdown();
    if std::env::var_os("FEEDSCOPE_BLESS").is_some() {
        std::fs::write(&path, &want).expect("writing docs/diagnostics.md");
        return;
    }
    let have = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        have == want,
        "{} is not the catalogue of feedscope::diag::Code; regenerate it with \
         `FEEDSCOPE_BLESS=1 cargo test -p feedscope --test diagnostics_doc`",
        path.display()
    );
}
