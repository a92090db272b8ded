#!/usr/bin/env bash
# The workspace's API docs build with every rustdoc warning an error: no broken or private
# intra-doc link, no redundant link target. Only the workspace's crates are documented
# (--no-deps); the root package's default features pull in gradtac-stages' `train`, so the
# trainers' docs are checked too. ≈ 15–35 s warm on 2 cores (the dependencies' metadata is
# built by the test step before it).
set -euo pipefail
cd "$(dirname "$0")/.."
echo "== API docs: cargo doc --workspace --no-deps with RUSTDOCFLAGS=\"-D warnings\""
RUSTDOCFLAGS="-D warnings" cargo doc --workspace --no-deps
