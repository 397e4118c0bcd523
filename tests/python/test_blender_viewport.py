"""The Cubist viewport in Blender's interactive UI: a windowed Blender (Debian's
3.4.1) under Xvfb, driven by tests/blender_ui/viewport_driver.py as a user would: Rendered
shading in the factory scene's 3D view, a panel value changed, looking through the camera, F12
with the scene unchanged, back to Solid, a binary that does not exist, and quitting Blender
while a view renders.

What is checked: the pixels `view_draw` puts on the screen (read back from the framebuffer)
are the server's image; that image is what `cubist render` paints from the same exported
scene and settings; 1/4, 1/2 and full size are rendered in turn and drawn in that order; a panel change re-runs paint
only, on the same server; the camera view renders the scene camera at the render's size; F12
renders on the viewport's server; leaving Rendered shading and quitting Blender end the
server and remove its folder; an error is drawn as text; the main thread is held briefly.

Responsiveness: Blender's own timers (`bpy.app.timers`) run once per pass of its main loop
(events, notifiers, drawing), so the gaps between a 20 ms heartbeat's ticks are how long the
interface went without handling events. Once Blender's start-up draws are over, an idle
Blender ticks every 20-25 ms; one redraw of the 3D view (measured in the same run) is the
floor of any stall. Bounded: the median gap in each phase (Rendered shading, a panel value
dragged, the camera view, F12), the longest gap against that redraw cost plus our own
`view_update` and `view_draw`, and which views redraw.

Needs `blender`, `xvfb-run` and `xdotool` on PATH (.ci/run installs them); without them every
test here is skipped, saying why (CUBIST_REQUIRE_UI_TEST=1 makes that a failure)."""

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from addon_support import BINARY, ROOT, cubist_binary, require_windowed_blender, run_windowed_blender  # noqa: F401

DRIVER = ROOT / "tests" / "blender_ui" / "viewport_driver.py"
TOOLS = ("blender", "xvfb-run")


def alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    # A zombie (exited, not reaped) is gone for our purposes.
    try:
        return Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0] != "Z"
    except OSError:
        return False


def drawn_as(draw, expected, magnified: bool) -> bool:
    """The framebuffer's pixel at the rect's centre is the image's there (a rounding step),
    or, for an image drawn magnified (filtered), within its neighbours' range."""
    nearest, low, high = (np.array(e[:3]) for e in expected)
    got = np.array(draw["readback"][:3])
    if not magnified:
        return bool(np.abs(got - nearest).max() <= 2.5 / 255)
    return bool((got >= low - 2.5 / 255).all() and (got <= high + 2.5 / 255).all())


@pytest.fixture(scope="module")
def ui(cubist_binary, tmp_path_factory):
    require_windowed_blender(TOOLS, "windowed Blender viewport test", "apt-get install blender xvfb xauth")
    return run_windowed_blender(DRIVER, tmp_path_factory.mktemp("blender_viewport"), cubist_binary, " (viewport)")


def test_viewport_blender_runs_every_step_without_crashing(ui):
    r = ui["results"]
    assert r["background"] is False, "the driver must run in Blender's interface, not background mode"
    assert "failure" not in r, r.get("failure")
    assert r["done"], ui["log"][-3000:]
    assert ui["proc"].returncode == 0, ui["log"][-3000:]
    assert "Segmentation fault" not in ui["log"] and "Writing: " not in ui["log"]  # Blender's crash report
    assert "Fatal Python error" not in ui["log"], ui["log"][-3000:]  # PYTHONMALLOC=debug: no GIL misuse


