//! Reading the fleet store (a reader's login): a wheel's passes at every site, each checked
//! as `history` checks a site's; the wheels needing action; each site's health. Every list
//! is bounded; every query is served by an index (docs/fleet.md, "Scale").

use super::{schema, FleetError, FleetTarget};
use crate::history::db::row::{severity_range, RawRow};
use crate::history::{StoredPass, Window};
use crate::identify::SeverityRange;
use postgres::Client;
use serde::Serialize;

/// The most wheels a list returns.
pub const MAX_WHEELS: i64 = 500;

/// A pass of a wheel at one site.
#[derive(Debug, Clone, PartialEq)]
pub struct SitePass {
    /// The site that measured it (and judged it with its own calibrated bank).
    pub site: String,
    /// The pass (`pass_id` is the site's row id).
    pub pass: StoredPass,
}

/// A wheel's newest pass at any site.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WheelLatest {
    /// `<bogie_id>/leading` or `…/trailing`.
    pub wheel_id: String,
    /// The site of its newest pass.
    pub site: String,
    /// When (Unix seconds).
    pub time_s: f64,
    /// The newest pass's claim.
    pub claim: String,
    /// Its classes.
    pub severity: Option<SeverityRange>,
    /// Its L0 range (mm).
    pub l0_mm: Option<[f64; 2]>,
    /// Passes of the wheel in the store, every site.
    pub passes: i64,
}

/// One site's health as the store sees it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SiteHealth {
    /// The site.
    pub site: String,
    /// The row id of its newest pass in the store (its passes shipped: ids are consecutive).
    pub newest_seq: i64,
    /// Its newest pass (Unix seconds).
    pub newest_pass_s: Option<f64>,
    /// The bank of its newest pass.
    pub bank_id: Option<String>,
    /// The first pass the site judged with that bank (Unix seconds): the bank's age there.
    pub bank_since_s: Option<f64>,
    /// Passes refused or failed in the last 24 hours.
    pub refusals_24h: i64,
    /// `calibration-drift` alarms raised in the last 7 days.
    pub drift_alarms_7d: i64,
    /// The site's newest heartbeat (Unix seconds).
    pub heartbeat_s: Option<f64>,
    /// Passes still at the site at that heartbeat.
    pub pending: Option<i64>,
    /// How far behind the store is (s): now − the newest heartbeat with nothing pending, or
    /// now − the oldest pass pending at the newest heartbeat.
    pub lag_s: Option<f64>,
}

/// A reader's connection.
pub struct FleetReader {
    target: FleetTarget,
    client: Client,
}

impl FleetReader {
    /// Connects and checks the store's schema.
    pub fn connect(target: &FleetTarget) -> Result<FleetReader, FleetError> {
        let mut client = target.connect()?;
        schema::check(&mut client, target)?;
        Ok(FleetReader {
            target: target.clone(),
            client,
        })
    }

    /// The store.
    pub fn target(&self) -> &FleetTarget {
        &self.target
    }

    pub(crate) fn client(&mut self) -> &mut Client {
        &mut self.client
    }

    /// Whether the connection is closed (a server restart): the caller connects anew.
    pub fn is_closed(&self) -> bool {
        self.client.is_closed()
    }

    /// The passes of one wheel at every site in `window` (the newest `last`, within `hours` of
    /// the newest), oldest first; each checked before it is trusted.
    pub fn wheel_passes(
        &mut self,
        wheel_id: &str,
        window: Window,
    ) -> Result<Vec<SitePass>, FleetError> {
        let last = window.last.clamp(1, crate::history::db::MAX_WINDOW_PASSES) as i64;
        let rows = self
            .client
            .query(
                "SELECT p.site, p.seq, p.time, p.time_s, p.measurement, p.speed_km_per_h,
                        p.bank_speed_km_per_h, p.bank_id, w.wheel, w.claim, w.l0_min_mm, w.l0_max_mm,
                        w.severity_lowest, w.severity_highest, w.limit_l0_mm, w.space, w.cells,
                        w.boxes, w.dynamic_ratio_min, w.dynamic_ratio_max
                 FROM fleet.wheel_passes w JOIN fleet.passes p USING (site, seq)
                 WHERE w.wheel_id = $1 ORDER BY w.time_s DESC, p.site, p.seq DESC LIMIT $2",
                &[&wheel_id, &last],
            )
            .map_err(self.target.sql("reading a wheel's passes"))?;
        let mut out = Vec::with_capacity(rows.len());
        for r in rows {
            let site: String = r.get(0);
            let seq: i64 = r.get(1);
            let raw = RawRow {
                pass_id: seq,
                time: r.get(2),
                time_s: r.get(3),
                measurement: r.get(4),
                speed: r.get(5),
                bank_speed: r.get(6),
                bank_id: r.get(7),
                wheel: r.get(8),
                claim: r.get(9),
                l0: (r.get(10), r.get(11)),
                severity: (r.get(12), r.get(13)),
                limit: r.get(14),
                space: r.get(15),
                cells: i64::from(r.get::<_, i32>(16)),
                boxes: r.get(17),
                dynamic_ratio: (r.get(18), r.get(19)),
            };
            let pass = raw.parse().map_err(|what| FleetError::Corrupt {
                target: self.target.shown().to_string(),
                site: site.clone(),
                seq,
                what,
            })?;
            out.push(SitePass { site, pass });
        }
        if let (Some(h), Some(newest)) = (window.hours, out.first().map(|p| p.pass.time_s)) {
            out.retain(|p| p.pass.time_s >= newest - h * 3600.0);
        }
        out.reverse();
        Ok(out)
    }

