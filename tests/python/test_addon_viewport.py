"""The viewport's path in headless Blender (bpy 5.0.1): what `view_update` does with a
depsgraph (export when the content changed, settings from the panel and the view, a job to
the session-wide `cubist serve`), the progressive images (1/4, 1/2, full) and their pixels
against `cubist render` of the same exported scene and settings, a panel change re-running only
paint, F12 on the same server as the viewport, and every session ended on a file load and when
the add-on is disabled (the server too when the add-on is).

Not here: drawing. Headless Blender has no GPU context for Python ("GPU functions for drawing
are not available in background mode"; an EEVEE render, which would make one, fails to get an
EGL context on this machine's Mesa), so `view_draw` and the texture upload are checked in the
windowed Blender (tests/python/test_blender_viewport.py); the pixels the texture gets are
checked here (`gpu_pixels`)."""

import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from addon_support import BINARY, addon, bpy, bpy_module, cubist_binary, new_scene, read_png  # noqa: F401


@pytest.fixture
def vp(addon):
    mod = sys.modules["blender_addon.viewport"]
    yield mod
    mod.close_all(wait=True)


def export_mod():
    return sys.modules["blender_addon.export"]


def camera_view(bpy, scene, width, height):
    """The View of a 3D view looking through the scene camera, at this size."""
    vp = sys.modules["blender_addon.viewport"]
    dg = bpy.context.evaluated_depsgraph_get()
    cam = export_mod().scene_camera(dg)
    return vp.View(width, height, export_mod().camera_facts(cam), through_camera=True)


def wait_for(session, generation, scale=1.0, timeout=120):
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        img = session.image
        if img is not None and img.generation == generation and img.scale == scale:
            return img
        if session.error:
            raise AssertionError(session.error)
        time.sleep(0.02)
    raise AssertionError(f"no image of job {generation} at {scale} within {timeout} s: {session.counts}")


def cli_pixels(tmp_path, glb, settings, name):
    cfg = tmp_path / f"{name}.json"
    cfg.write_text(json.dumps(settings))
    out = tmp_path / f"{name}.png"
    r = subprocess.run([str(BINARY), "render", str(glb), "-o", str(out), "--config", str(cfg)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "blender_addon"))
    import pngio

    return pngio.read(out)


def test_view_update_renders_progressively_what_cubist_render_paints(bpy, vp, tmp_path):
    scene = new_scene(bpy, 120, 90)
    session = vp.ViewportSession(vp._binary())
    dg = bpy.context.evaluated_depsgraph_get()
    view = camera_view(bpy, scene, 120, 90)
    assert vp.update(session, dg, view, True)
    full = wait_for(session, session.generation)
    assert [h[1] for h in session.history] == [0.25, 0.5, 1.0]
    assert (full.width, full.height) == (120, 90)
    # Each pass is `cubist render` of the exported scene with the pass's settings.
    glb = tmp_path / "view.glb"
    glb.write_bytes(session.scene_path.read_bytes())
    settings = vp.settings_for(scene, view)
    assert np.array_equal(full.pixels, cli_pixels(tmp_path, glb, settings, "full"))
    quarter = vp.scaled(settings, 0.25)
    assert (quarter["width"], quarter["height"], quarter["spp"]) == (30, 22, 1)
    # Nothing changed: no new job.
    assert not vp.update(session, dg, view, False)
    assert session.counts["jobs"] == 1 and session.counts["exports"] == 1

    # A panel change: a new job, the scene not exported again, and only paint runs (at every
    # size: each kept its own outputs).
    scene.cubist.border_width = 3.0
    dg = bpy.context.evaluated_depsgraph_get()
    assert vp.update(session, dg, view, False)
    full = wait_for(session, session.generation)
    assert session.counts["exports"] == 1
    for gen, scale, _seconds, reused in session.history[3:]:
        assert reused[:5] == ["pre-render", "saliency", "faceting", "imprecision", "re-trace"], (scale, reused)
    settings = vp.settings_for(scene, view)
    assert settings["border_width"] == 3.0
    assert np.array_equal(full.pixels, cli_pixels(tmp_path, glb, settings, "border"))

    # The object moved: exported again, rendered again.
    bpy.data.objects["Cube"].location.x += 0.3
    dg = bpy.context.evaluated_depsgraph_get()
    dg.update()
    assert vp.update(session, dg, view, True)
    wait_for(session, session.generation)
    assert session.counts["exports"] == 2
    client = session.client
    session.close(wait=True)
    # The session's folder goes; the session-wide server stays for F12 and other views.
    assert not session.workspace.exists() and client.alive()


