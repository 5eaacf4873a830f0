//! [`Extras`]: which optional parts of the analysis a pass runs besides the method itself.

/// Which optional parts of the analysis to run besides the method itself.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Extras {
    /// Residual minimisation, random subsets and equidistant points (paper §4.4–4.6).
    pub baselines: bool,
    /// Joint entropy curves per sensor set (paper Fig. 16).
    pub curves: bool,
    /// The record as recorded: its load read and reported, but not put on the bank's load
    /// (diagnosis, which asks whether the model explains the record itself).
    pub as_recorded: bool,
}

impl Extras {
    /// The method alone: no baselines, no entropy curves.
    pub const NONE: Extras = Extras {
        baselines: false,
        curves: false,
        as_recorded: false,
    };
    /// The method alone on the record as recorded ([`Extras::as_recorded`]).
    pub const AS_RECORDED: Extras = Extras {
        baselines: false,
        curves: false,
        as_recorded: true,
    };
}
