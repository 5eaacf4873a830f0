//! A site's SQLite shipped to the fleet store (docs/fleet.md, "Shipping").
//!
//! - **Where it stands is the store's.** A round starts from the highest row id of the site
//!   the store holds (its passes, refusals, alarms: `max(seq)`, read back through the site's
//!   own rows); nothing is kept beside the site database, so no local mark can disagree.
//! - **A batch is whole or absent, in order.** Rows go in row-id order, one transaction a
//!   batch (the passes with their wheels): a shipper killed mid-batch leaves the store at the
//!   end of the batch before, and the next round starts there.
//! - **Once.** `(site, seq)` and `(site, key)` are unique: a batch shipped again (a shipper
//!   killed after the commit reached the server, before it heard back) inserts nothing.
//! - **The SQLite is the buffer.** While the store is unreachable the site goes on answering
//!   and storing; the next round that reaches it catches up.
//! - **A heartbeat a round**: what is still to ship, the site's newest pass — the fleet
//!   page's shipping lag.

use super::{schema, FleetError, FleetTarget};
use crate::history::{Db, ExportPass};
use postgres::Client;
use serde::Serialize;

/// Rows a batch by default.
pub const DEFAULT_BATCH: usize = 500;
/// The most rows a batch (bounds one transaction's memory: boxes are up to ~140 kB a wheel).
pub const MAX_BATCH: usize = 5_000;

/// What one round shipped.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct Shipped {
    /// Passes the store did not have.
    pub passes: usize,
    /// Passes sent that the store had already (same key).
    pub passes_known: usize,
    /// Refused or failed passes.
    pub failures: usize,
    /// Alarms raised.
    pub alarms: usize,
    /// Transactions committed.
    pub batches: usize,
    /// Passes still at the site only after the round (rows behind the newest).
    pub pending: i64,
}

/// A site's connection to the store, reconnected after a failure.
pub struct Shipper {
    target: FleetTarget,
    client: Option<Client>,
    site: Option<String>,
    last_heartbeat: Option<std::time::Instant>,
}

/// A round that shipped nothing and has nothing pending sends its heartbeat only this long
/// (s) after the last (a site polling every few seconds adds one row a minute, not twelve).
pub const QUIET_HEARTBEAT_S: u64 = 60;

impl Shipper {
    /// A shipper for `target` (connects at its first round).
    pub fn new(target: FleetTarget) -> Shipper {
        Shipper {
            target,
            client: None,
            site: None,
            last_heartbeat: None,
        }
    }

    /// The store.
    pub fn target(&self) -> &FleetTarget {
        &self.target
    }

    /// Connects (when not connected), checks the schema and finds the site this login ships
    /// as; the site's name.
    pub fn connect(&mut self) -> Result<String, FleetError> {
        if self.client.is_none() {
            let mut client = self.target.connect()?;
            schema::check(&mut client, &self.target)?;
            let site: Option<String> = client
                .query_one("SELECT fleet.my_site()", &[])
                .map_err(self.target.sql("finding the login's site"))?
                .get(0);
            let Some(site) = site else {
                return Err(FleetError::NotASite {
                    target: self.target.shown().to_string(),
                    role: self.target.user().to_string(),
                });
            };
            self.site = Some(site);
            self.client = Some(client);
        }
        Ok(self.site.clone().unwrap_or_default())
    }

