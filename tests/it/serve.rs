//! `wheelflat serve` (docs/serve.md): every page and JSON endpoint on a database made by
//! `identify --db` (good wheels, a flat, a grown flat, a refused pass), through the server's
//! whole router (its access check included); bad paths and queries answered 4xx; a database
//! that is missing, not wheelflat's or newer refused with `history`'s words; a non-local bind
//! without a token refused; reads beside a writer; a version-1 file read as it is.

use crate::common::{cached_bank, narrow_calibration, wheelflat, CachedBank};
use axum::body::Body;
use axum::http::{header, Request, StatusCode};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use tower::ServiceExt;
use wheelflat::history::Db;
use wheelflat::identify::synth::{synthesize, synthesize_pass, FieldNoise};
use wheelflat::model::Flat;
use wheelflat::serve::{router, Settings, Token};

pub(crate) fn bank() -> &'static CachedBank {
    cached_bank("history-narrow", narrow_calibration, 2000, 500)
}

/// The site the tests read: `G1` good wheels (two passes), `F1` a flat (two passes of one
/// flat, the second with its report), `R1` a flat that grew (two shallow passes, then two
/// deep), and a pass refused (its speed outside the bank's).
pub(crate) struct Site {
    _dir: tempfile::TempDir,
    pub(crate) db: PathBuf,
    pub(crate) root: PathBuf,
}

fn identify(bank: &Path, measured: &Path, out: &Path, db: &Path, report: bool) -> bool {
    let mut c = wheelflat();
    c.args(["identify", "--bank"])
        .arg(bank)
        .arg("--measured")
        .arg(measured)
        .arg("--out")
        .arg(out)
        .arg("--db")
        .arg(db);
    if report {
        c.arg("--report");
    }
    c.output().unwrap().status.success()
}

pub(crate) fn site() -> &'static Site {
    static SITE: OnceLock<Site> = OnceLock::new();
    SITE.get_or_init(|| {
        let (bank_dir, cal) = bank();
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().to_path_buf();
        let db = root.join("results.sqlite");
        let good = |seed: u64| {
            let mut csv = synthesize_pass(cal, None, seed, true, FieldNoise::TABLE)
                .unwrap()
                .csv;
            csv.insert_str(0, "# bogie_id = G1\n");
            csv
        };
        let flat = |bogie: &str, l: f64, d: f64, x: f64, seed: u64| {
            let f = Flat::from_mm(l, d, 0.03, x).unwrap();
            let csv = synthesize(cal, &f, seed, true).unwrap().csv;
            format!("# bogie_id = {bogie}\n{csv}")
        };
        let passes: Vec<(&str, String, bool)> = vec![
            ("g0", good(1), false),
            ("g1", good(2), false),
            ("f0", flat("F1", 62.0, 0.47, 12.33, 11), false),
            ("f1", flat("F1", 62.0, 0.47, 12.41, 12), true),
            ("r0", flat("R1", 50.0, 0.31, 12.33, 40), false),
            ("r1", flat("R1", 52.0, 0.31, 12.45, 41), false),
            ("r2", flat("R1", 70.0, 0.59, 12.36, 42), false),
            ("r3", flat("R1", 72.0, 0.59, 12.44, 43), false),
        ];
        for (name, csv, report) in &passes {
            let f = root.join(format!("{name}.csv"));
            std::fs::write(&f, csv).unwrap();
            assert!(
                identify(bank_dir, &f, &root.join(format!("o-{name}")), &db, *report),
                "{name} is identified"
            );
        }
        // A pass refused: its speed 30 % above the bank's.
        let refused = good(3).replace(
            &format!("# speed_km_per_h = {}", cal.run.speed_km_per_h),
            &format!("# speed_km_per_h = {}", cal.run.speed_km_per_h * 1.3),
        );
        let f = root.join("fast.csv");
        std::fs::write(&f, refused).unwrap();
        assert!(!identify(bank_dir, &f, &root.join("o-fast"), &db, false));
        Site {
            _dir: dir,
            db,
            root,
        }
    })
}

pub(crate) fn settings(db: &Path) -> Settings {
    Settings {
        db: db.to_path_buf(),
        bank: Some(bank().0.clone()),
        limits_l0_mm: [25.0, 40.0],
        limits_dynamic_ratio: [2.0, 3.0],
        phi: 0.95,
        token: None,
    }
}

