//! A throw-away PostgreSQL cluster for the fleet store's tests and its scale measurement: a
//! real server from the distribution's package (Debian's `postgresql`, which `.ci/run`
//! installs), in a fresh folder, on a free loopback port, with TLS (a CA and a server
//! certificate made by `openssl` for the run), stopped and removed when dropped. Never a mock.
//!
//! As root the server runs as the package's `postgres` user (`runuser`): PostgreSQL refuses
//! to run as root.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering};

/// The cluster's owner login.
pub const ADMIN: &str = "wfadmin";
/// The database the fleet store lives in.
pub const DATABASE: &str = "fleet";

/// A running cluster.
pub struct PgCluster {
    base: PathBuf,
    bin: PathBuf,
    run_as: Option<String>,
    /// The loopback port it listens on.
    pub port: u16,
    /// The owner's password.
    pub admin_password: String,
    /// The CA that signed the server's certificate (PEM).
    pub ca: PathBuf,
}

static NEXT: AtomicUsize = AtomicUsize::new(0);

/// Where the server's programs are: `WHEELFLAT_PG_BIN`, else the newest
/// `/usr/lib/postgresql/*/bin` with `initdb`.
fn bin_dir() -> Option<PathBuf> {
    if let Some(b) = std::env::var_os("WHEELFLAT_PG_BIN") {
        return Some(PathBuf::from(b));
    }
    let mut found: Vec<(u32, PathBuf)> = std::fs::read_dir("/usr/lib/postgresql")
        .ok()?
        .flatten()
        .filter_map(|e| {
            let v: u32 = e.file_name().to_str()?.parse().ok()?;
            let bin = e.path().join("bin");
            bin.join("initdb").exists().then_some((v, bin))
        })
        .collect();
    found.sort();
    found.pop().map(|(_, b)| b)
}

