#!/usr/bin/env bash
# Builds the user guide (docs/, an mdBook) into target/guide/ (not committed): installs
# mdBook into target/tools/ first when it is missing (cargo install from crates.io, about
# 5 minutes on the shared 2-core machine; 0.4.40 builds with Rust 1.95). Open target/guide/index.html.
set -euo pipefail
cd "$(dirname "$0")/.."
version=0.4.40
mdbook=target/tools/bin/mdbook
if ! [ -x "$mdbook" ] || ! "$mdbook" --version | grep -q "v$version"; then
  cargo install mdbook --locked --version "$version" --root target/tools
fi
python3 scripts/check-links.py
"$mdbook" build docs
echo "guide in target/guide/index.html"
