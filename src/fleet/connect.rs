//! Reaching the fleet store: a `postgresql://` URL without its password, the password from a
//! file or the environment (never the command line, never a log line), TLS checked against
//! the operator's CA (rustls; the same stack as the alarms' webhooks). A store on another
//! machine is only reached over TLS.

use super::FleetError;
use postgres::config::{Host, SslMode};
use postgres::{Client, Config, NoTls};
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

/// The longest password file read (bytes).
pub const MAX_PASSWORD_BYTES: u64 = 1024;
/// The longest CA file read (bytes).
pub const MAX_CA_BYTES: u64 = 1 << 20;
/// How long a connection attempt waits (s) unless the URL says (`connect_timeout=`).
pub const CONNECT_TIMEOUT_S: u64 = 10;

/// A password, kept out of `Debug` and `Display`.
#[derive(Clone)]
pub struct Password(String);

impl Password {
    /// A password given as text (trailing newline removed); refused when empty or with a NUL.
    pub fn new(text: &str, from: &Path) -> Result<Password, FleetError> {
        let p = text.trim_end_matches(['\n', '\r']);
        let why = if p.is_empty() {
            Some("empty")
        } else if p.contains('\0') {
            Some("holds a NUL byte")
        } else {
            None
        };
        match why {
            Some(why) => Err(FleetError::File {
                what: "password",
                path: from.to_path_buf(),
                why: why.into(),
            }),
            None => Ok(Password(p.to_string())),
        }
    }

    /// The password in a file (its first line; at most [`MAX_PASSWORD_BYTES`]); refused when
    /// others than its owner may read it (as libpq ignores such a `.pgpass`).
    pub fn from_file(path: &Path) -> Result<Password, FleetError> {
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            if let Ok(m) = std::fs::metadata(path) {
                if m.permissions().mode() & 0o077 != 0 {
                    return Err(FleetError::File {
                        what: "password",
                        path: path.to_path_buf(),
                        why: format!(
                            "mode {:o}: readable by others than its owner (chmod 600 it)",
                            m.permissions().mode() & 0o777
                        ),
                    });
                }
            }
        }
        let text = read_bounded(path, MAX_PASSWORD_BYTES, "password")?;
        Password::new(text.lines().next().unwrap_or(""), path)
    }

    /// The text.
    pub(crate) fn expose(&self) -> &str {
        &self.0
    }
}

impl fmt::Debug for Password {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("Password(…)")
    }
}

/// A file read whole, refused by name when absent, too long or not UTF-8.
fn read_bounded(path: &Path, max: u64, what: &'static str) -> Result<String, FleetError> {
    let err = |why: String| FleetError::File {
        what,
        path: path.to_path_buf(),
        why,
    };
    let meta = std::fs::metadata(path).map_err(|e| err(e.to_string()))?;
    if !meta.is_file() {
        return Err(err("not a regular file".into()));
    }
    if meta.len() > max {
        return Err(err(format!(
            "{} bytes, more than the {max} allowed",
            meta.len()
        )));
    }
    let bytes = std::fs::read(path).map_err(|e| err(e.to_string()))?;
    String::from_utf8(bytes).map_err(|_| err("not UTF-8 text".into()))
}

/// Where the fleet store is and how to reach it.
#[derive(Clone)]
pub struct FleetTarget {
    config: Config,
    tls: Option<Arc<rustls::ClientConfig>>,
    shown: String,
}

impl fmt::Debug for FleetTarget {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "FleetTarget({})", self.shown)
    }
}

impl FleetTarget {
    /// The store at `url` (no password in it), logging in with `password`, checking the
    /// server's certificate against `ca` (PEM) when TLS is used. A host other than this
    /// machine must be reached with `sslmode=require`.
    pub fn new(
        url: &str,
        password: Option<Password>,
        ca: Option<&Path>,
    ) -> Result<FleetTarget, FleetError> {
        let bad = |why: String| FleetError::Url {
            url: url.to_string(),
            why,
        };
        if !(url.starts_with("postgresql://") || url.starts_with("postgres://")) {
            return Err(bad("not a postgresql:// URL".into()));
        }
        let mut config: Config = url.parse().map_err(|e| bad(format!("{e}")))?;
        if config.get_password().is_some() {
            return Err(FleetError::PasswordInUrl);
        }
        if config.get_hosts().is_empty() {
            return Err(bad("no host".into()));
        }
        if config.get_user().is_none() {
            return Err(bad("no user (postgresql://USER@HOST/…)".into()));
        }
        let mode = config.get_ssl_mode();
        let remote = config.get_hosts().iter().find_map(|h| match h {
            Host::Tcp(name) if !is_loopback(name) => Some(name.clone()),
            _ => None,
        });
        if let Some(host) = remote {
            if mode != SslMode::Require {
                return Err(FleetError::Plaintext { host });
            }
        }
        let tls = match (ca, mode) {
            (Some(ca), _) => Some(Arc::new(client_config(ca)?)),
            (None, SslMode::Require) => return Err(FleetError::NoCa),
            (None, _) => None,
        };
        if tls.is_none() {
            config.ssl_mode(SslMode::Disable);
        }
        if config.get_connect_timeout().is_none() {
            config.connect_timeout(Duration::from_secs(CONNECT_TIMEOUT_S));
        }
        config.application_name("wheelflat");
        if let Some(p) = &password {
            config.password(p.expose());
        }
        let shown = show(&config);
        Ok(FleetTarget { config, tls, shown })
    }

