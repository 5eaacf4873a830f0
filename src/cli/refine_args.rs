//! `--refine [--refine-simulations N]`: one argument group for every command that identifies
//! (`identify`, `train`, `watch`).

use clap::Args;

/// `--refine [--refine-simulations N]`, shared by `identify`, `train` and `watch`.
#[derive(Debug, Clone, Copy, Args)]
pub(super) struct RefineArgs {
    /// Also refine: simulate new flats inside the surviving cells with the bank's calibration
    /// and falsify them at the same points (about 1.2 s a measurement, or a train's wheel with
    /// a flat, on 2 cores); reported beside the bank-only answer, and a train's wheel takes its
    /// severity from it (docs/identification.md#refinement).
    #[arg(long)]
    pub refine: bool,
    /// Simulations of each refinement, split over its rounds (1–20000).
    #[arg(long, default_value_t = 640, requires = "refine")]
    pub refine_simulations: usize,
}

impl RefineArgs {
    /// The simulations of each refinement, when asked for.
    pub(super) fn simulations(&self) -> Option<usize> {
        self.refine.then_some(self.refine_simulations)
    }
}
