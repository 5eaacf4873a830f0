//! The fleet store at scale (docs/fleet.md, "Scale"): SITES sites × PASSES passes each
//! shipped into a real PostgreSQL server (a throw-away cluster, durable settings), the rows
//! made from the real answers of a template results database (every pass of it reused with a
//! new key, time and wheel: a fleet of WHEELS wheels, each seen at many sites). Measured: the
//! ship rate per site (the real shipper, 500 rows a transaction, over TLS), the fleet page's
//! time and a wheel's cross-site history's, each over repeated requests (p50, p95).
//!
//! `cargo bench --bench fleet_scale -- TEMPLATE.sqlite [SITES] [PASSES] [WHEELS] [OUT.json]`
//! (defaults 100, 10000, 20000). A program, not a criterion bench: one measurement takes
//! minutes and a database of gigabytes.

use rusqlite::params;
use std::path::Path;
use std::time::Instant;
use tower::ServiceExt;
use wheelflat::fleet::{across_sites, roles, schema, FleetTarget, LoginKind, Password, Shipper};
use wheelflat::history::{Db, ExportPass, FusionRule, Window};
use wheelflat_testkit::pg::{PgCluster, ADMIN};

fn pw(p: &str) -> Password {
    Password::new(p, Path::new("bench")).unwrap()
}

/// A site's database of `n` passes made of the template's, in one transaction.
fn site_db(path: &Path, template: &[ExportPass], site: usize, n: usize, wheels: usize) {
    let _ = std::fs::remove_file(path);
    drop(Db::open(path).unwrap());
    let mut c = rusqlite::Connection::open(path).unwrap();
    let tx = c.transaction().unwrap();
    let mut seed = 0x9E37_79B9_7F4A_7C15u64 ^ (site as u64).wrapping_mul(0xD1B5_4A32_D192_ED03);
    for i in 0..n {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        let t = &template[(site * 7919 + i) % template.len()];
        let bogie = format!("W{:05}", seed % (wheels as u64 / 2));
        let time_s = 1.8e9 + 60.0 * i as f64 + site as f64;
        tx.execute(
            "INSERT INTO passes (key, time, time_s, measurement, bank_id, speed_km_per_h, bank_speed_km_per_h, load_kn, bogie_id, summary, result_dir, answer_ms) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12)",
            params![format!("s{site}-{i}"), t.time, time_s, t.meta.measurement, t.meta.bank_id, t.meta.speed_km_per_h, t.meta.bank_speed_km_per_h, t.meta.load_kn, bogie, t.meta.summary, t.meta.result_dir, t.meta.answer_ms],
        )
        .unwrap();
        let id = tx.last_insert_rowid();
        for w in &t.wheels {
            tx.execute(
                "INSERT INTO wheel_passes (pass_id, wheel, wheel_id, claim, l0_min_mm, l0_max_mm, severity_lowest, severity_highest, limit_l0_mm, space, cells, boxes, dynamic_ratio_min, dynamic_ratio_max) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14)",
                params![id, w.wheel, format!("{bogie}/{}", w.wheel), w.claim, w.l0_mm.0, w.l0_mm.1, w.severity.0, w.severity.1, w.limit_l0_mm, w.space, w.cells, w.boxes, w.dynamic_ratio.0, w.dynamic_ratio.1],
            )
            .unwrap();
        }
    }
    tx.commit().unwrap();
}

