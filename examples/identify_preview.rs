//! Writes the identification report (HTML, JSON and figures) of a hand-made identification,
//! for people to look at the layout without building a bank:
//! `cargo run --release --example identify_preview -- [OUT_DIR]`
//! (default `$TMPDIR/wheelflat-identify-preview`).
//!
//! Three reports: `OUT_DIR` (2 series of 300 samples, 20 PIP, 6 EIP, 15 candidate instances,
//! 200 random subsets), `OUT_DIR/refuted` (every instance falsified) and `OUT_DIR/dense`
//! (paper-sized: 30 PIP per series, 18 EIP crowded after the impact, 500 candidates). The
//! identification is `wheelflat::report::identify::sample`, the one the report's tests use.
use std::path::PathBuf;
use wheelflat::report::identify::{sample, write_identification_report};

fn main() {
    let dir = std::env::args().nth(1).map_or_else(
        || std::env::temp_dir().join("wheelflat-identify-preview"),
        PathBuf::from,
    );
    let plain = write_identification_report(&sample::identification(), &dir).expect("write report");

    let mut refuted = sample::identification();
    refuted.cms.clear();
    refuted.model_class_refuted = true;
    let refuted =
        write_identification_report(&refuted, &dir.join("refuted")).expect("write refuted report");

    let dense = write_identification_report(&sample::dense(), &dir.join("dense"))
        .expect("write dense report");
    for files in [plain, refuted, dense] {
        println!("{}", files.html.display());
    }
}