    /// Ships what the store lacks of `db`, `batch` rows a transaction (1–[`MAX_BATCH`]),
    /// telling `on_batch` the running totals after each commit. After an error the next
    /// round connects anew.
    pub fn round(
        &mut self,
        db: &Db,
        batch: usize,
        mut on_batch: impl FnMut(&Shipped),
    ) -> Result<Shipped, FleetError> {
        let site = self.connect()?;
        let batch = batch.clamp(1, MAX_BATCH);
        let client = self.client.as_mut().expect("connected above");
        let quiet_ok = self
            .last_heartbeat
            .is_some_and(|t| t.elapsed().as_secs() < QUIET_HEARTBEAT_S);
        let res =
            ship_all(client, &self.target, db, &site, batch, &mut on_batch).and_then(|mut done| {
                let sent = heartbeat(client, &self.target, db, &site, &mut done, quiet_ok)?;
                if sent {
                    self.last_heartbeat = Some(std::time::Instant::now());
                }
                Ok(done)
            });
        if matches!(
            res,
            Err(FleetError::Sql { .. } | FleetError::Connect { .. })
        ) {
            self.client = None;
        }
        res
    }
}

/// The highest seq the store holds of `site` in `table`.
fn cursor(
    client: &mut Client,
    target: &FleetTarget,
    table: &str,
    site: &str,
) -> Result<i64, FleetError> {
    Ok(client
        .query_one(
            &format!("SELECT coalesce(max(seq), 0) FROM fleet.{table} WHERE site = $1"),
            &[&site],
        )
        .map_err(target.sql("reading where the site stands"))?
        .get(0))
}

fn ship_all(
    client: &mut Client,
    target: &FleetTarget,
    db: &Db,
    site: &str,
    batch: usize,
    on_batch: &mut impl FnMut(&Shipped),
) -> Result<Shipped, FleetError> {
    let mut done = Shipped::default();
    let mut at = cursor(client, target, "passes", site)?;
    let newest = db.newest_ids()?.passes;
    if at > newest {
        return Err(FleetError::Behind {
            target: target.shown().to_string(),
            site: site.to_string(),
            fleet: at,
            local: newest,
            path: db.path().to_path_buf(),
        });
    }
    loop {
        let passes = db.passes_after(at, batch)?;
        let Some(last) = passes.last() else { break };
        at = last.id;
        let new = send_passes(client, target, site, &passes)?;
        done.passes += new;
        done.passes_known += passes.len() - new;
        done.batches += 1;
        on_batch(&done);
    }
    let mut at = cursor(client, target, "failures", site)?;
    loop {
        let rows = db.failures_after(at, batch)?;
        let Some(last) = rows.last() else { break };
        at = last.id;
        let n = client
            .execute(
                "INSERT INTO fleet.failures (site, seq, time, time_s, measurement, bogie_id, outcome, reason)
                 SELECT $1, * FROM unnest($2::bigint[], $3::text[], $4::float8[], $5::text[], $6::text[], $7::text[], $8::text[])
                 ON CONFLICT DO NOTHING",
                &[
                    &site,
                    &rows.iter().map(|r| r.id).collect::<Vec<_>>(),
                    &rows.iter().map(|r| r.time.as_str()).collect::<Vec<_>>(),
                    &rows.iter().map(|r| r.time_s).collect::<Vec<_>>(),
                    &rows.iter().map(|r| r.measurement.as_str()).collect::<Vec<_>>(),
                    &rows.iter().map(|r| r.bogie_id.as_deref()).collect::<Vec<_>>(),
                    &rows.iter().map(|r| r.kind.as_str()).collect::<Vec<_>>(),
                    &rows.iter().map(|r| r.reason.as_str()).collect::<Vec<_>>(),
                ],
            )
            .map_err(target.sql("shipping refusals"))?;
        done.failures += n as usize;
        done.batches += 1;
        on_batch(&done);
    }
    let mut at = cursor(client, target, "alarms", site)?;
    loop {
        let rows = db.alarms_after(at, batch)?;
        let Some(last) = rows.last() else { break };
        at = last.id;
        let n = client
            .execute(
                "INSERT INTO fleet.alarms (site, seq, destination, key, rule, wheel_id, pass_seq, created, created_s, body)
                 SELECT $1, * FROM unnest($2::bigint[], $3::text[], $4::text[], $5::text[], $6::text[], $7::bigint[], $8::text[], $9::float8[], $10::text[])
                 ON CONFLICT DO NOTHING",
                &[
                    &site,
                    &rows.iter().map(|r| r.id).collect::<Vec<_>>(),
                    &rows.iter().map(|r| r.destination.as_str()).collect::<Vec<_>>(),
                    &rows.iter().map(|r| r.key.as_str()).collect::<Vec<_>>(),
                    &rows.iter().map(|r| r.rule.as_str()).collect::<Vec<_>>(),
                    &rows.iter().map(|r| r.wheel_id.as_deref()).collect::<Vec<_>>(),
                    &rows.iter().map(|r| r.pass_id).collect::<Vec<_>>(),
                    &rows.iter().map(|r| r.created.as_str()).collect::<Vec<_>>(),
                    &rows.iter().map(|r| r.created_s).collect::<Vec<_>>(),
                    &rows.iter().map(|r| r.body.as_str()).collect::<Vec<_>>(),
                ],
            )
            .map_err(target.sql("shipping alarms"))?;
        done.alarms += n as usize;
        done.batches += 1;
        on_batch(&done);
    }
    Ok(done)
}

