"""Render ahead of F12 (blender_addon/ahead.py) in headless Blender (bpy 5.0.1): F12's job
prepared on the session's renderer from the main thread's read of the scene, F12 then finding
every stage kept and skipping its preview, the same picture as without it, an edit cancelling
the prepare in flight, and nothing done for a scene whose engine is not Cubist or with the
preference off.

Headless Blender runs no timers, so the tests call `ahead.prepare` where the idle timer would;
the windowed host test (tests/python/test_blender_host.py) presses F12 after a real idle wait."""

import sys
import time
from pathlib import Path

import numpy as np
import pytest

from addon_support import addon, bpy, bpy_module, cubist_binary, new_scene, read_png  # noqa: F401

STAGES = ["pre-render", "saliency", "faceting", "imprecision", "re-trace", "anti-aliasing", "paint"]


@pytest.fixture
def ahead(addon):
    mod = sys.modules["blender_addon.ahead"]
    yield mod
    mod.forget()
    prefs().render_ahead = True


def prefs():
    import bpy

    return bpy.context.preferences.addons["blender_addon"].preferences


def engine():
    return sys.modules["blender_addon.engine"]


def server():
    return sys.modules["blender_addon.server"]


def wait_done(p, timeout=120):
    assert p is not None
    assert p.done.wait(timeout), f"the prepare did not end within {timeout} s"
    return p


def f12(bpy, scene, path: Path):
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)
    run = engine().last_run
    assert run.get("error") is None, run
    return dict(run)


def layouts(scene):
    folder = engine().layout_folder(scene.cubist)
    return sorted(folder.glob("*.facets.json")) if folder.is_dir() else []


def test_f12_uses_the_prepared_job_and_paints_the_same_picture(bpy, ahead, tmp_path):
    scene = new_scene(bpy, 160, 120)
    for f in layouts(scene):
        f.unlink()
    p = wait_done(ahead.prepare(scene))
    assert p.ok and p.skipped is None, (p.skipped, p.reply)
    assert p.rect is not None and p.rect.shape == (120, 160, 4)
    # The prepare saved nothing beside the scene's layout folder: F12 saves the layout.
    assert layouts(scene) == []
    served = server().current().stats()["served"]
    ready = f12(bpy, scene, tmp_path / "ahead.png")
    assert ready["ahead"] == "ready" and ready["preview"] is False and ready.get("ahead_picture"), ready
    # Every stage kept: one request, nothing computed again.
    assert server().current().stats()["served"] == served + 1
    assert not set(STAGES) & set(ready["timings"]) and "pre-render" in ready["reused"], ready["timings"]
    assert len(layouts(scene)) == 1  # F12's own save_facets, served from the kept layout

    # Without render ahead, on a new renderer that keeps nothing, the layout computed again:
    # the same pixels (the PNGs differ only in Blender's date stamp).
    prefs().render_ahead = False
    server().shutdown()
    for f in layouts(scene):
        f.unlink()
    cold = f12(bpy, scene, tmp_path / "cold.png")
    assert cold["ahead"] is None and cold["reused"] == [] and cold["preview"] is True, cold
    a, b = read_png(bpy, tmp_path / "ahead.png"), read_png(bpy, tmp_path / "cold.png")
    assert np.array_equal(a, b)


def test_an_edit_cancels_the_prepare_and_the_last_edit_wins(bpy, ahead, tmp_path):
    scene = new_scene(bpy, 1280, 960)  # a long render: 64 samples in every pixel
    scene.cubist.spp = 64
    scene.cubist.aa_threshold = 0.0
    bpy.context.evaluated_depsgraph_get()
    p = ahead.prepare(scene)
    assert p is not None
    client = server().current() or server().client(sys.modules["blender_addon.viewport"]._binary())
    t0 = time.monotonic()
    while client.stats()["running"] is None and time.monotonic() - t0 < 30:
        time.sleep(0.02)
    # An edit: Blender's depsgraph update handler cancels the prepare in flight.
    bpy.data.objects["Cube"].location.x += 0.3
    bpy.context.view_layer.update()
    assert p.cancelled.is_set() and not p.ok
    assert p.pending.wait(30)["cancelled"] is True
    stats = client.stats()
    assert stats["running"] is None and stats["queued"] == 0, stats
    # Smaller, and still: the next still moment prepares the edited scene; F12 finds it.
    scene.render.resolution_x, scene.render.resolution_y = 320, 240
    scene.cubist.spp = 1
    bpy.context.view_layer.update()
    q = wait_done(ahead.prepare(scene))
    assert q is not p and q.ok and q.key != p.key, (q.skipped, q.reply)
    ready = f12(bpy, scene, tmp_path / "edited.png")
    assert ready["ahead"] == "ready" and not set(STAGES) & set(ready["timings"]), ready
    # A panel change: F12's job differs from the prepared one, which is not used.
    scene.cubist.border_width += 1.0
    changed = f12(bpy, scene, tmp_path / "changed.png")
    assert changed["ahead"] is None and "pre-render" in changed["reused"], changed


