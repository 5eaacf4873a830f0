//! `--refine [--refine-simulations N] [--refine-strategy S]`: one argument group for every
//! command that identifies (`identify`, `train`, `watch`).

use clap::{Args, ValueEnum};
use wheelflat::identify::refine::{RefineSettings, RefineStrategy};

/// How a refinement spends its simulations (`--refine-strategy`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(super) enum StrategyArg {
    /// At the cells that decide the L0 bounds, round by round, until the bounds stop moving
    /// (within 0.5 mm over two rounds) or the simulations are spent.
    Bounds,
    /// Over every surviving cell in two rounds (the earlier refinement).
    Spread,
}

/// `--refine [--refine-simulations N] [--refine-strategy S]`, shared by `identify`, `train`
/// and `watch`.
#[derive(Debug, Clone, Copy, Args)]
pub(super) struct RefineArgs {
    /// Also refine: simulate new flats where the bank's surviving cells decide the answer's
    /// L0 bounds, with the bank's calibration, and falsify them at the same points until the
    /// bounds stop moving (about 1–2 s a measurement, or a train's wheel with a flat, on 2
    /// cores); reported beside the bank-only answer, and a train's wheel takes its severity
    /// from it (docs/identification.md#refinement).
    #[arg(long)]
    pub refine: bool,
    /// The most simulations of each refinement (1–20000).
    #[arg(long, default_value_t = 640, requires = "refine")]
    pub refine_simulations: usize,
    /// How the simulations are spent.
    #[arg(long, value_enum, default_value_t = StrategyArg::Bounds, requires = "refine")]
    pub refine_strategy: StrategyArg,
}

impl RefineArgs {
    /// The refinement's settings, when asked for.
    pub(super) fn settings(&self) -> Option<RefineSettings> {
        self.refine.then_some(RefineSettings {
            simulations: self.refine_simulations,
            strategy: match self.refine_strategy {
                StrategyArg::Bounds => RefineStrategy::Bounds,
                StrategyArg::Spread => RefineStrategy::Spread,
            },
            ..RefineSettings::default()
        })
    }
}
