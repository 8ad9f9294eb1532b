#!/usr/bin/env bash
# Set up .venv (first run installs the ROS 2 Jazzy wheels) and run the whole test suite, on two
# worker processes a test file each (pytest-xdist; each worker has its own ROS_DOMAIN_ID, see
# test/conftest.py). `-n 0` after it runs everything in one process.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup_env.sh"
cd "$repo"
exec python -m pytest -p no:cacheprovider -n 2 --dist loadfile test "$@"
