#!/usr/bin/env bash
# Reproduces the convergence table in the README (mesh and time-step choice).
# Extra arguments: quadruples "elements_per_bay coarse_steps_per_sample fine_steps_per_coarse fine_after_ms".
set -euo pipefail
cd "$(dirname "$0")/.."
cargo run --release -p wheelflat-studies --bin convergence -- "$@"
