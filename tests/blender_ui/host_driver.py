"""Drives a windowed Blender through F12 on the session's renderer and through everything a
renderer can do wrong, for tests/python/test_blender_host.py.

    xvfb-run -a -s "-screen 0 1280x1024x24" blender --factory-startup --python host_driver.py -- \
        ROOT OUT BINARY TINY

TINY is an empty folder (a 1 MiB tmpfs mounted by the test, or "-" when it could not mount
one) for the full and read-only temporary folder steps. The scene is the factory one with
Suzanne and a sphere instead of the cube and a sun, at the factory 1920 x 1080, in an unsaved
file (its layouts in the unsaved file's temporary folder). From a `bpy.app.timers` callback
(the main thread), as a user would, with F12 pressed as a key (user_input.py):

1. speed: the first F12 of the session once render ahead has prepared it (where its time goes:
   the engine's timeline), F12 again with one panel value changed, the first F12 again on a new
   renderer without render ahead (the same picture), Render Animation of three frames with a
   moving camera (render ahead is then off until the last step);
2. the renderer killed (SIGKILL) during F12, then during the viewport's render, each followed
   by a working F12;
3. fifty panel edits in five seconds while the viewport renders;
4. a renderer that stops answering (a fake `cubist` that sleeps), a binary for another
   platform, one that is not executable;
5. the temporary folder full, then read-only;
6. the .blend saved, its facet layout truncated, then replaced by garbage;
7. File > New during F12, then Ctrl+Q during F12 (render ahead on again).

A 20 ms heartbeat timer runs all along: the gaps between its ticks are how long the interface
went without handling events. Everything goes to OUT/results.json; the test checks it and,
after Blender has quit, that no process or temporary folder of the add-on is left.
"""

import json
import os
import signal
import subprocess
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
ROOT, OUT, BINARY, TINY = Path(ARGS[0]), Path(ARGS[1]), ARGS[2], ARGS[3]
OUT.mkdir(parents=True, exist_ok=True)
results: dict = {"blender": bpy.app.version_string, "background": bpy.app.background, "done": False, "steps": {}}
heartbeat: list = []


def log(message):
    print(f"HOST-TEST: {message}", flush=True)


def beat():
    heartbeat.append(time.monotonic())
    return 0.02


def longest_gap(since):
    ticks = [t for t in heartbeat if t >= since]
    return round(max((b - a for a, b in zip(ticks, ticks[1:])), default=0.0), 3), len(ticks)


def engine():
    return sys.modules["blender_addon.engine"]


def server():
    return sys.modules["blender_addon.server"]


def vp():
    return sys.modules["blender_addon.viewport"]


def ahead():
    return sys.modules["blender_addon.ahead"]


def prefs():
    return bpy.context.preferences.addons["blender_addon"].preferences


def view3d():
    window = bpy.context.window_manager.windows[0]
    area = max((a for a in window.screen.areas if a.type == "VIEW_3D"), key=lambda a: a.width * a.height)
    return window, area, next(r for r in area.regions if r.type == "WINDOW")


def alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    try:
        return Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0] != "Z"
    except OSError:
        return False


def wait_job(timeout=300):
    t0 = time.monotonic()
    while bpy.app.is_job_running("RENDER"):
        if time.monotonic() - t0 > timeout:
            raise TimeoutError(f"the render job still runs after {timeout} s")
        yield 0.02
    return time.monotonic() - t0


def f12(animation=False, timeout=300):
    """F12 (or Ctrl+F12) pressed; yields until the job ended. Returns what the engine saw, with
    the seconds from the key press to the end of the job."""
    user_input.focus_main_window()
    yield 0.3
    t0 = time.monotonic()
    started = yield from user_input.press_render(animation=animation)
    yield from wait_job(timeout)
    run = engine().last_run
    return {"operator": started, "seconds": round(time.monotonic() - t0, 3), "error": run.get("error"),
            "cancelled": run.get("cancelled"), "server": run.get("server"), "timeline": run.get("timeline"),
            "preview_seconds": run.get("preview_seconds"), "timings": run.get("timings"),
            "preview_timings": run.get("preview_timings"), "reused": run.get("reused"),
            "scene_load": run.get("scene_load"), "warnings": run.get("warnings"), "chosen": run.get("chosen"),
            "ahead": run.get("ahead"), "ahead_picture": run.get("ahead_picture"), "preview": run.get("preview"),
            "job_started": next((round(t - t0, 3) for t in user_input._jobs_started if t >= t0), None),
            "gap": longest_gap(t0)}


