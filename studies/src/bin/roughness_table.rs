//! A bank's roughness table (docs/detection.md, "Rough wheels"), computed or read from its
//! cache: `cargo run --release -p wheelflat-studies --bin roughness_table -- BANK [iso3095]`.
use wheelflat::model::surface::RoughnessClass;
use wheelflat_studies::study;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let (bank, _) = study::open_bank(args.get(1).expect("usage: roughness_table BANK [iso3095]"));
    let rail = args
        .iter()
        .any(|a| a == "iso3095")
        .then_some(RoughnessClass::RailIso3095);
    let started = std::time::Instant::now();
    let t = wheelflat::bank::roughness::load_or_compute(&bank, rail).expect("table");
    println!("{:.1} s", started.elapsed().as_secs_f64());
    println!("wheels            rail          near-wheel  floor kN  HF kN");
    for r in t.on_rail(rail) {
        println!(
            "{:16}  {:12}  {:10.3}  {:8.3}  {:5.3}",
            r.wheel.map_or("round", |c| c.name()),
            r.rail.map_or("smooth", |c| c.name()),
            r.near_wheel_fraction,
            r.floor_kn,
            r.hf_kn
        );
    }
}
