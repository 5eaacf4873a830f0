//! `wheelflat demo --serve`: the demo's site — passes of four bogies (good wheels, the demo's
//! flat, a flat that grows, a pass at a speed the bank does not cover) identified against the
//! demo's bank the way `watch --db` does, stored in a results database, then served.

use super::create_output_folder;
use anyhow::Result;
use std::net::SocketAddr;
use std::path::Path;
use wheelflat::identify::synth::{synthesize_pass, FieldNoise};
use wheelflat::identify::Extras;
use wheelflat::model::Flat;
use wheelflat::pass::single::{identify_file, Request};
use wheelflat::pass::store::open_db;

/// The site's passes: name, bogie, flat (L, d, c, X_p) or a good wheel, seed, speed factor.
type SitePass = (
    &'static str,
    &'static str,
    Option<(f64, f64, f64, f64)>,
    u64,
    f64,
);

const PASSES: [SitePass; 12] = [
    ("d1-1", "D1", None, 101, 1.0),
    ("d1-2", "D1", None, 102, 1.0),
    ("d1-3", "D1", None, 103, 1.0),
    ("d2-1", "D2", Some((62.0, 0.55, 0.05, 12.156)), 111, 1.0),
    ("d2-2", "D2", Some((62.0, 0.55, 0.05, 12.201)), 112, 1.0),
    ("d2-3", "D2", Some((62.0, 0.55, 0.05, 12.244)), 113, 1.0),
    ("d3-1", "D3", Some((50.0, 0.31, 0.03, 12.33)), 121, 1.0),
    ("d3-2", "D3", Some((52.0, 0.31, 0.03, 12.45)), 122, 1.0),
    ("d3-3", "D3", Some((70.0, 0.59, 0.03, 12.36)), 123, 1.0),
    ("d3-4", "D3", Some((72.0, 0.59, 0.03, 12.44)), 124, 1.0),
    ("d4-1", "D4", None, 131, 1.0),
    // 30 % faster than the bank's speed: refused, with its reason.
    ("d4-2", "D4", None, 132, 1.3),
];

/// Identifies the site's passes into `out/site/results.sqlite` (a pass stored before is
/// kept once; with `alarms`, the alarms they raise posted to its webhooks) and serves it on
/// `listen` until Ctrl-C.
pub(super) fn run(
    out: &Path,
    bank_dir: &Path,
    listen: SocketAddr,
    alarms: Option<&Path>,
) -> Result<()> {
    println!("\n5. A site (the passes of four bogies, as `watch --db` stores them)");
    let cal = super::load_calibration(None)?;
    let site = out.join("site");
    let inbox = site.join("measurements");
    create_output_folder(&inbox)?;
    let db_path = site.join("results.sqlite");
    let config = alarms
        .map(wheelflat::alarm::AlarmConfig::read)
        .transpose()?;
    let mut db = open_db(&db_path)?;
    if let Some(config) = &config {
        let rules = &cal.identification;
        db.raise_alarms(config.plan([rules.inspect_l0_mm, rules.urgent_l0_mm], rules.phi));
    }
    let mut members = super::open_members(bank_dir, None)?;
    let speed = cal.run.speed_km_per_h;
    for (name, bogie, flat, seed, factor) in PASSES {
        let flat = flat
            .map(|(l, d, c, x)| Flat::from_mm(l, d, c, x))
            .transpose()?;
        let csv = synthesize_pass(&cal, flat.as_ref(), seed, true, FieldNoise::TABLE)?
            .csv
            .replace(
                &format!("# speed_km_per_h = {speed}"),
                &format!("# speed_km_per_h = {}", speed * factor),
            );
        let file = inbox.join(format!("{name}.csv"));
        super::write_file(&file, format!("# bogie_id = {bogie}\n{csv}").as_bytes())?;
        let result = site.join("results").join(name);
        let request = Request {
            sensors: None,
            extras: Extras::NONE,
            refine: None,
            out: &result,
        };
        match identify_file(&mut members, &file, request, Some(&mut db)) {
            Ok(pass) => println!("{name} (bogie {bogie}): {}", pass.id.summary),
            Err(e) => {
                let e = anyhow::Error::from(e);
                super::history::store_failure(&mut db, &file, &e);
                println!("{name} (bogie {bogie}): refused: {e:#}");
            }
        }
    }
    let store = super::db_args::Store {
        db: Some(db),
        sender: config.map(wheelflat::alarm::Sender::new),
    };
    store.send_once(String::new)?;
    drop(store);
    let settings = wheelflat::serve::Settings::new(
        db_path.clone(),
        Some(bank_dir.to_path_buf()),
        &cal.identification,
        None,
    );
    wheelflat::serve::run(settings, listen, |bound| {
        println!(
            "\nserving {} on http://{bound}/ — open it in a browser (read-only; Ctrl-C stops)",
            db_path.display()
        );
    })?;
    Ok(())
}
