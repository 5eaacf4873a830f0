//! wheelflat's integration tests, one binary (`cargo test --release`): each module tests one
//! capability through the library or the `wheelflat` binary. The long acceptance suites are
//! `#[ignore = "acceptance: …"]`; `cargo test --release -- --include-ignored` runs them too
//! (README, "Tests").

mod common;

mod alarms;
mod audit;
mod bank;
mod batch;
mod bounds;
mod calibrate;
mod cli;
mod cli_bank;
mod corruption;
mod diagnose;
mod effects;
mod family;
mod fleet;
mod fleet_cli;
mod fuzz;
mod growing;
mod history;
mod identify;
mod kill;
mod landing;
mod layout;
mod load;
mod nightly;
mod peer;
mod physics;
mod refine;
mod rough;
mod serve;
mod serve_browser;
mod site;
mod train;
mod watch;
mod writers;