def test_rendered_shading_draws_cubist_pixels_progressively(ui):
    r, out = ui["results"]["rendered"], ui["out"]
    region = r["region"]
    draw = r["draw"]
    # The view matrix's picture (no camera view yet), the region's size, the whole region.
    assert r["through_camera"] is False
    assert draw["image"] == region and draw["rect"] == [0, 0, *region], draw
    # Progressive: the job's images came 1/4, 1/2 then full size, and the screen showed them in
    # that order, a preview before the full image. A redraw draws the newest image, so on a busy
    # machine a preview that a finer one overtook before the next redraw is rightly never drawn.
    job = draw["generation"]
    assert [h[1] for h in r["history"] if h[0] == job] == [0.25, 0.5, 1.0], r["history"]
    drawn = [scale for i, scale in enumerate(r["scales_drawn"]) if i == 0 or scale != r["scales_drawn"][i - 1]]
    assert drawn == sorted(set(drawn)) and drawn[-1] == 1.0 and len(drawn) >= 2, r["scales_drawn"]
    # On the screen: the framebuffer pixel at the rect's centre is the image's, drawn
    # scene-linear (Blender's view transform shows it as the image's sRGB; a rounding step).
    assert drawn_as(draw, r["expected_centre"], magnified=False), r
    # The image is what `cubist render` paints from the exported scene and settings.
    generation, scale, job = r["saved_image"]
    assert (generation, scale) == (draw["generation"], 1.0) and job == generation, r["saved_image"]
    image = np.load(out / "rendered" / "image.npy").astype(np.int32)
    assert list(image.shape) == [region[1], region[0], 4]
    settings = json.loads((out / "rendered" / "settings.json").read_text())
    png = out / "rendered" / "cli.png"
    cli = subprocess.run([str(BINARY), "render", str(out / "rendered" / "scene.glb"), "-o", str(png),
                          "--config", str(out / "rendered" / "settings.json")], capture_output=True, text=True)
    assert cli.returncode == 0, cli.stderr
    sys.path.insert(0, str(ROOT / "blender_addon"))
    import pngio

    expected = pngio.read(png).astype(np.int32)
    assert (settings["width"], settings["height"]) == tuple(region)
    assert np.abs(image - expected).max() == 0, f"{np.abs(image - expected).max()}/255"
    assert len(np.unique(image[..., :3].reshape(-1, 3), axis=0)) > 30  # a painting, not a blank
    print(f"\nviewport {region[0]}x{region[1]}: first full image in {r['seconds']:.1f} s; images (job, scale, "
          f"seconds): {[(h[0], h[1], round(h[2], 2)) for h in r['history'][:3]]}", file=sys.stderr)


def test_a_panel_change_reruns_paint_only_on_the_same_server(ui):
    p = ui["results"]["panel_change"]
    assert p["border_width_sent"] == 25.0 and p["same_server"], p
    assert drawn_as(p["draw"], p["expected_centre"], magnified=False), p
    job = p["draw"]["generation"]
    images = [h for h in p["history"] if h[0] == job]
    assert [h[1] for h in images] == [0.25, 0.5, 1.0], images
    for _, scale, _, reused in images:
        # Each size kept its own pre-render, saliency and layout from the first view.
        assert {"pre-render", "saliency", "faceting"} <= set(reused), (scale, reused)
    print(f"\npanel change: images {[(h[1], round(h[2], 3)) for h in images]} s after it", file=sys.stderr)


def test_the_camera_view_renders_the_scene_camera_at_the_render_size(ui):
    c = ui["results"]["camera_view"]
    assert c["through_camera"] is True and c["size"] == [200, 150], c
    assert c["draw"]["image"] == [200, 150]
    # Drawn over the whole camera frame, whatever its size on screen (not in a corner of it).
    x, y, w, h = c["draw"]["rect"]
    assert w >= 200 and abs(w / h - 200 / 150) < 0.03, c["draw"]
    assert drawn_as(c["draw"], c["expected_centre"], magnified=True), c


def test_f12_renders_on_the_server_the_viewport_uses(ui):
    f = ui["results"]["f12"]
    assert f["operator"] == ["RUNNING_MODAL"] and f["error"] is None and f["saved"], f
    assert f["server"] == f["viewport_server"], f
    assert f["served_after"] == f["served_before"] + 2, f  # the preview, then the picture


def test_leaving_rendered_shading_ends_the_session_and_quitting_the_server(ui):
    s = ui["results"]["solid"]
    # The view's session and folder end; the session-wide server stays for F12 and other views.
    assert s == {**s, "server_alive": True, "sessions": 0, "workspace_exists": False}, s
    q = ui["results"]["at_quit"]
    assert q["workspace_exists"] and Path(q["workspace"]).name in q["temp"], q  # it was there
    # Blender has exited: the server it left running at quit ends with it (at exit, or by
    # seeing its parent gone within a second).
    deadline = time.monotonic() + 5
    while alive(q["server_pid"]) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not alive(q["server_pid"]), f"cubist serve {q['server_pid']} outlived Blender"
    assert not Path(q["workspace"]).exists()
    # Nothing of the add-on's is left: no server folder, no unsaved-file folder (Ctrl+Q
    # disables the add-on before Python's exit handlers run).
    assert sorted(p.name for p in ui["tmp"].glob("cubist-*")) == []


def test_an_error_is_drawn_as_text(ui):
    texts = ui["results"]["error_text"]
    assert texts and any("not found" in line for line in texts[0]), texts


def percentile(values, q):
    return float(np.percentile(np.array(values, dtype=np.float64), q)) if values else float("nan")