    /// The wheels whose newest pass (any site) allows the inspect class or worse: urgent
    /// first, then newest first; at most `limit` ([`MAX_WHEELS`]).
    pub fn action_wheels(&mut self, limit: i64) -> Result<Vec<WheelLatest>, FleetError> {
        let rows = self
            .client
            .query(
                "SELECT wheel_id, site, time_s, claim, severity_lowest, severity_highest, l0_min_mm,
                        l0_max_mm, passes
                 FROM fleet.wheels WHERE severity_highest IN ('urgent', 'inspect')
                 ORDER BY severity_highest = 'urgent' DESC, time_s DESC LIMIT $1",
                &[&limit.clamp(1, MAX_WHEELS)],
            )
            .map_err(self.target.sql("reading the wheels needing action"))?;
        Ok(rows
            .iter()
            .map(|r| WheelLatest {
                wheel_id: r.get(0),
                site: r.get(1),
                time_s: r.get(2),
                claim: r.get(3),
                severity: severity_range(r.get::<_, Option<&str>>(4), r.get::<_, Option<&str>>(5)),
                l0_mm: r
                    .get::<_, Option<f64>>(6)
                    .zip(r.get::<_, Option<f64>>(7))
                    .map(|(a, b)| [a, b]),
                passes: r.get(8),
            })
            .collect())
    }

    /// Named wheels in the store.
    pub fn wheel_count(&mut self) -> Result<i64, FleetError> {
        Ok(self
            .client
            .query_one("SELECT count(*) FROM fleet.wheels", &[])
            .map_err(self.target.sql("counting wheels"))?
            .get(0))
    }

    /// Every site's health at `now_s` (Unix seconds), by name.
    pub fn sites(&mut self, now_s: f64) -> Result<Vec<SiteHealth>, FleetError> {
        let rows = self
            .client
            .query(
                "SELECT s.site, np.seq, np.time_s, np.bank_id,
                        (SELECT min(time_s) FROM fleet.passes b WHERE b.site = s.site AND b.bank_id = np.bank_id),
                        (SELECT count(*) FROM fleet.failures f WHERE f.site = s.site AND f.time_s >= $1::float8 - 86400),
                        (SELECT count(*) FROM fleet.alarms a WHERE a.site = s.site AND a.rule = 'calibration-drift'
                                                          AND a.created_s >= $1::float8 - 7 * 86400),
                        h.at_s, h.pending, h.oldest_pending_s,
                        (SELECT max(at_s) FROM fleet.heartbeats z WHERE z.site = s.site AND z.pending = 0)
                 FROM fleet.sites s
                 LEFT JOIN LATERAL (SELECT seq, time_s, bank_id FROM fleet.passes p WHERE p.site = s.site
                                    ORDER BY seq DESC LIMIT 1) np ON true
                 LEFT JOIN LATERAL (SELECT at_s, pending, oldest_pending_s FROM fleet.heartbeats h
                                    WHERE h.site = s.site ORDER BY at_s DESC LIMIT 1) h ON true
                 ORDER BY s.site",
                &[&now_s],
            )
            .map_err(self.target.sql("reading the sites' health"))?;
        Ok(rows
            .iter()
            .map(|r| {
                let pending: Option<i32> = r.get(8);
                let oldest: Option<f64> = r.get(9);
                let caught_up: Option<f64> = r.get(10);
                let lag_s = match (pending, oldest) {
                    (Some(p), Some(o)) if p > 0 => Some(now_s - o),
                    _ => caught_up.map(|t| now_s - t),
                };
                SiteHealth {
                    site: r.get(0),
                    newest_seq: r.get::<_, Option<i64>>(1).unwrap_or(0),
                    newest_pass_s: r.get(2),
                    bank_id: r.get(3),
                    bank_since_s: r.get(4),
                    refusals_24h: r.get(5),
                    drift_alarms_7d: r.get(6),
                    heartbeat_s: r.get(7),
                    pending: pending.map(i64::from),
                    lag_s: lag_s.map(|l| l.max(0.0)),
                }
            })
            .collect())
    }
}