def test_a_newer_job_cancels_the_running_request(bpy, vp):
    scene = new_scene(bpy, 64, 48)
    session = vp.ViewportSession(vp._binary())
    dg = bpy.context.evaluated_depsgraph_get()
    # A long first job (many samples at full size), then a change while it runs.
    scene.cubist.spp = 64
    big = camera_view(bpy, scene, 900, 700)
    vp.update(session, dg, big, True)
    t0 = time.monotonic()
    while session.counts["requests"] < 3 and time.monotonic() - t0 < 60:
        time.sleep(0.01)
    scene.cubist.spp = 1
    small = camera_view(bpy, scene, 64, 48)
    vp.update(session, bpy.context.evaluated_depsgraph_get(), small, False)
    wait_for(session, session.generation)
    assert session.counts["cancelled"] >= 1, session.counts
    assert [h[0] for h in session.history].count(1) < 3  # the first job never finished
    session.close(wait=True)


def test_the_worker_writes_the_scene_read_on_the_main_thread(bpy, vp):
    """`view_update` only reads the scene (export.read_scene); the worker writes the file before
    its first request. An export superseded by a newer scene read stops and writes nothing; a
    failed one is shown as the view's error."""
    scene = new_scene(bpy, 64, 48)
    session = vp.ViewportSession(vp._binary())
    dg = bpy.context.evaluated_depsgraph_get()
    view = camera_view(bpy, scene, 64, 48)
    settings = vp.settings_for(scene, view)
    old, new = (vp.SceneExport(n, export_mod().read_scene(dg)) for n in (1, 2))
    with session.cond:  # the newest job (the worker is not told: it stays asleep)
        session.job = vp.Job(2, session.scene_path, settings, view, new)
    assert not session._write_scene(vp.Job(1, session.scene_path, settings, view, old))
    assert not old.written and not session.scene_path.exists()

    def broken(path, should_cancel):
        raise OSError("No space left on device")

    new.exporter.write = broken
    assert not session._write_scene(session.job)
    assert session.error == "export failed: OSError: No space left on device" and not new.written

    # The whole path: the file is written by the worker, then rendered.
    assert vp.update(session, dg, view, True)
    assert session.export.number == 1
    wait_for(session, session.generation)
    assert session.export.written and session.export.exporter is None
    whole = session.scene_path.with_name("whole.glb")
    export_mod().export_glb(bpy.context.evaluated_depsgraph_get(), whole)
    assert whole.read_bytes() == session.scene_path.read_bytes()
    session.close(wait=True)


def test_views_not_through_a_camera_use_the_view_matrix(bpy, vp):
    from mathutils import Matrix

    # A view 5 units up +Z looking down -Z (Blender's top view), perspective, 50 mm.
    view_matrix = Matrix.Translation((0.0, 0.0, -5.0))
    facts = vp.view_camera_facts(view_matrix, True, 50.0, 5.0)
    assert facts.position() == pytest.approx([0.0, 0.0, 5.0])
    assert facts.forward() == pytest.approx([0.0, 0.0, -1.0])
    # Blender draws the viewport with a 72 mm sensor: 50 mm lens -> ~71.5 deg horizontally.
    assert facts.vertical_fov_deg(400, 400) == pytest.approx(71.50, abs=0.01)
    ortho = vp.view_camera_facts(view_matrix, False, 50.0, 5.0)
    assert ortho.type == "ORTHO" and ortho.ortho_scale == pytest.approx(7.2)
    scene = new_scene(bpy, 64, 48)
    settings = vp.settings_for(scene, vp.View(200, 100, facts))
    assert settings["camera_position"] == pytest.approx([0.0, 5.0, 0.0])  # glTF is Y-up
    assert (settings["width"], settings["height"], settings["passes"]) == (200, 100, [])


def test_content_changed_tells_panel_changes_from_scene_changes(bpy, vp):
    """Only updates beyond the scene datablock (where the panel's values and the render
    settings live) export the scene again. (Headless Blender sends no depsgraph update for a
    property set from Python; in the interface view_draw picks panel changes up anyway.)"""
    from types import SimpleNamespace

    scene = new_scene(bpy, 64, 48)
    seen = []

    def handler(scene_, depsgraph):
        seen.append(vp.content_changed(depsgraph))

    bpy.app.handlers.depsgraph_update_post.append(handler)
    try:
        bpy.context.view_layer.update()
        seen.clear()
        bpy.data.objects["Cube"].location.z += 0.1
        bpy.context.view_layer.update()
        moved = list(seen)
        seen.clear()
        scene.world.color = (0.1, 0.2, 0.3)
        bpy.context.view_layer.update()
        world = list(seen)
    finally:
        bpy.app.handlers.depsgraph_update_post.remove(handler)
    assert moved == [True] and world == [True], (moved, world)
    assert vp.content_changed(SimpleNamespace(updates=[SimpleNamespace(id=scene)])) is False


