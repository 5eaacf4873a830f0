//! What `/metrics` has counted so far (kept in the server's state between scrapes), advanced
//! by the rows stored since the scrape before.

use crate::identify::Severity;
use std::collections::HashMap;

/// The answer-time histogram's upper bounds (s).
pub(super) const ANSWER_BUCKETS_S: [f64; 10] =
    [0.05, 0.1, 0.25, 0.5, 1.0, 2.5, 5.0, 10.0, 30.0, 60.0];

/// What the counters have counted so far.
#[derive(Debug, Default)]
pub(crate) struct Counts {
    pub(super) last_pass_id: i64,
    pub(super) last_failure_id: i64,
    pub(super) answered: u64,
    pub(super) refused: u64,
    pub(super) failed: u64,
    /// Per bucket of [`ANSWER_BUCKETS_S`] (not cumulative), then the sum (s) and the count.
    pub(super) buckets: [u64; ANSWER_BUCKETS_S.len()],
    pub(super) answer_sum_s: f64,
    pub(super) answer_count: u64,
    pub(super) newest_time_s: Option<f64>,
    /// Each named wheel's class acted on at its newest pass.
    pub(super) wheels: HashMap<String, Option<Severity>>,
}

impl Counts {
    /// Advances the counts by the rows stored since the last scrape.
    pub(super) fn advance(&mut self, t: crate::history::Tally) {
        self.last_pass_id = t.last_pass_id;
        self.last_failure_id = t.last_failure_id;
        self.answered += t.answered;
        self.refused += t.refused;
        self.failed += t.failed;
        for ms in t.answer_ms {
            let s = ms / 1e3;
            if let Some(i) = ANSWER_BUCKETS_S.iter().position(|&b| s <= b) {
                self.buckets[i] += 1;
            }
            self.answer_sum_s += s;
            self.answer_count += 1;
        }
        if let Some(n) = t.newest_time_s {
            self.newest_time_s = Some(self.newest_time_s.map_or(n, |o| o.max(n)));
        }
        for (w, c) in t.wheel_classes {
            self.wheels.insert(w, c);
        }
    }
}
