//! `alarms.toml`: the rules on, the site's name, the webhooks (each with its HMAC secret in a
//! file of its own) and how delivery retries — read once, at start, and refused by name when
//! anything in it is wrong (docs/alarms.md, "Configuration").

use super::error::AlarmError;
use crate::history::{AlarmPlan, Rule};
use serde::Deserialize;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// The largest configuration or secret file read (bytes).
const MAX_FILE_BYTES: u64 = 64 << 10;
/// The shortest secret accepted (bytes, after trimming white space).
pub const MIN_SECRET_BYTES: usize = 16;

/// The file as written.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Raw {
    site: Option<String>,
    rules: Vec<String>,
    #[serde(default = "default_refusals")]
    refusals_per_hour: usize,
    #[serde(default = "default_window")]
    window: usize,
    #[serde(default)]
    delivery: RawDelivery,
    #[serde(default)]
    webhook: Vec<RawWebhook>,
}

fn default_refusals() -> usize {
    5
}

fn default_window() -> usize {
    5
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawDelivery {
    #[serde(default = "default_timeout")]
    timeout_s: f64,
    #[serde(default = "default_first_retry")]
    first_retry_s: f64,
    #[serde(default = "default_max_retry")]
    max_retry_s: f64,
}

impl Default for RawDelivery {
    fn default() -> RawDelivery {
        RawDelivery {
            timeout_s: default_timeout(),
            first_retry_s: default_first_retry(),
            max_retry_s: default_max_retry(),
        }
    }
}

fn default_timeout() -> f64 {
    30.0
}

fn default_first_retry() -> f64 {
    5.0
}

fn default_max_retry() -> f64 {
    600.0
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawWebhook {
    name: String,
    url: String,
    secret_file: PathBuf,
}

/// An HMAC key, read from its file; never printed (its `Debug` says only that it is one).
#[derive(Clone)]
pub struct Secret(Vec<u8>);

impl Secret {
    /// The key's bytes.
    pub(super) fn bytes(&self) -> &[u8] {
        &self.0
    }
}

impl std::fmt::Debug for Secret {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Secret(…)")
    }
}

/// A webhook alarms are posted to.
#[derive(Debug, Clone)]
pub struct Webhook {
    /// Its name: the outbox's destination.
    pub name: String,
    /// Where (https, or http on localhost only).
    pub url: String,
    /// The key of the `X-Wheelflat-Signature` header.
    pub secret: Secret,
}

/// How delivery waits and retries.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Delivery {
    /// The longest a request may take, connection to answer.
    pub timeout: Duration,
    /// The wait after a first failed try (s); doubled after each further one.
    pub first_retry_s: f64,
    /// The longest wait between tries (s).
    pub max_retry_s: f64,
}

impl Delivery {
    /// The wait after the `attempts`-th failed try (1: the first): `first_retry_s · 2^(attempts−1)`,
    /// at most `max_retry_s`.
    pub fn backoff_s(&self, attempts: u32) -> f64 {
        let doublings = attempts.saturating_sub(1).min(40) as i32;
        (self.first_retry_s * 2f64.powi(doublings)).min(self.max_retry_s)
    }
}

/// The alarms' configuration, checked.
#[derive(Debug, Clone)]
pub struct AlarmConfig {
    /// The file it was read from.
    pub path: PathBuf,
    /// The site's name, put in every body.
    pub site: Option<String>,
    /// The rules on.
    pub rules: Vec<Rule>,
    /// [`Rule::Refusals`]: this many refused passes within an hour.
    pub refusals_per_hour: usize,
    /// How many of a wheel's newest passes [`Rule::FlatGrew`] fuses.
    pub window: usize,
    /// How delivery waits and retries.
    pub delivery: Delivery,
    /// Where alarms go.
    pub webhooks: Vec<Webhook>,
}

/// Reads a small file whole, refusing one over [`MAX_FILE_BYTES`].
fn read_small(path: &Path) -> Result<Vec<u8>, std::io::Error> {
    use std::io::Read;
    let mut bytes = Vec::new();
    std::fs::File::open(path)?
        .take(MAX_FILE_BYTES + 1)
        .read_to_end(&mut bytes)?;
    if bytes.len() as u64 > MAX_FILE_BYTES {
        return Err(std::io::Error::other(format!(
            "more than {MAX_FILE_BYTES} bytes"
        )));
    }
    Ok(bytes)
}

/// Why `url` may not receive alarms: it must be https, or http to this machine (localhost,
/// 127.0.0.1, [::1]), with a host and no user or password in it.
// Err(String): the reason, which AlarmError::Url names with the webhook and the URL.
fn check_url(url: &str) -> Result<(), String> {
    let uri: ureq::http::Uri = url.parse().map_err(|e| format!("not a URL ({e})"))?;
    let host = uri.host().ok_or("no host")?;
    if uri.authority().is_some_and(|a| a.as_str().contains('@')) {
        return Err("a user or password in the URL (the secret goes in secret_file)".into());
    }
    let local = matches!(host, "localhost" | "127.0.0.1" | "[::1]" | "::1");
    match uri.scheme_str() {
        Some("https") => Ok(()),
        Some("http") if local => Ok(()),
        Some("http") => Err("http outside localhost: alarms travel over https".into()),
        Some(other) => Err(format!("scheme `{other}`: alarms travel over https")),
        None => Err("no scheme (https://…)".into()),
    }
}