fn percentiles(mut ms: Vec<f64>) -> (f64, f64, f64) {
    ms.sort_by(f64::total_cmp);
    let at = |q: f64| ms[((ms.len() as f64 - 1.0) * q).round() as usize];
    (at(0.5), at(0.95), ms[ms.len() - 1])
}

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
    if args.first().map(String::as_str) == Some("--measure") {
        // A store built by an earlier run, still up: `--measure PORT CA.pem [WHEELS]`.
        let port: u16 = args
            .get(1)
            .expect("--measure PORT CA [WHEELS]")
            .parse()
            .unwrap();
        let ca = std::path::PathBuf::from(args.get(2).expect("--measure PORT CA [WHEELS]"));
        let wheels = args.get(3).map_or(20_000, |w| w.parse().unwrap());
        let url = format!("postgresql://planner@127.0.0.1:{port}/fleet?sslmode=require");
        let reader = FleetTarget::new(&url, Some(pw("pw")), Some(&ca)).unwrap();
        measure(&reader, wheels);
        return;
    }
    let template = args
        .first()
        .expect("usage: fleet_scale TEMPLATE.sqlite [SITES] [PASSES] [WHEELS] [OUT.json]");
    let num = |i: usize, d: usize| args.get(i).map_or(d, |a| a.parse().unwrap());
    let (sites, passes, wheels) = (num(1, 100), num(2, 10_000), num(3, 20_000));
    let template = Db::open_read_only(Path::new(template))
        .unwrap()
        .passes_after(0, 100_000)
        .unwrap();
    assert!(!template.is_empty(), "the template has no pass");
    println!(
        "template: {} passes; {sites} sites × {passes} passes, {wheels} wheels",
        template.len()
    );

    let pg = PgCluster::start_with(true).unwrap();
    let admin =
        FleetTarget::new(&pg.url(ADMIN, false), Some(pw(&pg.admin_password)), None).unwrap();
    let mut c = admin.connect().unwrap();
    schema::migrate(&mut c, &admin).unwrap();
    for s in 0..sites {
        roles::add_site(
            &mut c,
            &admin,
            &format!("site{s:03}"),
            &format!("site{s:03}"),
            &pw("pw"),
        )
        .unwrap();
    }
    roles::add_login(&mut c, &admin, LoginKind::Reader, "planner", &pw("pw")).unwrap();
    let work = tempfile::tempdir().unwrap();
    let db_path = work.path().join("site.sqlite");
    let mut rates = Vec::new();
    let t_all = Instant::now();
    for s in 0..sites {
        let t = Instant::now();
        site_db(&db_path, &template, s, passes, wheels);
        let made_s = t.elapsed().as_secs_f64();
        let target = FleetTarget::new(
            &pg.url(&format!("site{s:03}"), true),
            Some(pw("pw")),
            Some(&pg.ca),
        )
        .unwrap();
        let mut shipper = Shipper::new(target);
        let db = Db::open_read_only(&db_path).unwrap();
        let t = Instant::now();
        let done = shipper.round(&db, 500, |_| {}).unwrap();
        let ship_s = t.elapsed().as_secs_f64();
        assert_eq!(done.passes, passes);
        rates.push(passes as f64 / ship_s);
        if s % 10 == 0 || s + 1 == sites {
            println!(
                "site {s:3}: made in {made_s:.1} s, shipped {} passes in {ship_s:.2} s ({:.0} passes/s); {:.0} s in all",
                done.passes,
                passes as f64 / ship_s,
                t_all.elapsed().as_secs_f64()
            );
        }
    }
    c.batch_execute("VACUUM ANALYZE").unwrap();
    let size: String = c
        .query_one("SELECT pg_size_pretty(pg_database_size('fleet'))", &[])
        .unwrap()
        .get(0);
    let counts: (i64, i64) = {
        let r = c.query_one("SELECT (SELECT count(*) FROM fleet.passes), (SELECT count(*) FROM fleet.wheel_passes)", &[]).unwrap();
        (r.get(0), r.get(1))
    };
    println!(
        "store: {} passes, {} wheel rows, {size}",
        counts.0, counts.1
    );

    let reader = FleetTarget::new(&pg.url("planner", true), Some(pw("pw")), Some(&pg.ca)).unwrap();
    let mut sorted = rates.clone();
    sorted.sort_by(f64::total_cmp);
    println!(
        "ship rate per site (passes/s): median {:.0}, p5 {:.0}, max {:.0}",
        sorted[sorted.len() / 2],
        sorted[(sorted.len() as f64 * 0.05) as usize],
        sorted[sorted.len() - 1]
    );
    measure(&reader, wheels);
    if let Some(out) = args.get(4) {
        let v = serde_json::json!({
            "sites": sites, "passes_per_site": passes, "wheels": wheels, "store": size,
            "ship_rate_median": sorted[sorted.len() / 2],
        });
        std::fs::write(out, serde_json::to_string_pretty(&v).unwrap()).unwrap();
    }
}

