//! [`Identifier`]: what is kept open between measurements (the memory-mapped bank, its
//! parameters and cells, the settings and their combined uncertainty, the working buffers and
//! the tables loaded when a pass first needs them), and its accessors. The stages that use it
//! are methods beside their stage ([`super::stages`], the stage folders).

use super::domain::uncertainty::{CombinedUncertainty, ThresholdCurve};
use super::input::compare::{self, Comparison};
use crate::bank::departures::{self, Departures};
use crate::bank::out_of_round::OutOfRoundBasis;
use crate::bank::roughness::RoughnessTable;
use crate::bank::{Bank, Parameters};
use crate::identify::domain::cells::Cells;
use crate::identify::domain::discretisation::{self, share, static_load_kn};
use crate::identify::domain::falsify::Resolution;
use crate::identify::domain::load_shapes::LoadShapes;
use crate::identify::domain::table_bounds::TableBounds;
use crate::identify::error::IdentifyError;
use crate::identify::input;
use crate::model::average::weights_at;
use crate::model::calibration::IdentificationParams;
use std::sync::{Arc, Mutex};

/// What is kept open between measurements.
pub struct Identifier {
    pub(super) bank: Bank,
    pub(super) params: Parameters,
    /// Each instance's neighbours and cell (the bank's resolution).
    pub(super) cells: Cells,
    pub(super) settings: IdentificationParams,
    pub(super) uncertainty: CombinedUncertainty,
    /// The table's hard bounds the detection step and the departure rule judge with.
    pub(super) bounds: TableBounds,
    /// Each instance's discretisation share (empty: none; [`Identifier::discretisation`]).
    pub(super) discretisation: Vec<f32>,
    pub(super) buffers: Mutex<input::buffer::HugeBuffer>,
    pub(super) bin_buffers: Mutex<input::buffer::HugeBuffer>,
    /// The bank's departures tables (samples, averaged), loaded when a pass first needs one.
    pub(super) departures: [Mutex<Option<std::sync::Arc<crate::bank::departures::Departures>>>; 2],
    /// The bank's flat-free predictions through the average, per axis ([`compare`]).
    pub(super) flat_free_averaged: Vec<Vec<f32>>,
    /// The table's level factor per number of sensors ([`input::load::level_factor`]), drawn once.
    pub(super) load_levels: Mutex<std::collections::HashMap<usize, (f64, [f64; 2])>>,
    /// The bank's roughness table, loaded when a pass first needs it ([`roughness`]).
    pub(super) roughness: Mutex<Option<std::sync::Arc<crate::bank::roughness::RoughnessTable>>>,
    /// The high-frequency level the settings' noise alone gives ([`roughness::noise_hf_kn`]),
    /// drawn when a pass first needs it.
    pub(super) noise_hf: std::sync::OnceLock<f64>,
    /// The bank's out-of-round basis, simulated when a pass first needs it ([`out_of_round`]).
    pub(super) out_of_round:
        Mutex<Option<std::sync::Arc<crate::bank::out_of_round::OutOfRoundBasis>>>,
    /// The flat-free predictions of the family's members at this bank's speed, by load
    /// ([`crate::identify::domain::load_shapes`]); `None` on a single bank or one load.
    pub(super) load_shapes: Option<Arc<LoadShapes>>,
}

impl Identifier {
    /// Opens the reusable state for a bank, with identification settings (the bank's stored
    /// calibration's, or the user's).
    pub fn new(bank: Bank, settings: IdentificationParams) -> Result<Identifier, IdentifyError> {
        // The stored graph when it was searched in today's metric; else (a bank written
        // before the metric was stretched) searched now, 0.3 s for 50,000 instances.
        let population = &bank.metadata().calibration.population;
        let stored = bank
            .neighbour_weights()
            .is_some_and(|w| crate::bank::neighbours::in_metric_of(w, population));
        let params = bank.read_parameters()?;
        let cells = Cells::new(&params, population, bank.neighbours().filter(|_| stored));
        Ok(Identifier::from_parts(bank, settings, params, cells))
    }

    /// [`Identifier::new`] with the cells' neighbour graph given (`None`: searched now).
    pub fn with_neighbours(
        bank: Bank,
        settings: IdentificationParams,
        graph: Option<Vec<u32>>,
    ) -> Result<Identifier, IdentifyError> {
        let params = bank.read_parameters()?;
        let population = &bank.metadata().calibration.population;
        let cells = Cells::new(&params, population, graph.as_deref());
        Ok(Identifier::from_parts(bank, settings, params, cells))
    }

