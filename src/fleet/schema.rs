//! The fleet store's schema, one migration a version (`src/fleet/migrations/NNNN_*.sql`,
//! applied in order, each in its own transaction under an advisory lock, recorded in
//! `fleet.schema_migrations`). Every connection checks the store's version before it reads
//! or writes: an older store is migrated by its owner, a newer one is refused by name.

use super::{FleetError, FleetTarget};
use postgres::Client;

/// The migrations, in order: (version, name, SQL).
pub const MIGRATIONS: &[(i32, &str, &str)] =
    &[(1, "fleet", include_str!("migrations/0001_fleet.sql"))];

/// The schema version this wheelflat reads and writes.
pub const FLEET_SCHEMA_VERSION: i32 = MIGRATIONS[MIGRATIONS.len() - 1].0;

/// The advisory lock key of migrations (`WFLT`).
const MIGRATION_LOCK: i64 = 0x5746_4C54;

/// The store's schema version (0: no fleet schema).
pub fn version(client: &mut Client, target: &FleetTarget) -> Result<i32, FleetError> {
    read_version(
        &mut client
            .transaction()
            .map_err(target.sql("reading the schema version"))?,
        target,
    )
}

/// The version within a transaction (0: no fleet schema). The table's existence is asked
/// first: a query naming an absent table fails when parsed, whatever its `CASE`.
fn read_version(
    tx: &mut postgres::Transaction<'_>,
    target: &FleetTarget,
) -> Result<i32, FleetError> {
    let sql = target.sql("reading the schema version");
    let exists: bool = tx
        .query_one(
            "SELECT to_regclass('fleet.schema_migrations') IS NOT NULL",
            &[],
        )
        .map_err(&sql)?
        .get(0);
    if !exists {
        return Ok(0);
    }
    Ok(tx
        .query_one(
            "SELECT coalesce(max(version), 0) FROM fleet.schema_migrations",
            &[],
        )
        .map_err(&sql)?
        .get(0))
}

/// Refuses a store whose schema is not this wheelflat's, naming both versions.
pub fn check(client: &mut Client, target: &FleetTarget) -> Result<(), FleetError> {
    let found = version(client, target)?;
    let known = FLEET_SCHEMA_VERSION;
    if found == 0 {
        return Err(FleetError::NoSchema {
            target: target.shown().to_string(),
        });
    }
    if found != known {
        return Err(FleetError::Version {
            target: target.shown().to_string(),
            found,
            known,
            advice: if found < known {
                "the store's owner migrates it (`wheelflat fleet migrate`)"
            } else {
                "a newer wheelflat migrated it: use that version here"
            },
        });
    }
    Ok(())
}

/// Applies the migrations the store lacks, in order, each in one transaction; the versions
/// applied (none when up to date). A store newer than this wheelflat is refused.
pub fn migrate(client: &mut Client, target: &FleetTarget) -> Result<Vec<i32>, FleetError> {
    let mut applied = Vec::new();
    for &(v, name, sql) in MIGRATIONS {
        let mut tx = client
            .transaction()
            .map_err(target.sql("starting a migration"))?;
        tx.execute("SELECT pg_advisory_xact_lock($1)", &[&MIGRATION_LOCK])
            .map_err(target.sql("waiting for another migration"))?;
        let found = read_version(&mut tx, target)?;
        if found > FLEET_SCHEMA_VERSION {
            return Err(FleetError::Version {
                target: target.shown().to_string(),
                found,
                known: FLEET_SCHEMA_VERSION,
                advice: "a newer wheelflat migrated it: use that version here",
            });
        }
        if found >= v {
            continue;
        }
        tx.batch_execute(sql)
            .map_err(target.sql("applying a migration"))?;
        tx.execute(
            "INSERT INTO fleet.schema_migrations (version, name, wheelflat) VALUES ($1, $2, $3)",
            &[&v, &name, &env!("CARGO_PKG_VERSION")],
        )
        .map_err(target.sql("recording a migration"))?;
        tx.commit().map_err(target.sql("committing a migration"))?;
        applied.push(v);
    }
    Ok(applied)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_migrations_are_numbered_from_one_without_a_gap() {
        for (i, (v, _, sql)) in MIGRATIONS.iter().enumerate() {
            assert_eq!(*v, i as i32 + 1);
            assert!(!sql.trim().is_empty());
        }
        assert_eq!(FLEET_SCHEMA_VERSION, MIGRATIONS.len() as i32);
    }
}
