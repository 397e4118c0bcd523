"""Drives a windowed Blender as a user would, for tests/python/test_blender_ui.py.

Run inside Blender's interface (Debian's Blender 3.4.1 under Xvfb), never in background mode:

    xvfb-run -a -s "-screen 0 1280x1024x24" blender --factory-startup --python driver.py -- \
        ROOT OUT BINARY

It enables the add-on from ROOT/blender_addon as a legacy add-on and, from a `bpy.app.timers`
callback (the main thread, between interface events), does what a user does: chooses the
Cubist engine on the factory scene, presses F12 (a key press through X, user_input.py) with
Lock Interface off and on, renders an animation whose camera and cube
move, renders it again with facets that follow the scene and F12 on one of its frames alone,
renders a frame away from the facet layout's frame, presses Esc (a real key press sent
to the X server with xdotool) during a long render, and opens a scene whose colour management
was set deliberately. Each render runs `RenderEngine.render()` on Blender's render-job thread,
as for users. Everything it sees goes to OUT/results.json; the pytest side checks it (and
renders the exported files with the CLI). Blender quits at the end, also after a failure.
"""

import json
import random
import sys
import tempfile
import time
from pathlib import Path

import addon_utils
import bpy

sys.path.insert(0, str(Path(__file__).resolve().parent))
import stepper  # noqa: E402 - beside this script, which Blender runs by path
import user_input  # noqa: E402

ARGS = sys.argv[sys.argv.index("--") + 1:]
ROOT, OUT, BINARY = Path(ARGS[0]), Path(ARGS[1]), ARGS[2]
OUT.mkdir(parents=True, exist_ok=True)
results: dict = {"blender": bpy.app.version_string, "background": bpy.app.background, "done": False}


def log(message):
    print(f"UI-TEST: {message}", flush=True)


def window_context():
    window = bpy.context.window_manager.windows[0]
    screen = window.screen
    area = max(screen.areas, key=lambda a: a.width * a.height)
    region = next(r for r in area.regions if r.type == "WINDOW")
    return {"window": window, "screen": screen, "area": area, "region": region}


def engine_module():
    return sys.modules["blender_addon.engine"]


def invoke_render(animation=False):
    """F12 / Ctrl+F12 pressed (user_input.py says why not the operator from Python); yields
    until the job has begun."""
    return (yield from user_input.press_render(animation=animation))


def wait_for_render(timeout):
    """Yields (to the timer) until the render job has ended; returns its wall time."""
    t0 = time.monotonic()
    while bpy.app.is_job_running("RENDER"):
        if time.monotonic() - t0 > timeout:
            raise TimeoutError(f"the render job still runs after {timeout} s")
        yield 0.1
    return time.monotonic() - t0


class RecordingLayout:
    """Stands in for a panel's layout: records the labels and operators drawn."""

    def __init__(self, drawn):
        self.drawn = drawn
        self.use_property_split = False
        self.active = True

    def prop(self, *a, **kw):
        pass

    template_icon_view = prop

    def label(self, text="", **kw):
        self.drawn.append(text)

    def operator(self, idname, text="", **kw):
        self.drawn.append(f"[{idname}]")
        return type("Props", (), {})()

    def menu(self, *a, **kw):
        pass

    def separator(self, *a, **kw):
        pass

    def box(self, **kw):
        return self

    column = row = box


def panel_lines():
    drawn = []
    ui = sys.modules["blender_addon.ui"]
    panel = type("P", (), {"layout": RecordingLayout(drawn)})()
    with bpy.context.temp_override(**window_context()):
        ui.CUBIST_PT_render.draw(panel, bpy.context)
    return drawn


def temp_entries():
    """The add-on's temporary files and folders (its render workspaces are cubist-render-*)."""
    return sorted(p.name for p in Path(tempfile.gettempdir()).glob("cubist-*"))


def pose(ob, frame):
    """Location of an object at a frame from its f-curves (what the frame must show)."""
    loc = list(ob.location)
    action = ob.animation_data.action if ob.animation_data else None
    if action is not None:
        for fc in action.fcurves:
            if fc.data_path == "location":
                loc[fc.array_index] = fc.evaluate(frame)
    return loc


# ---------------------------------------------------------------------------------------------


