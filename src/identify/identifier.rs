//! [`Identifier`]: what is kept open between measurements (the memory-mapped bank, its
//! parameters and cells, the settings and their combined uncertainty, the working buffers and
//! the tables loaded when a pass first needs them), and its accessors. The stages that use it
//! are methods beside their stage ([`super::stages`], the stage folders).

use super::answer::ranges::ranges_of;
use super::answer::result::ParamRanges;
use super::detect::{self, roughness::RoughnessUse};
use super::domain::cells::Cells;
use super::domain::discretisation;
use super::domain::falsify::Resolution;
use super::domain::uncertainty::{CombinedUncertainty, ThresholdCurve};
use super::input;
use super::input::compare::{self, Comparison};
use super::IdentifyError;
use crate::bank::departures::{self, Departures};
use crate::bank::out_of_round::OutOfRoundBasis;
use crate::bank::roughness::RoughnessTable;
use crate::bank::{Bank, Parameters};
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
    pub(super) bounds: detect::TableBounds,
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
        let bounds = detect::TableBounds::of(&settings);
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
        }
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

    /// The table's hard bounds a good wheel's record stays within ([`detect::TableBounds`];
    /// a pass adds its roughness, [`RoughnessUse::bounds`]).
    pub fn table_bounds(&self) -> detect::TableBounds {
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

    /// The threshold curve of a point measured at `y_kn` whose flat-free prediction is
    /// `flat_free_kn`, in a pass judged with `roughness`: the table's curve widened by its
    /// bounded sources and by the roughness' bound there.
    pub fn point_curve(
        &self,
        roughness: &RoughnessUse,
        y_kn: f64,
        flat_free_kn: f64,
        p: f64,
    ) -> ThresholdCurve {
        let (a, b) = self.uncertainty.good_wheel_widening(flat_free_kn);
        let w = roughness.widening_kn(flat_free_kn);
        self.uncertainty.curve(y_kn, p).widened((a - w, b + w))
    }

    /// The thresholds of a point measured at `y_kn` whose flat-free prediction is
    /// `flat_free_kn`, in a pass judged with `roughness` (as [`Identifier::point_curve`]).
    pub fn point_thresholds(
        &self,
        roughness: &RoughnessUse,
        y_kn: f64,
        flat_free_kn: f64,
        p: f64,
    ) -> (f64, f64) {
        let (lo, hi) = self.uncertainty.thresholds_at(y_kn, flat_free_kn, p);
        let w = roughness.widening_kn(flat_free_kn);
        (lo - w, hi + w)
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

    /// The parameter ranges a set of instances stands for.
    pub(super) fn ranges(
        &self,
        members: impl Iterator<Item = usize> + Clone,
    ) -> Option<ParamRanges> {
        let cal = &self.bank.metadata().calibration;
        ranges_of(
            &self.params,
            self.resolution().map(|r| r.cells),
            &cal.population,
            (
                cal.vehicle.wheel_radius_m,
                cal.vehicle.static_wheel_load_n() / 1e3,
            ),
            members,
        )
    }

    // The tables loaded when a pass first needs them, kept for the next.

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
