//! The fleet store against a real PostgreSQL server (a throw-away cluster per test, from the
//! distribution's package: `wheelflat_testkit::pg`): sites shipping at once, every pass once
//! and in order, a batch sent twice, another site's rows refused, a wheel id carrying SQL
//! kept as text, a store of another schema version refused, a wheel fused across sites with
//! a disagreeing site named. The command-line tests are in `fleet_cli.rs`.

use std::path::{Path, PathBuf};
use wheelflat::fleet::{
    across_sites, roles, schema, ship, FleetError, FleetReader, FleetTarget, LoginKind, Password,
    Shipper,
};
use wheelflat::history::{Claim, Db, FusionRule, PassMeta, PassRecord, Space, WheelPass, Window};
use wheelflat::identify::{Severity, SeverityRange};
use wheelflat::model::{Calibration, Flat, WheelPosition};
use wheelflat_testkit::pg::{PgCluster, ADMIN};

/// The default calibration's sizing space.
pub fn space() -> Space {
    let cal = Calibration::default();
    Space {
        length_mm: cal.population.length_mm,
        depth_mm: cal.population.depth_mm,
        curvature_mm: cal.population.curvature_mm,
        wheel_radius_m: cal.vehicle.wheel_radius_m,
    }
}

/// A pass of `bogie` whose leading wheel carries a flat of (L, d) mm (one cell ±10 % in L,
/// ±20 % in d, every c) or none, the trailing wheel none; keyed `key`.
pub fn record(key: &str, bogie: &str, time_s: f64, flat: Option<(f64, f64)>) -> PassRecord {
    let s = space();
    let l0 = |d: f64| Flat::fresh_length_mm(d, s.wheel_radius_m);
    let good = |wheel| WheelPass {
        wheel,
        claim: Claim::None,
        l0_mm: None,
        severity: Some(SeverityRange::single(Severity::None)),
        space: s,
        limit_l0_mm: Some(15.0),
        boxes: Vec::new(),
        dynamic_ratio: None,
    };
    let leading = match flat {
        Some((l, d)) => WheelPass {
            wheel: WheelPosition::Leading,
            claim: Claim::Flat,
            l0_mm: Some([l0(d * 0.8), l0(d * 1.2)]),
            severity: Some(SeverityRange::of_l0([l0(d * 0.8), l0(d * 1.2)], 40.0, 25.0)),
            space: s,
            limit_l0_mm: None,
            boxes: vec![[
                (l * 0.9) as f32,
                (l * 1.1) as f32,
                (d * 0.8) as f32,
                (d * 1.2) as f32,
                s.curvature_mm[0] as f32,
                s.curvature_mm[1] as f32,
            ]],
            dynamic_ratio: Some([1.5, 2.0]),
        },
        None => good(WheelPosition::Leading),
    };
    PassRecord {
        meta: PassMeta {
            key: key.to_string(),
            time_s,
            measurement: format!("{key}.csv"),
            bank_id: "bank-v1".into(),
            speed_km_per_h: Some(80.0),
            bank_speed_km_per_h: 80.0,
            load_kn: None,
            bogie_id: Some(bogie.to_string()),
            summary: "synthetic".into(),
            result_dir: None,
            answer_ms: Some(7.0),
        },
        wheels: [leading, good(WheelPosition::Trailing)],
    }
}

/// A site database at `path` with `n` passes: every 10th of wheel `W1` with a 60 mm × 0.8 mm
/// flat, the others of bogies `B<i>` with good wheels; times from `t0`, a minute apart.
pub fn site_db(path: &Path, tag: &str, n: usize, t0: f64) -> Db {
    let mut db = Db::open(path).unwrap();
    for i in 0..n {
        let (bogie, flat) = if i % 10 == 0 {
            ("W1".to_string(), Some((60.0, 0.8)))
        } else {
            (format!("B{i}"), None)
        };
        db.insert(&record(
            &format!("{tag}-{i}"),
            &bogie,
            t0 + 60.0 * i as f64,
            flat,
        ))
        .unwrap();
    }
    db
}

pub fn password(p: &str) -> Password {
    Password::new(p, Path::new("test")).unwrap()
}

/// The owner's connection target (plain, loopback).
pub fn admin(pg: &PgCluster) -> FleetTarget {
    FleetTarget::new(
        &pg.url(ADMIN, false),
        Some(password(&pg.admin_password)),
        None,
    )
    .unwrap()
}