def test_the_main_thread_is_held_briefly_and_keeps_running_while_the_server_renders(ui):
    r = ui["results"]
    main = r["panel_change"]["main_thread"]  # the longest of the whole session so far
    # The export (view_update) and the texture upload (view_draw) are the main thread's part.
    assert main["longest_view_update"] < 1.0 and main["longest_view_draw"] < 1.0, main
    # The main loop ran between Rendered shading starting and the full image (a heartbeat every
    # 20 ms; a main thread held by the render would give one or two ticks, one gap spanning it).
    # How many depends on how long the server takes: 4 on a loaded 2-core machine when the
    # server answers in about a second, 17 on a quiet one with a slower render. So: at least
    # three ticks here; how long a stall may be is the next test's question.
    longest_gap, ticks = r["rendered"]["gap"]
    assert ticks >= 3, r["rendered"]["gap"]


def test_blender_stays_responsive_in_rendered_shading_panel_changes_and_f12(ui):
    """Blender's own responsiveness: a 20 ms `bpy.app.timers` heartbeat runs from Blender's main
    loop, once per pass of it, so the gaps between its ticks are how long the interface went
    without handling events. They are compared with what one plain redraw of the 3D view costs
    Blender in this very run (measured in Solid shading before: its own drawing, software OpenGL
    under Xvfb, 0.1-0.9 s on a loaded 2-core machine), which any viewport that shows a new
    image must pay once per image. A viewport that blocked (waiting for the server, exporting
    or decoding on the main thread) would show stalls beyond that floor, or many of them."""
    r = ui["results"]
    idle = r["idle"]["gaps"]
    redraw = r["redraw_baseline"]["gaps"]
    workbench = r["workbench_f12"]["gaps"]
    main = r["panel_change"]["main_thread"]
    ours = main["longest_view_update"] + main["longest_view_draw"]
    phases = {name: r[name]["gaps"] for name in ("rendered", "panel_change", "object_moved", "camera_view", "f12")}
    rows = []
    for name, gaps in {"idle (Solid)": idle, "redraw (Solid)": redraw, "F12 Workbench": workbench, **phases}.items():
        stalled = sum(g for g in gaps if g > 0.1)
        rows.append(f"{name}: {len(gaps)} gaps, median {percentile(gaps, 50) * 1000:.0f} ms, p90 "
                    f"{percentile(gaps, 90) * 1000:.0f} ms, p95 {percentile(gaps, 95) * 1000:.0f} ms, max "
                    f"{max(gaps, default=0) * 1000:.0f} ms, stalled (gaps > 0.1 s) {stalled:.2f} of {sum(gaps):.2f} s")
    moved = r["object_moved"]
    print("\nBlender's main loop (heartbeat gaps):\n  " + "\n  ".join(rows) +
          f"\n  our longest view_update + view_draw: {ours * 1000:.0f} ms" +
          f"\n  object moved: view_update {moved['main_thread'].get('longest_view_update', 0) * 1000:.0f} ms, "
          f"scene written on the worker in {moved['worker'].get('longest_scene_write', 0) * 1000:.0f} ms",
          file=sys.stderr)
    # The object moved: the main thread only read the scene; the worker wrote it.
    assert moved["worker"].get("longest_scene_write", 0) > 0, moved
    assert moved["counts"]["exports"] == 2, moved["counts"]
    # Idle, the loop runs at the heartbeat's own rate (the baseline is sound).
    assert percentile(idle, 50) < 0.05 and max(idle) < 0.25, idle
    for name, gaps in phases.items():
        assert len(gaps) >= 1, (name, gaps)  # a short phase under load may be one long pass
        # The floor: one redraw of the view; for F12, what F12 with Blender's Workbench costs.
        floor = max(max(redraw), max(workbench) if name == "f12" else 0.0)
        # No stall beyond that floor plus our own main-thread work, with a margin for a loaded
        # machine (another process's burst between the two measurements).
        bound = 1.5 * floor + ours + 0.5
        assert max(gaps) <= bound, (name, max(gaps), bound, floor, ours)
        if name != "f12":
            # Every stall is a redraw of a 3D view (the images' redraws): the time the loop was
            # held beyond its idle rate is at most one redraw (plus our part) per view drawn.
            draws = r[name]["draws"]
            stalled = sum(g for g in gaps if g > 0.1)
            assert stalled <= draws * (1.5 * max(redraw) + ours) + 1.0, (name, stalled, draws, gaps)
    # F12 keeps the interface going as F12 with Workbench does.
    assert percentile(phases["f12"], 50) <= 1.5 * percentile(workbench, 50) + 0.05, (phases["f12"], workbench)
    # The rendered view's images (1/4, 1/2, full) redraw the view that shows them: the viewport
    # tags that view alone, never the other 3D view (Solid shading), as a redraw is the costly
    # part. (The other view still draws a few times meanwhile, on Blender's own notifiers.)
    draws = r["view_draws"]
    assert draws["rendered"] >= 3, draws
    assert r["tagged"] and all(t == [r["rendered_view"]] for t in r["tagged"]), (r["tagged"], r["rendered_view"])
