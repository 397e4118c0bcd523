"""Installs the extension zip into headless Blender (bpy) as a user installs it, renders with
it as the interface does, and uninstalls it; for tests/python/test_blender_versions.py, which
runs this with the python of each Blender release's venv (bpy 4.2 LTS, 4.5 LTS, 5.0):

    python driver.py ZIP OUT_DIR

The caller sets BLENDER_USER_RESOURCES and TMPDIR to scratch folders. Each step's outcome goes
to OUT_DIR/results.json (a failing step is recorded, the next ones still run); the test judges.
Renders run on a `threading.Thread`, as F12 and Render Animation run render() off the main
thread in the interface (bpy.ops and bpy.context are unusable there)."""

import hashlib
import json
import os
import sys
import tempfile
import threading
import time
import traceback
from pathlib import Path

import bpy

ZIP, OUT = Path(sys.argv[1]), Path(sys.argv[2])
ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "python"))
from exr_support import exr_channels, use_multilayer_exr  # noqa: E402 (plain numpy)

PKG = "bl_ext.user_default.cubist"
SIZE = (64, 48)
results = {"blender": ".".join(map(str, bpy.app.version)), "python": sys.version.split()[0], "steps": {}}


def step(fn):
    """Runs one step, recording what it returns or the exception it raised."""
    t0 = time.monotonic()
    try:
        out = fn()
    except Exception as e:  # noqa: BLE001 - recorded for the test, which names it
        out = {"exception": f"{type(e).__name__}: {e}", "traceback": traceback.format_exc()[-3000:]}
    out = dict(out or {}, seconds=round(time.monotonic() - t0, 2))
    results["steps"][fn.__name__] = out
    OUT.joinpath("results.json").write_text(json.dumps(results, indent=1, default=str))
    return out


def on_thread(call, timeout=300.0):
    """`call()` on a worker thread (the render-job thread of the interface): its error text."""
    box = {"error": None}

    def run():
        try:
            call()
        except Exception as e:  # noqa: BLE001 - RuntimeError from self.report({'ERROR'}) is the message
            box["error"] = str(e)

    t = threading.Thread(target=run, name="render-job")
    t.start()
    t.join(timeout)
    if t.is_alive():
        raise TimeoutError(f"the render did not return in {timeout:.0f} s")
    return box["error"]


def module(name):
    return sys.modules[f"{PKG}.{name}"]


def child_processes():
    """This process's live children (pid, command line), from /proc."""
    out = []
    me = os.getpid()
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
            if int(fields[1]) == me and fields[0] != "Z":
                cmd = (stat.parent / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
                out.append([int(stat.parent.name), cmd.strip()])
        except (OSError, IndexError, ValueError):
            continue
    return out


def cubist_files(folder: Path):
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if "cubist" in p.name.lower())


def panel_text(cls):
    """The labels a panel draws (no interface in background mode: a layout that records)."""
    labels = []

    class Layout:
        def label(self, text="", icon="NONE", **kw):
            labels.append([icon, text])

        def __getattr__(self, name):
            return lambda *a, **kw: self

    cls.draw(type("Panel", (), {"layout": Layout()})(), bpy.context)
    return labels


def install():
    before = cubist_files(Path(os.environ["BLENDER_USER_RESOURCES"]))
    ret = bpy.ops.extensions.package_install_files(filepath=str(ZIP), repo="user_default", enable_on_install=True)
    return {"operator": sorted(ret), "enabled": PKG in bpy.context.preferences.addons,
            "engine": bpy.types.RenderEngine.bl_rna_get_subclass_py("CUBIST") is not None,
            "files_before": before,
            "installed": cubist_files(Path(os.environ["BLENDER_USER_RESOURCES"]))}


def build_scene():
    """A monkey and a cube seen by a camera that moves over frames 1-3, a sun; Cubist at a
    small size, one sample, colours kept exact; saved, as users' files are (the layouts go
    beside it)."""
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_monkey_add(location=(0, 0, 0))
    bpy.ops.mesh.primitive_cube_add(size=0.8, location=(1.4, 0.5, -0.3))
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(cam)
    cam.location, cam.rotation_euler = (0.0, -6.0, 0.5), (1.4908, 0.0, 0.0)
    scene.camera = cam
    for frame, x in ((1, -1.5), (3, 1.5)):
        cam.location.x = x
        cam.keyframe_insert("location", index=0, frame=frame)
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.rotation_euler = (0.6, 0.2, 0.4)
    scene.collection.objects.link(sun)
    scene.frame_start, scene.frame_end = 1, 3
    scene.frame_set(1)
    r = scene.render
    r.engine = "CUBIST"
    r.resolution_x, r.resolution_y, r.resolution_percentage = *SIZE, 100
    r.dither_intensity = 0.0
    r.image_settings.file_format = "PNG"
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.cubist.spp = 1
    bpy.ops.wm.save_as_mainfile(filepath=str(OUT / "scene.blend"))
    return {"file": bpy.data.filepath}


