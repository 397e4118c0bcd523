"""Images as the GLB carries them: the file's own PNG or JPEG bytes when it is one (packed or
on disk), else the pixels encoded as PNG (float images turned to sRGB)."""

from __future__ import annotations

from pathlib import Path
from typing import Callable, Optional

import numpy as np

import bpy

from .. import pngio


def _srgb(linear: np.ndarray) -> np.ndarray:
    c = np.clip(linear, 0.0, 1.0)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1.0 / 2.4) - 0.055)


def image_bytes(img, warn: Callable[[str], None]) -> tuple[Optional[bytes], str]:
    """The image as PNG or JPEG bytes: the file's own bytes when it is one (packed or on
    disk), else its pixels encoded as PNG (float images turned to sRGB)."""
    data = None
    packed = getattr(img, "packed_file", None)
    try:
        if packed is not None:
            data = bytes(packed.data)
        elif img.source == "FILE":
            path = Path(bpy.path.abspath(img.filepath_raw or img.filepath, library=img.library))
            if path.is_file():
                data = path.read_bytes()
    except (OSError, ValueError):
        data = None
    colourspace = img.colorspace_settings.name
    as_colour = colourspace not in {"Non-Color", "Raw", "Linear", "Linear Rec.709", "Linear CIE-XYZ E"}
    if data is not None and as_colour:
        if data[:8] == pngio.SIGNATURE:
            return data, "image/png"
        if data[:3] == b"\xff\xd8\xff":
            return data, "image/jpeg"
    w, h = int(img.size[0]), int(img.size[1])
    if w * h == 0:
        warn(f"image '{img.name}' cannot be read: its texture is left out")
        return None, ""
    px = np.empty(w * h * 4, dtype=np.float32)
    img.pixels.foreach_get(px)
    px = px.reshape(h, w, 4)[::-1]  # Blender's rows run bottom-up, PNG's top-down
    if img.is_float:
        px = np.concatenate([_srgb(px[..., :3]), np.clip(px[..., 3:], 0.0, 1.0)], axis=2)
    px8 = np.round(np.clip(px, 0.0, 1.0) * 255.0).astype(np.uint8)
    return pngio.encode(px8, level=1), "image/png"
