//! `wheelflat serve`'s page times on a large results database (a timing probe, not a criterion
//! bench; docs/serve.md, "Measured"):
//!
//! - `cargo bench --bench serve_pages -- grow SEED_DB OUT_DB PASSES BOGIES`: a database of
//!   PASSES passes of BOGIES bogies over the last 30 days, each pass a copy of a real pass of
//!   SEED_DB (one `identify --db` made) under a new key, bogie and time — nine bogies in ten
//!   drawn from SEED_DB's good-wheel passes, one in ten from its flats.
//! - `cargo bench --bench serve_pages -- time URL REQUESTS`: REQUESTS requests of each of the
//!   metrics (docs/alarms.md), the site page, its JSON, a wheel page and its JSON (wheels drawn
//!   from the site's list), one at a time; prints each route's median, 95th percentile and
//!   largest time (ms), over HTTP.
use std::path::Path;
use std::time::Instant;
use wheelflat::history::{Claim, Db, PassMeta, PassRecord};

fn main() {
    let args: Vec<String> = std::env::args()
        .filter(|a| a != "--bench")
        .skip(1)
        .collect();
    match args.first().map(String::as_str) {
        Some("grow") if args.len() == 5 => grow(
            Path::new(&args[1]),
            Path::new(&args[2]),
            args[3].parse().expect("PASSES"),
            args[4].parse().expect("BOGIES"),
        ),
        Some("time") if args.len() == 3 => time(&args[1], args[2].parse().expect("REQUESTS")),
        _ => eprintln!(
            "serve_pages: a timing probe; `cargo bench --bench serve_pages -- grow SEED_DB OUT_DB PASSES BOGIES` or `-- time URL REQUESTS`"
        ),
    }
}

/// A small deterministic generator (SplitMix64): the same database for the same arguments.
struct Draw(u64);

impl Draw {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
}

fn grow(seed_db: &Path, out: &Path, passes: usize, bogies: usize) {
    let seed = Db::open_read_only(seed_db).expect("the seed database");
    let mut pool: (Vec<PassRecord>, Vec<PassRecord>) = (Vec::new(), Vec::new());
    for id in 1.. {
        let Some(d) = seed.pass_detail(id).expect("a seed pass") else {
            break;
        };
        if d.wheels.len() != 2 {
            continue;
        }
        let rec = PassRecord {
            meta: PassMeta {
                key: String::new(),
                time_s: 0.0,
                measurement: d.row.measurement.clone(),
                bank_id: d.row.bank_id.clone(),
                speed_km_per_h: d.row.speed_km_per_h,
                bank_speed_km_per_h: d.wheels[0].bank_speed_km_per_h,
                load_kn: d.row.load_kn,
                bogie_id: None,
                summary: d.row.summary.clone(),
                result_dir: None,
                answer_ms: None,
            },
            wheels: [d.wheels[0].wheel.clone(), d.wheels[1].wheel.clone()],
        };
        let good = rec
            .wheels
            .iter()
            .all(|w| matches!(w.claim, Claim::None | Claim::Below));
        if good {
            pool.0.push(rec);
        } else {
            pool.1.push(rec);
        }
    }
    assert!(
        !pool.0.is_empty() && !pool.1.is_empty(),
        "the seed needs good-wheel and flat passes"
    );
    println!(
        "seed: {} good-wheel passes, {} with a flat",
        pool.0.len(),
        pool.1.len()
    );
    let mut db = Db::open(out).expect("the database to grow");
    let mut draw = Draw(7);
    let now = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_secs_f64();
    let span = 30.0 * 86_400.0;
    let start = Instant::now();
    for i in 0..passes {
        let b = draw.below(bogies);
        let flat_bogie = b.is_multiple_of(10);
        let from = if flat_bogie { &pool.1 } else { &pool.0 };
        let mut rec = from[draw.below(from.len())].clone();
        rec.meta.key = format!("grown-{i}");
        rec.meta.time_s = now - span + span * i as f64 / passes as f64;
        rec.meta.bogie_id = Some(format!("T{:03}-B{b:04}", b / 8));
        db.insert(&rec).expect("a pass stored");
        if (i + 1).is_multiple_of(10_000) {
            println!("{} passes, {:.0} s", i + 1, start.elapsed().as_secs_f64());
        }
    }
    println!(
        "{passes} passes of {bogies} bogies in {:.1} s",
        start.elapsed().as_secs_f64()
    );
}

/// Percentiles (nearest rank) of `ms`.
fn summary(ms: &mut [f64]) -> (f64, f64, f64) {
    ms.sort_by(f64::total_cmp);
    let at = |q: f64| ms[((q * ms.len() as f64).ceil() as usize).clamp(1, ms.len()) - 1];
    (at(0.5), at(0.95), ms[ms.len() - 1])
}

fn time(url: &str, requests: usize) {
    let agent: ureq::Agent = ureq::Agent::config_builder()
        .http_status_as_error(false)
        .build()
        .into();
    let get = |path: &str| -> (f64, usize) {
        let t = Instant::now();
        let mut r = agent
            .get(&format!("{url}{path}"))
            .call()
            .expect("a response");
        assert_eq!(r.status(), 200, "{path}");
        let body = r
            .body_mut()
            .with_config()
            .limit(64 << 20)
            .read_to_string()
            .expect("a body");
        (t.elapsed().as_secs_f64() * 1e3, body.len())
    };
    let site: serde_json::Value = serde_json::from_str(
        &agent
            .get(&format!("{url}/api/site"))
            .call()
            .unwrap()
            .body_mut()
            .with_config()
            .limit(64 << 20)
            .read_to_string()
            .unwrap(),
    )
    .unwrap();
    println!(
        "database: {} passes, {} wheels",
        site["passes_stored"], site["wheels_known"]
    );
    let wheels: Vec<String> = site["wheels"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| w["wheel_id"].as_str().unwrap().to_string())
        .collect();
    let mut draw = Draw(11);
    println!("route\trequests\tmedian ms\tp95 ms\tmax ms\tbytes (last)");
    // `/metrics` first: its first request reads the whole database (the largest time), the
    // others only what is new since the one before.
    for route in ["/metrics", "/", "/api/site", "/wheel", "/api/wheel"] {
        let mut ms = Vec::new();
        let mut bytes = 0;
        for _ in 0..requests {
            let path = if route.ends_with("wheel") {
                let q = form_urlencoded::Serializer::new(String::new())
                    .append_pair("id", &wheels[draw.below(wheels.len())])
                    .finish();
                format!("{route}?{q}")
            } else {
                route.to_string()
            };
            let (t, b) = get(&path);
            ms.push(t);
            bytes = b;
        }
        let (p50, p95, max) = summary(&mut ms);
        println!("{route}\t{requests}\t{p50:.1}\t{p95:.1}\t{max:.1}\t{bytes}");
    }
}