def setup():
    sys.path.insert(0, str(ROOT))
    mod = addon_utils.enable("blender_addon", default_set=True, persistent=True)
    assert mod is not None, "the add-on did not enable"
    prefs = bpy.context.preferences.addons["blender_addon"].preferences
    prefs.binary_path = BINARY
    user_input.install()
    results["addon"] = "enabled"


def scene_f12():
    """The factory scene (default cube, camera, light) plus a monkey and a text: the user
    chooses Cubist, which (main thread, message bus) sets a never-configured scene to
    Standard; then F12 with Lock Interface off and on."""
    scene = bpy.context.scene
    results["factory_view_transform"] = scene.view_settings.view_transform
    with bpy.context.temp_override(**window_context()):
        bpy.ops.mesh.primitive_monkey_add(location=(0.0, 0.0, 2.2), size=1.2)
        bpy.ops.object.text_add(location=(-1.5, -1.5, -1.0))
    scene.render.engine = "CUBIST"  # as the Render Engine menu does
    yield 1.0  # the message bus is handled by the interface's event loop
    results["after_choosing_cubist"] = {"view_transform": scene.view_settings.view_transform,
                                        "switched_from": scene.cubist_colour.switched_from}
    results["panel_after_choosing_cubist"] = panel_lines()
    r = scene.render
    r.resolution_x, r.resolution_y, r.resolution_percentage = 200, 150, 100
    scene.cubist.spp = 1
    scene.cubist.layout_folder = str(OUT / "layouts")
    engine = engine_module()
    engine.keep_exports = str(OUT / "f12_exports")
    results["f12"] = []
    for lock in (False, True):
        r.use_lock_interface = lock
        t0 = time.monotonic()
        started = yield from invoke_render()
        seconds = yield from wait_for_render(300)
        out = OUT / f"f12_lock{int(lock)}.png"
        img = bpy.data.images["Render Result"]
        img.save_render(str(out), scene=scene)
        results["f12"].append({"lock": lock, "operator": started, "seconds": time.monotonic() - t0,
                               "job_seconds": seconds, "saved": out.is_file(),
                               "error": engine.last_run.get("error"),
                               "exports": engine.last_run.get("exports"), "frame": scene.frame_current})
        log(f"F12 lock={lock}: {time.monotonic() - t0:.1f} s")
    engine.keep_exports = None


def scene_animation():
    """Render Animation over frames 1-3 with the camera and the cube moving."""
    scene = bpy.context.scene
    cam, cube = scene.camera, bpy.data.objects["Cube"]
    for frame, x in ((1, 6.0), (3, 8.5)):
        cam.location.x = x
        cam.keyframe_insert("location", index=0, frame=frame)
    for frame, z in ((1, -0.5), (3, 1.5)):
        cube.location.z = z
        cube.keyframe_insert("location", index=2, frame=frame)
    scene.frame_start, scene.frame_end = 1, 3
    scene.frame_set(1)
    scene.render.filepath = str(OUT / "anim" / "frame_####")
    scene.render.image_settings.file_format = "PNG"
    scene.render.use_lock_interface = False
    # Its own layout folder: the F12 step's layout stays for the test to render the CLI with.
    scene.cubist.layout_folder = str(OUT / "anim_layouts")
    results["animation_expected"] = {f: {"camera": pose(cam, f), "cube": pose(cube, f)} for f in (1, 2, 3)}
    engine = engine_module()
    engine.keep_exports = str(OUT / "anim_exports")
    engine.history.clear()
    t0 = time.monotonic()
    started = yield from invoke_render(animation=True)
    yield from wait_for_render(600)
    results["animation"] = {"operator": started, "seconds": time.monotonic() - t0,
                            "frames": [h["frame"] for h in engine.history],
                            "errors": [h["error"] for h in engine.history if h["error"]],
                            "written": sorted(p.name for p in (OUT / "anim").glob("*.png"))}
    engine.keep_exports = None
    log(f"animation: {results['animation']}")


def scene_layout_from_another_frame():
    """F12 on frame 3 with no facet layout yet: the layout is computed on frame 1 first, the
    render's depsgraph evaluated there with RenderEngine.frame_set and back."""
    scene = bpy.context.scene
    scene.frame_set(3)
    scene.cubist.layout_folder = str(OUT / "layouts_other_frame")
    engine = engine_module()
    engine.keep_exports = str(OUT / "prepass_exports")
    started = yield from invoke_render()
    yield from wait_for_render(300)
    img = bpy.data.images["Render Result"]
    img.save_render(str(OUT / "prepass_frame3.png"), scene=scene)
    results["prepass"] = {"operator": started, "prepass": engine.last_run.get("prepass"),
                          "error": engine.last_run.get("error"), "frame_after": scene.frame_current,
                          "exports": engine.last_run.get("exports"),
                          "layouts": sorted(p.name for p in (OUT / "layouts_other_frame").glob("*.facets.json"))}
    engine.keep_exports = None
    scene.frame_set(1)


