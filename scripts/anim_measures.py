#!/usr/bin/env python3
"""Temporal coherence of an animation rendered by `cubist render --frames` (docs/animation.md).

Reads, for every frame of FIRST-LAST, the picture and its passes `objects`, `normals`,
`facet-ids` and `motion` (render with `--pass objects --pass normals --pass facet-ids --pass
motion`), and reports per pair of consecutive frames, then their mean:

- flicker: mean change (0-255, mean of R, G, B) of the pixels whose surface point and lighting
  did not change: background in both frames, or the same object with no motion either way
  (under 0.05 px) and the same normal; `bg_flicker` and `bg_changed` (the share of those
  background pixels that changed at all) for the background alone, and `far_bg_changed` for
  the background farther than 20 px from the subject (in both frames);
- coherence: over the pixels of frame t+1 showing a surface that moved (at least 0.5 px) and
  was visible at frame t (the motion pass's two halves agree within a pixel, same object), the
  mean change after warping frame t onto t+1 along the motion, divided by the mean change
  without warping: 1 = the paint does not follow the surface, 0 = it moves with it exactly;
  `coherence_floor` is the same measure of frame t carried exactly along the motion (each such
  pixel copied from the pixel of frame t its point came from): the warp blends pixels, so a
  painting that moves exactly with its surfaces reads this much, not 0 (crisp strokes: ~0.2);
  `coherence_outline`, `coherence_edges` and `coherence_inside` split it by where the residual
  is (they add up to it): within 4 px of the subject's outline, within 2 px of a plane edge
  (elsewhere), and inside the planes;
- pops: the share of tracked pixels (still background and surface points seen in both frames)
  whose colour changes by more than 40/255 after warping (strokes or planes appearing or
  vanishing away from disocclusions), and `plane_pops`: facets of at least 0.05% of the canvas
  appearing or vanishing while most of their pixels stay tracked;
- changed: the share of all pixels that changed between the frames.

With `--plain PLAIN` (the same frames rendered unpainted, `--preset plain`, with the same
passes), each pair also reports `coherence_plain`, the render's own coherence (its shading
changes as surfaces turn to the light, or as lights that follow the camera move), and
`coherence_excess`, what the painting adds to it: where the light moves, no painting of the
render reads under the render's own figure.

Usage: anim_measures.py PATTERN FIRST LAST [--plain PLAIN] [--json]   (PATTERN: frame path with a
run of #, as given to `-o`). Needs numpy, Pillow and pypng (16-bit RGBA).
"""

import json
import re
import sys

import numpy as np
import png
from PIL import Image

STILL_PX = 0.05
MOVING_PX = 0.5
POP_LEVEL = 40.0
PLANE_SHARE = 0.0005
FAR_PX = 20
OUTLINE_PX = 4
EDGE_PX = 2


def frame_path(pattern, f, pass_name=None):
    m = list(re.finditer(r"#+", pattern))[-1]
    p = pattern[: m.start()] + str(f).zfill(m.end() - m.start()) + pattern[m.end() :]
    return p if pass_name is None else p[: -len(".png")] + "." + pass_name + ".png"


def rgb(path):
    return np.asarray(Image.open(path).convert("RGB")).astype(np.float64)


def png16(path):
    w, h, rows, info = png.Reader(filename=path).asDirect()
    planes = info["planes"]
    return np.vstack([np.asarray(r, dtype=np.float64) for r in rows]).reshape(h, w, planes)


def motion(path):
    """Per pixel (previous -> this, this -> next) in pixels, y down."""
    m = (png16(path) - 32768.0) / 32.0
    m[..., 1] *= -1
    m[..., 3] *= -1
    return m


def load(pattern, f):
    return {
        "img": rgb(frame_path(pattern, f)),
        "obj": rgb(frame_path(pattern, f, "objects")).astype(np.int64) @ np.array([1, 256, 65536]),
        "nrm": rgb(frame_path(pattern, f, "normals")),
        "mot": motion(frame_path(pattern, f, "motion")),
        "ids": png16(frame_path(pattern, f, "facet-ids"))[..., 0].astype(np.int64),
    }