/// One request through the whole router: status, headers, body.
pub(crate) fn get(
    app: &axum::Router,
    uri: &str,
    headers: &[(&str, &str)],
) -> (StatusCode, header::HeaderMap, String) {
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(async {
        let mut req = Request::builder().uri(uri);
        for (k, v) in headers {
            req = req.header(*k, *v);
        }
        let resp = app
            .clone()
            .oneshot(req.body(Body::empty()).unwrap())
            .await
            .unwrap();
        let (parts, body) = resp.into_parts();
        let bytes = axum::body::to_bytes(body, 64 << 20).await.unwrap();
        (
            parts.status,
            parts.headers,
            String::from_utf8_lossy(&bytes).into_owned(),
        )
    })
}

pub(crate) fn json(app: &axum::Router, uri: &str) -> serde_json::Value {
    let (status, _, body) = get(app, uri, &[]);
    assert_eq!(status, StatusCode::OK, "{uri}: {body}");
    serde_json::from_str(&body).unwrap()
}

#[test]
fn every_page_and_its_json_say_the_same_of_the_site() {
    let s = site();
    let app = router(settings(&s.db)).unwrap();

    // The site: 8 passes, 6 wheels, one refused pass with its reason.
    let v = json(&app, "/api/site");
    assert_eq!(v["passes_stored"], 8, "{v}");
    assert_eq!(v["wheels_known"], 6, "{v}");
    let failures = v["failures"].as_array().unwrap();
    assert_eq!(failures.len(), 1, "{v}");
    assert_eq!(failures[0]["kind"], "refused");
    assert!(
        failures[0]["reason"].as_str().unwrap().contains("km/h"),
        "{v}"
    );
    // Needing action, gravest first: R1's flat grew to urgent, F1's is urgent or inspect; the
    // good wheels are not listed.
    let action = action_wheels(&v);
    assert!(!action.is_empty(), "{v}");
    assert!(action.iter().all(|w| !w.starts_with("G1")), "{action:?}");
    assert_eq!(
        v["action"][0]["wheel"]["severity"]["highest"], "urgent",
        "the wheel listed first is acted on as urgent: {v}"
    );
    let (status, _, html) = get(&app, "/", &[]);
    assert_eq!(status, StatusCode::OK);
    // The page lists the same first wheel first, and the refused pass with its reason.
    let first = action[0];
    let table = &html[html.find("id=\"action\"").expect("the action table")..];
    let row = &table[table.find("<tr><td>").unwrap()..];
    assert!(row[..row.find("</tr>").unwrap()].contains(first), "{row}");
    assert!(
        html.contains("refused") && html.contains("fast.csv"),
        "{html}"
    );
    // Filters: class and bogie.
    let u = json(&app, "/api/site?class=none");
    assert!(u["wheels"]
        .as_array()
        .unwrap()
        .iter()
        .all(|w| w["severity"]["highest"] == "none"));
    let g = json(&app, "/api/site?bogie=G1");
    assert_eq!(g["wheels_total"], 2, "{g}");

    // A wheel: the same joint answer `history` gives for the same window.
    let out = s.root.join("h-R1");
    let h = wheelflat()
        .args(["history", "--wheel", "R1/trailing", "--last", "5", "--db"])
        .arg(&s.db)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(h.status.success());
    let history: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("history.json")).unwrap()).unwrap();
    let w = json(&app, "/api/wheel?id=R1%2Ftrailing");
    assert_eq!(w["joint"], history["joint"], "{w}");
    assert_eq!(w["joint"]["agreement"]["kind"], "changed");
    assert_eq!(w["passes"], history["passes"]);
    // Each pass that sized the flat on this wheel carries its impact (the dynamic ratio).
    for p in w["passes"].as_array().unwrap() {
        if p["claim"] == "flat" {
            let d = &p["dynamic_ratio"];
            assert!(
                d[0].as_f64().unwrap() >= 1.0 && d[1].as_f64() >= d[0].as_f64(),
                "{p}"
            );
        }
    }
    let (status, _, page) = get(&app, "/wheel?id=R1%2Ftrailing", &[]);
    assert_eq!(status, StatusCode::OK);
    assert!(page.contains("CHANGED: the flat grew"), "{page}");
    let (status, headers, svg) = get(&app, "/wheel/trend.svg?id=R1%2Ftrailing", &[]);
    assert_eq!(status, StatusCode::OK);
    assert_eq!(headers[header::CONTENT_TYPE], "image/svg+xml");
    assert!(
        svg.starts_with("<svg") && svg.contains("joint ["),
        "{}",
        &svg[..200.min(svg.len())]
    );

    // A pass with its report: the page links the report, the files are handed out, the record
    // downloads.
    let f1 = w_pass_ids(&app, "F1/leading");
    let last = *f1.last().unwrap();
    let p = json(&app, &format!("/api/pass/{last}"));
    assert_eq!(p["pass"]["bogie_id"], "F1");
    assert!(lists_result_file(&p, "report.html"), "{p}");
    report_linked(&app, last, "files");
    let (status, headers, record) = get(&app, &format!("/pass/{last}/record.json"), &[]);
    assert_eq!(status, StatusCode::OK);
    assert!(headers[header::CONTENT_DISPOSITION]
        .to_str()
        .unwrap()
        .contains("attachment"));
    let record: serde_json::Value = serde_json::from_str(&record).unwrap();
    assert_eq!(record, p);

    // A pass whose command wrote only identification.json: its report is drawn by the server
    // (into its own folder: the result folder is left as it was), its figures handed out.
    let r1 = w_pass_ids(&app, "R1/trailing");
    let newest = *r1.last().unwrap();
    let p = json(&app, &format!("/api/pass/{newest}"));
    let dir = std::path::PathBuf::from(p["pass"]["result_dir"].as_str().unwrap());
    let before = std::fs::read_dir(&dir).unwrap().count();
    assert_eq!(
        p["drawn_files"].as_array().unwrap().len(),
        0,
        "the JSON draws nothing"
    );
    let page = report_linked(&app, newest, "drawn");
    let png = page
        .split('"')
        .find(|s| s.starts_with(&format!("/pass/{newest}/drawn/")) && s.ends_with(".png"))
        .expect("the page shows a drawn figure");
    served(&app, png, "image/png");
    assert_eq!(
        std::fs::read_dir(&dir).unwrap().count(),
        before,
        "nothing written beside the result"
    );

    // The health check.
    assert_eq!(json(&app, "/health")["passes"], 8);
}