def scene_follow_animation():
    """Render Animation 1-3 with Facet Motion Follow (each frame's facets carried from frame 1's
    layout and follow data), then F12 on frame 3 alone with no layout yet: frame 1 is exported
    on the render thread (RenderEngine.frame_set) and its layout and follow data computed
    first; the picture must be the animation's frame 3."""
    scene = bpy.context.scene
    scene.cubist.facet_motion = "FOLLOW"
    scene.frame_set(1)
    scene.render.filepath = str(OUT / "follow" / "frame_####")
    scene.cubist.layout_folder = str(OUT / "follow_layouts")
    engine = engine_module()
    engine.history.clear()
    started = yield from invoke_render(animation=True)
    yield from wait_for_render(600)
    results["follow"] = {"operator": started, "frames": [h["frame"] for h in engine.history],
                         "errors": [h["error"] for h in engine.history if h["error"]],
                         "facet_motion": [(h["settings"] or {}).get("facet_motion") for h in engine.history],
                         "written": sorted(p.name for p in (OUT / "follow").glob("*.png")),
                         "layouts": sorted(p.name for p in (OUT / "follow_layouts").glob("*.facets.json*"))}
    scene.frame_set(3)
    scene.cubist.layout_folder = str(OUT / "follow_layouts_f12")
    started = yield from invoke_render()
    yield from wait_for_render(300)
    bpy.data.images["Render Result"].save_render(str(OUT / "follow_f12_frame3.png"), scene=scene)
    results["follow"]["f12"] = {"operator": started, "prepass": engine.last_run.get("prepass"),
                                "error": engine.last_run.get("error"), "frame_after": scene.frame_current,
                                "facet_motion": (engine.last_run.get("settings") or {}).get("facet_motion")}
    scene.cubist.facet_motion = "STATIC"
    scene.frame_set(1)
    log(f"follow: {results['follow']}")


def scene_cancel():
    """Esc during a long render: a real key press (xdotool) on the X server Blender listens to."""
    scene = bpy.context.scene
    r = scene.render
    r.resolution_x, r.resolution_y = 1280, 960
    # 64 samples on every pixel (anti-aliasing threshold 0): long enough that Esc comes before
    # the end however fast the renderer gets (adaptive sampling alone ended it in under a second).
    scene.cubist.spp = 64
    scene.cubist.aa_threshold = 0.0
    engine = engine_module()
    before = temp_entries()
    engine.last_run.clear()  # what follows is this render's (render() fills it on its thread)
    started = yield from invoke_render()
    t0 = time.monotonic()
    while not engine.last_run.get("progress_lines"):
        if time.monotonic() - t0 > 120 or not bpy.app.is_job_running("RENDER"):
            raise RuntimeError("the long render did not get under way")
        yield 0.1
    # F12 renders on the session's renderer (a `cubist serve` kept for the whole session): Esc
    # stops its render, the process stays for the next one.
    client = sys.modules["blender_addon.server"].current()
    workspace = str(engine.last_run["workspace"])
    during = temp_entries()
    # The pointer over Blender's windows, then Escape, as a user's key press.
    ahead = sys.modules["blender_addon.ahead"]
    sent_at_esc = ahead.counts["sent"]
    user_input.press("Escape", focus=False)
    t_esc = time.monotonic()
    while bpy.app.is_job_running("RENDER"):
        if time.monotonic() - t_esc > 60:
            raise TimeoutError("the render job still runs 60 s after Esc")
        yield 0.05
    seconds = time.monotonic() - t_esc
    # A render that did not stop within a few seconds was stopped with its server (the next
    # render starts another): either way nothing of it runs on.
    try:
        stats = client.stats()
    except sys.modules["blender_addon.serve_client"].ServerGone:
        stats = {"running": None, "queued": 0}
    # The render-ahead timer comes round within ahead.IDLE of the job's end: it must not send
    # the job the user just stopped.
    t_end = time.monotonic()
    while time.monotonic() - t_end < ahead.IDLE + 0.5:
        yield 0.1
    results["cancel"] = {"operator": started, "cancelled": engine.last_run.get("cancelled"),
                         "error": engine.last_run.get("error"),
                         "engine_saw_cancel_after_esc": engine.last_run.get("cancel_seen", t_esc - 1) - t_esc,
                         "job_ended_after_esc": seconds, "renderer_running": stats["running"],
                         "sent_ahead_after_esc": ahead.counts["sent"] - sent_at_esc, "ahead_skip": ahead.last_skip,
                         "renderer_queued": stats["queued"], "server": engine.last_run.get("server"),
                         "server_pid": client.pid, "server_alive": client.alive(),
                         "workspace": workspace, "workspace_exists": Path(workspace).exists(),
                         "temp_before": before, "temp_during": during, "temp_after": temp_entries()}
    r.resolution_x, r.resolution_y = 200, 150
    scene.cubist.spp = 1
    log(f"cancel: {results['cancel']}")


