#!/usr/bin/env python3
"""PSNR of the default render against its own 64 spp reference.

For each scene, renders the picture twice with the same settings: as `cubist render` gives it
(4 spp on the pixels the adaptive anti-aliasing picks, one sample elsewhere) and as the
reference (`--spp 64 --aa-threshold 0`: 64 stratified samples on every pixel), and prints the
PSNR of the 8-bit RGB images. The facets are laid out from the one-sample pre-render in both,
so what differs is the film's sampling, and how much the painterly chain amplifies it.

`--toggles` repeats the pair with one effect changed on both sides (e.g. `--palette none`), so
a table shows which effect amplifies the film's differences: the effect whose removal raises
PSNR the most.

    cargo build --release --bin cubist
    .venv/bin/python eval/psnr_spp.py                                   # venus_11k, 1000 x 1000
    .venv/bin/python eval/psnr_spp.py --scenes venus_11k still-life Duck bunny_full --size 500
    .venv/bin/python eval/psnr_spp.py --size 500 --toggles              # the per-effect table
    .venv/bin/python eval/psnr_spp.py --thresholds 0 0.02 0.05 0.1      # adaptive AA's threshold

`--thresholds` renders each scene once per `--aa-threshold` against one reference and adds the
anti-aliasing stage's CPU and the whole process's CPU: the time-against-error table behind the
default threshold.

Scenes: a path to a .glb/.gltf, a name looked up in ../shared/models and
../shared/gltf-samples (`venus_11k`, `Duck`), or `still-life` (the built-in scene).
Needs numpy and Pillow (the tests' .venv has both). Prints a markdown table; `--json` also
writes the rows. The renders are kept in `--out` (default a temporary folder).
"""

import argparse
import json
import math
import os
import re
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from PIL import Image

ROOT = Path(__file__).resolve().parent.parent
SHARED = Path(os.environ.get("SHARED", ROOT.parent / "shared"))

# Each toggle: a name and the flags added to both renders of the pair.
TOGGLES = [
    ("default", []),
    ("--palette none", ["--palette", "none"]),
    ("--chiaroscuro 0", ["--chiaroscuro", "0"]),
    ("--plane-light 0", ["--plane-light", "0"]),
    ("--border-style symmetric", ["--border-style", "symmetric"]),
    ("--border-strength 0", ["--border-strength", "0"]),
    ("--brushwork 0", ["--brushwork", "0"]),
    ("--canvas-grain 0", ["--canvas-grain", "0"]),
    ("--preset plain", ["--preset", "plain"]),
]


def scene_path(name):
    """The scene argument of `cubist render` (None = the built-in still life)."""
    if name in ("still-life", "still_life"):
        return None
    p = Path(name)
    if p.suffix in (".glb", ".gltf") and p.exists():
        return str(p)
    for d in (SHARED / "models", SHARED / "gltf-samples"):
        for ext in (".glb", ".gltf"):
            if (d / (name + ext)).exists():
                return str(d / (name + ext))
    sys.exit(f"psnr_spp: no scene named {name!r} (a path, a name in {SHARED}/models or gltf-samples, or still-life)")


def render(binary, scene, size, extra, out, stages=None):
    """Renders and returns the wall time; with `stages` (a dict), also fills it with the whole
    process's CPU seconds ("process") and each stage's CPU ms as `-v` prints them."""
    cmd = [binary, "render"] + ([scene] if scene else [])
    cmd += ["--width", str(size), "--height", str(size), "--progress", "none", "-o", str(out)] + extra
    if stages is not None:
        cmd.append("-v")
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.time()
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"psnr_spp: {' '.join(cmd)} failed:\n{r.stderr}")
    wall = time.time() - t
    if stages is not None:
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        stages["process"] = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
        for m in re.finditer(r"^\s*([a-z+ -]+):\s+[0-9.]+ ms \(([0-9.]+) ms CPU\)", r.stderr, re.M):
            stages[m.group(1).strip()] = float(m.group(2))
    return wall


