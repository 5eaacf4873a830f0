//! `wheelflat serve` in a real browser (acceptance tier): headless Chromium (Debian's package,
//! which `.ci/run` installs) loads the site, a wheel and a pass page from the binary; the
//! screenshots are checked — the wheel needing action listed first on the site page (read from
//! the DOM Chromium built, the refresh script included), the trend figure not empty (the
//! urgent limit's red and the pass bars' black drawn) — and kept in
//! `target/serve-screenshots/` for a person to look at. And the README's one command,
//! `demo --serve`: its site served with the passes it says.

use super::serve::site;
use crate::common::wheelflat_path;
use std::io::BufRead;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

/// The browser: `WHEELFLAT_CHROMIUM`, else Debian's `/usr/bin/chromium`.
fn chromium() -> PathBuf {
    let p = std::env::var_os("WHEELFLAT_CHROMIUM")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("/usr/bin/chromium"));
    assert!(
        p.is_file(),
        "no browser at {} (Debian: apt-get install chromium; .ci/run installs it; or set WHEELFLAT_CHROMIUM)",
        p.display()
    );
    p
}

/// The server, stopped when dropped.
pub(super) struct Server(Child);

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Starts `wheelflat serve` on a free port; the server and its base URL.
fn serve(db: &Path) -> (Server, String) {
    let mut child = Command::new(wheelflat_path())
        .args(["serve", "--listen", "127.0.0.1:0", "--db"])
        .arg(db)
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .unwrap();
    let mut line = String::new();
    std::io::BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    let url = line
        .split_whitespace()
        .find(|w| w.starts_with("http://"))
        .unwrap_or_else(|| panic!("no address in `{line}`"))
        .trim_end_matches('/')
        .to_string();
    (Server(child), url)
}

fn browser(args: &[&str], url: &str) -> std::process::Output {
    let home = tempfile::tempdir().unwrap();
    Command::new(chromium())
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--hide-scrollbars",
            "--window-size=1300,1600",
            "--virtual-time-budget=3000",
        ])
        .arg(format!("--user-data-dir={}", home.path().display()))
        .args(args)
        .arg(url)
        .output()
        .unwrap()
}

