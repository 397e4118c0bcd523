"""Drives the Cubist viewport in a windowed Blender, for tests/python/test_blender_viewport.py.

Run inside Blender's interface (Debian's Blender 3.4.1 under Xvfb), never in background mode:

    xvfb-run -a -s "-screen 0 1280x1024x24" blender --factory-startup --python viewport_driver.py -- \
        ROOT OUT BINARY

From a `bpy.app.timers` callback (the main thread), as a user would: chooses Cubist on the
factory scene, switches the largest 3D view to Rendered shading, waits for the progressive
images to be drawn, changes a panel value, looks through the camera, presses F12 with the scene
unchanged, switches the view back to Solid, gives the viewport a binary that does not exist
(the error must be drawn as text), and last switches to Rendered shading again and quits Blender
while that view's server runs (the test then checks the server and its folder are gone). A
second timer ticks every 20 ms all along; its real firing times, kept per step, are the gaps
between passes of Blender's main loop: how long the interface went without handling input.
Before the viewport steps it measures Blender's own costs in the same run: idle, a redraw of
the 3D view (Solid shading), F12 with the Workbench engine. The timeline is turned into a
second 3D view (Solid) and every 3D view's draws are counted, with the views the viewport tags. The full-size image of the first view, the scene and settings
it was rendered from go to OUT/rendered/ (the test renders them with `cubist render`);
everything else to OUT/results.json. Blender quits at the end, also after a failure.
"""

import json
import os
import sys
import tempfile
import time
from pathlib import Path

import addon_utils
import bpy
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import stepper  # noqa: E402 - beside this script, which Blender runs by path
import user_input  # noqa: E402

ARGS = sys.argv[sys.argv.index("--") + 1:]
ROOT, OUT, BINARY = Path(ARGS[0]), Path(ARGS[1]), ARGS[2]
OUT.mkdir(parents=True, exist_ok=True)
results: dict = {"blender": bpy.app.version_string, "background": bpy.app.background, "done": False}
heartbeat: list = []


def log(message):
    print(f"VIEWPORT-TEST: {message}", flush=True)


def beat():
    heartbeat.append(time.monotonic())
    return 0.02


def view3d():
    window = bpy.context.window_manager.windows[0]
    areas = [a for a in window.screen.areas if a.type == "VIEW_3D"]
    area = max(areas, key=lambda a: a.width * a.height)
    region = next(r for r in area.regions if r.type == "WINDOW")
    return window, area, region


def override():
    window, area, region = view3d()
    return {"window": window, "screen": window.screen, "area": area, "region": region}


def vp():
    return sys.modules["blender_addon.viewport"]


def session():
    sessions = list(vp().sessions)
    return sessions[0] if len(sessions) == 1 else None


def gaps(since):
    """The longest gap between heartbeat ticks after `since` (seconds)."""
    ticks = [t for t in heartbeat if t >= since]
    return max((b - a for a, b in zip(ticks, ticks[1:])), default=None), len(ticks)


def gap_list(since, until=None):
    """Every gap between heartbeat ticks from `since` to `until` (seconds): how long Blender's
    main loop went between two runs of its timers."""
    until = time.monotonic() if until is None else until
    ticks = [t for t in heartbeat if since <= t <= until]
    return [round(b - a, 4) for a, b in zip(ticks, ticks[1:])]


# Draws of each 3D view (as_pointer() -> count), by a draw handler.
view_draws: dict = {}


def count_draw():
    area = bpy.context.area
    if area is not None:
        view_draws[area.as_pointer()] = view_draws.get(area.as_pointer(), 0) + 1


def settle(timeout=90.0):
    """Yields until the heartbeat has run at its own rate for a second and no 3D view has drawn
    for two (Blender's start-up draws, which go on for 10-20 s under Xvfb, are over)."""
    t0 = time.monotonic()
    last = (time.monotonic(), dict(view_draws))
    while time.monotonic() - t0 < timeout:
        if view_draws != last[1]:
            last = (time.monotonic(), dict(view_draws))
        recent = gap_list(time.monotonic() - 1.0)
        if len(recent) >= 30 and max(recent) < 0.1 and time.monotonic() - last[0] > 2.0:
            return
        yield 0.2


def draws_since(before):
    """3D view draws since the `before` counts (all views)."""
    return sum(view_draws.values()) - sum(before.values())


