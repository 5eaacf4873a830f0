//! The store's logins (docs/fleet.md, "Roles"): one a site, member of `wheelflat_site`
//! (inserts and reads its own rows only, by row-level security: never updates, deletes or
//! another site's rows); readers (`serve --fleet`, `history --fleet`) in `wheelflat_reader`;
//! the workshop (`found`) in `wheelflat_workshop`. Made by the store's owner.
//!
//! The password is sent as its SCRAM-SHA-256 verifier, computed here: the plain text never
//! reaches the server's statement log.

use super::{schema, FleetError, FleetTarget, Password};
use postgres::Client;

/// What a login may do.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LoginKind {
    /// Reads everything (the fleet page, cross-site histories, the validation table).
    Reader,
    /// Enters workshop findings.
    Workshop,
}

impl LoginKind {
    fn group(self) -> &'static str {
        match self {
            LoginKind::Reader => "wheelflat_reader",
            LoginKind::Workshop => "wheelflat_workshop",
        }
    }
}

/// A site name: `[a-z0-9][a-z0-9_-]{0,39}` (also the table's check).
pub fn check_site_name(site: &str) -> Result<(), FleetError> {
    let ok = (1..=40).contains(&site.len())
        && site.bytes().enumerate().all(|(i, b)| {
            b.is_ascii_lowercase() || b.is_ascii_digit() || (i > 0 && (b == b'_' || b == b'-'))
        });
    if ok {
        Ok(())
    } else {
        Err(FleetError::BadName {
            what: "site",
            value: site.to_string(),
            rule: "1–40 lower-case letters, digits, `_` or `-`, starting with a letter or digit",
        })
    }
}

/// A login name: `[a-z_][a-z0-9_]{0,62}`, not `wheelflat_…` nor `pg_…` (kept for the groups
/// and the server).
pub fn check_login_name(role: &str) -> Result<(), FleetError> {
    let ok = (1..=63).contains(&role.len())
        && role
            .bytes()
            .enumerate()
            .all(|(i, b)| b.is_ascii_lowercase() || b == b'_' || (i > 0 && b.is_ascii_digit()))
        && !role.starts_with("wheelflat_")
        && !role.starts_with("pg_");
    if ok {
        Ok(())
    } else {
        Err(FleetError::BadName {
            what: "login",
            value: role.to_string(),
            rule: "1–63 lower-case letters, digits or `_`, starting with a letter or `_`, not wheelflat_… or pg_…",
        })
    }
}

/// `CREATE ROLE … LOGIN PASSWORD '<verifier>'` or, when it exists, its password changed.
fn login(
    client: &mut postgres::Transaction<'_>,
    target: &FleetTarget,
    role: &str,
    password: &Password,
) -> Result<(), FleetError> {
    check_login_name(role)?;
    let verifier = postgres_protocol::password::scram_sha_256(password.expose().as_bytes());
    // The verifier is base64 with `$`, `:` and `-`: no quote to escape. Checked anyway.
    assert!(
        !verifier.contains('\''),
        "a SCRAM verifier has no quote: {verifier}"
    );
    let exists = client
        .query_opt("SELECT 1 FROM pg_roles WHERE rolname = $1", &[&role])
        .map_err(target.sql("looking up the login"))?
        .is_some();
    let verb = if exists { "ALTER" } else { "CREATE" };
    client
        .batch_execute(&format!(
            "{verb} ROLE \"{role}\" LOGIN NOSUPERUSER NOCREATEDB NOCREATEROLE PASSWORD '{verifier}'"
        ))
        .map_err(target.sql("making the login"))
}

/// Makes `site` and its login `role` (a member of `wheelflat_site`); a site that exists
/// gets the password anew. The owner's connection.
pub fn add_site(
    client: &mut Client,
    target: &FleetTarget,
    site: &str,
    role: &str,
    password: &Password,
) -> Result<(), FleetError> {
    check_site_name(site)?;
    schema::check(client, target)?;
    let mut tx = client
        .transaction()
        .map_err(target.sql("starting a transaction"))?;
    login(&mut tx, target, role, password)?;
    tx.batch_execute(&format!("GRANT wheelflat_site TO \"{role}\""))
        .map_err(target.sql("granting the site role"))?;
    tx.execute(
        "INSERT INTO fleet.sites (site, role_name) VALUES ($1, $2)
         ON CONFLICT (site) DO NOTHING",
        &[&site, &role],
    )
    .map_err(target.sql("recording the site"))?;
    let owner: String = tx
        .query_one(
            "SELECT role_name::text FROM fleet.sites WHERE site = $1",
            &[&site],
        )
        .map_err(target.sql("reading the site"))?
        .get(0);
    if owner != role {
        return Err(FleetError::BadName {
            what: "site",
            value: site.to_string(),
            rule: "already ships with another login (one login a site)",
        });
    }
    tx.commit().map_err(target.sql("committing the site"))
}

/// Makes the login `role` of `kind` (its password anew when it exists). The owner's
/// connection.
pub fn add_login(
    client: &mut Client,
    target: &FleetTarget,
    kind: LoginKind,
    role: &str,
    password: &Password,
) -> Result<(), FleetError> {
    schema::check(client, target)?;
    let mut tx = client
        .transaction()
        .map_err(target.sql("starting a transaction"))?;
    login(&mut tx, target, role, password)?;
    tx.batch_execute(&format!("GRANT {} TO \"{role}\"", kind.group()))
        .map_err(target.sql("granting the role"))?;
    tx.commit().map_err(target.sql("committing the login"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_outside_their_rule_are_refused() {
        for ok in ["depot-north", "s1", "a_b"] {
            check_site_name(ok).unwrap();
        }
        for bad in ["", "-x", "North", "a b", "x'; drop", &"a".repeat(41)] {
            assert!(check_site_name(bad).is_err(), "{bad}");
        }
        for ok in ["site_north", "_x", "reader1"] {
            check_login_name(ok).unwrap();
        }
        for bad in ["1a", "a-b", "wheelflat_site", "pg_read", "x\"y"] {
            assert!(check_login_name(bad).is_err(), "{bad}");
        }
    }
}