/// The body at `uri`, answered 200 with a content type starting `kind`.
/// The wheels `/api/site` lists as needing action, in its order.
pub(crate) fn action_wheels(site: &serde_json::Value) -> Vec<&str> {
    site["action"]
        .as_array()
        .unwrap()
        .iter()
        .map(|a| a["wheel"]["wheel_id"].as_str().unwrap())
        .collect()
}

/// Whether `/api/pass/ID` lists `name` among the files its command wrote.
pub(crate) fn lists_result_file(pass: &serde_json::Value, name: &str) -> bool {
    pass["result_files"]
        .as_array()
        .unwrap()
        .iter()
        .any(|f| f == name)
}

fn served(app: &axum::Router, uri: &str, kind: &str) -> String {
    let (status, headers, body) = get(app, uri, &[]);
    assert_eq!(status, StatusCode::OK, "{uri}: {body}");
    let got = headers[header::CONTENT_TYPE].to_str().unwrap();
    assert!(got.starts_with(kind), "{uri}: {got}");
    body
}

/// Pass `id`'s page, which links its `report.html` under `/pass/<id>/<route>/`, handed out as
/// HTML.
fn report_linked(app: &axum::Router, id: i64, route: &str) -> String {
    let uri = format!("/pass/{id}/{route}/report.html");
    let page = served(app, &format!("/pass/{id}"), "text/html");
    assert!(page.contains(&uri), "{page}");
    let report = served(app, &uri, "text/html");
    assert!(report.contains("<html"), "{report}");
    page
}

/// The row ids of a wheel's passes, oldest first.
fn w_pass_ids(app: &axum::Router, wheel: &str) -> Vec<i64> {
    let q = form_urlencoded::Serializer::new(String::new())
        .append_pair("id", wheel)
        .finish();
    json(app, &format!("/api/wheel?{q}"))["pass_ids"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_i64().unwrap())
        .collect()
}

