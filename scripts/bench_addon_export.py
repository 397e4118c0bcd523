#!/usr/bin/env python3
"""Benchmark of the Blender add-on's hand-off: exporting a 1M-triangle scene from
the depsgraph with the add-on's exporter (blender_addon/export.py) against Blender's glTF
exporter operator (the add-on's former path, which only works in background mode), on the same
scenes, in headless Blender (bpy). Prints a markdown table; `--write` also puts it in
BENCHMARKS.md (its own section, kept by scripts/bench.sh).

    .venv/bin/python scripts/bench_addon_export.py [--runs 7] [--gltf-runs 3] [--write]

Scenes: Suzanne, Subdivision level 4, Array x4 (1,007,616 triangles), smooth shaded, flat
shaded, and smooth with an image texture (UVs per corner); and the same triangle count as 64
instances of one mesh (collection instances). Benchmarks, not tests: nothing fails on a slow
machine; medians and CPU times are quoted because the machine is shared.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
os.environ.setdefault("BLENDER_USER_RESOURCES", tempfile.mkdtemp(prefix="cubist-bench-user-"))
sys.path.insert(0, str(ROOT))

import bpy  # noqa: E402

from blender_addon import export  # noqa: E402

BEGIN, END = "## Blender add-on: the export's hand-off", "<!-- end of the export's hand-off -->"


def build(kind: str):
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_monkey_add()
    ob = bpy.context.object
    if kind == "flat":
        ob.data.shade_flat()
    else:
        ob.data.shade_smooth()
    if kind == "instances":
        sub = ob.modifiers.new("Subdivision", "SUBSURF")
        sub.levels = sub.render_levels = 2  # 15,744 triangles
        coll = bpy.data.collections.new("Monkeys")
        scene.collection.objects.unlink(ob)
        coll.objects.link(ob)
        for i in range(64):
            e = bpy.data.objects.new(f"Monkey{i}", None)
            e.instance_type, e.instance_collection = "COLLECTION", coll
            e.location = (2.5 * (i % 8), 2.5 * (i // 8), 0.0)
            scene.collection.objects.link(e)
    else:
        sub = ob.modifiers.new("Subdivision", "SUBSURF")
        sub.levels = sub.render_levels = 4
        ob.modifiers.new("Array", "ARRAY").count = 4
    if kind == "textured":
        mat = bpy.data.materials.new("Textured")
        if bpy.app.version < (5, 0, 0):
            mat.use_nodes = True  # always on from 5.0
        tex = mat.node_tree.nodes.new("ShaderNodeTexImage")
        tex.image = bpy.data.images.new("Grid", 1024, 1024)
        tex.image.generated_type = "COLOR_GRID"
        mat.node_tree.links.new(tex.outputs["Color"], mat.node_tree.nodes["Principled BSDF"].inputs["Base Color"])
        ob.data.materials.append(mat)
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(cam)
    cam.location, cam.rotation_euler = (3.0, -12.0, 2.0), (1.45, 0.0, 0.2)
    scene.camera = cam
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    scene.collection.objects.link(sun)
    return bpy.context.evaluated_depsgraph_get()


def timed(fn, runs: int) -> tuple[list, list]:
    walls, cpus = [], []
    for _ in range(runs):
        w0, c0 = time.perf_counter(), time.process_time()
        fn()
        walls.append(time.perf_counter() - w0)
        cpus.append(time.process_time() - c0)
    return walls, cpus


def gltf_operator(path: Path):
    bpy.ops.export_scene.gltf(filepath=str(path), export_format="GLB", use_selection=False, use_renderable=True,
                              use_active_scene=True, export_cameras=True, export_lights=True, export_apply=True,
                              export_yup=True, export_texcoords=True, export_normals=True,
                              export_materials="EXPORT", export_animations=False, export_extras=False,
                              will_save_settings=False)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=7, help="runs of the add-on's exporter per scene")
    ap.add_argument("--gltf-runs", type=int, default=3, help="runs of Blender's glTF exporter per scene")
    ap.add_argument("--write", action="store_true", help="update BENCHMARKS.md")
    args = ap.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="cubist-bench-export-"))
    load_before = os.getloadavg()
    rows, target = [], None
    for kind in ("smooth", "flat", "textured", "instances"):
        print(f"scene {kind} ...", file=sys.stderr)
        depsgraph = build(kind)
        ours, theirs = tmp / f"{kind}.ours.glb", tmp / f"{kind}.gltf.glb"
        stats = export.export_glb(depsgraph, ours)  # warm-up (and the figures below)
        w, c = timed(lambda: export.export_glb(depsgraph, ours), args.runs)
        gw, gc = timed(lambda: gltf_operator(theirs), args.gltf_runs)
        row = {"kind": kind, "triangles": stats.triangles, "meshes": stats.meshes, "instances": stats.instances,
               "wall": statistics.median(w), "wmin": min(w), "wmax": max(w), "cpu": statistics.median(c),
               "gwall": statistics.median(gw), "gmin": min(gw), "gmax": max(gw), "gcpu": statistics.median(gc),
               "mb": ours.stat().st_size / 1e6, "gmb": theirs.stat().st_size / 1e6}
        rows.append(row)
        if kind == "smooth":
            target = row
    load_after = os.getloadavg()
    names = {"smooth": "Suzanne subdiv 4 x array 4, smooth", "flat": "same, flat shaded",
             "textured": "same, smooth + image texture (UVs)", "instances": "Suzanne subdiv 2, 64 collection instances"}
    lines = [BEGIN, "",
             "Regenerate with `.venv/bin/python scripts/bench_addon_export.py --write` (headless bpy "
             f"{bpy.app.version_string}, about 3 minutes). What F12 and Render Animation do before the "
             "renderer starts: the scene from the depsgraph to a GLB file. The add-on's exporter "
             "(`blender_addon/export.py`, numpy) against Blender's glTF exporter operator, the add-on's "
             "former path (background mode only: it crashes Blender's interface), on the same evaluated "
             f"scenes. Median of {args.runs} runs (ours) and {args.gltf_runs} (glTF operator) after a warm-up, "
             "seconds; CPU = this process's CPU time. Load average before "
             f"{load_before[0]:.2f}, after {load_after[0]:.2f} (the machine is shared: wall times vary, "
             "see min-max).", "",
             "| scene | triangles | glTF meshes / nodes | ours: wall (min-max) | CPU | glTF operator: wall (min-max) "
             "| CPU | speed-up (wall) | file MB ours / glTF |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {names[r['kind']]} | {r['triangles']:,} | {r['meshes']} / {r['instances']} | "
                     f"{r['wall']:.3f} ({r['wmin']:.3f}-{r['wmax']:.3f}) | {r['cpu']:.3f} | "
                     f"{r['gwall']:.2f} ({r['gmin']:.2f}-{r['gmax']:.2f}) | {r['gcpu']:.2f} | "
                     f"x{r['gwall'] / r['wall']:.1f} | {r['mb']:.1f} / {r['gmb']:.1f} |")
    met = "yes" if target["wall"] <= 1.0 else "**no**"
    lines += ["", f"Target: the 1M-triangle scene exported in <= 1 s: {target['wall']:.3f} s median wall "
              f"({target['cpu']:.3f} s CPU), met: {met}.", END]
    table = "\n".join(lines)
    print(table)
    if args.write:
        path = ROOT / "BENCHMARKS.md"
        text = path.read_text(encoding="utf-8")
        if BEGIN in text:
            a = text.index(BEGIN)
            b = text.index(END, a) + len(END) if END in text[a:] else len(text)
            text = text[:a] + table + text[b:]
        else:
            text = text.rstrip("\n") + "\n\n" + table + "\n"
        path.write_text(text, encoding="utf-8")
        print("wrote BENCHMARKS.md", file=sys.stderr)


if __name__ == "__main__":
    main()
