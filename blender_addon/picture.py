"""The renderer's 8-bit picture as Blender's render result wants it: scene-linear float RGBA,
alpha premultiplied, rows bottom-up; and a coarse preview blown up to the full size.

Handing raw pixels over (`pass.rect`) instead of a PNG (`RenderLayer.load_from_file`) saves
the renderer's PNG encoding and Blender's decoding of it (BENCHMARKS.md, "F12 on the session's
renderer"). The decoding is Blender's own for an sRGB PNG: the sRGB curve to linear, then
premultiplied. No bpy here: tests/python/test_addon_picture.py checks it in plain Python.
"""

from __future__ import annotations

import numpy as np


def _srgb_to_linear_table() -> np.ndarray:
    v = np.arange(256, dtype=np.float64) / 255.0
    lin = np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)
    return lin.astype(np.float32)


SRGB_TO_LINEAR = _srgb_to_linear_table()


def upscale(pixels: np.ndarray, width: int, height: int) -> np.ndarray:
    """`pixels` (h, w, C) blown up to (height, width, C), each pixel repeated (nearest)."""
    h, w = pixels.shape[:2]
    ys = (np.arange(height) * h) // height
    xs = (np.arange(width) * w) // width
    return pixels[ys][:, xs]


# One table for the four channels (colour: sRGB to linear; alpha: / 255), indexed by the 8-bit
# value plus its channel's offset: one lookup pass over the picture makes its floats.
_TABLE4 = np.concatenate([SRGB_TO_LINEAR] * 3 + [np.arange(256, dtype=np.float32) / np.float32(255.0)])
_OFFSETS = np.array([0, 256, 512, 768], dtype=np.uint16)


def result_rect(pixels: np.ndarray, region: tuple) -> np.ndarray:
    """8-bit sRGB RGBA rows, top row first, as a render result's rect for `region` (x, y,
    width, height; y from the bottom): float32 (width * height, 4), scene-linear, alpha
    premultiplied, rows bottom-up."""
    x0, y0, rw, rh = region
    bottom_up = pixels[::-1][y0:y0 + rh, x0:x0 + rw]
    index = bottom_up.astype(np.uint16)
    index += _OFFSETS
    out = _TABLE4.take(index)
    if bottom_up[..., 3].min() < 255:  # opaque pictures (most) need no premultiplying
        out[..., :3] *= out[..., 3:4]
    return out.reshape(rw * rh, 4)


def preview_rect(pixels: np.ndarray, width: int, height: int, region: tuple) -> np.ndarray:
    """A small picture blown up to width x height, as `result_rect` gives it for `region`:
    converted at its own size, then repeated (nearest), which costs a fraction of converting
    the blown-up picture."""
    small = result_rect(pixels, (0, 0, pixels.shape[1], pixels.shape[0])).reshape(pixels.shape[0], pixels.shape[1], 4)
    h, w = small.shape[:2]
    x0, y0, rw, rh = region
    ys = ((np.arange(y0, y0 + rh) * h) // height)
    xs = ((np.arange(x0, x0 + rw) * w) // width)
    return small[ys][:, xs].reshape(rw * rh, 4)


__all__ = ["SRGB_TO_LINEAR", "preview_rect", "result_rect", "upscale"]