    /// The identifier of an opened bank, its parameters and cells (the buffers empty until the
    /// first measurement).
    fn from_parts(
        bank: Bank,
        settings: IdentificationParams,
        params: Parameters,
        cells: Cells,
    ) -> Identifier {
        let uncertainty = CombinedUncertainty::new(&settings);
        let bounds = TableBounds::of(&settings);
        let discretisation = discretisation::shares(&settings, &params, &bank);
        let flat_free_averaged = compare::averaged_templates(&bank.metadata().flat_free_kn);
        Identifier {
            bank,
            params,
            cells,
            settings,
            uncertainty,
            bounds,
            discretisation,
            buffers: Mutex::new(input::buffer::HugeBuffer::default()),
            bin_buffers: Mutex::new(input::buffer::HugeBuffer::default()),
            departures: [Mutex::new(None), Mutex::new(None)],
            flat_free_averaged,
            load_levels: Mutex::new(std::collections::HashMap::new()),
            roughness: Mutex::new(None),
            noise_hf: std::sync::OnceLock::new(),
            out_of_round: Mutex::new(None),
            load_shapes: None,
        }
    }

    /// Reads and puts every pass on this bank's load with the members' shapes `shapes` (a
    /// family over loads; [`crate::identify::domain::load_shapes`]).
    pub(crate) fn set_load_shapes(&mut self, shapes: Option<Arc<LoadShapes>>) {
        self.load_shapes = shapes;
    }

    /// The bank.
    pub fn bank(&self) -> &Bank {
        &self.bank
    }

    /// The bank's parameters (one row per instance).
    pub fn params(&self) -> &Parameters {
        &self.params
    }

    /// The settings in use.
    pub fn settings(&self) -> &IdentificationParams {
        &self.settings
    }

    /// The table's hard bounds a good wheel's record stays within ([`TableBounds`];
    /// a pass adds its roughness, [`crate::identify::RoughnessUse::bounds`]).
    pub fn table_bounds(&self) -> TableBounds {
        self.bounds
    }

    /// Thresholds `[low, high]` on `prediction − measurement` (kN) where the measured force is
    /// `y_kn`, holding probability `p` (the combined uncertainty of the settings).
    pub fn thresholds(&self, y_kn: f64, p: f64) -> (f64, f64) {
        self.uncertainty.thresholds(y_kn, p)
    }

    /// The thresholds `[low, high]` on `g − y` that falsification applies to a prediction
    /// `g_kn` at a point measured at `y_kn`, with per-point probability `p`: the measured
    /// force's, or the prediction's own where it is larger ([`ThresholdCurve`]).
    pub fn band(&self, y_kn: f64, g_kn: f64, p: f64) -> (f64, f64) {
        if g_kn.abs() > y_kn.abs() {
            self.threshold_curve(y_kn, p).at(g_kn)
        } else {
            self.uncertainty.thresholds(y_kn, p)
        }
    }

    /// The thresholds of a point measured at `y_kn` as a function of the prediction's force
    /// ([`ThresholdCurve`]), at per-point probability `p`.
    pub fn threshold_curve(&self, y_kn: f64, p: f64) -> ThresholdCurve {
        self.uncertainty.curve(y_kn, p)
    }

    /// The bank's flat-free prediction of bank axis `axis` at its samples `from..=to` as
    /// comparison `c` sees it (kN), the largest magnitude: what the bounded sources (a rough
    /// tread or rail) scale with at a comparison point or window.
    pub fn flat_free_peak_kn(&self, axis: usize, from: usize, to: usize, c: Comparison) -> f64 {
        let t = self.flat_free(axis, c);
        let last = t.len().saturating_sub(1);
        t[from.min(last)..=to.min(last)]
            .iter()
            .fold(0.0f64, |m, &g| m.max(f64::from(g).abs()))
    }

