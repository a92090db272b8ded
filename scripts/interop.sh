#!/usr/bin/env bash
# Install pyarrow, DuckDB, Polars and DataFusion (Python packages) into a virtual environment and
# run tests/interop.rs with it: each engine reads a sensor-partitioned gradtac archive.
#
#   scripts/interop.sh            # venv in $CARGO_TARGET_DIR/interop-venv (or target/interop-venv)
#   INTEROP_VENV=/tmp/v scripts/interop.sh
set -euo pipefail
cd "$(dirname "$0")/.."
venv="${INTEROP_VENV:-${CARGO_TARGET_DIR:-target}/interop-venv}"
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
fi
"$venv/bin/pip" install --quiet --upgrade pyarrow duckdb polars datafusion
"$venv/bin/python" -c 'import pyarrow, duckdb, polars, datafusion
print("pyarrow", pyarrow.__version__, "| duckdb", duckdb.__version__, "| polars", polars.__version__, "| datafusion", datafusion.__version__)'
GRADTAC_PYTHON="$venv/bin/python" cargo test --test interop -- --nocapture
