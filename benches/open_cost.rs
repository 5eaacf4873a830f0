//! Where a cold `identify` spends its time before the measurement: open, parameters, cells,
//! uncertainty tables. `cargo bench --bench open_cost -- BANK`
use std::path::Path;
use std::time::Instant;
use wheelflat::bank::Bank;
use wheelflat::identify::Cells;
use wheelflat::identify::CombinedUncertainty;

fn main() {
    // A probe, not a criterion bench: without its bank (as in a plain `cargo bench`) it says so.
    let Some(dir) = std::env::args().filter(|a| a != "--bench").nth(1) else {
        eprintln!("open_cost: a timing probe; run `cargo bench --bench open_cost -- BANK`");
        return;
    };
    let t = Instant::now();
    let bank = Bank::open(Path::new(&dir)).unwrap();
    let open = t.elapsed();
    let t = Instant::now();
    let p = bank.read_parameters().unwrap();
    let params = t.elapsed();
    let t = Instant::now();
    let pop = &bank.metadata().calibration.population;
    let _c = Cells::new(&p, pop, bank.neighbours());
    let cells = t.elapsed();
    let t = Instant::now();
    if std::env::args()
        .filter(|a| a != "--bench")
        .nth(2)
        .as_deref()
        == Some("search")
    {
        let _c = Cells::new(&p, pop, None);
    }
    let searched = t.elapsed();
    let t = Instant::now();
    let _u = CombinedUncertainty::new(&bank.metadata().calibration.identification);
    let unc = t.elapsed();
    println!(
        "open {:.1} ms, parameters {:.1} ms, cells from stored graph {:.1} ms (searched {:.1} ms), uncertainty tables {:.1} ms",
        open.as_secs_f64() * 1e3,
        params.as_secs_f64() * 1e3,
        cells.as_secs_f64() * 1e3,
        searched.as_secs_f64() * 1e3,
        unc.as_secs_f64() * 1e3
    );
}
