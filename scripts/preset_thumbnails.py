#!/usr/bin/env python3
"""Writes the add-on's preset thumbnails, blender_addon/previews/<preset>.png: each preset's
picture in docs/presets/ (scripts/render-docs.sh) at 160 x 120, which the Cubist panel shows
as a grid of previews (bpy.utils.previews + template_icon_view) and the extension zip ships.

    .venv/bin/python scripts/preset_thumbnails.py          # after render-docs.sh
    .venv/bin/python scripts/preset_thumbnails.py --check  # exit 1 when a thumbnail is stale
"""

from __future__ import annotations

import io
import sys
from pathlib import Path

from PIL import Image

ROOT = Path(__file__).resolve().parents[1]
SOURCE = ROOT / "docs" / "presets"
TARGET = ROOT / "blender_addon" / "previews"
SIZE = (160, 120)


def thumbnail(picture: Path) -> bytes:
    """The picture reduced to SIZE (Lanczos), as an optimised RGB PNG."""
    with Image.open(picture) as im:
        small = im.convert("RGB").resize(SIZE, Image.LANCZOS)
    out = io.BytesIO()
    small.save(out, "PNG", optimize=True)
    return out.getvalue()


def main(argv) -> int:
    check = "--check" in argv
    TARGET.mkdir(exist_ok=True)
    stale = []
    for picture in sorted(SOURCE.glob("*.png")):
        data, path = thumbnail(picture), TARGET / picture.name
        if check:
            if not path.is_file() or path.read_bytes() != data:
                stale.append(path.name)
        else:
            path.write_bytes(data)
    if stale:
        print(f"error: stale thumbnails (run scripts/preset_thumbnails.py): {', '.join(stale)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