/// The fleet page, `/api/fleet`, a wheel's page and its cross-site history, timed.
fn measure(reader: &FleetTarget, wheels: usize) {
    let cal = wheelflat::model::Calibration::default();
    let rules = cal.identification.clone();
    // The fleet page through the server's router, as a browser asks for it.
    let app = wheelflat::serve::fleet_router(wheelflat::serve::FleetSettings::new(
        reader.clone(),
        &rules,
        None,
    ))
    .unwrap();
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap();
    let page = |uri: &str, n: usize| -> Vec<f64> {
        (0..n)
            .map(|_| {
                let t = Instant::now();
                let resp = rt
                    .block_on(
                        app.clone().oneshot(
                            axum::http::Request::builder()
                                .uri(uri)
                                .body(axum::body::Body::empty())
                                .unwrap(),
                        ),
                    )
                    .unwrap();
                assert_eq!(resp.status(), 200, "{uri}");
                rt.block_on(axum::body::to_bytes(resp.into_body(), 64 << 20))
                    .unwrap();
                t.elapsed().as_secs_f64() * 1e3
            })
            .collect()
    };
    page("/", 5);
    let fleet_page = percentiles(page("/", 200));
    println!(
        "fleet page /: p50 {:.1} ms, p95 {:.1} ms, max {:.1} ms",
        fleet_page.0, fleet_page.1, fleet_page.2
    );
    let fleet_json = percentiles(page("/api/fleet", 200));
    println!(
        "/api/fleet: p50 {:.1} ms, p95 {:.1} ms, max {:.1} ms",
        fleet_json.0, fleet_json.1, fleet_json.2
    );
    // A wheel's cross-site history: read and fused (the newest 5, and 100).
    let mut r = wheelflat::fleet::FleetReader::connect(reader).unwrap();
    // (total, read, fused) ms of each of 200 wheels, and the passes read on average.
    let mut hist = |last: usize| -> (Vec<f64>, Vec<f64>, Vec<f64>, usize) {
        let (mut total, mut read, mut fused, mut n_passes) = (vec![], vec![], vec![], 0);
        for k in 0..200 {
            let id = format!("W{:05}/leading", (k * 97) % (wheels / 2));
            let t = Instant::now();
            let p = r.wheel_passes(&id, Window { last, hours: None }).unwrap();
            let t_read = t.elapsed().as_secs_f64() * 1e3;
            let _ = across_sites(
                &p,
                FusionRule::Robust,
                rules.phi,
                rules.urgent_l0_mm,
                rules.inspect_l0_mm,
            );
            let t_all = t.elapsed().as_secs_f64() * 1e3;
            n_passes += p.len();
            total.push(t_all);
            read.push(t_read);
            fused.push(t_all - t_read);
        }
        (total, read, fused, n_passes / 200)
    };
    for last in [5, 20, 100] {
        let (total, read, fused, n) = hist(last);
        let (a, b, m) = percentiles(total);
        let (ra, rb, _) = percentiles(read);
        let (fa, fb, _) = percentiles(fused);
        println!("cross-site history, newest {last} ({n} passes read): p50 {a:.1} ms, p95 {b:.1} ms, max {m:.1} ms (read p50 {ra:.1} / p95 {rb:.1} ms, fused p50 {fa:.1} / p95 {fb:.1} ms)");
    }
    let wheel_page = percentiles(page("/wheel?id=W00042%2Fleading", 50));
    println!(
        "wheel page /wheel (20 passes): p50 {:.1} ms, p95 {:.1} ms",
        wheel_page.0, wheel_page.1
    );
}