def wait_for_draw(predicate, timeout, what):
    """Yields until a drawn frame satisfies `predicate(session, draw)`; returns (session, draw)."""
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        s = session()
        if s is not None and s.draws and predicate(s, s.draws[-1]):
            return s, s.draws[-1]
        yield 0.05
    state = [{"counts": s.counts, "error": s.error, "closed": s.closed, "draws": s.draws[-2:], "area": s.area}
             for s in list(vp().sessions)]
    engines = {k: (v if isinstance(v, str) else "session") for k, v in vp()._by_engine.items()}
    raise TimeoutError(f"{what}: nothing drawn within {timeout} s (sessions {state}, engines {engines}, "
                       f"rendered areas {vp().timer.rendered_areas()})")


def expected_centre(s, draw):
    """The image pixels drawn at the centre of the draw's rect, scene-linear as drawn (Blender's
    view transform makes them sRGB on the screen, as for F12): [the nearest pixel's colour,
    the least and the most of the 3 x 3 around it per channel] (a rect larger than the image
    draws it magnified, filtered between neighbours)."""
    img = s.image
    x, y, w, h = draw["rect"]
    cx, cy = draw["centre"]
    u = (cx + 0.5 - x) / w
    v = 1.0 - (cy + 0.5 - y) / h
    row, col = min(img.height - 1, int(v * img.height)), min(img.width - 1, int(u * img.width))
    linear = sys.modules["blender_addon.picture"].result_rect
    near = img.pixels[max(0, row - 1):row + 2, max(0, col - 1):col + 2]
    around = linear(near, (0, 0, near.shape[1], near.shape[0]))
    nearest = linear(img.pixels[row:row + 1, col:col + 1], (0, 0, 1, 1))[0]
    return [[float(c) for c in nearest], [float(c) for c in around.min(axis=0)], [float(c) for c in around.max(axis=0)]]


def setup():
    sys.path.insert(0, str(ROOT))
    mod = addon_utils.enable("blender_addon", default_set=True, persistent=True)
    assert mod is not None, "the add-on did not enable"
    prefs = bpy.context.preferences.addons["blender_addon"].preferences
    prefs.binary_path = BINARY
    user_input.install()
    vp().drawing.record_draws = True
    # The 3D views the viewport tags for redraw when it has a new image (pointers).
    original = vp().timer.redraw_views

    def redraw_views(areas):
        results.setdefault("tagged", []).append(sorted(a for a in areas if a is not None) or ["all"])
        original(areas)

    vp().timer.redraw_views = redraw_views
    scene = bpy.context.scene
    scene.render.engine = "CUBIST"
    yield 1.0  # the message bus (colour management) runs in the event loop
    r = scene.render
    r.resolution_x, r.resolution_y, r.resolution_percentage = 200, 150, 100
    scene.cubist.spp = 1
    bpy.app.timers.register(beat, first_interval=0.02)
    results["temp_before"] = sorted(p.name for p in Path(tempfile.gettempdir()).glob("cubist-*"))
    # A second 3D view, in Solid shading (the timeline turned into one): the viewport must not
    # tag it for redraw. Every 3D view's draws are counted.
    window = bpy.context.window_manager.windows[0]
    other = min((a for a in window.screen.areas if a.type != "VIEW_3D"), key=lambda a: a.width * a.height)
    other.type = "VIEW_3D"
    results["other_view"] = other.as_pointer()
    bpy.types.SpaceView3D.draw_handler_add(count_draw, (), "WINDOW", "POST_PIXEL")
    yield from settle()
    # The heartbeat in Solid shading, nothing rendering: this machine's baseline.
    t0 = time.monotonic()
    yield 2.0
    results["idle"] = {"gap": gaps(t0), "gaps": gap_list(t0)}
    # What one redraw of the 3D view costs Blender here (its own drawing, software OpenGL under
    # Xvfb): the floor of any stall a viewport that shows new images can cause.
    window, area, region = view3d()
    t0 = time.monotonic()
    for _ in range(6):
        area.tag_redraw()
        yield 0.5
    results["redraw_baseline"] = {"gaps": gap_list(t0)}
    # F12 with Blender's own Workbench engine, twice: what rendering costs the interface when
    # the engine is Blender's, to compare F12 with ours (pressed as keys, user_input.py).
    scene.render.engine = "BLENDER_WORKBENCH"
    for _ in range(2):
        t0 = time.monotonic()
        yield from user_input.press_render()
        while bpy.app.is_job_running("RENDER"):
            yield 0.05
        yield 0.5
    results["workbench_f12"] = {"gaps": gap_list(t0)}
    scene.render.engine = "CUBIST"
    yield from settle()


