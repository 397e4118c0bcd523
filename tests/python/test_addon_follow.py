"""Facets that follow the scene in Blender: the panel's Facet Motion choice,
the settings it sends, and Render Animation with follow in headless Blender (bpy 5.0.1):
each frame is its own `cubist` process carrying its facets from the layout frame's layout and
follow data, saved beside the .blend, so a frame rendered alone (F12, a farm chunk on another
machine) is byte for byte the same frame of a whole Render Animation.

Small images (64x48, 1 sample) keep each render to a fraction of a second."""

import hashlib
import sys
from pathlib import Path

import numpy as np
import pytest

from addon_support import ROOT, addon, bpy, bpy_module, cubist_binary, new_scene, read_png  # noqa: F401

if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


@pytest.fixture
def engine(addon):
    return sys.modules["blender_addon.engine"]


# ---------------------------------------------------------------------------------------------
# Panel -> settings (no rendering)


def test_facet_motion_is_the_panels_choice(bpy):
    presets = sys.modules["blender_addon.presets"]
    mapping = sys.modules["blender_addon.mapping"]
    schema = sys.modules["blender_addon.schema"]
    assert "facet_motion" not in presets.BLENDER_KEYS and "facet_motion" in presets.ENUM_KEYS
    scene = new_scene(bpy)
    c = scene.cubist
    assert c.facet_motion == "STATIC"  # the renderer's default
    prop = c.bl_rna.properties["facet_motion"]
    assert [i.identifier for i in prop.enum_items] == ["STATIC", "FOLLOW"]
    # The tooltip: the renderer's help, then what it means in Blender.
    assert prop.description.startswith(schema.SETTINGS["facet_motion"]["help"])
    assert "Layout Frame" in prop.description and "triangle count" in prop.description
    assert {i.identifier: i.description for i in prop.enum_items}["FOLLOW"] == dict(
        schema.choices("facet_motion"))["follow"]

    panel = sys.modules["blender_addon.properties"].panel_values(c)
    facts = mapping.SceneFacts(width=64, height=48, frame=1)
    assert mapping.settings_from_panel(panel, facts)["facet_motion"] == "static"
    c.facet_motion = "FOLLOW"
    panel = sys.modules["blender_addon.properties"].panel_values(c)
    assert mapping.settings_from_panel(panel, facts)["facet_motion"] == "follow"
    # A preset sets the look, not how facets move.
    bpy.ops.cubist.apply_preset(name="Braque")
    assert c.facet_motion == "FOLLOW"
    assert "facet_motion" not in presets.LOOK_KEYS


def test_follow_layouts_are_named_per_size_and_static_names_do_not_change():
    from blender_addon import runner

    s = {"faceting": "voronoi", "width": 64, "height": 48, "facet_motion": "static"}
    static = runner.layout_key(s)
    # The key of a static layout is the one saved before facet_motion reached the panel.
    assert static == runner.layout_key({k: v for k, v in s.items() if k != "facet_motion"})
    follow = runner.layout_key({**s, "facet_motion": "follow"})
    assert follow != static
    # Follow data is per pixel: a 50% preview keeps its own (static layouts are shared).
    assert runner.layout_key({**s, "facet_motion": "follow", "width": 32, "height": 24}) != follow
    assert runner.layout_key({**s, "width": 32, "height": 24}) == static
    assert runner.follows_scene({**s, "facet_motion": "follow"})
    assert not runner.follows_scene({**s, "facet_motion": "follow", "faceting": "none"})
    assert runner.follow_path(Path("/x/a.facets.json")) == Path("/x/a.facets.json.follow")


def test_a_follow_layout_without_its_follow_data_is_not_current(tmp_path):
    from blender_addon import runner

    layout = tmp_path / "a.facets.json"
    layout.write_text("{}")
    assert runner.layout_is_current(layout, None)
    assert not runner.layout_is_current(layout, None, follow=True)
    runner.follow_path(layout).write_bytes(b"x")
    assert runner.layout_is_current(layout, None, follow=True)


def test_frames_stage_moves_the_progress_bar():
    from blender_addon import runner

    t = runner.ProgressTracker()
    a = t.update("loading", 1.0)
    b = t.update("frames", 0.5)
    c = t.update("frames", 1.0)
    assert a < b < c < 1.0