def test_nothing_is_prepared_without_the_cubist_engine_or_with_the_preference_off(bpy, ahead):
    server().shutdown()
    started = server().started
    scene = new_scene(bpy, 64, 48, engine="BLENDER_WORKBENCH")
    assert ahead.prepare(scene) is None and "not Cubist" in ahead.last_skip
    scene.render.engine = "CUBIST"
    prefs().render_ahead = False
    assert ahead.prepare(scene) is None
    # No renderer was started for either.
    assert server().current() is None and server().started == started
    prefs().render_ahead = True
    p = wait_done(ahead.prepare(scene))
    assert p.ok and server().started == started + 1


def test_the_same_scene_and_settings_are_not_sent_twice(bpy, ahead):
    scene = new_scene(bpy, 64, 48)
    p = wait_done(ahead.prepare(scene))
    sent = ahead.counts["sent"]
    # An update that changes nothing F12 reads (a selection).
    bpy.data.objects["Cube"].select_set(not bpy.data.objects["Cube"].select_get())
    bpy.context.view_layer.update()
    q = wait_done(ahead.prepare(scene))
    assert q is not p and q.ok and q.key == p.key and ahead.counts["sent"] == sent


def test_f12_waits_for_its_job_under_way_and_esc_stops_both(bpy, ahead, tmp_path):
    scene = new_scene(bpy, 1280, 960)  # a long render: 64 samples in every pixel
    scene.cubist.spp = 64
    scene.cubist.aa_threshold = 0.0
    scene.render.filepath = str(tmp_path / "esc.png")  # (an edit: it would cancel the prepare)
    bpy.context.view_layer.update()
    p = ahead.prepare(scene)
    t0 = time.monotonic()
    while p.pending is None and time.monotonic() - t0 < 30:
        time.sleep(0.02)
    seen = []

    def esc():  # Esc half a second into F12 (the engine's test seam for test_break)
        seen.append(time.monotonic())
        return time.monotonic() - seen[0] > 0.5

    engine().cancel_hook = esc
    try:
        bpy.ops.render.render(write_still=True)
    finally:
        engine().cancel_hook = None
    run = engine().last_run
    # F12 found its own job under way (no second request computing it), and Esc stopped both.
    assert run["ahead"] == "running" and run.get("cancelled") and run.get("error") is None, run
    assert p.cancelled.is_set() and p.pending.wait(30)["cancelled"] is True
    stats = server().current().stats()
    assert stats["running"] is None and stats["queued"] == 0, stats
    # The job the user stopped is not sent again behind their back, until the next edit.
    sent = ahead.counts["sent"]
    assert ahead.prepare(scene) is None and "cancelled" in ahead.last_skip
    bpy.data.objects["Cube"].location.x += 0.3
    scene.cubist.spp = 1
    bpy.context.view_layer.update()
    q = ahead.prepare(scene)
    assert q is not None, ahead.last_skip
    assert wait_done(q).ok and ahead.counts["sent"] == sent + 1


def test_a_saved_files_folder_is_made_by_f12_not_by_the_prepare(bpy, ahead, tmp_path):
    scene = new_scene(bpy, 96, 72)
    blend = tmp_path / "shot.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    scene = bpy.context.scene
    p = wait_done(ahead.prepare(scene))
    # Nothing beside the .blend (the prepare leaves the saliency cache out there), yet F12,
    # which caches into a folder it makes, finds its job.
    assert p.ok and not (tmp_path / "cubist").exists(), p.skipped
    ready = f12(bpy, scene, tmp_path / "saved.png")
    assert ready["ahead"] == "ready" and not set(STAGES) & set(ready["timings"]), ready
    assert (tmp_path / "cubist").is_dir() and len(layouts(scene)) == 1
