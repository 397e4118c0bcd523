"""PNG reading and writing with zlib and numpy only (no bpy).

Why by hand: the render thread must not touch `bpy.data` (`bpy.data.images.load` adds an ID
to the file the interface is drawing from), Blender's `imbuf` module exposes no pixels, and
neither Pillow nor OpenImageIO ship with every Blender. The renderer's passes are plain
8-bit or 16-bit PNGs (the `image` crate, adaptive filtering, no interlace), so reading them is
zlib plus the five PNG filters; writing (textures Blender holds in other formats) uses filter 0.
"""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import numpy as np

SIGNATURE = b"\x89PNG\r\n\x1a\n"
# Colour type -> channels (grey, RGB, grey + alpha, RGBA; palettes are not used here).
CHANNELS = {0: 1, 2: 3, 4: 2, 6: 4}


class PngError(ValueError):
    pass


def read(path: Path) -> np.ndarray:
    """The pixels of an 8- or 16-bit non-interlaced PNG as integers, shape (h, w, channels),
    rows top-down, values as stored (no colour conversion: data passes stay data)."""
    data = Path(path).read_bytes()
    if data[:8] != SIGNATURE:
        raise PngError(f"{Path(path).name}: not a PNG file")
    pos, idat, ihdr = 8, [], None
    while pos + 8 <= len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        pos += 12 + n
        if kind == b"IHDR":
            ihdr = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat.append(body)
        elif kind == b"IEND":
            break
    if ihdr is None:
        raise PngError(f"{Path(path).name}: no IHDR chunk")
    w, h, depth, colour_type, _compression, _filter, interlace = ihdr
    if depth not in (8, 16) or colour_type not in CHANNELS or interlace != 0:
        raise PngError(f"{Path(path).name}: unsupported PNG (bit depth {depth}, colour type {colour_type}, "
                       f"interlace {interlace})")
    channels = CHANNELS[colour_type]
    bpp = channels * depth // 8
    raw = zlib.decompress(b"".join(idat))
    stride = w * bpp
    if len(raw) != h * (stride + 1):
        raise PngError(f"{Path(path).name}: truncated image data")
    rows = np.frombuffer(raw, dtype=np.uint8).reshape(h, stride + 1)
    pixels = unfilter(rows[:, 0], rows[:, 1:], bpp)
    if depth == 16:
        return pixels.reshape(h, w * channels * 2).view(">u2").reshape(h, w, channels).astype(np.uint16)
    return pixels.reshape(h, w, channels)


def unfilter(filters: np.ndarray, rows: np.ndarray, bpp: int) -> np.ndarray:
    """Undoes the PNG filters (spec section 9): `rows` (h, stride) filtered bytes, one filter
    type per row. Rows with None/Sub/Up filters are undone a row at a time (Sub is a running
    sum per channel); Average and Paeth depend on the reconstructed left neighbour, so an image
    using them is undone along anti-diagonals, all pixels of a diagonal at once."""
    h, stride = rows.shape
    if h == 0:
        return rows.copy()
    if int(filters.max()) > 4:
        raise PngError(f"unknown PNG filter type {int(filters.max())}")
    if not np.isin(filters, (3, 4)).any():
        out = np.empty((h, stride), dtype=np.uint8)
        prev = np.zeros(stride, dtype=np.uint8)
        for y in range(h):
            f, line = filters[y], rows[y]
            if f == 0:
                cur = line.copy()
            elif f == 1:
                cur = np.cumsum(line.reshape(-1, bpp), axis=0, dtype=np.uint8).reshape(-1)
            else:
                cur = line + prev
            out[y] = cur
            prev = cur
        return out
    w = stride // bpp
    # Skewed, transposed layout: pixel (y, x) at skew[x + y + 2, y + 1], so anti-diagonal k is
    # the contiguous row k + 2 and its left, up and up-left neighbours are in rows k + 1 and k.
    # Column 0 and the cells before each pixel row's start stay zero (the PNG's "outside").
    raw = np.zeros((h + w, h, bpp), dtype=np.int16)
    src = rows.reshape(h, w, bpp)
    ys = np.arange(h)
    for x in range(w):
        raw[x + ys, ys] = src[:, x]
    skew = np.zeros((h + w + 2, h + 1, bpp), dtype=np.int16)
    # One 0/1 mask per filter type and row: arithmetic selection is several times faster
    # than np.where on the small arrays of a diagonal.
    masks = [(filters == t).astype(np.int16)[:, None] for t in (1, 2, 3, 4)]
    for k in range(h + w - 1):
        y0, y1 = max(0, k - w + 1), min(k, h - 1) + 1
        a = skew[k + 1, y0 + 1:y1 + 1]
        b = skew[k + 1, y0:y1]
        c = skew[k, y0:y1]
        m_sub, m_up, m_avg, m_paeth = (m[y0:y1] for m in masks)
        # Paeth: the one of a, b, c nearest to a + b - c (ties: a, then b).
        pa, pb, pc = np.abs(b - c), np.abs(a - c), np.abs(a + b - 2 * c)
        take_a = (pa <= pb) & (pa <= pc)
        take_b = ~take_a & (pb <= pc)
        paeth = c + (a - c) * take_a + (b - c) * take_b
        pred = a * m_sub + b * m_up + ((a + b) >> 1) * m_avg + paeth * m_paeth
        skew[k + 2, y0 + 1:y1 + 1] = (raw[k, y0:y1] + pred) & 0xFF
    out = np.empty((h, w, bpp), dtype=np.uint8)
    for x in range(w):
        out[:, x] = skew[x + ys + 2, ys + 1]
    return out.reshape(h, stride)


def encode(pixels: np.ndarray, level: int = 6) -> bytes:
    """An 8-bit RGBA PNG (the bytes of the file) from a (h, w, 4) uint8 array, rows top-down."""
    h, w, channels = pixels.shape
    if channels != 4 or pixels.dtype != np.uint8:
        raise ValueError("encode expects (h, w, 4) uint8 pixels")
    rows = np.zeros((h, w * 4 + 1), dtype=np.uint8)  # filter byte 0 (None) before each row
    rows[:, 1:] = pixels.reshape(h, w * 4)

    def chunk(kind: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF)

    ihdr = struct.pack(">IIBBBBB", w, h, 8, 6, 0, 0, 0)
    return (SIGNATURE + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(rows.tobytes(), level))
            + chunk(b"IEND", b""))
