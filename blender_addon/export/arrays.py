"""Reading Blender's mesh data as whole arrays (`foreach_get`), never a Python loop per
element: the one way the exporter reads a mesh's vertices, corners, faces and attributes."""

from __future__ import annotations

import numpy as np


def read_array(collection, prop: str, count: int, dtype, width: int = 1) -> np.ndarray:
    a = np.empty(count * width, dtype=dtype)
    if count:
        collection.foreach_get(prop, a)
    return a.reshape(count, width) if width > 1 else a


def read_attribute(me, name: str, domain: str, width: int, prop: str, dtype=np.float32):
    """A generic attribute as an array (the fast path of Blender 3.5+), or None when absent."""
    attrs = getattr(me, "attributes", None)
    if attrs is None:
        return None
    a = attrs.get(name)
    if a is None or a.domain != domain:
        return None
    return read_array(a.data, prop, len(a.data), dtype, width)