def picture(path: Path):
    """(colours in the picture, its size): a painting has many colours, a blank result one."""
    import numpy as np

    px = module("pngio").read(path)
    return len(np.unique(px[..., :3].reshape(-1, 3), axis=0)), [int(px.shape[1]), int(px.shape[0])]


def f12_on_a_thread():
    scene = bpy.context.scene
    scene.render.filepath = str(OUT / "f12.png")
    error = on_thread(lambda: bpy.ops.render.render(write_still=True))
    colours, size = picture(OUT / "f12.png") if (OUT / "f12.png").is_file() else (0, None)
    return {"error": error, "colours": colours, "size": size, "last_error": module("engine").last_run.get("error")}


def animation_on_a_thread():
    engine = module("engine")
    scene = bpy.context.scene
    scene.render.filepath = str(OUT / "anim" / "frame_####")
    exports = OUT / "anim_exports"
    engine.keep_exports = exports
    try:
        error = on_thread(lambda: bpy.ops.render.render(animation=True))
    finally:
        engine.keep_exports = None
    written = sorted(p.name for p in (OUT / "anim").glob("*.png"))
    sent = {}
    for f in (1, 2, 3):
        s = exports / f"settings_{f:04d}.json"
        if s.is_file():
            sent[f] = json.loads(s.read_text()).get("camera_position")
    expected = {}
    for f in (1, 2, 3):
        scene.frame_set(f)
        loc = scene.camera.matrix_world.translation
        expected[f] = [loc.x, loc.z, -loc.y]  # glTF's Y-up
    scene.frame_set(1)
    pictures = {}
    for name in written:
        data = (OUT / "anim" / name).read_bytes()
        pictures[name] = [picture(OUT / "anim" / name)[0], hashlib.sha256(data).hexdigest()]
    return {"error": error, "written": written, "camera_sent": sent, "camera_expected": expected,
            "pictures": pictures, "frames": [h.get("frame") for h in engine.history[-3:]]}


def compositor_tree(scene):
    """The scene's compositor node tree with a Render Layers node (Blender 5 keeps it in a
    node group of its own; 4.x in scene.node_tree once use_nodes is on)."""
    if hasattr(scene, "compositing_node_group"):
        tree = scene.compositing_node_group
        if tree is None:
            tree = bpy.data.node_groups.new("Compositing", "CompositorNodeTree")
            scene.compositing_node_group = tree
    else:
        scene.use_nodes = True
        tree = scene.node_tree
    node = next((n for n in tree.nodes if n.bl_idname == "CompositorNodeRLayers"), None)
    if node is None:
        node = tree.nodes.new("CompositorNodeRLayers")
    node.scene = scene
    return tree, node


def passes_reach_the_compositor():
    scene = bpy.context.scene
    mapping = module("mapping")
    for toggle, *_ in mapping.PASSES:
        setattr(scene.cubist, toggle, True)
    bpy.context.view_layer.update_render_passes()
    _tree, node = compositor_tree(scene)
    sockets = {s.name: bool(s.enabled) for s in node.outputs}
    settings = scene.render.image_settings
    use_multilayer_exr(scene)
    scene.render.filepath = str(OUT / "passes.exr")
    try:
        error = on_thread(lambda: bpy.ops.render.render(write_still=True))
        layer = bpy.context.view_layer.name
        channels = exr_channels(OUT / "passes.exr") if (OUT / "passes.exr").is_file() else {}
        spread = {}
        for _toggle, _name, bname, n, chan_id, _kind in mapping.PASSES:
            names = [f"{layer}.{bname}.{c}" for c in (chan_id if n == 3 else "X")]
            spread[bname] = [float(channels[c].max() - channels[c].min()) if c in channels else None for c in names]
    finally:
        for toggle, *_ in mapping.PASSES:
            setattr(scene.cubist, toggle, False)
        if hasattr(settings, "media_type"):
            settings.media_type = "IMAGE"
        settings.file_format = "PNG"
    return {"error": error, "sockets": sockets, "spread": spread,
            "blender_pass_names": [p[2] for p in mapping.PASSES]}


