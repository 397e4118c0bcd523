#!/usr/bin/env python3
"""Benchmark: what a frame with Facet Motion Follow costs in Blender against a Static one,
through the add-on's F12 path (export, settings, the `cubist` process, loading the
picture), in headless Blender (bpy).

    .venv/bin/python scripts/bench_addon_follow.py [--size 1000] [--runs 5]

Scene: venus_11k imported with Blender's glTF importer, a camera orbiting it 2 degrees per frame
(the turntable of BENCHMARKS.md's animation frames), a sun, the panel's defaults. For each motion, frame 1
(the Layout Frame) is rendered once to make its layout (and, for Follow, its follow data); then
F12 on frame 2 is timed `--runs` times, Static and Follow in turn (paired). Wall time of
`bpy.ops.render.render` and the CPU time of the renderer's process (RUSAGE_CHILDREN), medians.
A benchmark, not a test: nothing fails on a slow machine.
"""

from __future__ import annotations

import argparse
import math
import os
import resource
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
os.environ.setdefault("BLENDER_USER_RESOURCES", tempfile.mkdtemp(prefix="cubist-bench-user-"))
sys.path.insert(0, str(ROOT))

import bpy  # noqa: E402, I001 (bpy first: it puts addon_utils on the path)
import addon_utils  # noqa: E402


def children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def build(size: int, folder: Path):
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    scene = bpy.context.scene
    bpy.ops.import_scene.gltf(filepath=str(ROOT.parent / "shared" / "models" / "venus_11k.glb"))
    pivot = bpy.data.objects.new("Pivot", None)
    scene.collection.objects.link(pivot)
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(cam)
    cam.location = (0.0, -4.0, 0.0)
    cam.rotation_euler = (math.radians(90), 0.0, 0.0)
    cam.parent = pivot
    scene.camera = cam
    for frame in (1, 2):
        pivot.rotation_euler.z = math.radians(2.0 * (frame - 1))
        pivot.keyframe_insert("rotation_euler", index=2, frame=frame)
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.rotation_euler = (0.6, 0.2, 0.4)
    scene.collection.objects.link(sun)
    r = scene.render
    r.engine = "CUBIST"
    r.resolution_x = r.resolution_y = size
    r.resolution_percentage = 100
    r.image_settings.file_format = "PNG"
    scene.cubist.layout_folder = str(folder)
    scene.frame_start, scene.frame_end = 1, 2
    return scene


def f12(scene, frame: int) -> tuple[float, float]:
    scene.frame_set(frame)
    c0, t0 = children_cpu(), time.perf_counter()
    bpy.ops.render.render(write_still=False)
    wall, cpu = time.perf_counter() - t0, children_cpu() - c0
    error = sys.modules["blender_addon.engine"].last_run.get("error")
    if error:
        raise SystemExit(f"F12 failed: {error}")
    return wall, cpu


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", type=int, default=1000)
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--binary", default=str(ROOT / "target" / "release" / "cubist"))
    args = ap.parse_args()
    assert addon_utils.enable("blender_addon", default_set=True, persistent=True) is not None
    bpy.context.preferences.addons["blender_addon"].preferences.binary_path = args.binary
    folder = Path(tempfile.mkdtemp(prefix="cubist-bench-follow-"))
    scene = build(args.size, folder)
    times: dict = {"STATIC": [], "FOLLOW": []}
    for motion in times:  # each motion's layout (and follow data) from frame 1, once
        scene.cubist.facet_motion = motion
        f12(scene, 1)
    load0 = os.getloadavg()[0]
    for _ in range(args.runs):
        for motion in times:
            scene.cubist.facet_motion = motion
            times[motion].append(f12(scene, 2))
    load1 = os.getloadavg()[0]
    med = {m: (statistics.median(w for w, _ in v), statistics.median(c for _, c in v)) for m, v in times.items()}
    ratios = [f[1] / s[1] for s, f in zip(times["STATIC"], times["FOLLOW"])]
    print(f"venus_11k turntable (2 deg/frame), {args.size} x {args.size}, panel defaults, F12 on frame 2 "
          f"(layout from frame 1 kept), bpy {bpy.app.version_string}, {args.runs} paired runs, "
          f"load {load0:.1f} -> {load1:.1f}")
    print("| motion | wall s (median) | renderer CPU s (median) |")
    print("|---|---:|---:|")
    for m, (w, c) in med.items():
        print(f"| {m.title()} | {w:.2f} | {c:.2f} |")
    print(f"Follow / Static, renderer CPU, paired median: {statistics.median(ratios):.3f} "
          f"(min {min(ratios):.3f}, max {max(ratios):.3f})")


if __name__ == "__main__":
    main()
