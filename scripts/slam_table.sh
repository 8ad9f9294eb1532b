#!/usr/bin/env bash
# Set up .venv (first run installs the ROS 2 Jazzy wheels) and print the SLAM score table: every
# real-data bag in bags/ through association_node + ekf_slam_node, every point algorithm, oracle
# and closed loop (da_slam_eval; arguments go to it, e.g. --markdown, --live, --steps 200).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup_env.sh"
cd "$repo"
exec python -m data_association_ros.bag.slam_eval "$@"
