"""The add-on in Blender's interactive UI, where F12 runs render() on the render-job thread:
a windowed Blender (Debian's 3.4.1) under Xvfb, driven by tests/blender_ui/driver.py
as a user: F12 with Lock Interface off and on, Render Animation with a moving camera and cube
(static facets, then facets that follow and F12 on one frame alone), a frame away from the
facet layout's frame, Esc during a render, colour management.

Needs `blender`, `xvfb-run` and `xdotool` on PATH (`.ci/run` installs them: apt-get install
blender xvfb xauth xdotool python3-numpy); without them every test here is skipped, saying why."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from addon_support import BINARY, ROOT, cubist_binary, require_windowed_blender, run_windowed_blender  # noqa: F401
from glb_support import Glb

DRIVER = ROOT / "tests" / "blender_ui" / "driver.py"
TOOLS = {"blender": "blender", "xvfb-run": "xvfb", "xdotool": "xdotool"}


@pytest.fixture(scope="module")
def ui(cubist_binary, tmp_path_factory):
    require_windowed_blender(TOOLS, "windowed Blender test", "apt-get install blender xvfb xauth xdotool python3-numpy")
    return run_windowed_blender(DRIVER, tmp_path_factory.mktemp("blender_ui"), cubist_binary, "")


def cli(glb: Path, settings: Path, out: Path) -> np.ndarray:
    r = subprocess.run([str(BINARY), "render", str(glb), "-o", str(out), "--config", str(settings)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return read(out)


def read(path: Path) -> np.ndarray:
    sys.path.insert(0, str(ROOT / "blender_addon"))
    import pngio

    return pngio.read(path).astype(np.int32)


def to_gltf(v):
    return [v[0], v[2], -v[1]]


def test_ui_blender_runs_every_step_without_crashing(ui):
    r = ui["results"]
    assert r["background"] is False, "the driver must run in Blender's interface, not background mode"
    assert "failure" not in r, r.get("failure")
    assert r["done"], ui["log"][-3000:]
    # Blender exits with 1 after an Esc press (its 'break' flag, set by the cancel step), never
    # from a signal (a crash).
    assert ui["proc"].returncode in (0, 1), ui["log"][-3000:]
    assert "Segmentation fault" not in ui["log"] and "Writing: " not in ui["log"]  # Blender's crash report
    assert "Fatal Python error" not in ui["log"], ui["log"][-3000:]  # PYTHONMALLOC=debug: no GIL misuse


def test_ui_f12_shows_the_renderers_picture_lock_interface_off_and_on(ui):
    r, out = ui["results"], ui["out"]
    # The factory scene's view transform (Filmic in 3.x) became Standard when Cubist was chosen,
    # on the main thread (the message bus), and the panel says so.
    assert r["factory_view_transform"] in ("Filmic", "AgX")
    assert r["after_choosing_cubist"] == {"view_transform": "Standard", "switched_from": r["factory_view_transform"]}
    # (The notice is wrapped over several labels to fit the panel.)
    assert "was " + r["factory_view_transform"] in " ".join(r["panel_after_choosing_cubist"])
    exports = out / "f12_exports"
    expected = cli(exports / "frame_0001.glb", exports / "settings_0001.json", out / "cli_f12.png")
    assert [f["lock"] for f in r["f12"]] == [False, True]
    for f12 in r["f12"]:
        assert f12["operator"] == ["RUNNING_MODAL"] and f12["error"] is None and f12["saved"], f12
        saved = read(out / f"f12_lock{int(f12['lock'])}.png")
        assert saved.shape == expected.shape == (150, 200, 4)
        assert np.abs(saved - expected).max() <= 1, f"lock {f12['lock']}: {np.abs(saved - expected).max()}/255"
    # A painting, not a blank result: many colours.
    assert len(np.unique(expected[..., :3].reshape(-1, 3), axis=0)) > 30
    print(f"\nF12 in the UI: {[round(f['seconds'], 2) for f in r['f12']]} s (export "
          f"{[round(f['exports'][0]['seconds'] * 1000) for f in r['f12']]} ms)", file=sys.stderr)


def test_ui_render_animation_writes_each_frame_as_posed(ui):
    r, out = ui["results"], ui["out"]
    anim = r["animation"]
    assert anim["errors"] == [] and anim["frames"] == [1, 2, 3], anim
    assert anim["written"] == ["frame_0001.png", "frame_0002.png", "frame_0003.png"]
    exports = out / "anim_exports"
    frames = {}
    for f in (1, 2, 3):
        saved = read(out / "anim" / f"frame_{f:04d}.png")
        expected = cli(exports / f"frame_{f:04d}.glb", exports / f"settings_{f:04d}.json", out / f"cli_{f}.png")
        assert np.abs(saved - expected).max() <= 1, f"frame {f}"
        frames[f] = saved
        # The frame's own pose: the camera sent to the renderer and the cube in the file.
        pose = r["animation_expected"][str(f)]
        sent = json.loads((exports / f"settings_{f:04d}.json").read_text())
        assert sent["camera_position"] == pytest.approx(to_gltf(pose["camera"]), abs=1e-4)
        glb = Glb(exports / f"frame_{f:04d}.glb")
        cube = next(n for n in glb.nodes_with_mesh() if n["name"] == "Cube")
        assert glb.node_matrix(cube)[:3, 3] == pytest.approx(pose["cube"], abs=1e-4)
    for a, b in ((1, 2), (2, 3), (1, 3)):
        assert np.abs(frames[a] - frames[b]).max() > 25, f"frames {a} and {b} are the same picture"


def test_ui_layout_frame_evaluated_from_another_frame(ui):
    """F12 on frame 3 with no layout: the layout is computed on frame 1 (the render's depsgraph
    re-evaluated there by RenderEngine.frame_set, and back to 3) without crashing Blender."""
    r, out = ui["results"], ui["out"]
    pre = r["prepass"]
    assert pre["error"] is None and pre["prepass"] == 1 and pre["frame_after"] == 3, pre
    assert [e["frame"] for e in pre["exports"]] == [3, 1] and len(pre["layouts"]) == 1
    exports = out / "prepass_exports"
    for name, frame in (("frame_0003", 3), ("layout_0001", 1)):
        glb = Glb(exports / f"{name}.glb")
        camera = glb.json["nodes"][glb.json["scenes"][0]["nodes"][0]]
        expected = r["animation_expected"][str(frame)]["camera"]
        assert glb.node_matrix(camera)[:3, 3] == pytest.approx(expected, abs=1e-4), name
    saved = read(out / "prepass_frame3.png")
    expected = cli(exports / "frame_0003.glb", exports / "settings_0003.json", out / "cli_prepass.png")
    assert np.abs(saved - expected).max() <= 1


def test_ui_render_animation_with_facets_that_follow_matches_f12_on_a_frame(ui):
    """Render Animation with Facet Motion Follow in the interface (render thread), then F12 on
    frame 3 alone in a fresh layout folder (frame 1's layout and follow data computed first,
    frame 1 exported on the render thread): the same picture as the animation's frame 3."""
    r, out = ui["results"], ui["out"]
    f = r["follow"]
    assert f["errors"] == [] and f["frames"] == [1, 2, 3] and f["facet_motion"] == ["follow"] * 3, f
    assert f["written"] == ["frame_0001.png", "frame_0002.png", "frame_0003.png"]
    name = f["layouts"][0]
    assert f["layouts"] == [name, name + ".follow", name + ".source"], f["layouts"]
    f12 = f["f12"]
    assert f12["operator"] == ["RUNNING_MODAL"] and f12["error"] is None, f12
    assert f12["prepass"] == 1 and f12["frame_after"] == 3 and f12["facet_motion"] == "follow", f12
    alone, in_run = read(out / "follow_f12_frame3.png"), read(out / "follow" / "frame_0003.png")
    assert np.array_equal(alone, in_run), f"{np.abs(alone - in_run).max()}/255"
    # Facets that follow are not the static facets' frame 3.
    assert np.abs(in_run - read(out / "anim" / "frame_0003.png")).max() > 0