#[test]
fn bad_paths_and_queries_are_answered_4xx_with_the_reason() {
    let s = site();
    let app = router(settings(&s.db)).unwrap();
    for (uri, code, words) in [
        ("/pass/0", 400, "not a pass id"),
        ("/pass/abc", 400, "not a pass id"),
        ("/pass/-3", 400, "not a pass id"),
        ("/pass/99999999", 404, "no pass 99999999"),
        ("/pass/1/files/..%2F..%2Fresults.sqlite", 404, "no file"),
        ("/pass/1/files/missing.png", 404, "no file"),
        ("/api/pass/1e3", 400, "not a pass id"),
        ("/wheel", 400, "id"),
        ("/wheel?id=", 400, "1–300"),
        (
            "/wheel?id=NOPE%2Fleading",
            404,
            "no pass of wheel `NOPE/leading`",
        ),
        ("/wheel?id=F1%2Fleading&last=0", 400, "last=0"),
        ("/wheel?id=F1%2Fleading&last=5000", 400, "last=5000"),
        ("/wheel?id=F1%2Fleading&rule=some", 400, "rule"),
        ("/?hours=-1", 400, "hours=-1"),
        ("/?hours=NaN", 400, "hours=NaN"),
        ("/?hours=abc", 400, "hours"),
        ("/?class=severe", 400, "class"),
        ("/?foo=1", 400, "unknown field `foo`"),
        ("/nothing/here", 404, "nothing at /nothing/here"),
    ] {
        let (status, _, body) = get(&app, uri, &[]);
        assert_eq!(status.as_u16(), code, "{uri}: {body}");
        assert!(body.contains(words), "{uri}: {body}");
    }
    // No write path: anything but GET is refused.
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    let status = rt.block_on(async {
        app.clone()
            .oneshot(Request::post("/").body(Body::from("x")).unwrap())
            .await
            .unwrap()
            .status()
    });
    assert_eq!(status, StatusCode::METHOD_NOT_ALLOWED);
}

#[test]
fn a_database_missing_not_ours_or_newer_is_refused_with_historys_words() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("none.sqlite");
    let text = dir.path().join("notes.sqlite");
    std::fs::write(&text, "plain text, not a database\n".repeat(30)).unwrap();
    let newer = dir.path().join("newer.sqlite");
    drop(Db::open(&newer).unwrap());
    rusqlite::Connection::open(&newer)
        .unwrap()
        .execute_batch("PRAGMA user_version = 9;")
        .unwrap();
    for db in [&missing, &text, &newer] {
        let served = router(settings(db)).expect_err("refused").to_string();
        let out = wheelflat()
            .args(["history", "--db"])
            .arg(db)
            .output()
            .unwrap();
        assert!(!out.status.success());
        let history = String::from_utf8_lossy(&out.stderr);
        assert!(
            history.contains(&served),
            "serve: {served}\nhistory: {history}"
        );
        // The binary says the same and writes nothing.
        let out = wheelflat()
            .args(["serve", "--listen", "127.0.0.1:0", "--db"])
            .arg(db)
            .output()
            .unwrap();
        assert!(!out.status.success());
        assert!(String::from_utf8_lossy(&out.stderr).contains(&served));
    }
    assert!(!missing.exists(), "serve creates no database");
}

#[test]
fn a_non_local_address_without_a_token_is_refused_and_a_token_is_required_when_set() {
    let s = site();
    let out = wheelflat()
        .args(["serve", "--listen", "0.0.0.0:0", "--db"])
        .arg(&s.db)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("refusing to listen on 0.0.0.0:0 without a token"),
        "{err}"
    );
    // A token too short is refused by name.
    let short = s.root.join("short.token");
    std::fs::write(&short, "abc\n").unwrap();
    let out = wheelflat()
        .args(["serve", "--listen", "0.0.0.0:0", "--token-file"])
        .arg(&short)
        .arg("--db")
        .arg(&s.db)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("short.token") && err.contains("at least 16"),
        "{err}"
    );

    let token = "correct-horse-battery-staple";
    let mut with = settings(&s.db);
    with.token = Some(Token::new(token).unwrap());
    let app = router(with).unwrap();
    let (status, _, body) = get(&app, "/api/site", &[]);
    assert_eq!(status, StatusCode::UNAUTHORIZED, "{body}");
    let (status, _, _) = get(
        &app,
        "/api/site",
        &[("authorization", "Bearer wrong-token-wrong-token")],
    );
    assert_eq!(status, StatusCode::UNAUTHORIZED);
    let bearer = format!("Bearer {token}");
    let (status, _, _) = get(&app, "/api/site", &[("authorization", &bearer)]);
    assert_eq!(status, StatusCode::OK);
    // Once in the query, then the cookie it sets.
    let (status, headers, _) = get(&app, &format!("/?token={token}"), &[]);
    assert_eq!(status, StatusCode::OK);
    let cookie = headers[header::SET_COOKIE].to_str().unwrap();
    assert!(cookie.contains("HttpOnly"), "{cookie}");
    let cookie = cookie.split(';').next().unwrap();
    let (status, _, _) = get(&app, "/wheel?id=F1%2Fleading", &[("cookie", cookie)]);
    assert_eq!(status, StatusCode::OK);
}