def scene_configured_colours():
    """A scene whose colour management the user set (Filmic, a look) then switched to Cubist:
    left as set, with the warning in the panel."""
    scene = bpy.data.scenes.new("Configured")
    bpy.context.window.scene = scene
    scene.view_settings.view_transform = "Filmic"
    scene.view_settings.look = "Medium High Contrast"
    yield 0.3
    scene.render.engine = "CUBIST"
    yield 1.0
    results["configured"] = {"view_transform": scene.view_settings.view_transform,
                             "look": scene.view_settings.look,
                             "switched_from": scene.cubist_colour.switched_from, "panel": panel_lines()}


def scene_busy_interface():
    """Other add-ons a user has: panels and headers whose draw takes 30 ms, and a render_pre
    handler that waits up to 80 ms. F12 (lock off and on) and Render Animation, each followed by
    a write from this timer (the main thread), as any add-on's timer writes: Blender's one global
    write guard must not be left set by the render thread (turns.py says how it was)."""
    scene = bpy.context.scene
    rnd = random.Random(7)
    drawn = [0]

    def slow_draw(self, _context):
        drawn[0] += 1
        t = time.perf_counter()
        while time.perf_counter() - t < 0.03:
            pass
        self.layout.label(text="busy")

    @bpy.app.handlers.persistent
    def waiting_handler(*_args):
        time.sleep(rnd.uniform(0.0, 0.08))

    drawn_by = [getattr(bpy.types, n) for n in dir(bpy.types)
                if n.endswith("_HT_header") or n.startswith(("RENDER_PT_", "VIEW3D_PT_"))]
    drawn_by = [cls for cls in drawn_by if hasattr(cls, "append")]
    for cls in drawn_by:
        cls.append(slow_draw)
    bpy.app.handlers.render_pre.append(waiting_handler)
    engine = engine_module()
    results["busy"] = []
    try:
        for what in ("f12", "f12_lock", "animation", "f12"):
            scene.render.use_lock_interface = what == "f12_lock"
            scene.render.filepath = str(OUT / "busy" / "frame_####")
            engine.history.clear()
            started = yield from invoke_render(animation=what == "animation")
            yield from wait_for_render(300)
            try:
                scene.frame_current = scene.frame_current
                write = "ok"
            except Exception as e:  # what the stuck guard raises
                write = f"{type(e).__name__}: {e}"
            results["busy"].append({"what": what, "operator": started, "write": write,
                                    "frames": [h["frame"] for h in engine.history],
                                    "errors": [h["error"] for h in engine.history if h["error"]]})
            log(f"busy: {results['busy'][-1]}")
    finally:
        for cls in drawn_by:
            cls.remove(slow_draw)
        bpy.app.handlers.render_pre.remove(waiting_handler)
        scene.render.use_lock_interface = False
    results["busy_draws"] = drawn[0]


def main():
    setup()
    for step in (scene_f12, scene_animation, scene_layout_from_another_frame, scene_follow_animation,
                 scene_cancel, scene_busy_interface, scene_configured_colours):
        log(f"step {step.__name__}")
        yield from step()
    results["done"] = True


def write_results():
    (OUT / "results.json").write_text(json.dumps(results, indent=1, default=str))


stepper.run(main, results, write_results, log, stepper.quit_by_operator(window_context, log, exit_code=3))
