#!/usr/bin/env bash
# Renders the README's pictures from the built-in still life, so they can be regenerated
# whenever the pipeline changes: docs/cubist.png (`cubist render`, the defaults, 800x600) and
# the presets' (docs/presets/<preset>.png, 480x360), then the add-on's preset thumbnails
# (scripts/preset_thumbnails.py):
#   bash scripts/render-docs.sh            # every preset
#   bash scripts/render-docs.sh braque     # some presets
# Each picture is `cubist render --preset <name>` with nothing else changed but the size.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --locked --quiet
presets=("$@")
if [ ${#presets[@]} -eq 0 ]; then
    presets=(plain analytic braque blue-period grisaille thesis)
    target/release/cubist render --progress none -o docs/cubist.png
    echo "docs/cubist.png"
fi
mkdir -p docs/presets
for p in "${presets[@]}"; do
    target/release/cubist render --preset "$p" --width 480 --height 360 --spp 9 \
        --progress none -o "docs/presets/$p.png"
    echo "docs/presets/$p.png"
done
# The add-on's preset grid shows these pictures reduced: keep its thumbnails in step.
if [ -x .venv/bin/python ]; then
    .venv/bin/python scripts/preset_thumbnails.py
else
    echo "then: python3 scripts/preset_thumbnails.py (needs Pillow; scripts/setup-python.sh makes .venv)" >&2
fi
