#!/usr/bin/env bash
# Builds the Python package (an abi3 wheel, by maturin, in the workspace's target directory) into
# a virtual environment under target/, and runs its tests against the command's numbers, and the
# FMU tests with FMPy (validation, its co-simulation master against the package's stepping).
# Needs python3 with venv; everything else comes from PyPI. Run from anywhere:
#   bash python/test.sh
set -euo pipefail
cd "$(dirname "$0")/.."
if ! command -v python3 >/dev/null; then
  echo "python/test.sh: no python3 on this machine; the Rust crates are tested by cargo test"
  exit 0
fi
venv=target/python-venv
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
fi
"$venv/bin/pip" install -q --disable-pip-version-check "maturin>=1.5,<2" "numpy>=1.21" "pytest>=7" "matplotlib>=3.5" "fmpy>=0.3.20"
# The command whose numbers the tests compare with, and the library inside its FMUs.
cargo build --release -p lieflow-cli -p lieflow-fmu
# A fresh directory: the one wheel just built is the one installed.
rm -rf target/python-wheel
"$venv/bin/maturin" build --release -m python/Cargo.toml -o target/python-wheel --interpreter "$venv/bin/python"
"$venv/bin/pip" install -q --disable-pip-version-check --force-reinstall --no-deps target/python-wheel/lieflow-*.whl
LIEFLOW_BIN="$PWD/target/release/lieflow" "$venv/bin/python" -m pytest -q python/tests
# The example that plots (a notebook-style script).
"$venv/bin/python" python/examples/pendulum_plot.py target/pendulum.png