/// The store migrated, with sites `names` (login `site_<name>`, password `pw-<name>`) and a
/// reader `planner` (`pw-planner`).
pub fn fleet_with_sites(pg: &PgCluster, names: &[&str]) -> FleetTarget {
    let a = admin(pg);
    let mut c = a.connect().unwrap();
    assert_eq!(schema::migrate(&mut c, &a).unwrap(), vec![1]);
    assert!(
        schema::migrate(&mut c, &a).unwrap().is_empty(),
        "a second migrate applies nothing"
    );
    for n in names {
        roles::add_site(
            &mut c,
            &a,
            n,
            &format!("site_{n}"),
            &password(&format!("pw-{n}")),
        )
        .unwrap();
    }
    roles::add_login(
        &mut c,
        &a,
        LoginKind::Reader,
        "planner",
        &password("pw-planner"),
    )
    .unwrap();
    roles::add_login(
        &mut c,
        &a,
        LoginKind::Workshop,
        "workshop",
        &password("pw-workshop"),
    )
    .unwrap();
    a
}

/// Ships the database at `path` as `site` (login `site_<site>`, password `pw-<site>`), 100
/// rows a transaction.
pub fn ship(pg: &PgCluster, site: &str, path: &Path) -> wheelflat::fleet::Shipped {
    let t = login(pg, &format!("site_{site}"), &format!("pw-{site}"));
    Shipper::new(t)
        .round(&Db::open_read_only(path).unwrap(), 100, |_| {})
        .unwrap()
}

/// A login's target over TLS, checked against the run's CA.
pub fn login(pg: &PgCluster, role: &str, pw: &str) -> FleetTarget {
    FleetTarget::new(&pg.url(role, true), Some(password(pw)), Some(&pg.ca)).unwrap()
}

fn tmp() -> tempfile::TempDir {
    tempfile::tempdir().unwrap()
}

/// (count, min seq, max seq, distinct seqs) of a site's passes, read by the owner.
fn seqs(a: &FleetTarget, site: &str) -> (i64, i64, i64, i64) {
    let mut c = a.connect().unwrap();
    let r = c
        .query_one(
            "SELECT count(*), coalesce(min(seq),0), coalesce(max(seq),0), count(DISTINCT seq) FROM fleet.passes WHERE site = $1",
            &[&site],
        )
        .unwrap();
    (r.get(0), r.get(1), r.get(2), r.get(3))
}