def responsive(step):
    """The main thread writes to the scene (as any add-on's timer does), and the heartbeat runs."""
    scene = bpy.context.scene
    try:
        scene.frame_current = scene.frame_current
        write = "ok"
    except Exception as e:
        if WRITE_LOCK in str(e):
            raise  # Blender's stuck flag: main() hands the step back to the test
        write = f"{type(e).__name__}: {e}"
    t0 = time.monotonic()
    while longest_gap(t0)[1] < 3 and time.monotonic() - t0 < 30.0:
        yield 0.1
    results["steps"][step]["after"] = {"write": write, "ticks": longest_gap(t0)[1],
                                       "seconds": round(time.monotonic() - t0, 2)}


def press_start():
    """F12 pressed (a long render): yields until the renderer reports progress."""
    user_input.focus_main_window()
    yield 0.3
    engine().last_run.clear()
    yield from user_input.press_render()
    t0 = time.monotonic()
    while bpy.app.is_job_running("RENDER") and time.monotonic() - t0 < 60:
        c = server().current()
        if c is not None and c.stats()["running"] is not None:
            return c
        yield 0.05
    raise RuntimeError("the long render did not get under way")


def long_render(scene):
    scene.render.resolution_percentage = 100
    scene.cubist.spp = 64
    scene.cubist.aa_threshold = 0.0


def short_render(scene):
    scene.render.resolution_percentage = 10
    scene.cubist.spp = 1
    scene.cubist.aa_threshold = 0.05


# ---------------------------------------------------------------------------------------------


def setup():
    sys.path.insert(0, str(ROOT))
    assert addon_utils.enable("blender_addon", default_set=True, persistent=True) is not None
    prefs().binary_path = BINARY
    user_input.install()
    bpy.app.timers.register(beat, first_interval=0.02, persistent=True)  # File > New keeps it
    scene = bpy.context.scene
    window, area, region = view3d()
    bpy.data.objects.remove(bpy.data.objects["Cube"])
    with bpy.context.temp_override(window=window, screen=window.screen, area=area, region=region):
        bpy.ops.mesh.primitive_monkey_add(location=(0.0, 0.0, 0.0))
        bpy.ops.mesh.primitive_uv_sphere_add(location=(2.2, 0.5, 0.0))
    bpy.data.lights["Light"].type = "SUN"
    scene.render.engine = "CUBIST"
    results["size"] = [scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage]
    results["unsaved_folder"] = str(engine().unsaved_folder())
    yield 3.0  # the user looks at the panel


def wait_prepared(timeout=300):
    """Yields until render ahead has prepared F12's job for the scene as it is (the scene left
    still: the add-on's idle timer sends it); returns what the prepare did."""
    t0 = time.monotonic()
    mod = ahead()
    while time.monotonic() - t0 < timeout:
        p = mod.current()
        if p is not None and p.done.is_set() and p.edits == mod._edits:
            return {"ok": p.ok, "skipped": p.skipped, "seconds": p.seconds, "waited": round(time.monotonic() - t0, 2),
                    "timings": (p.reply or {}).get("timings"), "counts": dict(mod.counts), "last_skip": mod.last_skip}
        yield 0.1
    raise TimeoutError(f"render ahead prepared nothing within {timeout} s: {mod.counts}, {mod.last_skip}")