fn run(cmd: &mut Command, what: &str) -> Result<String, String> {
    let out = cmd
        .stdin(Stdio::null())
        .output()
        .map_err(|e| format!("{what}: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "{what}: {}\n{}{}",
            out.status,
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

impl PgCluster {
    /// Starts a cluster with the fleet database made; why not when the machine has no
    /// PostgreSQL server (or no `openssl`, or is root without a `postgres` user).
    pub fn start() -> Result<PgCluster, String> {
        PgCluster::start_with(false)
    }

    /// A cluster; `durable`: the server's defaults (fsync, synchronous commit, full pages),
    /// as a measurement of shipping needs; else those off (the tests' speed: a test's data
    /// need not survive a machine crash).
    pub fn start_with(durable: bool) -> Result<PgCluster, String> {
        let bin = bin_dir().ok_or(
            "no PostgreSQL server programs (/usr/lib/postgresql/*/bin; apt-get install postgresql, or set WHEELFLAT_PG_BIN)",
        )?;
        let root = is_root();
        let run_as = if root {
            run(
                Command::new("id").args(["-u", "postgres"]),
                "the postgres user",
            )
            .map_err(|_| "running as root and no `postgres` user to run the server".to_string())?;
            Some("postgres".to_string())
        } else {
            None
        };
        let n = NEXT.fetch_add(1, Ordering::SeqCst);
        let base = std::env::temp_dir().join(format!(
            "wheelflat-pg-{}-{n}-{}",
            std::process::id(),
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.subsec_nanos())
        ));
        std::fs::create_dir_all(&base).map_err(|e| format!("{}: {e}", base.display()))?;
        let port = std::net::TcpListener::bind("127.0.0.1:0")
            .and_then(|l| l.local_addr())
            .map_err(|e| format!("a free port: {e}"))?
            .port();
        let admin_password = format!("pw-{}-{n}", std::process::id());
        let cluster = PgCluster {
            base: base.clone(),
            bin,
            run_as,
            port,
            admin_password,
            ca: base.join("ca.crt"),
        };
        cluster.certificates()?;
        std::fs::write(base.join("pw"), &cluster.admin_password).map_err(|e| e.to_string())?;
        if let Some(user) = &cluster.run_as {
            run(
                Command::new("chown").args(["-R", user]).arg(&base),
                "chown the cluster folder",
            )?;
        }
        let data = base.join("data");
        cluster.as_owner(
            Command::new(cluster.bin.join("initdb"))
                .arg("-D")
                .arg(&data)
                .args(["-U", ADMIN, "-E", "UTF8", "--no-sync", "--auth-local=trust"])
                .args(["--auth-host=scram-sha-256", "--no-instructions"])
                .arg(format!("--pwfile={}", base.join("pw").display())),
            "initdb",
        )?;
        let mut conf = format!(
            "port = {port}\nlisten_addresses = '127.0.0.1'\nunix_socket_directories = '{}'\n\
             ssl = on\nssl_cert_file = '{}'\nssl_key_file = '{}'\nmax_connections = 200\n",
            base.display(),
            base.join("server.crt").display(),
            base.join("server.key").display()
        );
        if !durable {
            conf.push_str("fsync = off\nsynchronous_commit = off\nfull_page_writes = off\n");
        }
        let mut c =
            std::fs::read_to_string(data.join("postgresql.conf")).map_err(|e| e.to_string())?;
        c.push_str(&conf);
        std::fs::write(data.join("postgresql.conf"), c).map_err(|e| e.to_string())?;
        cluster.start_server()?;
        run(
            Command::new(cluster.bin.join("createdb"))
                .args([
                    "-h",
                    "127.0.0.1",
                    "-p",
                    &port.to_string(),
                    "-U",
                    ADMIN,
                    DATABASE,
                ])
                .env("PGPASSWORD", &cluster.admin_password),
            "createdb",
        )?;
        Ok(cluster)
    }

    /// The cluster, or `None` after saying why the test is skipped; with
    /// `WHEELFLAT_REQUIRE_POSTGRES` set (as `.ci/run` does once it installed the server), a
    /// machine without one fails the test instead.
    pub fn start_or_skip(test: &str) -> Option<PgCluster> {
        match PgCluster::start() {
            Ok(c) => Some(c),
            Err(why) if std::env::var_os("WHEELFLAT_REQUIRE_POSTGRES").is_none() => {
                eprintln!("SKIPPED {test}: {why}");
                None
            }
            Err(why) => panic!("{test}: WHEELFLAT_REQUIRE_POSTGRES is set and no cluster: {why}"),
        }
    }

    fn as_owner(&self, cmd: &mut Command, what: &str) -> Result<String, String> {
        match &self.run_as {
            Some(user) => {
                let prog = cmd.get_program().to_owned();
                let args: Vec<_> = cmd.get_args().map(|a| a.to_owned()).collect();
                run(
                    Command::new("runuser")
                        .args(["-u", user, "--"])
                        .arg(prog)
                        .args(args)
                        .current_dir(&self.base),
                    what,
                )
            }
            None => run(cmd, what),
        }
    }

    /// A CA and a server certificate for 127.0.0.1 and localhost, signed by it.
    fn certificates(&self) -> Result<(), String> {
        let b = &self.base;
        let p = |f: &str| b.join(f).display().to_string();
        run(
            Command::new("openssl").args([
                "req",
                "-x509",
                "-newkey",
                "ec",
                "-pkeyopt",
                "ec_paramgen_curve:prime256v1",
                "-nodes",
                "-keyout",
                &p("ca.key"),
                "-out",
                &p("ca.crt"),
                "-days",
                "2",
                "-subj",
                "/CN=wheelflat test CA",
            ]),
            "openssl: the CA",
        )?;
        run(
            Command::new("openssl").args([
                "req",
                "-newkey",
                "ec",
                "-pkeyopt",
                "ec_paramgen_curve:prime256v1",
                "-nodes",
                "-keyout",
                &p("server.key"),
                "-out",
                &p("server.csr"),
                "-subj",
                "/CN=localhost",
            ]),
            "openssl: the server key",
        )?;
        std::fs::write(
            b.join("ext.cnf"),
            "basicConstraints=CA:FALSE\nkeyUsage=digitalSignature,keyEncipherment\n\
             extendedKeyUsage=serverAuth\nsubjectAltName=DNS:localhost,IP:127.0.0.1\n",
        )
        .map_err(|e| e.to_string())?;
        run(
            Command::new("openssl").args([
                "x509",
                "-req",
                "-in",
                &p("server.csr"),
                "-CA",
                &p("ca.crt"),
                "-CAkey",
                &p("ca.key"),
                "-CAcreateserial",
                "-out",
                &p("server.crt"),
                "-days",
                "2",
                "-extfile",
                &p("ext.cnf"),
            ]),
            "openssl: the server certificate",
        )?;
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(b.join("server.key"), std::fs::Permissions::from_mode(0o600))
            .map_err(|e| e.to_string())?;
        Ok(())
    }

    /// `pg_ctl -D DATA -l LOG ARGS`, as the server's owner.
    fn pg_ctl(&self, args: &[&str]) -> Result<(), String> {
        self.as_owner(
            Command::new(self.bin.join("pg_ctl"))
                .arg("-D")
                .arg(self.base.join("data"))
                .arg("-l")
                .arg(self.base.join("log"))
                .args(args),
            &format!("pg_ctl {}", args.last().copied().unwrap_or("")),
        )
        .map(|_| ())
    }

    /// Starts the server (after [`PgCluster::stop`]), waiting until it accepts connections.
    pub fn start_server(&self) -> Result<(), String> {
        self.pg_ctl(&["-w", "-t", "60", "start"])
    }

    /// Stops the server (`fast`: open connections are cut).
    pub fn stop(&self) -> Result<(), String> {
        self.pg_ctl(&["-w", "-m", "fast", "stop"])
    }

    /// `postgresql://USER@127.0.0.1:PORT/fleet`, plain (loopback) or asking for TLS.
    pub fn url(&self, user: &str, tls: bool) -> String {
        format!(
            "postgresql://{user}@127.0.0.1:{}/{DATABASE}{}",
            self.port,
            if tls { "?sslmode=require" } else { "" }
        )
    }

    /// The server's log so far (for a failing test's message).
    pub fn log(&self) -> String {
        std::fs::read_to_string(self.base.join("log")).unwrap_or_default()
    }

    /// The folder (server files, log, certificates).
    pub fn base(&self) -> &Path {
        &self.base
    }
}

impl Drop for PgCluster {
    fn drop(&mut self) {
        let _ = self.pg_ctl(&["-w", "-m", "immediate", "stop"]);
        let _ = std::fs::remove_dir_all(&self.base);
    }
}

fn is_root() -> bool {
    // The effective user id, read from the kernel's view of this process.
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("Uid:"))
                .and_then(|l| l.split_whitespace().nth(2).map(|u| u == "0"))
        })
        .unwrap_or(false)
}