    /// The bank's resolution as falsification uses it (`None` when switched off).
    pub fn resolution(&self) -> Option<Resolution<'_>> {
        (self.settings.bank_resolution > 0.0).then_some(Resolution {
            cells: &self.cells,
            kappa: self.settings.bank_resolution,
        })
    }

    /// The typical widening at a point: κ × the median neighbour spread (0 when off).
    pub(super) fn typical_widening(&self, predictions: &[f32]) -> f64 {
        match self.resolution() {
            Some(r) => r.kappa * r.cells.typical_spread(predictions, 1024),
            None => 0.0,
        }
    }

    /// The discretisation share of a flat whose wheel's peak wheel–rail force is `peak_kn`
    /// (a refinement's simulated flats; [`Identifier::discretisation`]).
    pub fn discretisation_share(&self, peak_kn: f64) -> f32 {
        share(&self.settings, static_load_kn(&self.bank), peak_kn)
    }

    /// Every instance's prediction at `(axis, sample)` of each of `points` as comparison `c`
    /// sees it, into `out` (one column of `instances` after another).
    pub(crate) fn read_compared(
        &self,
        points: &[(usize, usize)],
        c: Comparison,
        out: &mut [f32],
    ) -> Result<(), IdentifyError> {
        let n = self.bank.instances();
        if c == Comparison::Samples {
            let cols: Vec<usize> = points
                .iter()
                .map(|&(a, k)| self.bank.sample_index(a, k))
                .collect();
            return Ok(self.bank.read_columns_flat(&cols, out)?);
        }
        let axes = &self.bank.metadata().sensors;
        for (b, block) in points.chunks(BLOCK).enumerate() {
            // The stored columns the block's averages take, and their weights.
            let mut stored: Vec<usize> = Vec::new();
            let terms: Vec<Vec<(usize, f64)>> = block
                .iter()
                .map(|&(a, k)| {
                    let (first, w) = weights_at(k, axes[a].samples, c.weights());
                    w.into_iter()
                        .enumerate()
                        .map(|(j, w)| {
                            let col = self.bank.sample_index(a, first + j);
                            let at = stored.iter().position(|&s| s == col).unwrap_or_else(|| {
                                stored.push(col);
                                stored.len() - 1
                            });
                            (at, w)
                        })
                        .collect()
                })
                .collect();
            let values = self.bank.read_columns(&stored)?;
            for (j, t) in terms.iter().enumerate() {
                let dest = &mut out[(b * BLOCK + j) * n..(b * BLOCK + j + 1) * n];
                for (i, d) in dest.iter_mut().enumerate() {
                    *d = t
                        .iter()
                        .map(|&(at, w)| w * f64::from(values[at][i]))
                        .sum::<f64>() as f32;
                }
            }
        }
        Ok(())
    }

    // The tables loaded when a pass first needs them, kept for the next (built with the bank,
    // bank::derived; computed here only for a bank without them).

    /// The bank's departures table of comparison `c` (read from its file, or computed and
    /// stored on first use; kept for the next pass).
    pub fn departures(&self, c: Comparison) -> Result<Arc<Departures>, IdentifyError> {
        let slot = &self.departures[usize::from(c == Comparison::Binomial5)];
        let mut slot = slot.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(d) = slot.as_ref() {
            return Ok(Arc::clone(d));
        }
        let d = Arc::new(departures::load_or_compute(&self.bank, c.weights())?);
        *slot = Some(Arc::clone(&d));
        Ok(d)
    }

    /// The bank's roughness table for the settings' rail (computed and stored on first use;
    /// kept for the next pass).
    pub fn roughness_table(&self) -> Result<Arc<RoughnessTable>, IdentifyError> {
        let mut slot = self.roughness.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(t) = slot.as_ref() {
            return Ok(Arc::clone(t));
        }
        let rail = self.settings.rail_roughness.class();
        let t = Arc::new(crate::bank::roughness::load_or_compute(&self.bank, rail)?);
        *slot = Some(Arc::clone(&t));
        Ok(t)
    }

    /// The bank's out-of-round basis (read from its cache, or simulated and stored on first
    /// use; kept for the next pass).
    pub fn out_of_round_basis(&self) -> Result<Arc<OutOfRoundBasis>, IdentifyError> {
        let mut slot = self.out_of_round.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(b) = slot.as_ref() {
            return Ok(Arc::clone(b));
        }
        let b = Arc::new(crate::bank::out_of_round::load_or_compute(&self.bank)?);
        *slot = Some(Arc::clone(&b));
        Ok(b)
    }

    /// Each instance's share of its step between adjacent samples allowed for the bank mesh's
    /// discretisation error at a comparison point (None when the settings allow none):
    /// `discretisation_fraction` for instances whose peak wheel–rail force reaches
    /// `discretisation_dynamic_ratio` times the static wheel load (a flat that loses contact
    /// and lands), 0 for the others.
    pub fn discretisation(&self) -> Option<&[f32]> {
        (!self.discretisation.is_empty()).then_some(self.discretisation.as_slice())
    }

    /// The bank's flat-free prediction of axis `axis` as comparison `c` sees it (kN).
    pub(crate) fn flat_free(&self, axis: usize, c: Comparison) -> &[f32] {
        match c {
            Comparison::Samples => &self.bank.metadata().flat_free_kn[axis],
            Comparison::Binomial5 => &self.flat_free_averaged[axis],
        }
    }
}

/// Requested columns averaged at a time: 32 columns need at most 160 stored ones
/// (32 MB for 50,000 instances).
const BLOCK: usize = 32;
