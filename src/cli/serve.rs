//! `wheelflat serve`: the site's results database as web pages (read-only).

use anyhow::{Context, Result};
use clap::Args;
use std::net::SocketAddr;
use std::path::PathBuf;
use wheelflat::serve::{Settings, Token};

// `serve`.
#[derive(Debug, Args)]
pub(super) struct ServeArgs {
    /// The results database `identify`, `train` and `watch` write with `--db` (read-only).
    #[arg(long, required_unless_present = "fleet", conflicts_with = "fleet")]
    pub db: Option<PathBuf>,
    /// Or the fleet store (a reader's login): wheels needing action at every site, each
    /// site's health and shipping lag, a wheel across sites, the workshop's findings.
    #[command(flatten)]
    pub fleet: super::fleet::FleetArgs,
    /// The bank or family the site identifies with: the site page shows its version (and
    /// when it cannot be read).
    #[arg(long)]
    pub bank: Option<PathBuf>,
    /// Where to listen. Addresses other than localhost need --token-file.
    #[arg(long, default_value = "127.0.0.1:8080")]
    pub listen: SocketAddr,
    /// A file holding the token requests must show (`Authorization: Bearer <token>`, or
    /// `?token=` once in a browser): at least 16 letters, digits or `-_.~`.
    #[arg(long)]
    pub token_file: Option<PathBuf>,
    /// The class limits and φ from this calibration's `[maintenance]` (default: 25 / 40 mm on
    /// L0, φ 0.95), as `history` uses them.
    #[arg(long)]
    pub calibration: Option<PathBuf>,
}

/// `wheelflat serve`.
pub(super) fn run(a: &ServeArgs) -> Result<()> {
    let cal = super::load_calibration(a.calibration.as_deref())?;
    let token = match &a.token_file {
        Some(f) => {
            let text =
                super::read_text(f, wheelflat::serve::access::MAX_TOKEN_FILE_BYTES, "token")?;
            Some(Token::new(&text).with_context(|| format!("in token file {}", f.display()))?)
        }
        None => None,
    };
    if let Some(target) = a.fleet.target()? {
        let shown = target.shown().to_string();
        let settings = wheelflat::serve::FleetSettings::new(target, &cal.identification, token);
        wheelflat::serve::run_fleet(settings, a.listen, |bound| {
            println!(
                "serving the fleet store {shown} on http://{bound}/ (read-only; Ctrl-C stops)"
            );
        })?;
        println!("stopped");
        return Ok(());
    }
    let path = a.db.clone().expect("clap requires --db or --fleet");
    let db = path.display().to_string();
    let settings = Settings::new(path, a.bank.clone(), &cal.identification, token);
    wheelflat::serve::run(settings, a.listen, |bound| {
        println!("serving {db} on http://{bound}/ (read-only; Ctrl-C stops)");
    })?;
    println!("stopped");
    Ok(())
}