impl AlarmConfig {
    /// Reads and checks `path`: every rule known, every URL https (or http on localhost),
    /// every secret file there and long enough, names unique, at least one webhook.
    pub fn read(path: &Path) -> Result<AlarmConfig, AlarmError> {
        let file = path.to_path_buf();
        let bytes = read_small(path).map_err(|source| AlarmError::Read {
            path: file.clone(),
            source,
        })?;
        let text =
            String::from_utf8(bytes).map_err(|_| AlarmError::NotUtf8 { path: file.clone() })?;
        let raw: Raw = toml::from_str(&text).map_err(|source| AlarmError::Parse {
            path: file.clone(),
            source: Box::new(source),
        })?;
        let mut rules = Vec::new();
        for r in &raw.rules {
            let rule = Rule::parse(r).ok_or_else(|| AlarmError::UnknownRule {
                path: file.clone(),
                rule: r.clone(),
            })?;
            if !rules.contains(&rule) {
                rules.push(rule);
            }
        }
        let positive = |key: &'static str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(AlarmError::Value {
                    path: file.clone(),
                    key,
                    why: format!("{v}: must be a positive number of seconds"),
                })
            }
        };
        positive("delivery.timeout_s", raw.delivery.timeout_s)?;
        positive("delivery.first_retry_s", raw.delivery.first_retry_s)?;
        positive("delivery.max_retry_s", raw.delivery.max_retry_s)?;
        if raw.refusals_per_hour == 0 {
            return Err(AlarmError::Value {
                path: file.clone(),
                key: "refusals_per_hour",
                why: "0: at least one refusal".into(),
            });
        }
        if !(2..=100).contains(&raw.window) {
            return Err(AlarmError::Value {
                path: file.clone(),
                key: "window",
                why: format!("{}: 2 to 100 passes", raw.window),
            });
        }
        if raw.webhook.is_empty() {
            return Err(AlarmError::NoDestination { path: file });
        }
        let dir = path.parent().unwrap_or(Path::new("."));
        let mut webhooks: Vec<Webhook> = Vec::new();
        for w in raw.webhook {
            let name_ok = !w.name.is_empty()
                && w.name.len() <= 64
                && w.name
                    .bytes()
                    .all(|b| b.is_ascii_alphanumeric() || b"-_.".contains(&b));
            if !name_ok {
                return Err(AlarmError::Value {
                    path: file.clone(),
                    key: "webhook.name",
                    why: format!("`{}`: 1–64 letters, digits, `-_.`", w.name),
                });
            }
            if webhooks.iter().any(|x| x.name == w.name) {
                return Err(AlarmError::DuplicateName {
                    path: file.clone(),
                    name: w.name,
                });
            }
            check_url(&w.url).map_err(|why| AlarmError::Url {
                path: file.clone(),
                name: w.name.clone(),
                url: w.url.clone(),
                why,
            })?;
            let secret_path = dir.join(&w.secret_file);
            let secret = read_small(&secret_path).map_err(|source| AlarmError::Secret {
                name: w.name.clone(),
                path: secret_path.clone(),
                source,
            })?;
            let trimmed = secret.trim_ascii().to_vec();
            if trimmed.len() < MIN_SECRET_BYTES {
                return Err(AlarmError::ShortSecret {
                    name: w.name.clone(),
                    path: secret_path,
                    bytes: trimmed.len(),
                    needed: MIN_SECRET_BYTES,
                });
            }
            webhooks.push(Webhook {
                name: w.name,
                url: w.url,
                secret: Secret(trimmed),
            });
        }
        Ok(AlarmConfig {
            path: file,
            site: raw.site,
            rules,
            refusals_per_hour: raw.refusals_per_hour,
            window: raw.window,
            delivery: Delivery {
                timeout: Duration::from_secs_f64(raw.delivery.timeout_s),
                first_retry_s: raw.delivery.first_retry_s,
                max_retry_s: raw.delivery.max_retry_s,
            },
            webhooks,
        })
    }

    /// What a writer raises ([`crate::history::Db::raise_alarms`]), with the class limits on
    /// L0 (mm: inspect, urgent) and φ the passes are fused at.
    pub fn plan(&self, limits_l0_mm: [f64; 2], phi: f64) -> AlarmPlan {
        AlarmPlan {
            rules: self.rules.clone(),
            destinations: self.webhooks.iter().map(|w| w.name.clone()).collect(),
            site: self.site.clone(),
            refusals_per_hour: self.refusals_per_hour,
            limits_l0_mm,
            phi,
            window: self.window,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_https_or_localhost_http_is_accepted() {
        assert!(check_url("https://alarms.example.org/wf").is_ok());
        assert!(check_url("http://127.0.0.1:8080/hook").is_ok());
        assert!(check_url("http://localhost/hook").is_ok());
        assert!(check_url("http://[::1]:9/hook").is_ok());
        assert!(check_url("http://alarms.example.org/wf").is_err());
        assert!(check_url("http://10.0.0.1/wf").is_err());
        assert!(check_url("ftp://localhost/wf").is_err());
        assert!(check_url("https://user:pw@alarms.example.org/").is_err());
        assert!(check_url("alarms.example.org").is_err());
    }

    #[test]
    fn the_wait_doubles_up_to_its_cap() {
        let d = Delivery {
            timeout: Duration::from_secs(1),
            first_retry_s: 5.0,
            max_retry_s: 600.0,
        };
        let waits: Vec<f64> = (1..=9).map(|a| d.backoff_s(a)).collect();
        let first = [5.0, 10.0, 20.0, 40.0];
        assert!(waits.iter().zip(first).all(|(w, f)| (w - f).abs() < 1e-9));
        assert!(waits.iter().all(|&w| w <= 600.0));
        assert!((d.backoff_s(9) - 600.0).abs() < 1e-9);
        assert!((d.backoff_s(1000) - 600.0).abs() < 1e-9);
    }

    #[test]
    fn a_secret_never_shows_in_debug() {
        let s = Secret(b"0123456789abcdef-very-secret".to_vec());
        assert!(!format!("{s:?}").contains("secret-"));
    }
}