class RecordingLayout:
    """A panel's UILayout in background mode: records the properties drawn, in order, and
    whether each was drawn active."""

    def __init__(self, drawn, active=True):
        self.drawn, self.active, self.use_property_split = drawn, active, False

    def prop(self, data, name, **kw):
        assert hasattr(data, name), name
        self.drawn.append((name, self.active))

    def label(self, **kw):
        self.drawn.append(("label:" + kw.get("text", ""), self.active))

    def operator(self, *a, **kw):
        return type("Props", (), {})()

    def separator(self, **kw):
        pass

    def column(self, **kw):
        return RecordingLayout(self.drawn, self.active)

    row = column


def test_facets_panel_offers_facet_motion_under_animation(bpy, tmp_path):
    ui = sys.modules["blender_addon.ui"]
    scene = new_scene(bpy)
    c = scene.cubist
    c.faceting = "VORONOI"
    c.layout_folder = str(tmp_path)

    def draw():
        drawn = []
        fake = type("P", (), {"layout": RecordingLayout(drawn)})()
        ui.CUBIST_PT_facets.draw(fake, bpy.context)
        return dict(drawn), [name for name, _ in drawn]

    active, order = draw()
    assert order.index("facet_motion") < order.index("static_facets") < order.index("layout_frame")
    assert active["static_facets"]
    c.facet_motion, c.static_facets = "FOLLOW", False
    active, order = draw()
    # Facets that follow always share the layout frame's layout: Static Facets is implied.
    assert not active["static_facets"] and active["layout_frame"] and active["layout_folder"]
    assert any(n.startswith("label:") and "computed on frame 1" in n for n in order), order
    # A layout file of the user's: the choice is still offered.
    c.layout_file = str(tmp_path / "mine.facets.json")
    _, order = draw()
    assert "facet_motion" in order and "layout_frame" not in order


# ---------------------------------------------------------------------------------------------
# Render Animation with follow: frames in separate processes agree


def animated_scene(bpy, layout_dir: Path):
    """Frames 1-4: the camera and the cube move, the monkey bends (a Simple Deform modifier:
    its vertices move, its triangles stay); Voronoi facets that follow, layout frame 1."""
    scene = new_scene(bpy, 64, 48)
    scene.frame_start, scene.frame_end = 1, 4
    cam = scene.camera
    for frame, x in ((1, -0.6), (4, 0.6)):
        cam.location.x = x
        cam.keyframe_insert("location", index=0, frame=frame)
    cube = scene.objects["Cube"]
    for frame, z in ((1, -0.3), (4, 0.5)):
        cube.location.z = z
        cube.keyframe_insert("location", index=2, frame=frame)
    monkey = scene.objects["Suzanne"]
    bend = monkey.modifiers.new("Bend", "SIMPLE_DEFORM")
    bend.deform_method = "BEND"
    for frame, angle in ((1, 0.0), (4, 0.8)):
        bend.angle = angle
        bend.keyframe_insert("angle", frame=frame)
    c = scene.cubist
    c.faceting = "VORONOI"
    c.facet_count = 12
    c.grid_cells = 4
    c.discontinuity = 100.0
    c.facet_motion = "FOLLOW"
    c.layout_folder = str(layout_dir)
    c.pass_facet_ids = True
    # No metadata in the saved files (date, time, render time, file name): their bytes are
    # then the pixels' alone, and compared whole.
    for name in scene.render.bl_rna.properties.keys():
        if name.startswith("use_stamp") and name != "use_stamp_labels":
            setattr(scene.render, name, False)
    return scene


def render_animation(bpy, scene, out_dir: Path) -> dict:
    scene.render.filepath = str(out_dir / "frame_####")
    bpy.ops.render.render(animation=True)
    return {f: out_dir / f"frame_{f:04d}.png" for f in range(scene.frame_start, scene.frame_end + 1)}


def render_still(bpy, scene, frame: int, path: Path) -> Path:
    scene.frame_set(frame)
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)
    return path


def saved(folder: Path) -> dict:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.glob("*.facets.json*"))}


