//! Writes the identification report (HTML, JSON and figures) of a hand-made identification,
//! for people to look at the layout without building a bank:
//! `cargo run --release --example identify_preview -- [OUT_DIR]`
//! (default `$TMPDIR/wheelflat-identify-preview`).
//!
//! Three reports: `OUT_DIR` (2 series of 300 samples, 20 PIP, 6 EIP, 15 candidate instances,
//! 200 random subsets), `OUT_DIR/refuted` (every instance falsified) and `OUT_DIR/dense`
//! (paper-sized: 30 PIP per series, 18 EIP crowded after the impact, 500 candidates). The
//! identifications are `examples/data/preview*.json`, the ones the report's tests use.
use std::path::{Path, PathBuf};
use wheelflat::identify::Identification;
use wheelflat::report::identify::write_identification_report;

fn read(name: &str) -> Identification {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("examples/data")
        .join(name);
    let text = std::fs::read_to_string(&path).expect("the preview fixture");
    serde_json::from_str(&text).expect("an identification")
}

fn main() {
    let dir = std::env::args().nth(1).map_or_else(
        || std::env::temp_dir().join("wheelflat-identify-preview"),
        PathBuf::from,
    );
    let plain = write_identification_report(&read("preview.json"), &dir).expect("write report");

    let mut refuted = read("preview.json");
    let sizing = refuted.sizing.as_mut().expect("the preview is sized");
    sizing.cms.clear();
    sizing.model_class_refuted = true;
    let refuted =
        write_identification_report(&refuted, &dir.join("refuted")).expect("write refuted report");

    let dense = write_identification_report(&read("preview-dense.json"), &dir.join("dense"))
        .expect("write dense report");
    for files in [plain, refuted, dense] {
        println!("{}", files.html.display());
    }
}