class FloorEngine(bpy.types.RenderEngine):
    """A render engine whose render() only fills its result with one colour, as the add-on
    delivers a picture: what F12 costs with any Python engine."""

    bl_idname = "CUBIST_TEST_FLOOR"
    bl_label = "Floor (test)"

    seconds: list = []  # how long each render() took

    def render(self, depsgraph):
        t0 = time.monotonic()
        r = depsgraph.scene.render
        w, h = int(r.resolution_x * r.resolution_percentage / 100), int(r.resolution_y * r.resolution_percentage / 100)
        result = self.begin_result(0, 0, w, h)
        rect = np.full(w * h * 4, 0.5, dtype=np.float32)
        p = result.layers[0].passes["Combined"]
        try:
            p.rect.foreach_set(rect)
        except TypeError:
            p.rect.foreach_set(rect.reshape(w * h, 4))
        self.end_result(result)
        FloorEngine.seconds.append(round(time.monotonic() - t0, 3))


def save_result(path, timeout=10.0):
    """Saves the Render Result to `path`; yields and tries again while nothing was written (a
    loaded machine's window may not have taken the finished render's pixels yet). Returns the
    tries taken, or None when nothing was written within `timeout` s."""
    t0, tries = time.monotonic(), 0
    while True:
        tries += 1
        bpy.data.images["Render Result"].save_render(str(path), scene=bpy.context.scene)
        if Path(path).is_file():
            return tries
        if time.monotonic() - t0 > timeout:
            return None
        yield 0.25


def step_speed():
    """The first F12 of the session once render ahead has prepared it; F12 again a second after
    one panel change, with render ahead off (the repeat alone), then on; the first F12 again
    without render ahead, on a new renderer that keeps nothing (the same picture, its preview
    first); Render Animation; F12 with Blender's Workbench engine and with `FloorEngine` (Blender's
    own time)."""
    scene = bpy.context.scene
    prepared = yield from wait_prepared()
    engine().keep_exports = OUT / "exports"  # the scene and settings F12 sent (frame_0001.*)
    first = yield from f12()
    engine().keep_exports = None
    first["prepared"] = prepared
    first["saved_tries"] = yield from save_result(OUT / "first.png")
    prefs().render_ahead = False
    scene.cubist.border_width += 2.0
    yield 1.0
    again = yield from f12()
    # The same with render ahead: the changed value's picture is under way when F12 comes.
    prefs().render_ahead = True
    scene.cubist.border_width += 2.0
    yield 1.0
    again_ahead = yield from f12()
    prefs().render_ahead = False
    # The same first F12 without render ahead: a new renderer, the layout computed again.
    scene.cubist.border_width -= 4.0
    server().shutdown()
    for f in Path(engine().layout_folder(scene.cubist)).glob("*.facets.json*"):
        f.unlink()
    yield 1.0
    cold = yield from f12()
    cold["saved_tries"] = yield from save_result(OUT / "cold.png")
    cam = scene.camera
    for frame, x in ((1, cam.location.x), (3, cam.location.x + 1.0)):
        cam.location.x = x
        cam.keyframe_insert("location", index=0, frame=frame)
    scene.frame_start, scene.frame_end = 1, 3
    scene.frame_set(1)
    scene.render.filepath = str(OUT / "anim" / "frame_####")
    engine().history.clear()
    frames = []

    def keep(*_args):
        run = engine().last_run
        frames.append({"frame": run.get("frame"), "reused": run.get("reused"), "scene": run.get("scene_load"),
                       "timings": run.get("timings"), "timeline": run.get("timeline"), "error": run.get("error")})

    bpy.app.handlers.render_post.append(keep)
    try:
        anim = yield from f12(animation=True)
    finally:
        bpy.app.handlers.render_post.remove(keep)
    anim["frames"] = frames
    anim["written"] = sorted(p.name for p in (OUT / "anim").glob("*.png"))
    cam.animation_data_clear()
    scene.frame_set(1)
    # Blender's own time on this scene and size: F12 with its Workbench engine, and with an
    # engine whose render() only fills the result with one colour (any Python engine's floor).
    own = {}
    bpy.utils.register_class(FloorEngine)
    try:
        for name in ("BLENDER_WORKBENCH", FloorEngine.bl_idname):
            scene.render.engine = name
            own[name] = []
            for _ in range(2):
                own[name].append((yield from f12())["seconds"])
    finally:
        scene.render.engine = "CUBIST"
        bpy.utils.unregister_class(FloorEngine)
    workbench, floor = own["BLENDER_WORKBENCH"], own[FloorEngine.bl_idname]
    results["steps"]["speed"] = {"first": first, "again": again, "again_ahead": again_ahead, "cold": cold,
                                 "animation": anim, "workbench": workbench, "floor": floor,
                                 "floor_render": FloorEngine.seconds}
    log(f"speed: first (rendered ahead) {first['seconds']} s, again {again['seconds']} s (with render ahead "
        f"{again_ahead['seconds']} s), without render ahead {cold['seconds']} s (preview {cold['preview_seconds']}), "
        f"Workbench {workbench} s, an engine that only fills its result {floor} s")
    yield from responsive("speed")


