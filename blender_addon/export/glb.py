"""The GLB container: JSON and one binary chunk, written with numpy and `struct` (no Blender
data is read here), the glTF constants, and the Z-up to Y-up node matrices."""

from __future__ import annotations

import json
import struct
from pathlib import Path
from typing import Callable, Optional

import numpy as np

# Blender Z-up -> glTF Y-up: (x, y, z) -> (x, z, -y).
Y_UP = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, -1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]])


# glTF constants.
FLOAT, UNSIGNED_SHORT, UNSIGNED_INT = 5126, 5123, 5125
ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963
REPEAT, CLAMP_TO_EDGE, MIRRORED_REPEAT = 10497, 33071, 33648
NEAREST, LINEAR = 9728, 9729


class ExportCancelled(Exception):
    """The user cancelled while the scene was being exported."""


class GlbBuilder:
    """Binary chunk and JSON of a GLB: buffer views are appended 4-byte aligned.

    An accessor's array may be given later (`accessor_later`: a function making it): its
    place in the JSON and the buffer is taken at once, its contents are made by `finish`, which
    may run on another thread (the viewport's worker: the arrays read from Blender on the main
    thread are turned into glTF there). The file is the same either way."""

    def __init__(self):
        self.parts: list = []  # per buffer view: its bytes (None while pending)
        self.pending: list = []  # (accessor, view, make, bounds) in order
        self.size = 0
        self.json: dict = {"asset": {"version": "2.0", "generator": "cubist Blender add-on"}, "scene": 0,
                           "scenes": [{"nodes": []}], "nodes": [], "bufferViews": [], "accessors": []}

    def view(self, data: Optional[bytes], target: Optional[int] = None) -> int:
        view = {"buffer": 0, "byteOffset": 0, "byteLength": 0 if data is None else len(data)}
        if target is not None:
            view["target"] = target
        self.parts.append(data)
        self.json["bufferViews"].append(view)
        return len(self.json["bufferViews"]) - 1

    def _fill(self, acc: dict, array: np.ndarray, bounds: bool) -> bytes:
        array = np.ascontiguousarray(array)
        acc["componentType"] = {np.dtype(np.float32): FLOAT, np.dtype(np.uint32): UNSIGNED_INT,
                                np.dtype(np.uint16): UNSIGNED_SHORT}[array.dtype]
        acc["count"] = int(array.shape[0])
        if bounds and len(array):
            acc["min"] = [float(v) for v in array.min(axis=0)]
            acc["max"] = [float(v) for v in array.max(axis=0)]
        return array.tobytes()

    def accessor(self, array: np.ndarray, kind: str, bounds: bool = False, target: int = ARRAY_BUFFER) -> int:
        acc = {"bufferView": 0, "componentType": 0, "count": 0, "type": kind}
        data = self._fill(acc, array, bounds)
        acc["bufferView"] = self.view(data, target)
        self.json["accessors"].append(acc)
        return len(self.json["accessors"]) - 1

    def accessor_later(self, make: Callable[[], np.ndarray], kind: str, bounds: bool = False,
                       target: int = ARRAY_BUFFER) -> int:
        """An accessor whose array `make()` gives when `finish` runs."""
        acc = {"bufferView": self.view(None, target), "componentType": 0, "count": 0, "type": kind}
        self.json["accessors"].append(acc)
        self.pending.append((acc, acc["bufferView"], make, bounds))
        return len(self.json["accessors"]) - 1

    def finish(self, should_cancel: Callable[[], bool] = lambda: False) -> None:
        """Makes the pending arrays (no Blender data is read here) and lays out the buffer."""
        for acc, view, make, bounds in self.pending:
            if should_cancel():
                raise ExportCancelled()
            data = self._fill(acc, make(), bounds)
            self.parts[view] = data
            self.json["bufferViews"][view]["byteLength"] = len(data)
        self.pending = []
        size = 0
        for view, data in zip(self.json["bufferViews"], self.parts):
            size += (-size) % 4
            view["byteOffset"] = size
            size += len(data)
        self.size = size

    def add(self, key: str, item: dict) -> int:
        self.json.setdefault(key, []).append(item)
        return len(self.json[key]) - 1

    def write(self, path: Path) -> None:
        self.finish()
        size = self.size + (-self.size) % 4
        if size:
            self.json["buffers"] = [{"byteLength": size}]
        else:
            del self.json["bufferViews"], self.json["accessors"]
        text = json.dumps(self.json, separators=(",", ":")).encode("utf-8")
        text += b" " * ((-len(text)) % 4)
        total = 12 + 8 + len(text) + (8 + size if size else 0)
        with open(path, "wb") as f:
            f.write(struct.pack("<4sII", b"glTF", 2, total))
            f.write(struct.pack("<I4s", len(text), b"JSON"))
            f.write(text)
            if size:
                f.write(struct.pack("<I4s", size, b"BIN\0"))
                offset = 0
                for data in self.parts:
                    pad = (-offset) % 4
                    if pad:
                        f.write(b"\0" * pad)
                    f.write(data)
                    offset += pad + len(data)
                if size > offset:
                    f.write(b"\0" * (size - offset))

    def use_extension(self, name: str) -> None:
        used = self.json.setdefault("extensionsUsed", [])
        if name not in used:
            used.append(name)


def gltf_matrix(m) -> list:
    """A Blender world matrix (4x4, rows) as a glTF node matrix: turned Y-up, column-major."""
    return (Y_UP @ np.asarray(m, dtype=np.float64)).T.reshape(-1).tolist()


def without_scale(m) -> np.ndarray:
    """Rotation and translation of a matrix (cameras and lights: their axes matter, not scale)."""
    m = np.array(m, dtype=np.float64)
    for c in range(3):
        n = np.linalg.norm(m[:3, c])
        if n > 0:
            m[:3, c] /= n
    return m
