#!/usr/bin/env bash
# Plausibility of the default contact track on every BioTacSP-DoS dev recording (issue #10):
# contact share, per-frame jumps, contact frames whose raw signal rises above noise.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ ! -d ../shared/data/biotacsp-dos ]; then
  echo "locate_dos: ../shared/data/biotacsp-dos absent, skipped"
  exit 0
fi
cargo run --release --example locate_dos -- ../shared/data/biotacsp-dos
