//! `--fleet URL` (shared by `ship`, `watch`, `history`, `found`, `serve`) and `wheelflat
//! fleet` (the store's owner: migrate, add a site or a login, the sites' health).

use anyhow::{Context, Result};
use clap::{Args, Subcommand};
use std::path::PathBuf;
use wheelflat::fleet::{roles, schema, words, FleetReader, FleetTarget, LoginKind, Password};

/// The environment variable a fleet password may come from.
pub(super) const PASSWORD_ENV: &str = "WHEELFLAT_FLEET_PASSWORD";

/// Where the fleet store is.
#[derive(Debug, Args, Clone)]
pub(super) struct FleetArgs {
    /// The fleet store: postgresql://USER@HOST:PORT/DATABASE (`?sslmode=require` for
    /// another machine), without a password (docs/fleet.md).
    #[arg(long, value_name = "URL", global = true)]
    pub fleet: Option<String>,
    /// A file holding the login's password (else WHEELFLAT_FLEET_PASSWORD; never on the
    /// command line).
    #[arg(long, value_name = "FILE", requires = "fleet", global = true)]
    pub fleet_password_file: Option<PathBuf>,
    /// The CA (PEM) that signed the store's certificate, for TLS (or WHEELFLAT_FLEET_CA).
    #[arg(long, value_name = "FILE", requires = "fleet", global = true)]
    pub fleet_ca: Option<PathBuf>,
}

impl FleetArgs {
    /// The store, when `--fleet` was given: the password from its file or the environment.
    pub(super) fn target(&self) -> Result<Option<FleetTarget>> {
        let Some(url) = &self.fleet else {
            return Ok(None);
        };
        let password = match (&self.fleet_password_file, std::env::var(PASSWORD_ENV)) {
            (Some(f), _) => Some(Password::from_file(f)?),
            (None, Ok(p)) => Some(Password::new(&p, std::path::Path::new(PASSWORD_ENV))?),
            (None, Err(_)) => None,
        };
        let ca = self
            .fleet_ca
            .clone()
            .or_else(|| std::env::var_os("WHEELFLAT_FLEET_CA").map(PathBuf::from));
        Ok(Some(FleetTarget::new(url, password, ca.as_deref())?))
    }

    /// The store, required.
    pub(super) fn required(&self) -> Result<FleetTarget> {
        self.target()?
            .context("--fleet URL is needed (the fleet store: docs/fleet.md)")
    }
}

// `fleet`.
#[derive(Debug, Args)]
pub(super) struct FleetCommandArgs {
    #[command(subcommand)]
    pub command: FleetCommand,
    #[command(flatten)]
    pub fleet: FleetArgs,
}

/// What the store's owner does.
#[derive(Debug, Subcommand)]
pub(super) enum FleetCommand {
    /// Apply the schema migrations the store lacks (the database's owner; each in one
    /// transaction; a store newer than this wheelflat is refused).
    Migrate,
    /// Make a site and the login it ships with (inserts and reads its own rows only).
    AddSite {
        /// The site's name (lower-case letters, digits, `_`, `-`).
        #[arg(long)]
        site: String,
        /// Its login.
        #[arg(long)]
        login: String,
        /// A file holding the login's password.
        #[arg(long)]
        password_file: PathBuf,
    },
    /// Make a login that reads everything (`reader`: serve, history) or enters findings
    /// (`workshop`: found).
    AddLogin {
        /// The login.
        #[arg(long)]
        login: String,
        /// What it may do.
        #[arg(long, value_enum)]
        kind: Kind,
        /// A file holding the login's password.
        #[arg(long)]
        password_file: PathBuf,
    },
    /// Every site's health: newest pass, bank, refusals, drift alarms, shipping lag.
    Sites,
}

/// A login's kind on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub(super) enum Kind {
    /// Reads everything.
    Reader,
    /// Enters workshop findings.
    Workshop,
}

/// `wheelflat fleet …`.
pub(super) fn run(a: &FleetCommandArgs) -> Result<()> {
    let target = a.fleet.required()?;
    match &a.command {
        FleetCommand::Migrate => {
            let mut client = target.connect()?;
            let before = schema::version(&mut client, &target)?;
            let applied = schema::migrate(&mut client, &target)?;
            if applied.is_empty() {
                println!("{}: schema version {before}, up to date", target.shown());
            } else {
                println!(
                    "{}: schema version {before} → {} (applied {:?})",
                    target.shown(),
                    schema::FLEET_SCHEMA_VERSION,
                    applied
                );
            }
        }
        FleetCommand::AddSite {
            site,
            login,
            password_file,
        } => {
            let password = Password::from_file(password_file)?;
            let mut client = target.connect()?;
            roles::add_site(&mut client, &target, site, login, &password)?;
            println!("site {site} ships as login {login} on {}", target.shown());
        }
        FleetCommand::AddLogin {
            login,
            kind,
            password_file,
        } => {
            let password = Password::from_file(password_file)?;
            let mut client = target.connect()?;
            let kind = match kind {
                Kind::Reader => LoginKind::Reader,
                Kind::Workshop => LoginKind::Workshop,
            };
            roles::add_login(&mut client, &target, kind, login, &password)?;
            println!("login {login} ({kind:?}) on {}", target.shown());
        }
        FleetCommand::Sites => {
            let mut reader = FleetReader::connect(&target)?;
            let now = words::now_s();
            let sites = reader.sites(now)?;
            println!("{}: {} sites", target.shown(), sites.len());
            println!(
                "{:<20} {:>9} {:>20} {:>10} {:>9} {:>8} {:>10}",
                "site", "shipped", "newest pass", "bank age", "refusals", "drift", "lag"
            );
            for s in sites {
                println!(
                    "{:<20} {:>9} {:>20} {:>10} {:>9} {:>8} {:>10}",
                    s.site,
                    s.newest_seq,
                    s.newest_pass_s.map_or("—".into(), words::time),
                    s.bank_since_s.map_or("—".into(), |t| words::age(now - t)),
                    s.refusals_24h,
                    s.drift_alarms_7d,
                    s.lag_s.map_or("never".into(), words::age)
                );
            }
        }
    }
    Ok(())
}
