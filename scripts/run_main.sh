#!/usr/bin/env bash
# Set up .venv (first run installs the ROS 2 Jazzy wheels) and run the main job: replay the
# clutter_range_bearing bag through the live association_node with every algorithm and print
# the score table. With arguments, they go to da_bag_eval instead (e.g. bags/boxes --offline).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup_env.sh"
cd "$repo"
if [ "$#" -eq 0 ]; then
  set -- bags/clutter_range_bearing --rate 2
fi
exec python -m data_association_ros.bag.evaluate "$@"