def bilinear(img, x, y):
    h, w = img.shape[:2]
    x = np.clip(x - 0.5, 0, w - 1)
    y = np.clip(y - 0.5, 0, h - 1)
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    x1, y1 = np.minimum(x0 + 1, w - 1), np.minimum(y0 + 1, h - 1)
    fx, fy = (x - x0)[..., None], (y - y0)[..., None]
    return (img[y0, x0] * (1 - fx) * (1 - fy) + img[y0, x1] * fx * (1 - fy) + img[y1, x0] * (1 - fx) * fy
            + img[y1, x1] * fx * fy)


def near(mask, r):
    """Pixels within r (a square of side 2r + 1) of a pixel of mask."""
    h, w = mask.shape
    s = np.zeros((h + 1, w + 1), np.int64)
    s[1:, 1:] = mask.astype(np.int64).cumsum(0).cumsum(1)
    ys, xs = np.mgrid[0:h, 0:w]
    y0, y1 = np.clip(ys - r, 0, h), np.clip(ys + r + 1, 0, h)
    x0, x1 = np.clip(xs - r, 0, w), np.clip(xs + r + 1, 0, w)
    return (s[y1, x1] - s[y0, x1] - s[y1, x0] + s[y0, x0]) > 0


def borders(labels):
    """Pixels whose right or lower neighbour has another label, and those neighbours."""
    e = np.zeros(labels.shape, bool)
    dx, dy = labels[:, 1:] != labels[:, :-1], labels[1:] != labels[:-1]
    e[:, 1:] |= dx
    e[:, :-1] |= dx
    e[1:] |= dy
    e[:-1] |= dy
    return e


def pair(a, b):
    h, w = a["obj"].shape
    diff = np.abs(b["img"] - a["img"]).mean(-1)
    bg = (a["obj"] == 0) & (b["obj"] == 0)
    far_bg = bg & ~near((a["obj"] != 0) | (b["obj"] != 0), FAR_PX)
    still_surface = ((a["obj"] == b["obj"]) & (a["obj"] != 0)
                     & (np.hypot(a["mot"][..., 2], a["mot"][..., 3]) < STILL_PX)
                     & (np.hypot(b["mot"][..., 0], b["mot"][..., 1]) < STILL_PX)
                     & (np.abs(a["nrm"] - b["nrm"]).max(-1) == 0))
    still = bg | still_surface
    # Frame t+1's surface pixels traced back to frame t along the motion, kept where frame t's
    # forward motion there comes back (visible in both frames).
    ys, xs = np.mgrid[0:h, 0:w]
    cx, cy = xs + 0.5, ys + 0.5
    p = b["mot"][..., 0:2]
    sx, sy = cx - p[..., 0], cy - p[..., 1]
    rx = np.clip(np.floor(sx).astype(int), 0, w - 1)
    ry = np.clip(np.floor(sy).astype(int), 0, h - 1)
    inside = (sx >= 0) & (sy >= 0) & (sx < w) & (sy < h)
    fwd = a["mot"][ry, rx, 2:4]
    seen = (inside & (b["obj"] != 0) & (a["obj"][ry, rx] == b["obj"])
            & (np.hypot(fwd[..., 0] - p[..., 0], fwd[..., 1] - p[..., 1]) < 1.0))
    moving = seen & (np.hypot(p[..., 0], p[..., 1]) >= MOVING_PX)
    warped = np.abs(b["img"] - bilinear(a["img"], sx, sy)).mean(-1)
    coherence = (warped[moving].mean() / max(diff[moving].mean(), 1e-9)) if moving.any() else float("nan")
    # Where the residual is: the subject's outline, plane edges, inside the planes.
    outline = near(borders(b["obj"] != 0), OUTLINE_PX)
    edges = near(borders(b["ids"]), EDGE_PX) & ~outline
    parts = {}
    for name, m in (("outline", outline), ("edges", edges), ("inside", ~outline & ~edges)):
        parts["coherence_" + name] = (float(warped[moving & m].sum() / max(diff[moving].sum(), 1e-9))
                                      if moving.any() else float("nan"))
    # The measure's own floor: frame t carried exactly to t+1, measured the same way.
    carried = b["img"].copy()
    carried[moving] = a["img"][ry, rx][moving]
    floor = float("nan")
    if moving.any():
        still_diff = np.abs(carried - a["img"]).mean(-1)[moving].mean()
        floor = np.abs(carried - bilinear(a["img"], sx, sy)).mean(-1)[moving].mean() / max(still_diff, 1e-9)
    tracked = still | seen
    change = np.where(seen, warped, diff)
    pops = (change[tracked] > POP_LEVEL).mean() if tracked.any() else 0.0
    # Planes appearing or vanishing while their pixels stay tracked.
    min_area = PLANE_SHARE * w * h
    plane_pops = 0
    ids_a, counts_a = np.unique(a["ids"], return_counts=True)
    ids_b, counts_b = np.unique(b["ids"], return_counts=True)
    for ids, counts, other, img_ids in ((ids_b, counts_b, set(ids_a.tolist()), b["ids"]),
                                        (ids_a, counts_a, set(ids_b.tolist()), a["ids"])):
        for f, n in zip(ids.tolist(), counts.tolist()):
            if n >= min_area and f not in other and tracked[img_ids == f].mean() > 0.5:
                plane_pops += 1
    return {
        "flicker": float(diff[still].mean()) if still.any() else 0.0,
        "bg_flicker": float(diff[bg].mean()) if bg.any() else 0.0,
        "bg_changed": float((diff[bg] > 0).mean()) if bg.any() else 0.0,
        "far_bg_changed": float((diff[far_bg] > 0).mean()) if far_bg.any() else 0.0,
        "coherence": float(coherence),
        "coherence_floor": float(floor),
        **parts,
        "pops": float(pops),
        "plane_pops": plane_pops,
        "changed": float((diff > 0).mean()),
        "moving_px": int(moving.sum()),
    }


