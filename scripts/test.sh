#!/usr/bin/env bash
# Set-up (Debian packages when missing; ccx_peer, scripts/ccx-peer.sh, and its rotated-deck
# check, scripts/calculix/rotated_cube_check.py), then the whole test suite: the offline
# link check of README.md and the guide (scripts/check-links.py, under a second), the cargo
# tests, then the Python package's tests and notebook (scripts/test-python.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh --no-build
# CalculiX with the follower-pressure load stiffness, for the tests that check exported
# decks where stock ccx gives up (built once from Debian's source, 1-2 minutes).
scripts/ccx-peer.sh >/dev/null
# Its load stiffness in every orientation, and its answer against stock ccx's (half a
# minute: a rotated soft cube with a pressurised cavity).
python3 scripts/calculix/rotated_cube_check.py
python3 scripts/check-links.py
cargo test --locked --all-targets "$@"
# The tests that mount a tmpfs (a full disk, a read-only output folder) need root: they are
# #[ignore]d for other users, and run here when the runner is root (CI is).
if [ "$(id -u)" = 0 ]; then
    # (by name: the other ignored tests are the slow checks of scripts/bench-calculix-slow.sh)
    cargo test --locked --test outputs --test reliability --test simulate -- --ignored \
        read_only full_disk
else
    echo "note: not root: the tmpfs tests (cargo test ... -- --ignored) were not run" >&2
fi
scripts/test-python.sh
