"""Users' scenes in Blender's interface: a windowed Blender (Debian's 3.4.1) under Xvfb, driven
by tests/blender_ui/scenes_driver.py, builds scenes the other tests never build and renders
them with F12 or Render Animation (render() on Blender's render-job thread, as for users):
an imported scan, an unapplied Subdivision Surface, collection instances and linked
duplicates, hidden objects, negative scale, no mesh, no camera, an orthographic camera,
several view layers, Render Region with and without crop, 50% resolution, a frame step, a
1M-triangle mesh (F12 and Rendered shading), Esc during Render Animation.

Each test says what a user expects: the picture, or a clear error in Blender, never a crash
or a hang. Needs `blender`, `xvfb-run` and `xdotool` on PATH (.ci/run installs them);
without them every test here is skipped, saying why (CUBIST_REQUIRE_UI_TEST=1 makes that a
failure)."""

import json
import sys

import numpy as np
import pytest

from addon_support import ROOT, cubist_binary, require_windowed_blender, run_windowed_blender  # noqa: F401
from glb_support import Glb

DRIVER = ROOT / "tests" / "blender_ui" / "scenes_driver.py"
TOOLS = ("blender", "xvfb-run", "xdotool")


@pytest.fixture(scope="module")
def ui(cubist_binary, tmp_path_factory):
    """The driver's run. Blender 3.4 can get its process-wide 'no writes to datablocks' flag
    stuck after a render (scenes_driver.WRITE_LOCK, a Blender bug no add-on can reset): the
    driver then stops and the steps left run in a new Blender (at most 3 runs)."""
    require_windowed_blender(TOOLS, "windowed Blender scenes test",
                             "apt-get install blender xvfb xauth xdotool python3-numpy")
    base = tmp_path_factory.mktemp("blender_scenes")
    out = base / "out"
    steps, locks, run = {}, [], None
    remaining = ""
    for attempt in range(4):
        (base / f"run{attempt}").mkdir()
        run = run_windowed_blender(DRIVER, base / f"run{attempt}", cubist_binary, " (scenes)",
                                   extra_args=[remaining] if remaining else [], out=out)
        steps.update(run["results"]["steps"])
        lock = run["results"].get("write_lock")
        # The steps not finished (results.json is written after each step).
        left = [n for n in run["results"].get("remaining") or [] if n not in run["results"]["steps"]]
        if lock is None:
            break
        locks.append(lock)
        remaining = ",".join(left)
    run["results"]["steps"] = steps
    run["results"]["write_locks"] = locks
    if locks:
        print(f"\nBlender 3.4's write flag got stuck {len(locks)} time(s): {locks}", file=sys.stderr)
    return run


def step(ui, name):
    s = ui["results"]["steps"].get(name)
    assert s is not None, f"the driver did not reach {name}: {ui['log'][-3000:]}"
    assert "failure" not in s, s["failure"]
    return s


def picture(ui, name):
    sys.path.insert(0, str(ROOT / "blender_addon"))
    import pngio

    return pngio.read(ui["out"] / name / "render.png").astype(np.int32)


def rendered_fine(s):
    assert s["operator"] == ["RUNNING_MODAL"] and s["error"] is None and s.get("saved"), s
    assert all(h["error"] is None for h in s["history"]), s["history"]


def painting(img):
    return len(np.unique(img[..., :3].reshape(-1, 3), axis=0)) > 30


def test_blender_runs_every_scene_without_crashing(ui):
    r = ui["results"]
    assert r["background"] is False and r["done"], ui["log"][-3000:]
    assert ui["proc"].returncode in (0, 1), ui["log"][-3000:]  # 1: Blender's 'break' flag after Esc
    # The last run (the whole list, or the steps left after a stuck write flag) ended by itself:
    # no crash, no "Python memory allocator called without holding the GIL" (PYTHONMALLOC=debug).
    assert "Segmentation fault" not in ui["log"] and "Writing: " not in ui["log"], ui["log"][-3000:]
    assert "Fatal Python error" not in ui["log"], ui["log"][-3000:]