def step_kill_f12():
    scene = bpy.context.scene
    long_render(scene)
    client = yield from press_start()
    pid = client.pid
    os.kill(pid, signal.SIGKILL)
    t0 = time.monotonic()
    yield from wait_job(60)
    killed = {"pid": pid, "job_ended_after": round(time.monotonic() - t0, 3),
              "error": engine().last_run.get("error"), "pid_alive": alive(pid)}
    short_render(scene)
    after = yield from f12()
    results["steps"]["kill_f12"] = {"killed": killed, "next_f12": after}
    log(f"kill during F12: {killed}, next {after['error']}")
    yield from responsive("kill_f12")


def wait_viewport(predicate, timeout=120):
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        sessions = list(vp().sessions)
        if sessions and predicate(sessions[0]):
            return sessions[0]
        yield 0.05
    raise TimeoutError("the viewport did not get there")


def step_kill_viewport():
    scene = bpy.context.scene
    scene.cubist.spp = 16
    window, area, region = view3d()
    area.spaces.active.shading.type = "RENDERED"
    s = yield from wait_viewport(lambda s: s.running is not None and s.counts["requests"] >= 2)
    pid = s.client.pid
    os.kill(pid, signal.SIGKILL)
    s = yield from wait_viewport(lambda s: s.error is not None, 60)
    error = s.error
    # The next edit starts another server, and the view renders again.
    scene.cubist.spp = 1
    scene.update_tag()
    s = yield from wait_viewport(lambda s: s.error is None and s.image is not None and
                                 s.image.generation == s.generation and s.image.scale == 1.0, 120)
    recovered = {"server": s.client.pid, "generation": s.generation}
    area.spaces.active.shading.type = "SOLID"
    yield 0.5
    short_render(scene)
    after = yield from f12()
    results["steps"]["kill_viewport"] = {"pid": pid, "error": error, "pid_alive": alive(pid), "recovered": recovered,
                                         "next_f12": after}
    log(f"kill during the viewport: {error}")
    yield from responsive("kill_viewport")


def step_fifty_edits():
    """Fifty border widths in five seconds while the view renders: the last one is drawn,
    nothing queues up behind it (the server's queue stays short, sampled during the edits)."""
    scene = bpy.context.scene
    window, area, region = view3d()
    area.spaces.active.shading.type = "RENDERED"
    s = yield from wait_viewport(lambda s: s.image is not None and s.image.scale == 1.0)
    before = dict(s.counts)
    queued = []
    t0 = time.monotonic()
    # Edit i is due at t0 + 0.1 i, as a dragged slider's events come: each pass of Blender's
    # main loop (one timer call) applies every edit due by then, as the interface does with
    # the events that came during a slow redraw.
    done = 0
    while done < 50:
        due = min(50, max(done + 1, int((time.monotonic() - t0) / 0.1) + 1))
        while done < due:
            scene.cubist.border_width = 2.0 + 0.5 * done
            done += 1
        scene.update_tag()
        c = s.client
        if c is not None:
            queued.append(c.stats()["queued"])
        yield 0.1
    edits_seconds = time.monotonic() - t0
    last = scene.cubist.border_width
    s = yield from wait_viewport(lambda s: s.image is not None and s.image.generation == s.generation and
                                 s.image.scale == 1.0 and s.job.settings["border_width"] == last, 120)
    settled = time.monotonic() - t0
    served_done = s.client.stats()
    counts = {k: s.counts[k] - before.get(k, 0) for k in s.counts}
    area.spaces.active.shading.type = "SOLID"
    yield 0.5
    results["steps"]["fifty_edits"] = {"edits_seconds": round(edits_seconds, 2), "settled_after": round(settled, 2),
                                       "last": last, "drawn_width": s.job.settings["border_width"],
                                       "queued_samples": queued, "queued_after": served_done["queued"],
                                       "counts": counts, "gap": longest_gap(t0)}
    log(f"fifty edits: {results['steps']['fifty_edits']}")
    yield from responsive("fifty_edits")