def cancel():
    """Blender's cancel as test_break() reports it once the renderer is under way (the
    engine's test seam: headless Blender has no Esc)."""
    engine = module("engine")
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = 640, 480
    scene.cubist.spp = 64  # seconds of work: long enough to be cancelled mid-way
    scene.render.filepath = str(OUT / "cancelled.png")
    engine.cancel_hook = lambda: engine.last_run.get("progress_lines", 0) > 0
    t0 = time.monotonic()
    try:
        error = on_thread(lambda: bpy.ops.render.render(write_still=True))
    finally:
        engine.cancel_hook = None
        scene.render.resolution_x, scene.render.resolution_y = SIZE
        scene.cubist.spp = 1
    # F12 renders on the session's renderer (`cubist serve`, kept for the session): the cancel
    # stops its render; the process stays for the next one (or, had the render not stopped
    # within a few seconds, was stopped itself).
    workspace = engine.last_run.get("workspace")
    client = module("server").current()
    try:
        stats = client.stats() if client is not None else {"running": None, "queued": 0}
    except module("serve_client").ServerGone:
        stats = {"running": None, "queued": 0}
    return {"error": error, "cancelled": bool(engine.last_run.get("cancelled")), "seconds_to_stop":
            round(time.monotonic() - t0, 2), "server": engine.last_run.get("server"),
            "server_pid": client.pid if client is not None else None,
            "renderer_running": stats["running"], "renderer_queued": stats["queued"],
            "workspace_left": bool(workspace) and Path(workspace).exists(),
            "children": child_processes()}


def missing_binary():
    prefs = bpy.context.preferences.addons[PKG].preferences
    missing = OUT / "no-such-dir" / "cubist"
    prefs.binary_path = str(missing)
    try:
        panel = panel_text(module("ui").CUBIST_PT_render)
        bpy.context.scene.render.filepath = str(OUT / "missing.png")
        error = on_thread(lambda: bpy.ops.render.render(write_still=True))
    finally:
        prefs.binary_path = ""
    return {"error": error, "panel": panel, "missing": str(missing), "written": (OUT / "missing.png").exists()}


def uninstall():
    repos = bpy.context.preferences.extensions.repos
    index = next(i for i, r in enumerate(repos) if r.module == "user_default")
    ret = bpy.ops.extensions.package_uninstall(repo_index=index, pkg_id="cubist")
    time.sleep(0.5)  # a renderer that is being stopped has a moment to go
    resources = Path(os.environ["BLENDER_USER_RESOURCES"])
    return {"operator": sorted(ret), "enabled": PKG in bpy.context.preferences.addons,
            "engine": bpy.types.RenderEngine.bl_rna_get_subclass_py("CUBIST") is not None,
            "files_left": cubist_files(resources),
            "temp_left": sorted(p.name for p in Path(tempfile.gettempdir()).glob("cubist*")),
            "children": child_processes(),
            "modules_left": sorted(m for m in sys.modules if m == PKG or m.startswith(PKG + ".")),
            "handlers": sorted({f"{kind}:{getattr(fn, '__module__', '')}" for kind in dir(bpy.app.handlers)
                                if not kind.startswith("_") and isinstance(getattr(bpy.app.handlers, kind), list)
                                for fn in getattr(bpy.app.handlers, kind)
                                if "cubist" in str(getattr(fn, "__module__", ""))})}


step(install)
if results["steps"]["install"].get("enabled"):
    if "exception" not in step(build_scene):
        # The compositor last: a render the engine's test seam cancels (not Blender's own Esc,
        # which skips compositing) with a Render Layers node in the compositor crashes bpy 5.0.1.
        for fn in (f12_on_a_thread, animation_on_a_thread, cancel, missing_binary, passes_reach_the_compositor):
            step(fn)
    step(uninstall)
results["done"] = True
OUT.joinpath("results.json").write_text(json.dumps(results, indent=1, default=str))
# bpy as a module does not always end cleanly once it has rendered (bpy 4.2.23 crashes and
# 4.5.15 hangs at interpreter exit, with any render engine, ours or a five-line one): the
# results are written, so leave at once.
sys.stdout.flush()
sys.stderr.flush()
os._exit(0)