def test_an_imported_scan_stands_up_in_the_exported_scene(ui):
    s = step(ui, "zup_import")
    rendered_fine(s)
    # Blender's OBJ importer turned the Y-up file into a figure standing along Blender's Z (by
    # an unapplied rotation of the object).
    (dx, dy, dz), = s["world_extent"]
    assert dz == pytest.approx(2.0, abs=0.01) and max(dx, dy) < 0.7, s
    assert s["rotation"][0][0] == pytest.approx(np.pi / 2, abs=1e-4), s
    # The renderer's scene (glTF, Y-up) has it standing along +Y.
    glb = Glb(ui["out"] / "zup_import" / "exports" / "frame_0001.glb")
    node = glb.nodes_with_mesh()[0]
    pos = glb.primitive(glb.json["meshes"][node["mesh"]]["primitives"][0])["POSITION"].astype(np.float64)
    m = np.array(node["matrix"], dtype=np.float64).reshape(4, 4).T
    world = pos @ m[:3, :3].T + m[:3, 3]
    extent = world.max(axis=0) - world.min(axis=0)
    assert extent[1] == pytest.approx(2.0, abs=0.01) and max(extent[0], extent[2]) < 0.7, extent
    assert painting(picture(ui, "zup_import"))


def test_an_unapplied_subdivision_renders_at_its_render_levels(ui):
    s = step(ui, "subdivision")
    rendered_fine(s)
    # Render levels 3 (F12 evaluates the depsgraph for rendering), not the viewport's 1: 12 x 4^3.
    assert s["exports"][0]["triangles"] == 12 * 4 ** 3, s["exports"]


def test_collection_instances_and_linked_duplicates_share_their_meshes(ui):
    s = step(ui, "instances")
    rendered_fine(s)
    e, want = s["exports"][0], s["expected"]
    assert (e["meshes"], e["instances"], e["triangles"]) == (want["meshes"], want["instances"], want["triangles"]), s


def test_hidden_objects_render_as_f12_renders_them(ui):
    s = step(ui, "hidden")
    rendered_fine(s)
    glb = Glb(ui["out"] / "hidden" / "exports" / "frame_0001.glb")
    assert sorted(n["name"] for n in glb.nodes_with_mesh()) == sorted(s["expected_nodes"])


def test_negative_scale_gives_the_same_picture(ui):
    s = step(ui, "negative_scale")
    rendered_fine(s["positive"])
    rendered_fine(s["negative"])
    a, b = picture(ui, "scale_positive"), picture(ui, "scale_negative")
    assert painting(a) and np.abs(a - b).max() <= 2, f"{np.abs(a - b).max()}/255"


def test_a_scene_without_a_mesh_reports_a_clear_error(ui):
    s = step(ui, "empty_scene")
    message = "scene 'empty_scene' has nothing to render: add a mesh"
    # The report reaches the user either way: through the running job (the status bar), or as
    # the operator's error when the job ended before the operator's invoke returned.
    assert s["operator"] in (["RUNNING_MODAL"], [f"ERROR: Error: Cubist: {message}\n"]), s
    assert s["error"] == message, s


def test_a_scene_without_a_camera_is_refused_by_blender(ui):
    s = step(ui, "no_camera")
    assert len(s["operator"]) == 1 and "No camera found" in s["operator"][0], s


def test_an_orthographic_camera_far_away_renders_the_scene(ui):
    s = step(ui, "orthographic")
    rendered_fine(s)
    settings = json.loads((ui["out"] / "orthographic" / "exports" / "settings_0001.json").read_text())
    assert settings["camera_position"] == pytest.approx([0.0, 1.0, 30.0], abs=1e-4)
    assert painting(picture(ui, "orthographic"))


def test_each_view_layer_renders_its_own_collections(ui):
    s = step(ui, "view_layers")
    rendered_fine(s)
    assert [h["frame"] for h in s["history"]] == [1, 1], s["history"]
    by_layer = {e["view_layer"]: e for e in s["exported"]}
    assert sorted(by_layer) == ["OnlyLeft", "OnlyRight"], s["exported"]
    assert by_layer["OnlyLeft"]["triangles"] == 968 and by_layer["OnlyRight"]["triangles"] == 12, s["exported"]


