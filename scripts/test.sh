#!/usr/bin/env bash
# Set-up (Debian packages when missing), then the whole test suite.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh --no-build
cargo test --locked --all-targets "$@"