    /// `user@host:port/database`, for messages (no password).
    pub fn shown(&self) -> &str {
        &self.shown
    }

    /// The login's name.
    pub fn user(&self) -> &str {
        self.config.get_user().unwrap_or("")
    }

    /// Whether connections use TLS.
    pub fn uses_tls(&self) -> bool {
        self.tls.is_some()
    }

    /// A new connection.
    pub fn connect(&self) -> Result<Client, FleetError> {
        let res = match &self.tls {
            Some(tls) => self
                .config
                .connect(tokio_postgres_rustls::MakeRustlsConnect::new(
                    (**tls).clone(),
                )),
            None => self.config.connect(NoTls),
        };
        res.map_err(|source| FleetError::Connect {
            target: self.shown.clone(),
            source,
        })
    }

    /// A statement's error, naming the store and what was being done.
    pub(crate) fn sql(&self, doing: &'static str) -> impl Fn(postgres::Error) -> FleetError + '_ {
        move |source| FleetError::Sql {
            target: self.shown.clone(),
            doing,
            source,
        }
    }
}

fn is_loopback(host: &str) -> bool {
    host == "localhost"
        || host
            .trim_matches(['[', ']'])
            .parse::<std::net::IpAddr>()
            .is_ok_and(|a| a.is_loopback())
}

/// `user@host:port/db` of a configuration.
fn show(c: &Config) -> String {
    let host = match c.get_hosts().first() {
        Some(Host::Tcp(h)) => h.clone(),
        Some(Host::Unix(p)) => p.display().to_string(),
        None => String::new(),
    };
    let port = c.get_ports().first().copied().unwrap_or(5432);
    format!(
        "{}@{host}:{port}/{}",
        c.get_user().unwrap_or("?"),
        c.get_dbname().unwrap_or(c.get_user().unwrap_or("?"))
    )
}

/// A rustls client trusting the certificates in `ca` (PEM) only.
fn client_config(ca: &Path) -> Result<rustls::ClientConfig, FleetError> {
    use rustls::pki_types::{pem::PemObject, CertificateDer};
    let err = |why: String| FleetError::File {
        what: "fleet CA",
        path: PathBuf::from(ca),
        why,
    };
    let text = read_bounded(ca, MAX_CA_BYTES, "fleet CA")?;
    let mut roots = rustls::RootCertStore::empty();
    for cert in CertificateDer::pem_slice_iter(text.as_bytes()) {
        let cert = cert.map_err(|e| err(format!("not PEM certificates: {e}")))?;
        roots
            .add(cert)
            .map_err(|e| err(format!("a certificate rustls refuses: {e}")))?;
    }
    if roots.is_empty() {
        return Err(err("no certificate in it".into()));
    }
    let provider = Arc::new(rustls::crypto::ring::default_provider());
    Ok(rustls::ClientConfig::builder_with_provider(provider)
        .with_safe_default_protocol_versions()
        .map_err(|e| err(e.to_string()))?
        .with_root_certificates(roots)
        .with_no_client_auth())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_password_in_the_url_is_refused_and_a_remote_store_needs_tls() {
        let e = FleetTarget::new("postgresql://site:secret@db.example/fleet", None, None);
        assert!(matches!(e, Err(FleetError::PasswordInUrl)));
        let e = FleetTarget::new("postgresql://site@db.example/fleet", None, None).unwrap_err();
        assert!(matches!(e, FleetError::Plaintext { .. }), "{e}");
        let e = FleetTarget::new(
            "postgresql://site@db.example/fleet?sslmode=require",
            None,
            None,
        )
        .unwrap_err();
        assert!(matches!(e, FleetError::NoCa), "{e}");
        let t = FleetTarget::new("postgresql://site@127.0.0.1:5433/fleet", None, None).unwrap();
        assert_eq!(t.shown(), "site@127.0.0.1:5433/fleet");
        assert!(!t.uses_tls());
        let e = FleetTarget::new("http://x", None, None).unwrap_err();
        assert!(e.to_string().contains("not a postgresql:// URL"), "{e}");
    }

    #[test]
    fn a_password_file_others_may_read_is_refused() {
        use std::os::unix::fs::PermissionsExt;
        let dir = std::env::temp_dir().join(format!("wf-pw-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("pw");
        std::fs::write(&f, "secret\n").unwrap();
        std::fs::set_permissions(&f, std::fs::Permissions::from_mode(0o644)).unwrap();
        let e = Password::from_file(&f).unwrap_err();
        assert!(
            e.to_string().contains("chmod 600") && !e.to_string().contains("secret"),
            "{e}"
        );
        std::fs::set_permissions(&f, std::fs::Permissions::from_mode(0o600)).unwrap();
        assert_eq!(Password::from_file(&f).unwrap().expose(), "secret");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_password_never_shows() {
        let p = Password::new("hunter2\n", Path::new("pw")).unwrap();
        assert_eq!(p.expose(), "hunter2");
        assert!(!format!("{p:?}").contains("hunter2"));
        let t = FleetTarget::new("postgresql://a@localhost/f", Some(p), None).unwrap();
        assert!(!format!("{t:?}").contains("hunter2"));
        assert!(Password::new("\n", Path::new("pw")).is_err());
    }
}
