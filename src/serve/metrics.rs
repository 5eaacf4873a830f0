//! `/metrics`: the site's health in the Prometheus text format (docs/alarms.md, "Metrics"),
//! read from the results database — so the counts are the database's, whichever process
//! serves them (`serve`, or `watch --metrics`), and they survive restarts — and from the bank
//! folder (the bank's age, the newest nightly check).
//!
//! The counters are kept between scrapes and advanced by the rows stored since the last one
//! ([`crate::history::Tally`]): a scrape reads what is new, not the whole database.

use super::counts::ANSWER_BUCKETS_S;
use super::state::AppState;
use crate::history::DbError;
use crate::identify::Severity;
use prometheus::proto::{
    Bucket, Counter, Gauge, Histogram, LabelPair, Metric, MetricFamily, MetricType,
};
use prometheus::{Encoder, TextEncoder};

pub(super) fn label(name: &str, value: &str) -> LabelPair {
    let mut l = LabelPair::default();
    l.set_name(name.to_string());
    l.set_value(value.to_string());
    l
}

pub(super) fn family(
    name: &str,
    help: &str,
    kind: MetricType,
    metrics: Vec<Metric>,
) -> MetricFamily {
    let mut f = MetricFamily::default();
    f.set_name(name.to_string());
    f.set_help(help.to_string());
    f.set_field_type(kind);
    f.set_metric(metrics);
    f
}

fn counter(labels: Vec<LabelPair>, v: f64) -> Metric {
    let mut c = Counter::default();
    c.set_value(v);
    let mut m = Metric::default();
    m.set_label(labels);
    m.set_counter(c);
    m
}

pub(super) fn gauge(labels: Vec<LabelPair>, v: f64) -> Metric {
    let mut g = Gauge::default();
    g.set_value(v);
    let mut m = Metric::default();
    m.set_label(labels);
    m.set_gauge(g);
    m
}

/// The metrics now, in the Prometheus text format.
pub(crate) fn metrics_text(state: &AppState) -> Result<String, DbError> {
    let (after_pass, after_failure) = state
        .counts
        .lock()
        .map(|c| (c.last_pass_id, c.last_failure_id))
        .unwrap_or((0, 0));
    let (tally, alarms) = state.read(|db| {
        Ok((
            db.tally_after(after_pass, after_failure)?,
            db.alarm_counts()?,
        ))
    })?;
    let mut fams = Vec::new();
    {
        let mut c = state.counts.lock().unwrap_or_else(|e| e.into_inner());
        // Another scrape may have advanced past these rows meanwhile: counted once.
        if c.last_pass_id == after_pass && c.last_failure_id == after_failure {
            c.advance(tally);
        }
        fams.push(family(
            "wheelflat_passes_total",
            "Passes by outcome: answered (stored; a train's bogies each), refused (wheelflat declined the input), failed (something broke).",
            MetricType::COUNTER,
            vec![
                counter(vec![label("outcome", "answered")], c.answered as f64),
                counter(vec![label("outcome", "refused")], c.refused as f64),
                counter(vec![label("outcome", "failed")], c.failed as f64),
            ],
        ));
        let mut h = Histogram::default();
        let mut cumulative = 0;
        let mut buckets = Vec::new();
        for (b, n) in ANSWER_BUCKETS_S.iter().zip(c.buckets) {
            cumulative += n;
            let mut bucket = Bucket::default();
            bucket.set_upper_bound(*b);
            bucket.set_cumulative_count(cumulative);
            buckets.push(bucket);
        }
        h.set_bucket(buckets);
        h.set_sample_count(c.answer_count);
        h.set_sample_sum(c.answer_sum_s);
        let mut m = Metric::default();
        m.set_histogram(h);
        fams.push(family(
            "wheelflat_answer_seconds",
            "How long a pass's answer took, from the measurement read to its result written (passes stored with schema 3 on).",
            MetricType::HISTOGRAM,
            vec![m],
        ));
        let mut by_class = [0usize; 4];
        for class in c.wheels.values().flatten() {
            by_class[*class as usize] += 1;
        }
        let classes = [
            Severity::None,
            Severity::Monitor,
            Severity::Inspect,
            Severity::Urgent,
        ];
        fams.push(family(
            "wheelflat_wheels",
            "Named wheels by the class acted on at their newest pass.",
            MetricType::GAUGE,
            classes
                .iter()
                .map(|k| {
                    gauge(
                        vec![label("class", k.as_str())],
                        by_class[*k as usize] as f64,
                    )
                })
                .collect(),
        ));
        if let Some(t) = c.newest_time_s {
            fams.push(family(
                "wheelflat_newest_pass_timestamp_seconds",
                "When the newest pass stored was answered (Unix seconds).",
                MetricType::GAUGE,
                vec![gauge(vec![], t)],
            ));
        }
    }
    fams.push(family(
        "wheelflat_alarms",
        "Alarms in the outbox by status, one a destination: pending (not tried), failed (tried, to be tried again), sent.",
        MetricType::GAUGE,
        vec![
            gauge(vec![label("status", "pending")], alarms.pending as f64),
            gauge(vec![label("status", "failed")], alarms.failed as f64),
            gauge(vec![label("status", "sent")], alarms.sent as f64),
        ],
    ));
    if let Some(bank) = &state.settings.bank {
        let now = crate::history::db::now_s();
        let switched = crate::alarm::drift::modified_s(&bank.join("CURRENT"))
            .or_else(|| crate::alarm::drift::modified_s(&bank.join("family.json")));
        if let Some(t) = switched {
            fams.push(family(
                "wheelflat_bank_age_seconds",
                "Since the bank version in use was switched to (CURRENT, or a family's family.json, written).",
                MetricType::GAUGE,
                vec![gauge(vec![], (now - t).max(0.0))],
            ));
        }
        if let Some(check) = crate::alarm::drift::newest_check(bank) {
            if let Some(t) = check.modified_s {
                fams.push(family(
                    "wheelflat_calibration_check_timestamp_seconds",
                    "When the newest nightly check (calibration-*.json in the bank folder) was written.",
                    MetricType::GAUGE,
                    vec![gauge(vec![], t)],
                ));
            }
            let drifted = match (&check.unreadable, &check.drifted) {
                (Some(_), _) => -1.0,
                (None, Some(d)) => d.len() as f64,
                (None, None) => 0.0,
            };
            fams.push(family(
                "wheelflat_calibration_check_drifted",
                "Values the newest nightly check found drifted (0: none; -1: the report cannot be read).",
                MetricType::GAUGE,
                vec![gauge(vec![], drifted)],
            ));
        }
    }
    let mut out = Vec::new();
    TextEncoder::new()
        .encode(&fams, &mut out)
        .expect("metric families with metrics encode");
    Ok(String::from_utf8(out).expect("the text format is UTF-8"))
}