#[test]
fn pages_are_read_while_identify_writes_and_the_new_passes_appear() {
    let s = site();
    let (bank_dir, cal) = bank();
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("results.sqlite");
    std::fs::copy(&s.db, &db).unwrap();
    let app = router(settings(&db)).unwrap();
    let before = json(&app, "/api/site")["passes_stored"].as_u64().unwrap();
    let writer = {
        let (bank_dir, cal, db, dir) = (
            bank_dir.clone(),
            cal.clone(),
            db.clone(),
            dir.path().to_path_buf(),
        );
        std::thread::spawn(move || {
            for k in 0..3u64 {
                let f = Flat::from_mm(62.0, 0.47, 0.03, 12.33 + 0.01 * k as f64).unwrap();
                let csv = synthesize(&cal, &f, 900 + k, true).unwrap().csv;
                let m = dir.join(format!("w{k}.csv"));
                std::fs::write(&m, format!("# bogie_id = W1\n{csv}")).unwrap();
                assert!(identify(
                    &bank_dir,
                    &m,
                    &dir.join(format!("o{k}")),
                    &db,
                    false
                ));
            }
        })
    };
    let mut reads = 0;
    while !writer.is_finished() {
        for uri in ["/", "/api/site", "/wheel?id=F1%2Fleading"] {
            let (status, _, body) = get(&app, uri, &[]);
            assert_eq!(status, StatusCode::OK, "{uri} beside the writer: {body}");
            reads += 1;
        }
    }
    writer.join().unwrap();
    assert!(reads > 0);
    let after = json(&app, "/api/site");
    assert_eq!(
        after["passes_stored"].as_u64().unwrap(),
        before + 3,
        "{after}"
    );
    // Only the writer's process wrote: the server's connections are read-only.
    let c = rusqlite::Connection::open_with_flags(&db, rusqlite::OpenFlags::SQLITE_OPEN_READ_ONLY)
        .unwrap();
    assert!(c.is_readonly(rusqlite::MAIN_DB).unwrap());
}

#[test]
fn a_version_1_database_is_read_as_it_is_and_upgraded_by_a_writer() {
    let s = site();
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("v1.sqlite");
    std::fs::copy(&s.db, &db).unwrap();
    // Version 1: no failures table, no result folders, no dynamic ratio.
    rusqlite::Connection::open(&db)
        .unwrap()
        .execute_batch(
            "DROP TABLE outbox; ALTER TABLE passes DROP COLUMN answer_ms; DROP TABLE failures; ALTER TABLE passes DROP COLUMN result_dir; ALTER TABLE wheel_passes DROP COLUMN dynamic_ratio_min; ALTER TABLE wheel_passes DROP COLUMN dynamic_ratio_max; PRAGMA user_version = 1;",
        )
        .unwrap();
    let app = router(settings(&db)).unwrap();
    let v = json(&app, "/api/site");
    assert_eq!(v["passes_stored"], 8);
    assert_eq!(v["failures"].as_array().unwrap().len(), 0);
    let version = |db: &Path| -> i32 {
        rusqlite::Connection::open(db)
            .unwrap()
            .query_row("PRAGMA user_version", [], |r| r.get(0))
            .unwrap()
    };
    assert_eq!(version(&db), 1, "serve leaves the file as it was");
    // A writer upgrades it, keeping every pass.
    drop(Db::open_existing(&db).unwrap());
    assert_eq!(version(&db), 3);
    let app = router(settings(&db)).unwrap();
    assert_eq!(json(&app, "/api/site")["passes_stored"], 8);
}
