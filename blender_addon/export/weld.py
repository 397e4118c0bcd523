"""Welding Blender's corners into glTF vertices: corners of one vertex share a glTF vertex
when all their attributes are bit-equal (no Blender data is read here)."""

from __future__ import annotations

import numpy as np

# Welding rounds before the general (sorting) fallback; see `weld`.
WELD_ROUNDS = 12


def weld(corner_vert: np.ndarray, attrs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """glTF vertices from Blender corners: corners of one vertex share a glTF vertex when all
    their attributes (normal, UV, colour) are bit-equal. Returns (the corner each glTF vertex is
    taken from, the glTF vertex of each corner).

    Why not one np.unique over all rows: sorting millions of rows costs seconds. Instead each
    round takes one corner per vertex as representative and settles every corner whose
    attributes hash equal to it; a smooth mesh's seams take a round or two. Hash matches are
    then checked bit by bit once, and whatever is left after WELD_ROUNDS (or failed the check)
    is sorted."""
    n = len(corner_vert)
    bits = np.ascontiguousarray(attrs, dtype=np.float32).view(np.uint32)
    # A 64-bit hash of each corner's attributes (odd multipliers, wrapping arithmetic).
    key = np.zeros(n, dtype=np.uint64)
    for j in range(bits.shape[1]):
        key = key * np.uint64(0x9E3779B97F4A7C15) + bits[:, j].astype(np.uint64)
    key ^= key >> np.uint64(29)
    index = np.full(n, -1, dtype=np.int32)
    new_id = np.empty(n, dtype=np.int32)
    rep_of = np.empty(n, dtype=np.int32)  # the representative each settled corner matched
    slot = np.empty(int(corner_vert.max()) + 1 if n else 0, dtype=np.int32)
    reps = []
    remaining = np.arange(n, dtype=np.int32)
    next_id = 0
    with np.errstate(over="ignore"):
        for _ in range(WELD_ROUNDS):
            if not len(remaining):
                break
            v = corner_vert[remaining]
            slot[v] = remaining  # one representative corner per vertex (numpy: the last written)
            rep = slot[v]
            same = key[remaining] == key[rep]
            rep_corners = remaining[rep == remaining]
            new_id[rep_corners] = np.arange(next_id, next_id + len(rep_corners), dtype=np.int32)
            next_id += len(rep_corners)
            reps.append(rep_corners)
            settled = remaining[same]
            index[settled] = new_id[rep[same]]
            rep_of[settled] = rep[same]
            remaining = remaining[~same]
    # Bit-exact check of the hash matches: a collision goes to the sorted remainder.
    matched = np.flatnonzero(index >= 0)
    wrong = matched[(bits[matched] != bits[rep_of[matched]]).any(axis=1)]
    if len(wrong):
        index[wrong] = -1
        remaining = np.union1d(remaining, wrong).astype(np.int32)
    if len(remaining):
        rows = np.concatenate([corner_vert[remaining, None].astype(np.uint32), bits[remaining]], axis=1)
        _, first, inverse = np.unique(rows, axis=0, return_index=True, return_inverse=True)
        order = np.argsort(first, kind="stable")  # keep corner order for a deterministic file
        rank = np.empty_like(order)
        rank[order] = np.arange(len(order))
        reps.append(remaining[first[order]])
        index[remaining] = next_id + rank[inverse.reshape(-1)]
    return (np.concatenate(reps) if reps else np.empty(0, np.int32)), index
