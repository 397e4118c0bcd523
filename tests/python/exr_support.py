"""An OpenEXR reader for the pass tests (plain Python + numpy: the headless Blender venvs of
tests/python/test_blender_versions.py run it too): every channel of an uncompressed scanline
file, single- or multi-part, as Blender writes a multilayer render, and the output settings
that make Blender write one."""

import struct
from pathlib import Path

import numpy as np


def exr_channels(path: Path) -> dict:
    """Channel name -> (h, w) float array of an uncompressed scanline OpenEXR, single- or
    multi-part (Blender writes each pass as a part). Enough to read Blender's multilayer
    output with codec NONE without an OpenEXR module."""
    data = path.read_bytes()
    assert data[:4] == b"\x76\x2f\x31\x01", "not an OpenEXR file"
    multipart = bool(struct.unpack_from("<I", data, 4)[0] & 0x1000)
    pos, headers = 8, []
    while True:
        attrs = {}
        while data[pos] != 0:
            name_end = data.index(b"\0", pos)
            type_end = data.index(b"\0", name_end + 1)
            size = struct.unpack_from("<i", data, type_end + 1)[0]
            attrs[data[pos:name_end].decode()] = data[type_end + 5:type_end + 5 + size]
            pos = type_end + 5 + size
        pos += 1
        headers.append(attrs)
        if not multipart or data[pos] == 0:
            pos += 1 if multipart else 0
            break
    parts = []
    for attrs in headers:
        chans, c, i = [], attrs["channels"], 0
        while c[i] != 0:
            end = c.index(b"\0", i)
            chans.append((c[i:end].decode(), struct.unpack_from("<i", c, end + 1)[0]))
            i = end + 1 + 16
        assert attrs["compression"][0] == 0, "expected an uncompressed EXR"
        x0, y0, x1, y1 = struct.unpack("<4i", attrs["dataWindow"])
        parts.append((chans, x1 - x0 + 1, y1 - y0 + 1, y0))
    offsets = []
    for part, (_, _, h, _) in enumerate(parts):
        offsets += [(part, o) for o in struct.unpack_from(f"<{h}Q", data, pos)]
        pos += 8 * h
    out = {name: np.zeros((h, w), np.float32) for chans, w, h, _ in parts for name, _ in chans}
    sizes = {2: ("<f4", 4), 1: ("<f2", 2), 0: ("<u4", 4)}
    for part, off in offsets:
        if multipart:
            assert struct.unpack_from("<i", data, off)[0] == part
            off += 4
        chans, w, h, y0 = parts[part]
        y = struct.unpack_from("<i", data, off)[0] - y0
        p = off + 8
        for name, ptype in chans:
            dtype, n = sizes[ptype]
            out[name][y] = np.frombuffer(data, dtype, w, p).astype(np.float32)
            p += n * w
    return out


def use_multilayer_exr(scene):
    """The scene's output as an uncompressed 32-bit multilayer EXR (what exr_channels reads)."""
    settings = scene.render.image_settings
    if hasattr(settings, "media_type"):  # Blender 5; 4.x has the file format only
        settings.media_type = "MULTI_LAYER_IMAGE"
    settings.file_format = "OPEN_EXR_MULTILAYER"
    settings.exr_codec = "NONE"
    settings.color_depth = "32"