def rendered_view():
    """Rendered shading in the default perspective view: the view matrix's picture, 1/4, 1/2
    then full size, drawn; the interface keeps ticking."""
    window, area, region = view3d()
    draws_before = dict(view_draws)
    t0 = time.monotonic()
    area.spaces.active.shading.type = "RENDERED"
    s, draw = yield from wait_for_draw(lambda s, d: d["scale"] == 1.0, 300, "rendered view")
    t1 = time.monotonic()
    results["view_draws"] = {name: view_draws.get(ptr, 0) - draws_before.get(ptr, 0)
                             for name, ptr in (("rendered", area.as_pointer()), ("other", results["other_view"]))}
    results["rendered_view"] = area.as_pointer()
    # What was drawn, and what it was rendered from, for `cubist render` in the test.
    kept = OUT / "rendered"
    kept.mkdir(exist_ok=True)
    np.save(kept / "image.npy", s.image.pixels)
    (kept / "scene.glb").write_bytes(Path(s.job.scene).read_bytes())
    (kept / "settings.json").write_text(json.dumps(s.job.settings))
    results["rendered"] = {
        "saved_image": [s.image.generation, s.image.scale, s.job.generation],
        "seconds": time.monotonic() - t0, "region": [region.width, region.height], "draw": draw,
        "scales_drawn": [d["scale"] for d in s.draws if d["generation"] == draw["generation"]], "history": s.history, "counts": dict(s.counts),
        "expected_centre": expected_centre(s, draw), "server_pid": s.client.pid,
        "through_camera": s.job.view.through_camera, "gap": gaps(t0), "main_thread": dict(s.main_thread),
        "gaps": gap_list(t0, t1), "draws": draws_since(draws_before)}
    log(f"rendered: {results['rendered']['seconds']:.1f} s, gap {results['rendered']['gap']}")


def panel_change():
    """A panel value changed: a new job, paint alone re-run, drawn; the interface keeps ticking."""
    scene = bpy.context.scene
    s = session()
    before = s.job.generation
    draws_before = dict(view_draws)
    t0 = time.monotonic()
    # As the panel does: the value set, and the scene tagged for the depsgraph (a button's edit
    # tags it; a Python assignment to an add-on property does not). First a drag over a few
    # values (each cancels the request before it), then the value it stops at.
    for value in (12.0, 15.0, 18.0, 21.0):
        scene.cubist.border_width = value
        scene.update_tag()
        yield 0.12
    scene.cubist.border_width = 25.0
    scene.update_tag()
    # The full image of the job for the value it stops at: with a fast paint, a job of the drag
    # (12 ... 21) can finish at full size before the next one starts, and its image be drawn.
    s, draw = yield from wait_for_draw(
        lambda s, d: (d["generation"] == s.job.generation > before and s.job.settings.get("border_width") == 25.0
                      and d["scale"] == 1.0),
        120, "after the panel change")
    results["panel_change"] = {
        "seconds": time.monotonic() - t0, "draw": draw, "history": s.history, "counts": dict(s.counts),
        "border_width_sent": s.job.settings.get("border_width"), "expected_centre": expected_centre(s, draw),
        "same_server": s.client.pid == results["rendered"]["server_pid"], "gap": gaps(t0), "gaps": gap_list(t0),
        "draws": draws_since(draws_before),
        "main_thread": dict(s.main_thread)}
    log(f"panel change: {results['panel_change']['seconds']:.1f} s")


def object_moved():
    """An object moved (a content change: the scene is read on the main thread, written by the
    worker): a new job, drawn; the interface keeps ticking."""
    s = session()
    before = s.job.generation
    draws_before = dict(view_draws)
    s.main_thread.clear()
    s.worker_times.clear()
    t0 = time.monotonic()
    bpy.data.objects["Cube"].location.x += 0.2
    s, draw = yield from wait_for_draw(lambda s, d: d["generation"] > before and d["scale"] == 1.0, 120,
                                       "after the object moved")
    results["object_moved"] = {
        "seconds": time.monotonic() - t0, "draw": draw, "counts": dict(s.counts), "gap": gaps(t0),
        "gaps": gap_list(t0), "draws": draws_since(draws_before), "main_thread": dict(s.main_thread),
        "worker": dict(s.worker_times)}
    log(f"object moved: {results['object_moved']['seconds']:.1f} s, {results['object_moved']['main_thread']}")


