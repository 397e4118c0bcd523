#!/usr/bin/env bash
# Regenerates the screenshots of docs/blender.md (docs/blender/*.png) in the windowed Blender
# the tests use (Debian's 3.4.1 under Xvfb, the add-on from blender_addon/): the Cubist panel at
# the Properties editor's default width, the viewport in Rendered shading, and an F12 result. tests/blender_ui/screenshots_driver.py drives Blender and takes
# each screenshot of the whole screen with ImageMagick's `import -window root`; they are cropped
# here to the part shown and written as small PNGs.
#
#   bash scripts/setup-blender-ui.sh && bash scripts/blender-screenshots.sh
set -euo pipefail
cd "$(dirname "$0")/.."
for tool in blender xvfb-run import; do
    command -v "$tool" >/dev/null || {
        echo "error: $tool not found (apt-get install blender xvfb xauth xdotool imagemagick)" >&2
        exit 1
    }
done
[ -x .venv/bin/python ] || bash scripts/setup-python.sh
cargo build --release --locked --bin cubist
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
env -u BLENDER_USER_RESOURCES BLENDER_USER_CONFIG="$work/config" TMPDIR="$work" \
    xvfb-run -a -s "-screen 0 1280x1024x24" blender --factory-startup \
    --python tests/blender_ui/screenshots_driver.py -- "$PWD" "$work/out" "$PWD/target/release/cubist" \
    >"$work/blender.log" 2>&1 || true
cp "$work/blender.log" /tmp/cubist-screenshots.log 2>/dev/null || true
.venv/bin/python - "$work/out" docs/blender <<'PY'
import json
import sys
from pathlib import Path

from PIL import Image

out, docs = Path(sys.argv[1]), Path(sys.argv[2])
shots = json.loads((out / "shots.json").read_text())
if "failure" in shots:
    sys.exit(f"error: the driver failed:\n{shots['failure']}")
docs.mkdir(exist_ok=True)
for name in ("panel", "viewport", "f12"):
    shot = shots[name]
    with Image.open(out / shot["file"]) as im:
        part = im.convert("RGB").crop(tuple(shot["box"]))
    if part.width > 560:  # the wide views at a size a page shows whole
        part = part.resize((560, round(part.height * 560 / part.width)), Image.LANCZOS)
    part.quantize(colors=64, dither=Image.Dither.NONE).save(docs / f"{name}.png", optimize=True)
    print(docs / f"{name}.png", part.size)
PY
