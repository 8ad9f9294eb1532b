#!/usr/bin/env bash
# Set up .venv (first run installs the ROS 2 Jazzy wheels) and run the main job.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup_env.sh"
cd "$repo"
exec python -m data_association_ros.demo "$@"
