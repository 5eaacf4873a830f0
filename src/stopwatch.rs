//! A stopwatch of named laps: how long each stage of a staged computation took, in the unit
//! its result names (ms for an identification's `timings_ms`, s for a diagnosis's
//! `timings_s`).

use std::time::Instant;

/// The laps of a staged computation, in order.
pub(crate) struct Stopwatch {
    clock: Instant,
    /// Units per second (1000 for ms).
    per_second: f64,
    /// (stage, time) in order.
    pub(crate) laps: Vec<(String, f64)>,
}

impl Stopwatch {
    /// The clock started, laps in ms.
    pub(crate) fn start_ms() -> Stopwatch {
        Stopwatch::start_in(1e3)
    }

    /// The clock started, laps in s.
    pub(crate) fn start_s() -> Stopwatch {
        Stopwatch::start_in(1.0)
    }

    fn start_in(per_second: f64) -> Stopwatch {
        Stopwatch {
            clock: Instant::now(),
            per_second,
            laps: Vec::new(),
        }
    }

    /// The time since the last lap (or the start), as `name`; the clock starts again.
    pub(crate) fn lap(&mut self, name: &str) {
        let t = self.clock.elapsed().as_secs_f64() * self.per_second;
        self.laps.push((name.to_string(), t));
        self.clock = Instant::now();
    }
}

#[cfg(test)]
mod tests {
    use super::Stopwatch;

    #[test]
    fn laps_are_named_in_order_and_never_negative() {
        let mut w = Stopwatch::start_ms();
        w.lap("read");
        w.lap("judge");
        let names: Vec<&str> = w.laps.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["read", "judge"]);
        assert!(w.laps.iter().all(|&(_, t)| t >= 0.0 && t.is_finite()));
    }
}