def fake_binary(name, body):
    path = OUT / name
    path.write_text(body)
    path.chmod(0o755)
    return path


def f12_with_binary(path, timeout=120):
    prefs().binary_path = str(path)
    try:
        out = yield from f12(timeout=timeout)
    finally:
        prefs().binary_path = BINARY
    return out


def step_bad_binaries():
    scene = bpy.context.scene
    short_render(scene)
    # Answers `--version` and `settings` as cubist does, then never answers a request.
    sleeper = fake_binary("sleeping-cubist", f"#!/bin/sh\ncase \"$1\" in --version|settings) exec {BINARY} \"$@\";; "
                                             f"esac\nexec sleep 600\n")
    out = {}
    out["stalled"] = yield from f12_with_binary(sleeper)
    # The sleeping server was killed.
    pid = out["stalled"]["server"]
    out["stalled"]["server_alive"] = bool(pid) and alive(pid)
    # A Windows program (a PE header): not runnable here.
    other = OUT / "cubist.exe-for-windows"
    other.write_bytes(b"MZ\x90\x00" + bytes(256))
    other.chmod(0o755)
    out["other_platform"] = yield from f12_with_binary(other)
    # Not executable, and not a program either.
    text = OUT / "not-executable-cubist"
    text.write_text("not a program\n")
    text.chmod(0o644)
    out["not_executable"] = yield from f12_with_binary(text)
    out["again"] = yield from f12()
    results["steps"]["bad_binaries"] = out
    log(f"bad binaries: {[(k, v.get('error')) for k, v in out.items()]}")
    yield from responsive("bad_binaries")


def step_temp_folder():
    scene = bpy.context.scene
    short_render(scene)
    out = {}
    if TINY == "-":
        results["steps"]["temp_folder"] = {"skipped": "no tmpfs could be mounted (not root?)"}
        return
    tiny = Path(TINY)
    filler = tiny / "filler"
    try:
        with open(filler, "wb") as f:
            while True:
                f.write(bytes(1 << 16))
                f.flush()
    except OSError:
        pass
    saved = tempfile.tempdir
    tempfile.tempdir = str(tiny)
    try:
        out["full"] = yield from f12()
        out["full"]["left"] = sorted(p.name for p in tiny.iterdir())
        filler.unlink()
        subprocess.run(["mount", "-o", "remount,ro", str(tiny)], check=True)
        out["read_only"] = yield from f12()
        subprocess.run(["mount", "-o", "remount,rw", str(tiny)], check=True)
    finally:
        tempfile.tempdir = saved
    out["again"] = yield from f12()
    results["steps"]["temp_folder"] = out
    log(f"temp folder: {[(k, v.get('error')) for k, v in out.items()]}")
    yield from responsive("temp_folder")