def test_ui_esc_stops_the_renderer_and_leaves_no_temp_files(ui):
    c = ui["results"]["cancel"]
    assert c["cancelled"] is True and c["error"] is None, c
    # The session's renderer stopped that render (nothing runs or waits), or, when it did not
    # within a few seconds, was stopped itself (the next F12, in the steps after, starts another).
    assert c["server"] == c["server_pid"], c
    assert c["renderer_running"] is None and c["renderer_queued"] == 0, c
    assert c["job_ended_after_esc"] < 15, c
    # Nothing rendered ahead the job the user just stopped (it would run on for minutes).
    assert c["sent_ahead_after_esc"] == 0 and "cancelled" in (c["ahead_skip"] or ""), c
    ws = Path(c["workspace"]).name
    assert ws in c["temp_during"], c  # the check below looks in the right place
    assert not c["workspace_exists"], c
    # Only the session's renderer's folder may be new (it started with the first F12 here).
    assert [t for t in c["temp_after"] if t not in c["temp_before"] and not t.startswith("cubist-serve-")] == [], c
    assert sorted(p.name for p in ui["tmp"].glob("cubist-*")) == []


def test_ui_colours_the_user_set_are_left_with_a_warning(ui):
    c = ui["results"]["configured"]
    assert (c["view_transform"], c["look"], c["switched_from"]) == ("Filmic", "Medium High Contrast", "")
    assert "change the painting's colours" in " ".join(c["panel"]), c["panel"]
    assert "[cubist.painting_colours]" in c["panel"]


def test_ui_render_thread_leaves_blenders_write_guard_as_it_found_it(ui):
    """With slow panels and a render_pre handler that waits (other add-ons'), the main thread
    can still write to the scene after every F12 and Render Animation (turns.py): without the
    add-on's turns every run here failed with 'Writing to ID classes in this context is not
    allowed' and Blender could not quit."""
    busy = ui["results"]["busy"]
    assert [b["what"] for b in busy] == ["f12", "f12_lock", "animation", "f12"]
    for b in busy:
        assert b["operator"] == ["RUNNING_MODAL"] and b["write"] == "ok" and not b["errors"], b
    assert busy[2]["frames"] == [1, 2, 3]
    # The slow draws really ran (about eight per render).
    assert ui["results"]["busy_draws"] >= 10
