//! What can go wrong with the fleet store, naming the store (never its password) and the
//! value at fault.

use crate::history::DbError;
use std::path::PathBuf;

/// A fleet store failure.
#[derive(Debug, thiserror::Error)]
pub enum FleetError {
    /// The URL is not a PostgreSQL connection string.
    #[error(
        "fleet URL `{url}`: {why} (expected postgresql://USER@HOST:PORT/DATABASE?sslmode=require)"
    )]
    Url {
        /// The URL as given (it carries no password: see [`FleetError::PasswordInUrl`]).
        url: String,
        /// What is wrong.
        why: String,
    },
    /// The URL carries a password (command lines are seen by `ps` and kept in shell history).
    #[error("the fleet URL carries a password: put it in a file (--fleet-password-file) or in WHEELFLAT_FLEET_PASSWORD, never on the command line")]
    PasswordInUrl,
    /// A password, token or CA file could not be read or is not what it must be.
    #[error("{what} file {path}: {why}")]
    File {
        /// Which file (`fleet password`, `fleet CA`, …).
        what: &'static str,
        /// The file.
        path: PathBuf,
        /// Why.
        why: String,
    },
    /// A store on another machine without TLS.
    #[error("the fleet store at {host} would be reached without TLS: add ?sslmode=require to the URL and give its CA (--fleet-ca); plain connections are for this machine only")]
    Plaintext {
        /// The host.
        host: String,
    },
    /// TLS asked for without a CA to check the server against.
    #[error("sslmode=require needs the CA that signed the server's certificate (--fleet-ca FILE or WHEELFLAT_FLEET_CA)")]
    NoCa,
    /// The store could not be reached or refused the login.
    #[error("cannot reach the fleet store {target}: {}", explain(source))]
    Connect {
        /// `user@host:port/db`.
        target: String,
        /// The client's error.
        #[source]
        source: postgres::Error,
    },
    /// A statement failed.
    #[error("fleet store {target}: {doing}: {}", explain(source))]
    Sql {
        /// `user@host:port/db`.
        target: String,
        /// What was being done.
        doing: &'static str,
        /// The server's or client's error.
        #[source]
        source: postgres::Error,
    },
    /// The store has no fleet schema yet.
    #[error("fleet store {target} has no wheelflat schema: its owner runs `wheelflat fleet migrate --fleet URL` first")]
    NoSchema {
        /// `user@host:port/db`.
        target: String,
    },
    /// The store's schema is not this wheelflat's.
    #[error(
        "fleet store {target} has schema version {found}, this wheelflat knows {known}: {advice}"
    )]
    Version {
        /// `user@host:port/db`.
        target: String,
        /// The store's version.
        found: i32,
        /// This wheelflat's.
        known: i32,
        /// What to do.
        advice: &'static str,
    },
    /// The login is not a site's, so it cannot ship.
    #[error("login `{role}` on {target} is not a site's (the store's owner makes one: `wheelflat fleet add-site`)")]
    NotASite {
        /// `user@host:port/db`.
        target: String,
        /// The login.
        role: String,
    },
    /// A name (site, login) outside its rule.
    #[error("{what} `{value}`: {rule}")]
    BadName {
        /// Which name.
        what: &'static str,
        /// The value given.
        value: String,
        /// The rule it breaks.
        rule: &'static str,
    },
    /// A workshop finding out of its range.
    #[error("{source_name}: {key} = `{value}`: {why}")]
    Finding {
        /// The CSV file and line, or `--flags`.
        source_name: String,
        /// The field.
        key: &'static str,
        /// The value given.
        value: String,
        /// Why it is refused.
        why: String,
    },
    /// The store holds more of the site than its database: a database restored from an
    /// older copy, or another site's file (its new passes would collide with shipped ones).
    #[error("fleet store {target} holds site {site}'s passes up to row {fleet}, but {path} ends at row {local}: a database restored from an older copy, or another site's? Nothing shipped; ship a new database under a new site name (docs/fleet.md)")]
    Behind {
        /// `user@host:port/db`.
        target: String,
        /// The site.
        site: String,
        /// The store's newest row of the site.
        fleet: i64,
        /// The database's newest row.
        local: i64,
        /// The database.
        path: PathBuf,
    },
    /// A row of the store is not what a wheelflat ships.
    #[error("fleet store {target}: site {site}, pass {seq}: {what}")]
    Corrupt {
        /// `user@host:port/db`.
        target: String,
        /// The site.
        site: String,
        /// The site's row id.
        seq: i64,
        /// What is wrong.
        what: String,
    },
    /// The site's own database.
    #[error(transparent)]
    Site(#[from] DbError),
}

/// A client error in full: the server's message (and detail) where there is one, else the
/// client's error with its cause (`postgres::Error`'s own text is only "db error").
pub(crate) fn explain(e: &postgres::Error) -> String {
    if let Some(db) = e.as_db_error() {
        let mut s = format!("{} ({})", db.message(), db.code().code());
        if let Some(d) = db.detail() {
            s.push_str(&format!("; {d}"));
        }
        return s;
    }
    let mut s = e.to_string();
    let mut cause = std::error::Error::source(e);
    while let Some(c) = cause {
        s.push_str(&format!(": {c}"));
        cause = c.source();
    }
    s
}
