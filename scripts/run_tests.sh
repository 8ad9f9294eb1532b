#!/usr/bin/env bash
# Set up .venv (first run installs the ROS 2 Jazzy wheels) and run the whole test suite.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup_env.sh"
cd "$repo"
exec python -m pytest -p no:cacheprovider test "$@"