def step_broken_layout():
    scene = bpy.context.scene
    short_render(scene)
    blend = OUT / "saved" / "scene.blend"
    blend.parent.mkdir(exist_ok=True)
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    out = {"first": (yield from f12())}
    layouts = sorted((blend.parent / "cubist").glob("*.facets.json"))
    out["layouts"] = [p.name for p in layouts]
    data = layouts[0].read_bytes()
    layouts[0].write_bytes(data[: len(data) // 2])
    out["truncated"] = yield from f12()
    out["truncated"]["layout_bytes"] = [len(data) // 2, layouts[0].stat().st_size]
    layouts[0].write_bytes(b"\x00\xffnot a layout at all" * 50)
    out["garbage"] = yield from f12()
    out["again"] = yield from f12()
    results["steps"]["broken_layout"] = out
    log(f"broken layout: {[(k, v.get('error') if isinstance(v, dict) else v) for k, v in out.items()]}")
    yield from responsive("broken_layout")


def step_new_file_during_render():
    """File > New while F12 renders: the render stops, the new file opens, nothing is left."""
    scene = bpy.context.scene
    long_render(scene)
    client = yield from press_start()
    pid = client.pid
    t0 = time.monotonic()
    bpy.ops.wm.read_homefile()
    yield from wait_job(60)
    out = {"job_ended_after": round(time.monotonic() - t0, 3), "error": engine().last_run.get("error"),
           "cancelled": engine().last_run.get("cancelled"), "server_alive": alive(pid),
           "scene": bpy.context.scene.name, "engine": bpy.context.scene.render.engine,
           "temp": sorted(p.name for p in Path(tempfile.gettempdir()).glob("cubist-*"))}
    results["steps"]["new_file"] = out
    log(f"File > New during F12: {out}")
    yield from responsive("new_file")


def step_quit_during_render():
    """Cubist again in the new file, F12, and Ctrl+Q while it renders (the test checks, after
    Blender has exited, that the renderer and every folder are gone)."""
    scene = bpy.context.scene
    scene.render.engine = "CUBIST"
    prefs().render_ahead = True  # (off since step_speed): quitting ends it too
    yield from wait_prepared()
    long_render(scene)
    client = yield from press_start()
    results["steps"]["quit"] = {"server_pid": client.pid, "server_workspace": str(client.workspace),
                                "unsaved_folder": str(engine().unsaved_folder()),
                                "temp": sorted(p.name for p in Path(tempfile.gettempdir()).glob("cubist-*"))}


# Blender 3.4's Python keeps "writes to ID data disallowed" in one process-wide flag, set
# around Python callbacks such as panels' draw; a render-thread callback can save and restore it
# while the main thread draws, and every later write to a datablock fails (blender_addon/turns.py
# makes it rare; nothing an add-on can call resets it). The driver then stops, and the test runs
# the steps left, the stuck one first, in a new Blender.
WRITE_LOCK = "Writing to ID classes in this context is not allowed"


def main():
    yield from setup()
    steps = (step_speed, step_kill_f12, step_kill_viewport, step_fifty_edits, step_bad_binaries, step_temp_folder,
             step_broken_layout, step_new_file_during_render, step_quit_during_render)
    # The steps to run (all by default): the test's rerun after a stuck write flag, or a few
    # steps alone when working on them.
    only = (ARGS[4] if len(ARGS) > 4 and ARGS[4] else None) or os.environ.get("CUBIST_HOST_STEPS")
    todo = [s for s in steps if not only or s.__name__ in only.split(",")]
    for index, step in enumerate(todo):
        log(f"step {step.__name__}")
        t0 = time.monotonic()
        try:
            yield from step()
        except Exception as e:  # noqa: BLE001 - only the stuck write flag is handed back
            if WRITE_LOCK not in str(e):
                raise
            results["write_lock"] = {"step": step.__name__, "error": str(e)}
            results["remaining"] = [s.__name__ for s in todo[index:]]
            log(f"Blender's write flag is stuck at {step.__name__}: {e}")
            while bpy.app.is_job_running("RENDER"):
                yield 0.1
            write_results()
            return
        results.setdefault("step_seconds", {})[step.__name__] = round(time.monotonic() - t0, 1)
        write_results()  # as far as it got, should a later step hang
    results["heartbeat"] = {"ticks": len(heartbeat), "longest_gap": longest_gap(0.0)[0]}
    results["done"] = True


def write_results():
    (OUT / "results.json").write_text(json.dumps(results, indent=1, default=str))


def override():
    window, area, region = view3d()
    return {"window": window, "screen": window.screen, "area": area, "region": region}


# A render may still run at the end (the last step): Ctrl+Q, as a user quits (user_input.py).
stepper.run(main, results, write_results, log, stepper.quit_by_keys(override, log, fallback_after=30.0),
            persistent=True)