#[test]
fn two_sites_ship_at_once_every_pass_once_in_order_and_no_site_touches_anothers_rows() {
    let Some(pg) = PgCluster::start_or_skip("fleet::two_sites_ship_at_once") else {
        return;
    };
    let a = fleet_with_sites(&pg, &["north", "south"]);
    let dir = tmp();
    let paths: Vec<PathBuf> = ["north", "south"]
        .iter()
        .map(|s| dir.path().join(format!("{s}.sqlite")))
        .collect();
    for (p, tag) in paths.iter().zip(["north", "south"]) {
        site_db(p, tag, 400, 1.8e9 + if tag == "north" { 0.0 } else { 30.0 });
    }
    // Both at once, over TLS, 25 passes a transaction.
    let threads: Vec<_> = ["north", "south"]
        .iter()
        .zip(paths.clone())
        .map(|(s, p)| {
            let t = login(&pg, &format!("site_{s}"), &format!("pw-{s}"));
            std::thread::spawn(move || {
                let mut sh = Shipper::new(t);
                let db = Db::open_read_only(&p).unwrap();
                sh.round(&db, 25, |_| {}).unwrap()
            })
        })
        .collect();
    for t in threads {
        let s = t.join().unwrap();
        assert_eq!((s.passes, s.passes_known, s.pending), (400, 0, 0), "{s:?}");
        assert_eq!(s.batches, 16);
    }
    for site in ["north", "south"] {
        assert_eq!(
            seqs(&a, site),
            (400, 1, 400, 400),
            "{site}: every pass once, rows 1–400"
        );
    }
    let mut c = a.connect().unwrap();
    let wheels: i64 = c
        .query_one("SELECT count(*) FROM fleet.wheel_passes", &[])
        .unwrap()
        .get(0);
    assert_eq!(wheels, 1600);
    let tls: bool = {
        let t = login(&pg, "site_north", "pw-north");
        let mut sc = t.connect().unwrap();
        sc.query_one(
            "SELECT ssl FROM pg_stat_ssl WHERE pid = pg_backend_pid()",
            &[],
        )
        .unwrap()
        .get(0)
    };
    assert!(tls, "the site's connection is encrypted");

    // A second round ships nothing; a batch sent again (a shipper killed after its commit
    // reached the server) inserts nothing.
    let north = login(&pg, "site_north", "pw-north");
    let mut sh = Shipper::new(north.clone());
    let db = Db::open_read_only(&paths[0]).unwrap();
    let again = sh.round(&db, 25, |_| {}).unwrap();
    assert_eq!((again.passes, again.passes_known, again.batches), (0, 0, 0));
    let first = db.passes_after(0, 25).unwrap();
    let mut nc = north.connect().unwrap();
    assert_eq!(
        ship::send_passes(&mut nc, &north, "north", &first).unwrap(),
        0
    );
    assert_eq!(seqs(&a, "north"), (400, 1, 400, 400));

    // Another site's rows: refused by row-level security; no update, no delete; a site
    // reads its own rows only.
    let e = ship::send_passes(&mut nc, &north, "south", &first).unwrap_err();
    assert!(e.to_string().contains("row-level security"), "{e}");
    for sql in [
        "UPDATE fleet.passes SET summary = 'x' WHERE site = 'north'",
        "DELETE FROM fleet.passes WHERE site = 'north'",
        "UPDATE fleet.passes SET summary = 'x' WHERE site = 'south'",
    ] {
        let e = nc.batch_execute(sql).unwrap_err();
        assert!(
            format!("{e:?}").contains("permission denied"),
            "{sql}: {e:?}"
        );
    }
    let seen: i64 = nc
        .query_one("SELECT count(*) FROM fleet.passes", &[])
        .unwrap()
        .get(0);
    assert_eq!(seen, 400, "north sees its own 400 passes, not south's");
    assert_eq!(seqs(&a, "south"), (400, 1, 400, 400));

    // The reader sees W1 at both sites; fused, the two sites agree.
    let mut r = FleetReader::connect(&login(&pg, "planner", "pw-planner")).unwrap();
    let w1 = r
        .wheel_passes(
            "W1/leading",
            Window {
                last: 1000,
                hours: None,
            },
        )
        .unwrap();
    assert_eq!(w1.len(), 80);
    assert!(
        w1.windows(2).all(|p| p[0].pass.time_s <= p[1].pass.time_s),
        "oldest first"
    );
    let across = across_sites(&w1, FusionRule::Robust, 0.95, 40.0, 25.0);
    assert!(across.disagreeing.is_empty());
    assert!(across
        .joint
        .allows(Some([60.0, 0.8, space().curvature_mm[0]])));
    assert_eq!(
        across.sites.iter().map(|s| s.agrees).collect::<Vec<_>>(),
        [Some(true), Some(true)]
    );
    // The site's heartbeat: nothing pending, a lag of seconds.
    let health = r.sites(wheelflat::fleet::words::now_s()).unwrap();
    assert_eq!(health.len(), 2);
    for h in &health {
        assert_eq!((h.newest_seq, h.pending), (400, Some(0)), "{h:?}");
        assert!(h.lag_s.is_some_and(|l| l < 120.0), "{h:?}");
    }
}