def against_plain(row, a, b):
    """The render's own coherence between the unpainted frames `a` and `b`, and what the
    painting's (`row`, from `pair`) adds to it."""
    own = pair(a, b)["coherence"]
    return {"coherence_plain": own, "coherence_excess": row["coherence"] - own}


def main(argv):
    if len(argv) < 4:
        print(__doc__.split("\n\n")[-1], file=sys.stderr)
        return 2
    pattern, first, last = argv[1], int(argv[2]), int(argv[3])
    plain = argv[argv.index("--plain") + 1] if "--plain" in argv[:-1] else None
    frames = [load(pattern, f) for f in range(first, last + 1)]
    rows = [dict(frame=first + k, **pair(frames[k], frames[k + 1])) for k in range(len(frames) - 1)]
    keys = ["flicker", "bg_flicker", "bg_changed", "far_bg_changed", "coherence", "coherence_floor",
            "coherence_outline", "coherence_edges", "coherence_inside", "pops", "plane_pops", "changed"]
    if plain is not None:
        bare = [load(plain, f) for f in range(first, last + 1)]
        for k, r in enumerate(rows):
            r.update(against_plain(r, bare[k], bare[k + 1]))
        keys += ["coherence_plain", "coherence_excess"]
    mean = {k: float(np.nanmean([r[k] for r in rows])) for k in keys}
    if "--json" in argv:
        print(json.dumps({"pairs": rows, "mean": mean}, indent=1))
        return 0
    width = {k: max(10, len(k)) for k in keys}
    print("frame " + " ".join(f"{k:>{width[k]}}" for k in keys))
    for r in rows:
        print(f"{r['frame']:>5} " + " ".join(f"{r[k]:>{width[k]}.4f}" for k in keys))
    print(" mean " + " ".join(f"{mean[k]:>{width[k]}.4f}" for k in keys))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