def test_render_region_with_and_without_crop(ui):
    s = step(ui, "border")
    for label in ("border", "border_crop", "full"):
        rendered_fine(s[label])
    full, border, crop = picture(ui, "border_full"), picture(ui, "border"), picture(ui, "border_crop")
    # x 0.25-0.75 of 160, y 0.2-0.7 of 120 from the bottom: rows 36-96 from the top.
    assert crop.shape == (60, 80, 4) and border.shape == full.shape == (120, 160, 4)
    assert np.abs(crop - full[36:96, 40:120]).max() <= 1
    assert np.abs(border[36:96, 40:120] - full[36:96, 40:120]).max() <= 1
    outside = np.ones(border.shape[:2], bool)
    outside[36:96, 40:120] = False
    assert border[outside][:, 3].max() == 0  # transparent outside the region, as Blender leaves it


def test_half_resolution_renders_the_full_size_scene_at_half_the_pixels(ui):
    s = step(ui, "half_resolution")
    rendered_fine(s)
    rendered_fine(s["reference"])
    half, ref = picture(ui, "half_resolution"), picture(ui, "half_reference")
    assert half.shape == ref.shape == (120, 160, 4)
    assert np.abs(half - ref).max() <= 1


def test_render_animation_with_a_frame_step(ui):
    s = step(ui, "animation_step")
    assert s["operator"] == ["RUNNING_MODAL"] and s["error"] is None, s
    assert [h["frame"] for h in s["history"]] == [2, 4, 6], s["history"]
    assert s["written"] == ["f_0002.png", "f_0004.png", "f_0006.png"]


def test_a_million_triangles_render_with_f12_and_in_the_viewport(ui):
    s = step(ui, "dense_mesh")
    rendered_fine(s)
    assert s["exports"][0]["triangles"] == s["triangles_in_blender"] >= 1_000_000, s["exports"]
    v = s["viewport"]
    assert v["drawn"] is not None and v["drawn"].get("scale") == 1.0, v
    main = v["drawn"]["main_thread"]
    print(f"\n1M triangles: F12 {s['seconds']:.1f} s (export {s['exports'][0]['seconds']:.2f} s on the render "
          f"thread); Rendered shading: full image after {v['seconds']:.1f} s, longest view_update "
          f"{main['longest_view_update']:.2f} s, heartbeat longest gap {max(v['gaps'], default=0):.2f} s",
          file=sys.stderr)
    # The object moved: view_update reads the scene (main thread), the worker writes it.
    assert len(s["changes"]) == 2, s["changes"]
    for c in s["changes"]:
        assert c["drawn"] is not None and "error" not in c["drawn"], c
        main = c["drawn"]["main_thread"]
        print(f"1M triangles, object moved: full image after {c['seconds']:.1f} s, longest view_update "
              f"{main['longest_view_update']:.2f} s, scene written on the worker in "
              f"{c['drawn']['worker'].get('longest_scene_write', 0):.2f} s, heartbeat longest gap "
              f"{max(c['gaps'], default=0):.2f} s", file=sys.stderr)
        # Reading 1M triangles' arrays is all the main thread does (0.5 s measured on a loaded
        # machine); building and writing the file (1.3 s) is the worker's.
        assert main["longest_view_update"] < 1.0, c
    # The mesh's data did not change: its arrays were not read again.
    assert [c["drawn"]["meshes_reused"] for c in s["changes"]] == [1, 2], s["changes"]
    print(f"1M triangles moved in Solid shading (Blender alone): heartbeat longest gap "
          f"{max(s['solid_move_gaps'], default=0):.2f} s", file=sys.stderr)


def test_esc_during_render_animation_stops_it(ui):
    s = step(ui, "animation_esc")
    assert s["operator"] == ["RUNNING_MODAL"] and s["errors"] == [], s
    assert s["ended_after_esc"] < 60, s
    assert len(s["frames"]) < 40, s  # the frames after Esc were not rendered
    # Every frame written was rendered whole; the one Esc interrupted is not written.
    done = [f for f, c in zip(s["frames"], s["cancelled"]) if not c]
    assert s["written"] == [f"f_{f:04d}.png" for f in done], s
