//! Why a site calibration could not be made: each variant names what failed.

/// Why `calibrate` stopped.
#[derive(Debug, thiserror::Error)]
pub enum SiteError {
    /// Too few usable passes to fit on and hold back.
    #[error("{passes} usable passes: calibration needs at least {need} ({min} fitted, every {every}th held back to measure the residual on)")]
    TooFewPasses {
        /// Usable passes given.
        passes: usize,
        /// Passes needed.
        need: usize,
        /// Of them fitted.
        min: usize,
        /// Every how many one is held back.
        every: usize,
    },
    /// A fit asked for with no pass.
    #[error("no pass to fit")]
    NoPass,
    /// A trial track's calibration does not check (a value the fit reached outside the
    /// calibration's ranges).
    #[error(transparent)]
    Calibration(#[from] crate::model::CalibrationError),
    /// A trial track could not be simulated.
    #[error(transparent)]
    Sim(#[from] crate::model::SimError),
}
