//! What a run of the simulator gives back: pad forces at the output rate, and what to record
//! besides.

use std::ops::Range;

/// What to record besides the pad forces.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Record {
    /// Also record the two wheel–rail contact forces at the output rate.
    pub contact: bool,
}

/// Output of one run: pad forces at the output rate over the span of all sensor windows.
#[derive(Debug, Clone, PartialEq)]
pub struct Response {
    /// Output sample rate (Hz).
    pub sample_rate_hz: f64,
    /// Global index of the first stored sample (`t = k / rate`).
    pub first_sample: usize,
    /// Pad force per sensor (calibration order), N, compression positive.
    pub pad_force_n: Vec<Vec<f64>>,
    /// Contact forces `[leading, trailing]` at the output rate, when recorded (N).
    pub contact_force_n: Option<[Vec<f64>; 2]>,
    /// Largest contact force of each wheel over all integration steps (N).
    pub peak_contact_force_n: [f64; 2],
    /// Total time each wheel spent out of contact (s).
    pub contact_loss_s: [f64; 2],
    /// Times at which the flat starts to strike (s).
    pub strike_times_s: Vec<f64>,
    /// Integration steps taken `[coarse, fine]`.
    pub steps: [usize; 2],
}

impl Response {
    /// Number of stored samples.
    pub fn len(&self) -> usize {
        self.pad_force_n.first().map_or(0, Vec::len)
    }

    /// True when no samples are stored.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Time of stored sample `j` (s).
    pub fn time_s(&self, j: usize) -> f64 {
        (self.first_sample + j) as f64 / self.sample_rate_hz
    }

    /// The window of sensor `i` (its own time axis starts at global sample `start`).
    pub fn window(&self, i: usize, start: usize, len: usize) -> &[f64] {
        let off = start - self.first_sample;
        &self.pad_force_n[i][off..off + len]
    }

    /// Resamples a response recorded with margins onto the output samples `samples`, delayed
    /// by the output delay τ = `delay_s` (time-offset and speed-deviation effects): sample k
    /// reads the recorded series at `k/rate − τ` (linear interpolation; before the first
    /// recorded sample, the first value).
    pub fn delay_onto(&mut self, samples: Range<usize>, delay_s: f64) {
        let rate = self.sample_rate_hz;
        let first = samples.start;
        let recorded_first = self.first_sample;
        let shift = |series: &[f64]| -> Vec<f64> {
            samples
                .clone()
                .map(|k| {
                    let pos = k as f64 - delay_s * rate - recorded_first as f64;
                    let i = pos.floor().clamp(0.0, (series.len() - 2) as f64) as usize;
                    let f = (pos - i as f64).clamp(0.0, 1.0);
                    series[i] * (1.0 - f) + series[i + 1] * f
                })
                .collect()
        };
        self.pad_force_n = self.pad_force_n.iter().map(|s| shift(s)).collect();
        if let Some(c) = self.contact_force_n.as_mut() {
            *c = [shift(&c[0]), shift(&c[1])];
        }
        self.first_sample = first;
    }
}
