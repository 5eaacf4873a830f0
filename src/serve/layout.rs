//! The page around every view: title, navigation, the class colours, and a refresh of the
//! page's main part every [`REFRESH_S`] seconds without reloading the page (a request with the
//! `x-wheelflat-fragment` header is answered with the main part alone).

use crate::identify::{Severity, SeverityRange};
use axum::http::HeaderMap;
use axum::response::{Html, IntoResponse, Response};
use maud::{html, Markup, PreEscaped, DOCTYPE};

/// Seconds between refreshes of an open page.
pub(super) const REFRESH_S: u32 = 15;

/// The header that asks for the main part alone.
pub(super) const FRAGMENT_HEADER: &str = "x-wheelflat-fragment";

const STYLE: &str = "
body{font-family:system-ui,sans-serif;margin:0;color:#1b1b1b;background:#fafafa}
header{background:#24313f;color:#fff;padding:.6rem 1.2rem;display:flex;gap:1.5rem;align-items:baseline}
header a{color:#fff;text-decoration:none;font-weight:600}
header .where{color:#b8c4d0;font-size:.9rem}
main{padding:1rem 1.2rem;max-width:1300px}
h1{font-size:1.35rem;margin:.2rem 0 .8rem} h2{font-size:1.1rem;margin:1.4rem 0 .5rem}
table{border-collapse:collapse;background:#fff;font-size:.9rem}
th,td{border:1px solid #d6d6d6;padding:.25rem .5rem;text-align:left;vertical-align:top}
th{background:#eef1f4}
td.num{text-align:right;font-variant-numeric:tabular-nums}
.badge{display:inline-block;border-radius:.3rem;padding:0 .4rem;font-weight:600;color:#fff}
.none{background:#8a8f95}.monitor{background:#2f6db5}.inspect{background:#c77a00}.urgent{background:#c0392b}
.refused,.failed{background:#6d4c9f} .pending{background:#8a8f95} .sent{background:#2e7d32}
.note{color:#555;font-size:.9rem} .changed{font-weight:600;color:#c0392b}
form.filter{display:flex;gap:.8rem;align-items:end;margin:.4rem 0 .6rem;font-size:.9rem}
form.filter label{display:flex;flex-direction:column}
.figure svg{max-width:100%;height:auto;background:#fff;border:1px solid #d6d6d6}
img.figure{max-width:100%;border:1px solid #d6d6d6;background:#fff}
";

/// Every REFRESH_S seconds, the main part again (a failed fetch keeps what is shown and says
/// so in the page's status line).
const SCRIPT: &str = "
setInterval(async () => {
  try {
    const r = await fetch(location.href, {headers: {'x-wheelflat-fragment': '1'}});
    if (!r.ok) throw new Error(r.status);
    document.querySelector('main').innerHTML = await r.text();
  } catch (e) {
    const s = document.getElementById('status');
    if (s) s.textContent = 'not refreshed: ' + e.message;
  }
}, REFRESH_MS);
";

/// The whole page, or its main part when the request asked for the fragment.
pub(super) fn respond(headers: &HeaderMap, title: &str, main: Markup) -> Response {
    if headers.contains_key(FRAGMENT_HEADER) {
        return Html(main.into_string()).into_response();
    }
    let script = SCRIPT.replace("REFRESH_MS", &(REFRESH_S * 1000).to_string());
    Html(
        html! {
            (DOCTYPE)
            html lang="en" {
                head {
                    meta charset="utf-8";
                    meta name="viewport" content="width=device-width, initial-scale=1";
                    title { (title) " — wheelflat" }
                    style { (PreEscaped(STYLE)) }
                }
                body {
                    header {
                        a href="/" { "wheelflat" }
                        span.where { (title) }
                        span.where id="status" {}
                    }
                    main { (main) }
                    script { (PreEscaped(script)) }
                }
            }
        }
        .into_string(),
    )
    .into_response()
}

/// A class as a coloured badge.
pub(super) fn class_badge(s: Severity) -> Markup {
    html! { span class={"badge " (s.as_str())} { (s.as_str()) } }
}

/// The classes of a range as badges (`inspect–urgent`), or a dash.
pub(super) fn range_badges(s: Option<SeverityRange>) -> Markup {
    match s {
        None => html! { "—" },
        Some(r) if r.lowest == r.highest => class_badge(r.highest),
        Some(r) => html! { (class_badge(r.lowest)) "–" (class_badge(r.highest)) },
    }
}

/// An L0 range in mm, or a dash.
pub(super) fn l0_words(r: Option<[f64; 2]>) -> String {
    r.map_or("—".into(), |r| format!("[{:.0}, {:.0}] mm", r[0], r[1]))
}

/// A number with `digits` decimals, or a dash.
pub(super) fn number(v: Option<f64>, digits: usize) -> String {
    v.map_or("—".into(), |v| format!("{v:.digits$}"))
}

/// The link to a wheel's page (its id percent-encoded as a query value).
pub(super) fn wheel_href(wheel_id: &str) -> String {
    let q = form_urlencoded::Serializer::new(String::new())
        .append_pair("id", wheel_id)
        .finish();
    format!("/wheel?{q}")
}