/// The round's heartbeat: what is still to ship and the site's newest pass; left out
/// (`false`) when `quiet_ok` and the round found nothing to do.
fn heartbeat(
    client: &mut Client,
    target: &FleetTarget,
    db: &Db,
    site: &str,
    done: &mut Shipped,
    quiet_ok: bool,
) -> Result<bool, FleetError> {
    let shipped = cursor(client, target, "passes", site)?;
    let newest = db.newest_ids()?.passes;
    done.pending = (newest - shipped).max(0);
    let quiet =
        done.passes + done.passes_known + done.failures + done.alarms == 0 && done.pending == 0;
    if quiet && quiet_ok {
        return Ok(false);
    }
    let newest_s = db.pass_time_s(newest)?;
    let oldest_pending_s = if done.pending > 0 {
        db.passes_after(shipped, 1)?.first().map(|p| p.meta.time_s)
    } else {
        None
    };
    client
        .execute(
            "INSERT INTO fleet.heartbeats (site, pending, newest_pass_s, oldest_pending_s, wheelflat)
             VALUES ($1, $2, $3, $4, $5)",
            &[
                &site,
                &(done.pending.min(i32::MAX as i64) as i32),
                &newest_s,
                &oldest_pending_s,
                &env!("CARGO_PKG_VERSION"),
            ],
        )
        .map_err(target.sql("sending the heartbeat"))?;
    Ok(true)
}

