"""Blender's faces as triangles, in the order and split of Blender's own `loop_triangles`:
triangles and quads in numpy (quads split as Blender splits them), n-gons read from Blender."""

from __future__ import annotations

import numpy as np

from .arrays import read_array

# A mesh whose n-gons make more triangles than this reads all its triangles from Blender's
# `loop_triangles` (one slow call) instead of one Python call per n-gon triangle.
NGON_TRIANGLES_ONE_BY_ONE = 20000


def loop_triangles_of_ngons(me, npoly: int, nloops: int, sizes: np.ndarray):
    """What `triangulate` needs of Blender's `loop_triangles` (read on the main thread): None
    without n-gons, else all of them (many n-gon triangles) or {triangle: corners} of the
    n-gons' triangles (few: read one by one)."""
    ngons = np.flatnonzero(sizes > 4)
    if not len(ngons):
        return None
    ntri = int(nloops - 2 * npoly)
    count = int((sizes[ngons] - 2).sum())
    if count > NGON_TRIANGLES_ONE_BY_ONE:
        return read_array(me.loop_triangles, "loops", ntri, np.int32, 3)
    starts = (np.cumsum(sizes, dtype=np.int64) - sizes).astype(np.int32)
    tri_start = starts - 2 * np.arange(npoly, dtype=np.int32)
    lts = me.loop_triangles
    out = {}
    for p in ngons.tolist():
        for i in range(int(tri_start[p]), int(tri_start[p]) + int(sizes[p]) - 2):
            out[i] = tuple(lts[i].loops)
    return out


def triangulate(me, npoly: int, nloops: int, positions: np.ndarray, corner_vert: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(triangles as corner indices (n, 3), polygon of each triangle, corners per polygon),
    in the order of Blender's `loop_triangles`: triangles and quads here in numpy, split as
    Blender splits them (`quad_flipped`), n-gons read from `loop_triangles`."""
    sizes = read_array(me.polygons, "loop_total", npoly, np.int32)
    return triangulate_arrays(sizes, npoly, nloops, positions, corner_vert,
                              loop_triangles_of_ngons(me, npoly, nloops, sizes))


def triangulate_arrays(sizes: np.ndarray, npoly: int, nloops: int, positions: np.ndarray, corner_vert: np.ndarray,
                       ngon_tris) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """`triangulate` from arrays (no Blender data): `ngon_tris` from `loop_triangles_of_ngons`."""
    ntri = int(nloops - 2 * npoly)
    poly_of = np.repeat(np.arange(npoly, dtype=np.int32), sizes - 2)
    if (sizes == 3).all():
        return np.arange(nloops, dtype=np.int32).reshape(-1, 3), poly_of, sizes
    starts = (np.cumsum(sizes, dtype=np.int64) - sizes).astype(np.int32)
    tri_start = starts - 2 * np.arange(npoly, dtype=np.int32)
    tris = np.empty((ntri, 3), dtype=np.int32)
    t = sizes == 3
    tris[tri_start[t]] = starts[t, None] + np.array([0, 1, 2], dtype=np.int32)
    quads = np.flatnonzero(sizes == 4)
    if len(quads):
        c = starts[quads, None] + np.arange(4, dtype=np.int32)
        corners_xyz = positions[corner_vert[c]]  # (quads, 4, 3)
        flip = quad_flipped(*(corners_xyz[:, k] for k in range(4)))
        first = np.where(flip[:, None], c[:, [0, 1, 3]], c[:, [0, 1, 2]])
        second = np.where(flip[:, None], c[:, [1, 2, 3]], c[:, [0, 2, 3]])
        if len(quads) == npoly:  # all quads (subdivision surfaces): no scattered writes
            tris = np.stack([first, second], axis=1).reshape(-1, 3)
        else:
            tris[tri_start[quads]] = first
            tris[tri_start[quads] + 1] = second
    if isinstance(ngon_tris, np.ndarray):
        tris[:] = ngon_tris
    elif ngon_tris:
        for i, corners in ngon_tris.items():
            tris[i] = corners
    return tris, poly_of, sizes


def quad_flipped(v1, v2, v3, v4) -> np.ndarray:
    """Whether Blender splits a quad along its 2-4 diagonal (triangles 1-2-4, 2-3-4) instead of
    1-3: when corners 2 and 4 lie on the same side of the 1-3 diagonal (a bent or concave quad),
    as Blender's `is_quad_flip_v3_first_third_fast` decides, in 32-bit floats like it."""
    a, b, c = (v2 - v1).T, (v3 - v1).T, (v4 - v1).T
    # cross(a, b) . cross(c, b), component by component (fewer temporaries than np.cross).
    x = (a[1] * b[2] - a[2] * b[1]) * (c[1] * b[2] - c[2] * b[1])
    x += (a[2] * b[0] - a[0] * b[2]) * (c[2] * b[0] - c[0] * b[2])
    x += (a[0] * b[1] - a[1] * b[0]) * (c[0] * b[1] - c[1] * b[0])
    return x > 0.0