def test_f12_renders_on_the_server_the_viewport_uses(bpy, vp, tmp_path):
    engine = sys.modules["blender_addon.engine"]
    scene = new_scene(bpy, 64, 48)
    session = vp.ViewportSession(vp._binary())
    vp.update(session, bpy.context.evaluated_depsgraph_get(), camera_view(bpy, scene, 64, 48), True)
    wait_for(session, session.generation)
    client = session.client
    engine.keep_exports = tmp_path / "exports"
    try:
        scene.render.filepath = str(tmp_path / "f12.png")
        served = client.stats()["served"]
        bpy.ops.render.render(write_still=True)
        assert engine.last_run.get("error") is None, engine.last_run
        assert engine.last_run.get("server") == client.pid
        # Background F12 is an F12: a preview, then the picture.
        assert client.stats()["served"] == served + 2
        # The picture is `cubist render`'s of what F12 exported.
        glb = tmp_path / "exports" / f"frame_{scene.frame_current:04d}.glb"
        f12 = read_png(bpy, tmp_path / "f12.png")
        cli = cli_pixels(tmp_path, glb, json.loads(engine.last_run["settings_json"]), "cli")
        assert np.abs(f12 * 255 - cli[::-1]).max() <= 1.0
        # A changed scene: the same server loads it.
        bpy.data.objects["Cube"].location.x += 0.5
        bpy.ops.render.render(write_still=True)
        assert engine.last_run.get("server") == client.pid and engine.last_run.get("error") is None
        assert client.stats()["served"] == served + 4
    finally:
        engine.keep_exports = None
    session.close(wait=True)


def test_sessions_end_on_file_load_and_when_the_addon_is_disabled(bpy, vp):
    import addon_utils

    scene = new_scene(bpy, 64, 48)
    a = vp.ViewportSession(vp._binary())
    vp.update(a, bpy.context.evaluated_depsgraph_get(), camera_view(bpy, scene, 64, 48), True)
    wait_for(a, a.generation)
    new_scene(bpy, 64, 48)  # loads the factory home file: load_pre
    assert a.closed and a not in vp.sessions
    a.thread.join(10)
    assert not a.workspace.exists()
    b = vp.ViewportSession(vp._binary())
    client = b.client
    addon_utils.disable("blender_addon", default_set=True)
    try:
        # Disabling the add-on ends the sessions and the session-wide server, and their folders.
        assert b.closed and not b.workspace.exists()
        assert client.proc.poll() is not None and not client.workspace.exists()
    finally:
        addon_utils.enable("blender_addon", default_set=True, persistent=True)
        bpy.context.preferences.addons["blender_addon"].preferences.binary_path = str(BINARY)


def test_blenders_quit_waits_for_sessions_being_closed(bpy, vp):
    """A view left Rendered shading (its engine freed) just before Blender quits: its session
    is being ended by its worker thread, which the exit would cut short. Ctrl+Q disables every
    add-on before Python's exit handlers run (the windowed test found a folder left behind):
    unregistering waits for that thread, so the folder goes, and ends the server."""
    import addon_utils

    scene = new_scene(bpy, 64, 48)
    s = vp.ViewportSession(vp._binary())
    vp.update(s, bpy.context.evaluated_depsgraph_get(), camera_view(bpy, scene, 64, 48), True)
    wait_for(s, s.generation)
    client = s.client
    s.close()  # as the engine's __del__ does: without waiting
    assert vp.ending == {s} or not s.workspace.exists()
    addon_utils.disable("blender_addon", default_set=True)
    try:
        assert vp.ending == set() and not s.workspace.exists()
        assert client.proc.poll() is not None and not client.workspace.exists()
    finally:
        addon_utils.enable("blender_addon", default_set=True, persistent=True)
        bpy.context.preferences.addons["blender_addon"].preferences.binary_path = str(BINARY)


def test_texture_pixels_are_bottom_up_and_premultiplied(vp):
    px = np.zeros((2, 3, 4), np.uint8)
    px[0, 0] = (255, 0, 0, 255)  # top left, opaque red
    px[1, 2] = (255, 255, 255, 51)  # bottom right, white at 20%
    flat = vp.gpu_pixels(px).reshape(2, 3, 4)
    assert flat[1, 0].tolist() == [1.0, 0.0, 0.0, 1.0]
    assert flat[0, 2] == pytest.approx([0.2, 0.2, 0.2, 0.2])