/// One batch of passes with their wheels, in one transaction, as the login's site; how many
/// the store lacked (a batch sent again inserts none).
pub fn send_passes(
    client: &mut Client,
    target: &FleetTarget,
    site: &str,
    passes: &[ExportPass],
) -> Result<usize, FleetError> {
    let mut tx = client
        .transaction()
        .map_err(target.sql("starting a batch"))?;
    let col = |f: fn(&ExportPass) -> Option<f64>| passes.iter().map(f).collect::<Vec<_>>();
    let new: Vec<i64> = tx
        .query(
            "INSERT INTO fleet.passes (site, seq, key, time, time_s, measurement, bank_id, speed_km_per_h,
                                       bank_speed_km_per_h, load_kn, bogie_id, summary, result_dir, answer_ms)
             SELECT $1, * FROM unnest($2::bigint[], $3::text[], $4::text[], $5::float8[], $6::text[], $7::text[],
                                      $8::float8[], $9::float8[], $10::float8[], $11::text[], $12::text[],
                                      $13::text[], $14::float8[])
             ON CONFLICT DO NOTHING RETURNING seq",
            &[
                &site,
                &passes.iter().map(|p| p.id).collect::<Vec<_>>(),
                &passes.iter().map(|p| p.meta.key.as_str()).collect::<Vec<_>>(),
                &passes.iter().map(|p| p.time.as_str()).collect::<Vec<_>>(),
                &passes.iter().map(|p| p.meta.time_s).collect::<Vec<_>>(),
                &passes.iter().map(|p| p.meta.measurement.as_str()).collect::<Vec<_>>(),
                &passes.iter().map(|p| p.meta.bank_id.as_str()).collect::<Vec<_>>(),
                &col(|p| p.meta.speed_km_per_h),
                &passes.iter().map(|p| p.meta.bank_speed_km_per_h).collect::<Vec<_>>(),
                &col(|p| p.meta.load_kn),
                &passes.iter().map(|p| p.meta.bogie_id.as_deref()).collect::<Vec<_>>(),
                &passes.iter().map(|p| p.meta.summary.as_str()).collect::<Vec<_>>(),
                &passes.iter().map(|p| p.meta.result_dir.as_deref()).collect::<Vec<_>>(),
                &col(|p| p.meta.answer_ms),
            ],
        )
        .map_err(target.sql("shipping passes"))?
        .iter()
        .map(|r| r.get(0))
        .collect();
    let new_set: std::collections::HashSet<i64> = new.iter().copied().collect();
    let wheels: Vec<_> = passes
        .iter()
        .filter(|p| new_set.contains(&p.id))
        .flat_map(|p| p.wheels.iter().map(move |w| (p, w)))
        .collect();
    if !wheels.is_empty() {
        tx.execute(
            "INSERT INTO fleet.wheel_passes (site, seq, wheel, wheel_id, time_s, claim, l0_min_mm, l0_max_mm,
                                             severity_lowest, severity_highest, limit_l0_mm, space, cells, boxes,
                                             dynamic_ratio_min, dynamic_ratio_max)
             SELECT $1, * FROM unnest($2::bigint[], $3::text[], $4::text[], $5::float8[], $6::text[], $7::float8[],
                                      $8::float8[], $9::text[], $10::text[], $11::float8[], $12::text[],
                                      $13::int4[], $14::bytea[], $15::float8[], $16::float8[])
             ON CONFLICT DO NOTHING",
            &[
                &site,
                &wheels.iter().map(|(p, _)| p.id).collect::<Vec<_>>(),
                &wheels.iter().map(|(_, w)| w.wheel.as_str()).collect::<Vec<_>>(),
                &wheels.iter().map(|(_, w)| w.wheel_id.as_deref()).collect::<Vec<_>>(),
                &wheels.iter().map(|(p, _)| p.meta.time_s).collect::<Vec<_>>(),
                &wheels.iter().map(|(_, w)| w.claim.as_str()).collect::<Vec<_>>(),
                &wheels.iter().map(|(_, w)| w.l0_mm.0).collect::<Vec<_>>(),
                &wheels.iter().map(|(_, w)| w.l0_mm.1).collect::<Vec<_>>(),
                &wheels.iter().map(|(_, w)| w.severity.0.as_deref()).collect::<Vec<_>>(),
                &wheels.iter().map(|(_, w)| w.severity.1.as_deref()).collect::<Vec<_>>(),
                &wheels.iter().map(|(_, w)| w.limit_l0_mm).collect::<Vec<_>>(),
                &wheels.iter().map(|(_, w)| w.space.as_str()).collect::<Vec<_>>(),
                &wheels.iter().map(|(_, w)| w.cells as i32).collect::<Vec<_>>(),
                &wheels.iter().map(|(_, w)| w.boxes.as_slice()).collect::<Vec<_>>(),
                &wheels.iter().map(|(_, w)| w.dynamic_ratio.0).collect::<Vec<_>>(),
                &wheels.iter().map(|(_, w)| w.dynamic_ratio.1).collect::<Vec<_>>(),
            ],
        )
        .map_err(target.sql("shipping wheels"))?;
    }
    tx.commit().map_err(target.sql("committing a batch"))?;
    Ok(new.len())
}
