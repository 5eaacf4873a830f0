//! Times reading 60 arbitrary force-sample columns of a bank through the memory map (the
//! identifier's hot path), after opening it once. `cargo bench --bench read_columns -- DIR`
use std::time::Instant;
use wheelflat::bank::Bank;

fn main() {
    // A probe, not a criterion bench: without its bank (as in a plain `cargo bench`) it says so.
    let Some(dir) = std::env::args().filter(|a| a != "--bench").nth(1) else {
        eprintln!("read_columns: a timing probe; run `cargo bench --bench read_columns -- BANK`");
        return;
    };
    let t0 = Instant::now();
    let bank = Bank::open(std::path::Path::new(&dir)).expect("open bank");
    let open_ms = t0.elapsed().as_secs_f64() * 1e3;
    let sensors = bank.metadata().sensors.len();
    let samples = bank.metadata().sensors[0].samples;
    // 60 columns spread over all sensors, deterministic "arbitrary" picks.
    let cols: Vec<usize> = (0..60)
        .map(|j| bank.sample_index(j % sensors, (j * 7919 + 13) % samples))
        .collect();
    let mut times = Vec::new();
    let mut v = vec![0.0f32; cols.len() * bank.instances()];
    for _ in 0..21 {
        let t = Instant::now();
        bank.read_columns_flat(&cols, &mut v).expect("read");
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    times.sort_by(f64::total_cmp);
    let bytes: u64 = bank.manifest().files.iter().map(|f| f.bytes).sum();
    println!(
        "{} instances, {:.1} MB ({:.2} kB/instance): open {open_ms:.1} ms, read 60 columns median {:.2} ms (min {:.2}, max {:.2})",
        bank.instances(),
        bytes as f64 / 1e6,
        bytes as f64 / 1e3 / bank.instances() as f64,
        times[10],
        times[0],
        times[20]
    );
}