def threshold_table(args, out):
    """Per scene, one reference and one render per `--aa-threshold`: PSNR, pixels off, CPU."""
    ref_flags = ["--spp", str(args.ref_spp), "--aa-threshold", "0"]
    print(f"Adaptive anti-aliasing's threshold against error: PSNR against the {args.ref_spp} spp reference (every pixel), {args.size} x {args.size}; CPU of the anti-aliasing stage and of the whole process, one run each\n")
    print("| scene | --aa-threshold | PSNR dB | pixels off by > 8/255 | anti-aliasing CPU ms | process CPU s |")
    print("|---|---:|---:|---:|---:|---:|")
    rows = []
    for name in args.scenes:
        scene = scene_path(name)
        stem = Path(scene).stem if scene else "still-life"
        ref = out / f"{stem}.ref.png"
        render(args.binary, scene, args.size, ref_flags, ref)
        ib = load_rgb(ref)
        for t in args.thresholds:
            a = out / f"{stem}.aa{t}.png"
            stages = {}
            render(args.binary, scene, args.size, ["--aa-threshold", str(t)], a, stages)
            ia = load_rgb(a)
            row = {
                "scene": stem,
                "aa_threshold": t,
                "psnr_db": psnr(ia, ib),
                "pixels_off_by_over_8": float(np.mean(np.abs(ia - ib).max(axis=2) > 8)),
                "aa_cpu_ms": stages.get("anti-aliasing", 0.0),
                "process_cpu_s": stages["process"],
            }
            rows.append(row)
            print(
                f"| {stem} | {t:g} | {row['psnr_db']:.2f} | {100 * row['pixels_off_by_over_8']:.2f}% | {row['aa_cpu_ms']:.0f} | {row['process_cpu_s']:.2f} |",
                flush=True,
            )
    return rows


def load_rgb(path):
    return np.asarray(Image.open(path).convert("RGB"), dtype=np.float64)


def psnr(a, b):
    """PSNR in dB of two 8-bit RGB images (infinite when identical)."""
    mse = np.mean((a - b) ** 2)
    return math.inf if mse == 0 else 10 * math.log10(255.0**2 / mse)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", nargs="+", default=["venus_11k"])
    ap.add_argument("--size", type=int, default=1000, help="image width and height (default 1000)")
    ap.add_argument("--ref-spp", type=int, default=64)
    ap.add_argument("--toggles", action="store_true", help="also each effect toggled (the per-effect table)")
    ap.add_argument("--binary", default=str(ROOT / "target" / "release" / "cubist"))
    ap.add_argument("--out", help="folder for the renders (default: a temporary one)")
    ap.add_argument("--json", help="write the rows here")
    ap.add_argument("--target", type=float, default=40.0, help="the PSNR asked for (dB)")
    ap.add_argument("--thresholds", type=float, nargs="+", help="the threshold table instead: these --aa-threshold values")
    args = ap.parse_args()
    if not Path(args.binary).exists():
        sys.exit(f"psnr_spp: {args.binary} not found (cargo build --release --bin cubist)")
    out = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="psnr_spp_"))
    out.mkdir(parents=True, exist_ok=True)
    if args.thresholds:
        rows = threshold_table(args, out)
        if args.json:
            Path(args.json).write_text(json.dumps(rows, indent=1))
        return
    toggles = TOGGLES if args.toggles else TOGGLES[:1]
    ref_flags = ["--spp", str(args.ref_spp), "--aa-threshold", "0"]
    rows = []
    for name in args.scenes:
        scene = scene_path(name)
        stem = Path(scene).stem if scene else "still-life"
        for label, flags in toggles:
            tag = label.replace("--", "").replace(" ", "_")
            a, b = out / f"{stem}.{tag}.png", out / f"{stem}.{tag}.ref.png"
            ta = render(args.binary, scene, args.size, flags, a)
            tb = render(args.binary, scene, args.size, flags + ref_flags, b)
            ia, ib = load_rgb(a), load_rgb(b)
            p = psnr(ia, ib)
            diff = np.abs(ia - ib).max(axis=2)
            rows.append(
                {
                    "scene": stem,
                    "flags": label,
                    "size": args.size,
                    "psnr_db": p,
                    "pixels_off_by_over_8": float(np.mean(diff > 8)),
                    "wall_s": ta,
                    "ref_wall_s": tb,
                }
            )
            print(f"{stem} {label}: {p:.2f} dB", file=sys.stderr, flush=True)
    print(f"PSNR of the render against its own {args.ref_spp} spp reference (every pixel), {args.size} x {args.size}, 8-bit RGB; target >= {args.target:g} dB\n")
    print("| scene | flags (both renders) | PSNR dB | pixels off by > 8/255 | met |")
    print("|---|---|---:|---:|---|")
    for r in rows:
        met = "yes" if r["psnr_db"] >= args.target else "**no**"
        print(f"| {r['scene']} | {r['flags']} | {r['psnr_db']:.1f} | {100 * r['pixels_off_by_over_8']:.2f}% | {met} |")
    print(f"\nrenders in {out}")
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
