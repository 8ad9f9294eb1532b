#!/usr/bin/env bash
# Set up .venv, add the benchmark-only extras (matplotlib, stonesoup) and run the benchmark
# suite: markdown tables on stdout and in benchmarks/results/, the plot
# benchmarks/results/associators.png. Arguments go to benchmarks/run_benchmarks.py
# (e.g. --quick, --sections jcbb,stonesoup).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup_env.sh"
cd "$repo"
if ! python -c 'import matplotlib, stonesoup' 2>/dev/null; then
  python -m pip install --quiet --disable-pip-version-check -r scripts/requirements-benchmarks.txt
fi
exec python benchmarks/run_benchmarks.py "$@"
