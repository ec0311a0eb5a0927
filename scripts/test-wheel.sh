#!/usr/bin/env bash
# The wheel of scripts/build-wheel.sh in a clean venv: installs it (pip, no Rust), checks
# that every OpenCV and FFmpeg library the extension loads comes from the wheel
# (bendscope.libs/), not from the system, and measures the example session against its
# ground truth. Usage: scripts/test-wheel.sh [--debug]  (passed to build-wheel.sh).
# Not part of scripts/test.sh: the wheel is about 270 MB and takes minutes to repair.
set -euo pipefail
cd "$(dirname "$0")/.."
root="$PWD"
target="${CARGO_TARGET_DIR:-$root/target}"
wheels="$target/wheels-test"
rm -rf "$wheels"
scripts/build-wheel.sh "$@" "$wheels"
venv="$(mktemp -d)"
trap 'rm -rf "$venv"' EXIT
python3 -m venv "$venv"
"$venv/bin/python" -m pip install -q --disable-pip-version-check "$wheels"/bendscope-*manylinux*.whl
cd "$venv"
"$venv/bin/python" - "$root/fixtures/sessions/example" <<'PY'
import json, subprocess, sys, tempfile
from pathlib import Path

import bendscope

session = Path(sys.argv[1])
native = next(Path(bendscope.__file__).parent.glob("_native*.so"))
bundled = Path(bendscope.__file__).parent.parent / "bendscope.libs"
loaded = subprocess.run(["ldd", str(native)], capture_output=True, text=True, check=True).stdout
vision = [l.split() for l in loaded.splitlines() if "libopencv" in l or "libav" in l or "libsw" in l]
outside = [l[0] for l in vision if not (len(l) > 2 and Path(l[2]).resolve().parent == bundled.resolve())]
if not vision or outside:
    sys.exit(f"OpenCV/FFmpeg libraries loaded from outside the wheel: {outside or 'none found'}")
r = bendscope.process(session, out=Path(tempfile.mkdtemp()) / "out")
truth = {v["file"]: v["radius_mm"] for v in json.loads((session / "truth.json").read_text())["videos"]}
worst = max(abs(row.radius_mm / truth[row.file] - 1) for row in r.per_video.itertuples())
if r.measured != len(truth) or worst >= 0.005:
    sys.exit(f"measured {r.measured} of {len(truth)}, worst radius error {100 * worst:.3f}%")
print(f"wheel: {len(vision)} OpenCV/FFmpeg libraries from bendscope.libs; "
      f"{r.measured} videos measured, worst radius error {100 * worst:.3f}% (limit 0.5%)")
PY