#[test]
fn a_wheel_id_carrying_sql_is_text_a_restored_database_and_another_schema_are_refused() {
    let Some(pg) = PgCluster::start_or_skip("fleet::sql_wheel_id") else {
        return;
    };
    let a = fleet_with_sites(&pg, &["east"]);
    let dir = tmp();
    let path = dir.path().join("east.sqlite");
    let evil = "X'); DROP TABLE fleet.passes; --";
    {
        let mut db = Db::open(&path).unwrap();
        db.insert(&record("e-1", evil, 1.8e9, Some((50.0, 0.6))))
            .unwrap();
        db.insert(&record("e-2", "B2", 1.8e9 + 60.0, None)).unwrap();
    }
    let east = login(&pg, "site_east", "pw-east");
    let db = Db::open_read_only(&path).unwrap();
    assert_eq!(
        Shipper::new(east.clone())
            .round(&db, 10, |_| {})
            .unwrap()
            .passes,
        2
    );
    let mut r = FleetReader::connect(&login(&pg, "planner", "pw-planner")).unwrap();
    let got = r
        .wheel_passes(
            &format!("{evil}/leading"),
            Window {
                last: 5,
                hours: None,
            },
        )
        .unwrap();
    assert_eq!(got.len(), 1, "the wheel id is stored and found as text");
    assert_eq!(got[0].pass.measurement, "e-1.csv");
    assert_eq!(seqs(&a, "east").0, 2, "fleet.passes is still there");

    // A database that ends before what the store holds (restored from an older copy).
    let older = dir.path().join("older.sqlite");
    {
        let mut db = Db::open(&older).unwrap();
        db.insert(&record("o-1", "B9", 1.8e9, None)).unwrap();
    }
    let e = Shipper::new(east.clone())
        .round(&Db::open_read_only(&older).unwrap(), 10, |_| {})
        .unwrap_err();
    assert!(
        matches!(
            e,
            FleetError::Behind {
                fleet: 2,
                local: 1,
                ..
            }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("older.sqlite"), "{e}");

    // A store migrated by a newer wheelflat: refused by name, both versions given.
    let mut c = a.connect().unwrap();
    c.execute(
        "INSERT INTO fleet.schema_migrations (version, name, wheelflat) VALUES (2, 'future', '9.9.9')",
        &[],
    )
    .unwrap();
    let e = match Shipper::new(east).connect() {
        Err(e) => e,
        Ok(_) => panic!("a newer store was accepted"),
    };
    assert!(
        matches!(
            e,
            FleetError::Version {
                found: 2,
                known: 1,
                ..
            }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("schema version 2"), "{e}");
    let e = FleetReader::connect(&login(&pg, "planner", "pw-planner"))
        .err()
        .unwrap();
    assert!(matches!(e, FleetError::Version { .. }), "{e}");
}

#[test]
fn a_site_whose_passes_leave_the_others_is_named_and_a_wrong_password_is_refused() {
    let Some(pg) = PgCluster::start_or_skip("fleet::disagreeing_site") else {
        return;
    };
    fleet_with_sites(&pg, &["a", "b", "c"]);
    let dir = tmp();
    // Wheel W7 seen three times at a and b (60 × 0.8 mm), three times at c as 30 × 0.3 mm,
    // interleaved in time: no growth explains c.
    for (k, site) in ["a", "b", "c"].iter().enumerate() {
        let path = dir.path().join(format!("{site}.sqlite"));
        let mut db = Db::open(&path).unwrap();
        for i in 0..3 {
            let flat = if *site == "c" {
                (30.0, 0.3)
            } else {
                (60.0, 0.8)
            };
            db.insert(&record(
                &format!("{site}-{i}"),
                "W7",
                1.8e9 + 600.0 * i as f64 + 60.0 * k as f64,
                Some(flat),
            ))
            .unwrap();
        }
        ship(&pg, site, &path);
    }
    let mut r = FleetReader::connect(&login(&pg, "planner", "pw-planner")).unwrap();
    let passes = r
        .wheel_passes(
            "W7/leading",
            Window {
                last: 50,
                hours: None,
            },
        )
        .unwrap();
    assert_eq!(passes.len(), 9);
    let across = across_sites(&passes, FusionRule::Robust, 0.95, 40.0, 25.0);
    assert_eq!(
        across.disagreeing,
        vec!["c".to_string()],
        "{:?}",
        across.sites
    );
    let text = wheelflat::fleet::words::across_text(&across);
    assert!(text.contains("DISAGREES"), "{text}");

    // Wheel W8: small at a (three passes), then larger at b (three passes, later): grew
    // across sites, the sites on both sides named.
    for (site, flat, t0) in [
        ("a", (30.0, 0.3), 1.9e9),
        ("b", (60.0, 0.8), 1.9e9 + 86_400.0),
    ] {
        let path = dir.path().join(format!("{site}.sqlite"));
        let mut db = Db::open(&path).unwrap();
        for i in 0..3 {
            db.insert(&record(
                &format!("{site}-w8-{i}"),
                "W8",
                t0 + 600.0 * i as f64,
                Some(flat),
            ))
            .unwrap();
        }
        ship(&pg, site, &path);
    }
    let passes = r
        .wheel_passes(
            "W8/leading",
            Window {
                last: 50,
                hours: None,
            },
        )
        .unwrap();
    let across = across_sites(&passes, FusionRule::Robust, 0.95, 40.0, 25.0);
    let change = across.change.clone().unwrap_or_default();
    assert!(
        change.starts_with("grew between a") && change.contains("and b"),
        "{change:?} {:?}",
        across.joint.agreement
    );
    assert!(
        across.disagreeing.is_empty(),
        "a flat that grew is not a disagreeing site"
    );

    let e = FleetReader::connect(&login(&pg, "planner", "not-the-password"))
        .err()
        .unwrap();
    assert!(matches!(e, FleetError::Connect { .. }), "{e}");
    assert!(!e.to_string().contains("not-the-password"), "{e}");
    // A reader is not a site: it cannot ship.
    let e = Shipper::new(login(&pg, "planner", "pw-planner"))
        .connect()
        .unwrap_err();
    assert!(matches!(e, FleetError::NotASite { .. }), "{e}");
}
