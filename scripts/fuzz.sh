#!/usr/bin/env bash
# The long robustness profile: 20x the generated hostile messages of the test suite's CI
# profile (about 120,000 through the node's pipeline, 500 batches on a live node).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup_env.sh"
cd "$repo"
export DA_FUZZ_PROFILE=long
exec python -m pytest -p no:cacheprovider -q -s test/test_fuzz_messages.py test/test_fuzz_node.py "$@"