def test_frames_rendered_alone_equal_the_same_frames_of_render_animation(bpy, engine, tmp_path):
    # The whole animation, 1-4: frame 1 saves the layout and its follow data, 2-4 load them.
    scene = animated_scene(bpy, tmp_path / "layouts_full")
    engine.history.clear()
    full = render_animation(bpy, scene, tmp_path / "full")
    runs = [h for h in engine.history if h["frame"] in full]
    assert [h["frame"] for h in runs] == [1, 2, 3, 4] and not any(h["error"] for h in runs), runs
    assert all(h["settings"]["facet_motion"] == "follow" for h in runs)
    layout = runs[0]["settings"]["save_facets"]
    assert [h["settings"].get("facets") for h in runs[1:]] == [layout] * 3
    files = saved(tmp_path / "layouts_full")
    assert set(files) >= {Path(layout).name, Path(layout).name + ".follow"}, files
    pictures = {f: read_png(bpy, p) for f, p in full.items()}
    assert np.abs(pictures[1] - pictures[4]).max() > 0.1, "nothing moved"

    # A farm chunk, 3-4, in a fresh folder (another machine): the layout frame is exported
    # and its layout and follow data computed first, the same bytes as the full run's.
    scene = animated_scene(bpy, tmp_path / "layouts_chunk")
    scene.frame_start, scene.frame_end = 3, 4
    engine.history.clear()
    chunk = render_animation(bpy, scene, tmp_path / "chunk")
    assert [h["prepass"] for h in engine.history] == [1, None], engine.history
    assert saved(tmp_path / "layouts_chunk") == files
    for f in (3, 4):
        assert chunk[f].read_bytes() == full[f].read_bytes(), f"frame {f} of the chunk differs"

    # F12 on frame 3 alone, in yet another fresh folder: the same frame again.
    scene = animated_scene(bpy, tmp_path / "layouts_f12")
    still = render_still(bpy, scene, 3, tmp_path / "f12_3.png")
    assert engine.last_run["prepass"] == 1 and not engine.last_run.get("error")
    assert still.read_bytes() == full[3].read_bytes(), "F12 on frame 3 differs from Render Animation's frame 3"
    # And with the layout now saved: loaded, not computed again.
    still = render_still(bpy, scene, 4, tmp_path / "f12_4.png")
    assert engine.last_run["prepass"] is None
    assert still.read_bytes() == full[4].read_bytes()


def test_facets_follow_the_scene_where_static_facets_stay(bpy, engine, tmp_path):
    """The facet index pass (multilayer EXR, as Blender saves the render result): with
    follow, frame 4's facets are not frame 1's (they moved with the camera and the objects);
    with static facets, every pixel keeps its facet."""
    from test_addon_blender import exr_channels, use_multilayer_exr

    ids = {}
    for motion in ("STATIC", "FOLLOW"):
        scene = animated_scene(bpy, tmp_path / f"layouts_{motion}")
        scene.cubist.facet_motion = motion
        use_multilayer_exr(scene)
        layer = bpy.context.view_layer.name
        for f in (1, 4):
            path = render_still(bpy, scene, f, tmp_path / f"{motion}_{f}.exr")
            assert engine.last_run["settings"]["facet_motion"] == motion.lower()
            ids[motion, f] = exr_channels(path)[f"{layer}.Facet Index.X"]
    assert len(np.unique(ids["FOLLOW", 1])) >= 4, np.unique(ids["FOLLOW", 1])
    assert np.array_equal(ids["STATIC", 1], ids["STATIC", 4]), "static facets moved"
    changed = np.mean(ids["FOLLOW", 1] != ids["FOLLOW", 4])
    assert changed > 0.02, f"facets that follow did not move ({changed:.1%} of pixels changed facet)"


def test_a_frame_whose_triangle_count_differs_is_a_clear_error(bpy, engine, tmp_path):
    scene = animated_scene(bpy, tmp_path / "layouts")
    cube = scene.objects["Cube"]
    for frame, hidden in ((1, False), (3, True)):
        cube.hide_render = hidden
        cube.keyframe_insert("hide_render", frame=frame)
    render_still(bpy, scene, 1, tmp_path / "1.png")
    assert not engine.last_run.get("error")
    with pytest.raises(RuntimeError) as e:
        render_still(bpy, scene, 3, tmp_path / "3.png")
    message = str(e.value)
    assert "triangles" in message and "Facet Motion Follow" in message and "\n" not in message.strip(), message
    assert "triangles" in engine.last_run["error"]
