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


def result_rect(pixels: np.ndarray, region: tuple) -> np.ndarray:
    """8-bit sRGB RGBA rows, top row first, as a render result's rect for `region` (x, y,
    width, height; y from the bottom): float32 (width * height, 4), scene-linear, alpha
    premultiplied, rows bottom-up."""
    x0, y0, rw, rh = region
    bottom_up = pixels[::-1][y0:y0 + rh, x0:x0 + rw]
    out = np.empty((rh, rw, 4), dtype=np.float32)
    alpha = bottom_up[..., 3].astype(np.float32) * np.float32(1.0 / 255.0)
    out[..., :3] = SRGB_TO_LINEAR[bottom_up[..., :3]] * alpha[..., None]
    out[..., 3] = alpha
    return out.reshape(rw * rh, 4)


__all__ = ["SRGB_TO_LINEAR", "result_rect", "upscale"]