fn screenshot(url: &str, to: &Path) -> image::RgbImage {
    let out = browser(&[&format!("--screenshot={}", to.display())], url);
    assert!(
        to.is_file(),
        "{url}: no screenshot: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    image::open(to).unwrap().to_rgb8()
}

/// Pixels within 40 (per channel) of `rgb`.
fn pixels_near(img: &image::RgbImage, rgb: [u8; 3]) -> usize {
    img.pixels()
        .filter(|p| (0..3).all(|i| (p.0[i] as i32 - rgb[i] as i32).abs() <= 40))
        .count()
}

#[test]
#[ignore = "acceptance: a real browser (headless Chromium), ~10 s"]
fn a_browser_shows_the_site_the_wheel_needing_action_first_and_a_non_empty_trend() {
    if std::env::var_os("WHEELFLAT_SKIP_BROWSER").is_some() {
        eprintln!("SKIPPED: WHEELFLAT_SKIP_BROWSER is set (no browser on this machine; .ci/run installs Debian's chromium as root)");
        return;
    }
    let s = site();
    let (_server, url) = serve(&s.db);
    let shots = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .parent()
        .unwrap()
        .join("serve-screenshots");
    std::fs::create_dir_all(&shots).unwrap();

    // The site: what the JSON lists first is the first row Chromium shows.
    let site_json: serde_json::Value =
        serde_json::from_slice(&browser(&["--dump-dom"], &format!("{url}/api/site")).stdout)
            .ok()
            .or_else(|| {
                // Chromium wraps JSON in a <pre>: read it from the DOM.
                let dom = String::from_utf8_lossy(
                    &browser(&["--dump-dom"], &format!("{url}/api/site")).stdout,
                )
                .to_string();
                let a = dom.find('{')?;
                let b = dom.rfind('}')?;
                serde_json::from_str(&decode_entities(&dom[a..=b])).ok()
            })
            .expect("the site's JSON in the browser");
    let first = site_json["action"][0]["wheel"]["wheel_id"]
        .as_str()
        .expect("a wheel needs action")
        .to_string();
    assert_eq!(
        site_json["action"][0]["wheel"]["severity"]["highest"],
        "urgent"
    );
    let dom =
        String::from_utf8_lossy(&browser(&["--dump-dom"], &format!("{url}/")).stdout).to_string();
    let table = &dom[dom
        .find("id=\"action\"")
        .expect("the action table in the DOM")..];
    let first_row = &table[table.find("<td>").unwrap()..];
    let first_row = &first_row[..first_row.find("</tr>").unwrap()];
    assert!(first_row.contains(&first), "first row: {first_row}");
    let img = screenshot(&format!("{url}/"), &shots.join("site.png"));
    // The badges: urgent's red is on the page.
    assert!(
        pixels_near(&img, [192, 57, 43]) > 200,
        "no urgent badge drawn"
    );

    // The wheel: the trend figure is drawn (the urgent limit's red dashes, the pass bars).
    let q = form_urlencoded::Serializer::new(String::new())
        .append_pair("id", &first)
        .finish();
    let img = screenshot(&format!("{url}/wheel?{q}"), &shots.join("wheel.png"));
    let red = pixels_near(&img, [200, 0, 0]);
    let black = pixels_near(&img, [0, 0, 0]);
    assert!(
        red > 300,
        "the urgent limit is not drawn ({red} red pixels)"
    );
    assert!(
        black > 2000,
        "no pass bars or axes drawn ({black} black pixels)"
    );

    // The pass: its page and the report figures it links.
    let pass = site_json["action"][0]["wheel"]["last_pass_id"]
        .as_i64()
        .unwrap();
    let img = screenshot(&format!("{url}/pass/{pass}"), &shots.join("pass.png"));
    assert!(
        pixels_near(&img, [36, 49, 63]) > 1000,
        "the page's header is not drawn"
    );
    let dom =
        String::from_utf8_lossy(&browser(&["--dump-dom"], &format!("{url}/pass/{pass}")).stdout)
            .to_string();
    assert!(dom.contains(&format!("Pass {pass}")), "{dom}");
}

/// The few entities Chromium writes in a `<pre>` of JSON.
fn decode_entities(s: &str) -> String {
    s.replace("&quot;", "\"")
        .replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&amp;", "&")
}

/// `demo --instances 2000 --serve` into `dir` (with `extra` arguments): the server and the
/// base URL it says it serves on (read from its output, after the demo's passes are stored
/// and, with `--alarms`, their alarms posted).
pub(super) fn serve_the_demo(dir: &Path, extra: &[&std::ffi::OsStr]) -> (Server, String) {
    let mut child = Command::new(wheelflat_path())
        .args([
            "demo",
            "--instances",
            "2000",
            "--serve",
            "--listen",
            "127.0.0.1:0",
        ])
        .arg("--out")
        .arg(dir.join("demo"))
        .arg("--bank")
        .arg(dir.join("bank"))
        .args(extra)
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let stdout = std::io::BufReader::new(child.stdout.take().unwrap());
    let mut url = None;
    for line in stdout.lines() {
        let line = line.unwrap();
        if let Some(u) = line.split_whitespace().find(|w| w.starts_with("http://")) {
            url = Some(u.trim_end_matches('/').to_string());
            break;
        }
    }
    let server = Server(child);
    (server, url.expect("the demo says where it serves"))
}

#[test]
#[ignore = "acceptance: the demo with a 2,000-instance bank, then its site served (over HTTP, no browser), ~20 s"]
fn the_demo_serves_its_site() {
    let dir = tempfile::tempdir().unwrap();
    let (server, url) = serve_the_demo(dir.path(), &[]);
    let body = ureq::get(&format!("{url}/api/site"))
        .call()
        .unwrap()
        .body_mut()
        .read_to_string()
        .unwrap();
    let site: serde_json::Value = serde_json::from_str(&body).unwrap();
    assert_eq!(site["passes_stored"], 11, "{site}");
    assert_eq!(site["wheels_known"], 8, "{site}");
    let failures = site["failures"].as_array().unwrap();
    assert_eq!(failures.len(), 1, "{site}");
    assert_eq!(failures[0]["kind"], "refused");
    let action = super::serve::action_wheels(&site);
    assert!(
        action
            .iter()
            .all(|w| !w.starts_with("D1") && !w.starts_with("D4")),
        "good wheels need no action: {action:?}"
    );
    drop(server);
}