def camera_view():
    """Looking through the scene camera: the render's aspect, in the camera frame."""
    s = session()
    before = s.job.generation
    draws_before = dict(view_draws)
    t0 = time.monotonic()
    user_input.press("KP_0", area=view3d()[1])  # Numpad 0, over the Rendered view
    s, draw = yield from wait_for_draw(lambda s, d: d["generation"] > before and d["scale"] == 1.0, 120,
                                       "camera view")
    results["camera_view"] = {"seconds": time.monotonic() - t0, "draw": draw, "through_camera": s.job.view.through_camera,
                              "size": [s.job.settings["width"], s.job.settings["height"]],
                              "expected_centre": expected_centre(s, draw), "gap": gaps(t0),
                              "gaps": gap_list(t0), "draws": draws_since(draws_before)}


def f12_unchanged():
    """F12 with the scene as the viewport has it: rendered on the viewport's server."""
    engine = sys.modules["blender_addon.engine"]
    engine.keep_exports = str(OUT / "f12_exports")
    s = session()
    served = s.client.stats()["served"]
    t0 = time.monotonic()
    started = yield from user_input.press_render()
    while bpy.app.is_job_running("RENDER"):
        if time.monotonic() - t0 > 300:
            raise TimeoutError("F12 still runs after 300 s")
        yield 0.05
    yield 0.5  # as long after the job as the Workbench F12's measure
    out = OUT / "f12.png"
    bpy.data.images["Render Result"].save_render(str(out), scene=bpy.context.scene)
    results["f12"] = {"operator": started, "seconds": time.monotonic() - t0, "server": engine.last_run.get("server"),
                      "viewport_server": s.client.pid, "error": engine.last_run.get("error"),
                      "served_before": served, "served_after": s.client.stats()["served"],
                      "settings": engine.last_run.get("settings"), "saved": out.is_file(), "gap": gaps(t0),
                      "gaps": gap_list(t0)}
    engine.keep_exports = None
    log(f"F12: {results['f12']}")


def solid_again():
    """Back to Solid shading: the session and its folder end; the session-wide server stays
    (F12 and other views use it)."""
    window, area, region = view3d()
    s = session()
    pid = s.client.pid
    workspace = s.workspace
    t0 = time.monotonic()
    area.spaces.active.shading.type = "SOLID"
    while time.monotonic() - t0 < 30:
        if not vp().sessions and not workspace.exists():
            break
        yield 0.05
    try:
        os.kill(pid, 0)
        alive = True
    except ProcessLookupError:
        alive = False
    results["solid"] = {"seconds": time.monotonic() - t0, "server_alive": alive, "sessions": len(vp().sessions),
                        "workspace_exists": workspace.exists()}


def error_as_text():
    """A binary that does not exist: Rendered shading shows the error as text, no crash."""
    prefs = bpy.context.preferences.addons["blender_addon"].preferences
    prefs.binary_path = str(OUT / "no-such-cubist")
    texts = []
    original = vp().drawing.draw_text

    def recording(region, lines):
        texts.append(list(lines))
        original(region, lines)

    vp().drawing.draw_text = recording
    window, area, region = view3d()
    area.spaces.active.shading.type = "RENDERED"
    t0 = time.monotonic()
    while not texts and time.monotonic() - t0 < 30:
        area.tag_redraw()
        yield 0.1
    area.spaces.active.shading.type = "SOLID"
    yield 0.5
    vp().drawing.draw_text = original
    prefs.binary_path = BINARY
    results["error_text"] = texts[:3]


def rendered_at_quit():
    """Rendered shading again, then Blender quits (main's end) while its server runs."""
    window, area, region = view3d()
    area.spaces.active.shading.type = "RENDERED"
    s, draw = yield from wait_for_draw(lambda s, d: True, 120, "rendered again")
    results["at_quit"] = {"server_pid": s.client.pid, "workspace": str(s.client.workspace),
                          "workspace_exists": s.client.workspace.exists(), "draw": draw,
                          "temp": sorted(p.name for p in Path(tempfile.gettempdir()).glob("cubist-*"))}


def main():
    yield from setup()
    for step in (rendered_view, panel_change, object_moved, camera_view, f12_unchanged, solid_again, error_as_text,
                 rendered_at_quit):
        log(f"step {step.__name__}")
        yield from step()
    results["heartbeat"] = {"ticks": len(heartbeat), "longest_gap": gaps(0.0)[0]}
    results["done"] = True


def write_results():
    (OUT / "results.json").write_text(json.dumps(results, indent=1, default=str))


# The viewport's threads may still run at the end: Ctrl+Q rather than the operator (user_input.py).
stepper.run(main, results, write_results, log, stepper.quit_by_keys(override, log, fallback_after=20.0))
