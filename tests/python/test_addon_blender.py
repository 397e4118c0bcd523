"""The add-on in headless Blender (bpy 5.0.1): enable, F12 against the CLI, the panel's
defaults and presets against the binary's, animation with static facets, cancel, errors,
panel -> settings JSON, render passes, the extension zip.

Small images (64x48, 1 sample) keep the whole file to a few seconds of rendering."""

import hashlib
import json
import os
import struct
import subprocess
import sys
import tempfile
import zlib
from pathlib import Path

import numpy as np
import pytest

from addon_support import BINARY, ROOT, addon, bpy, bpy_module, cubist_binary, new_scene, read_png  # noqa: F401
from exr_support import exr_channels, use_multilayer_exr


@pytest.fixture
def engine(addon):
    return sys.modules["blender_addon.engine"]


@pytest.fixture
def exports(engine, tmp_path):
    """The folder where the engine copies each scene it exports (frame_NNNN.glb): the CLI
    then renders exactly what F12 sent."""
    folder = tmp_path / "exports"
    engine.keep_exports = folder
    yield folder
    engine.keep_exports = None


def render_still(bpy, scene, path: Path):
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)
    return path


def set_world_colour(scene, rgb):
    bg = next(n for n in scene.world.node_tree.nodes if n.type == "BACKGROUND")
    bg.inputs["Color"].default_value = (*rgb, 1.0)
    bg.inputs["Strength"].default_value = 1.0


def srgb(c):
    c = np.asarray(c, dtype=np.float64)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1 / 2.4) - 0.055)


def cubist_temp_dirs():
    return set(Path(tempfile.gettempdir()).glob("cubist-render-*"))


# ---------------------------------------------------------------------------------------------


def test_addon_enables_with_engine_panels_and_properties(bpy):
    assert bpy.types.RenderEngine.bl_rna_get_subclass_py("CUBIST") is not None
    scene = new_scene(bpy)  # selects the engine: fails unless it is registered
    assert scene.render.engine == "CUBIST"
    assert scene.cubist.ambiguity == 0.0  # automatic: chosen per scene by the renderer
    for name in ("CUBIST_PT_render", "CUBIST_PT_camera", "CUBIST_PT_facets", "CUBIST_PT_imprecision",
                 "CUBIST_PT_saliency", "CUBIST_PT_painterly", "CUBIST_PT_sampling", "CUBIST_PT_passes",
                 "CUBIST_PT_output", "CUBIST_MT_presets"):
        assert hasattr(bpy.types, name), name
    # Blender's generic panels (output format, camera lens and depth of field) show for Cubist.
    assert "CUBIST" in bpy.types.DATA_PT_camera_dof.COMPAT_ENGINES


class FakeLayout:
    """Stands in for a panel's UILayout (no UI in background mode): records every property
    drawn and checks it exists, so a typo in ui.py fails here rather than in a user's panel."""

    def __init__(self, drawn):
        self.drawn = drawn
        self.use_property_split = False
        self.active = True

    def prop(self, data, name, **kw):
        assert hasattr(data, name), f"{type(data).__name__} has no property {name!r}"
        self.drawn.append(name)

    template_icon_view = prop

    def operator(self, idname, **kw):
        module, op = idname.split(".")
        assert hasattr(getattr(bpy_ops(), module), op), idname
        return type("Props", (), {})()

    def label(self, **kw):
        self.drawn.append("label:" + kw.get("text", ""))

    def menu(self, *a, **kw):
        pass

    def separator(self, **kw):
        pass

    def column(self, **kw):
        return self

    def row(self, **kw):
        return self

    def box(self, **kw):
        return self


def bpy_ops():
    import bpy

    return bpy.ops


def test_every_panel_draws_existing_properties(bpy, engine):
    ui = sys.modules["blender_addon.ui"]
    scene = new_scene(bpy)
    drawn = []
    panels = [c for c in ui.classes if issubclass(c, bpy.types.Panel)]
    for camera in ("AUTO", "PLANAR", "PERSPECTIVE", "ORTHOGRAPHIC"):
        for faceting in ("NONE", "CONSTANT", "VORONOI", "PATCH", "SEGMENT", "PLANES"):
            scene.cubist.camera, scene.cubist.faceting = camera, faceting
            scene.cubist.facet_projection = "LINEAR"
            for panel in panels:
                fake = type("P", (), {"layout": FakeLayout(drawn)})()
                panel.draw(fake, bpy.context)
    # Every panel property is reachable from the panels (an Auto setting through its checkbox).
    props = set(sys.modules["blender_addon.presets"].DEFAULTS)
    drawn = {name.removesuffix("_auto") for name in drawn}
    assert props - drawn == set(), "not shown in any panel"


def cli_render(tmp_path, scene_glb, out, settings_json=None, args=()):
    argv = [str(BINARY), "render", str(scene_glb), "-o", str(out), *args]
    if settings_json is not None:
        cfg = tmp_path / "settings.json"
        cfg.write_text(settings_json)
        argv += ["--config", str(cfg)]
    r = subprocess.run(argv, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return out


def test_f12_renders_the_cli_picture(bpy, engine, exports, tmp_path):
    scene = new_scene(bpy)
    scene.cubist.preset = "PLAIN"  # no palette: the background keeps the world's colour
    set_world_colour(scene, (0.3, 0.35, 0.4))
    out = render_still(bpy, scene, tmp_path / "f12.png")
    assert out.is_file(), engine.last_run
    img = read_png(bpy, out)
    assert img.shape == (48, 64, 4)
    progress = engine.last_run["progress"]
    assert progress == sorted(progress) and progress[-1] == 1.0, progress

    # Not a blank render: a good share of pixels differ from the background.
    bg = srgb([0.3, 0.35, 0.4])
    assert np.abs(img[0, 0, :3] - bg).max() < 1.5 / 255  # a corner is background: the world colour
    differs = (np.abs(img[..., :3] - bg).max(axis=2) > 0.1).mean()
    assert differs > 0.1, f"only {differs:.1%} of pixels show the scene"

    # The CLI on the same exported scene with the same settings gives the same pixels.
    glb = exports / f"frame_{scene.frame_current:04d}.glb"
    cli = read_png(bpy, cli_render(tmp_path, glb, tmp_path / "cli.png", engine.last_run["settings_json"]))
    assert np.abs(cli - img).max() <= 1.0 / 255 + 1e-6


def test_f12_with_an_untouched_panel_is_cubist_render(bpy, engine, exports, tmp_path):
    """An untouched panel paints what `cubist render` paints with its defaults (the analytic
    preset): only what Blender decides (size, camera, world colour, samples) is given as flags."""
    scene = new_scene(bpy, 80, 60)
    out = render_still(bpy, scene, tmp_path / "f12.png")
    sent = json.loads(engine.last_run["settings_json"])
    assert (sent["preset"], sent["faceting"], sent["palette"]) == ("analytic", "planes", "ochre-grey")
    glb = exports / f"frame_{scene.frame_current:04d}.glb"
    vec = lambda k: ",".join(repr(float(c)) for c in sent[k])  # noqa: E731
    flags = ["--width", "80", "--height", "60", "--spp", "1", "--camera-position", vec("camera_position"),
             "--camera-target", vec("camera_target"), "--camera-up", vec("camera_up"), "--background",
             vec("background")]
    cli = cli_render(tmp_path, glb, tmp_path / "cli.png", args=flags)
    img, ref = read_png(bpy, out), read_png(bpy, cli)
    assert np.array_equal(img, ref), f"max difference {np.abs(img - ref).max() * 255:.1f}/255"
    # A painted picture, not a blank one: many colours.
    assert len(np.unique(np.round(img[..., :3] * 255).reshape(-1, 3), axis=0)) > 30


def binary_settings(*args):
    r = subprocess.run([str(BINARY), "settings", *args], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout)


def effective(settings):
    """Resolved settings as the renderer uses them, nulls dropped (the panel's automatic 0s,
    the convergence angle among them, are sent as null)."""
    return {k: v for k, v in settings.items() if v is not None}


def panel_settings(scene):
    """The settings the panel gives without a camera or world, at the binary's default size."""
    mapping = sys.modules["blender_addon.mapping"]
    engine = sys.modules["blender_addon.engine"]
    panel = dict(engine._panel(scene.cubist), use_world_background=False)
    return mapping.settings_from_panel(panel, mapping.SceneFacts(width=800, height=600, frame=1))


def test_panel_defaults_and_presets_are_the_binarys(bpy):
    """In Blender (32-bit float properties): the untouched panel is `cubist settings`, and
    choosing each preset in the panel's Preset menu is `cubist settings --preset NAME`."""
    scene = new_scene(bpy)
    scene.cubist.spp = 4  # new_scene's previews use 1; the binary's default is 4
    assert panel_settings(scene) == effective(binary_settings())
    presets = sys.modules["blender_addon.presets"]
    for name in presets.PRESET_LABELS:
        c = scene.cubist
        c.discontinuity, c.palette, c.faceting, c.weight_object, c.fill = 3.0, "GREY", "PATCH", 0.1, 0.5
        c.preset = presets.enum_id(name)
        assert panel_settings(scene) == effective(binary_settings("--preset", name)), name


def test_every_enum_choice_is_accepted_by_the_binary(bpy, tmp_path):
    scene = new_scene(bpy)
    presets = sys.modules["blender_addon.presets"]
    for key in presets.ENUM_KEYS:
        for item in scene.cubist.bl_rna.properties[key].enum_items:
            scene.cubist.preset = "ANALYTIC"
            setattr(scene.cubist, key, item.identifier)
            s = panel_settings(scene)
            if s["faceting"] == "constant":
                s["facet_map"] = str(tmp_path / "map.png")
            cfg = tmp_path / "s.json"
            cfg.write_text(json.dumps(s))
            r = subprocess.run([str(BINARY), "settings", "--config", str(cfg)], capture_output=True, text=True)
            assert r.returncode == 0, f"{key} = {item.identifier}: {r.stderr}"
            assert json.loads(r.stdout)[key] == s[key]


def test_settings_json_follows_the_panel_and_the_scene(bpy, engine, tmp_path):
    scene = new_scene(bpy, 48, 32)
    render_still(bpy, scene, tmp_path / "a.png")
    before = json.loads(engine.last_run["settings_json"])
    c = scene.cubist
    c.discontinuity = 120.0
    c.ambiguity = 150.0
    c.spp = 2
    c.palette = "OLIVE"
    c.weight_depth = 0.75
    c.fill = 0.7
    scene.render.resolution_percentage = 50
    scene.render.film_transparent = True
    set_world_colour(scene, (0.5, 0.25, 0.125))
    render_still(bpy, scene, tmp_path / "b.png")
    after = json.loads(engine.last_run["settings_json"])
    assert (before["discontinuity"], after["discontinuity"]) == (110.0, 120.0)
    assert (before.get("ambiguity"), after["ambiguity"]) == (None, 150.0)
    assert (before["spp"], after["spp"]) == (1, 2)
    assert (before["palette"], after["palette"]) == ("ochre-grey", "olive")
    assert (before["weight_depth"], after["weight_depth"]) == (0.5, 0.75)
    assert "fill" not in before and after["fill"] == 0.7  # typed values, not 32-bit floats' digits
    assert (after["width"], after["height"]) == (24, 16)
    assert after["transparent"] is True
    assert after["background"] == pytest.approx([0.5, 0.25, 0.125])
    # The Blender camera at (0, -6, 0.5) is at (0, 0.5, 6) in the exported (Y-up) scene.
    assert after["camera_position"] == pytest.approx([0.0, 0.5, 6.0], abs=1e-5)
    # Untouched values stay.
    for k in ("faceting", "seed", "camera", "border_width", "superpixels", "saliency_method"):
        assert before[k] == after[k]


def test_render_region_is_the_same_part_of_the_frame(bpy, tmp_path):
    scene = new_scene(bpy)
    full = read_png(bpy, render_still(bpy, scene, tmp_path / "full.png"))
    r = scene.render
    r.use_border, r.use_crop_to_border = True, True
    r.border_min_x, r.border_max_x, r.border_min_y, r.border_max_y = 0.25, 0.75, 0.5, 1.0
    crop = read_png(bpy, render_still(bpy, scene, tmp_path / "crop.png"))
    # Rows bottom-up: y from 24 to 48 is the top half.
    assert crop.shape == (24, 32, 4)
    assert np.array_equal(crop, full[24:48, 16:48])


def test_render_region_rounds_as_blender_does(bpy, tmp_path):
    """A border whose edge falls on a pixel in Blender's single precision (0.7 x 120 = 84) but
    just below it in double precision (83.99999857): the region is Blender's, whole, with and
    without crop (a region one row short left the crop's top row empty in the interface)."""
    scene = new_scene(bpy, 160, 120)
    full = read_png(bpy, render_still(bpy, scene, tmp_path / "full.png"))
    r = scene.render
    r.border_min_x, r.border_max_x, r.border_min_y, r.border_max_y = 0.25, 0.75, 0.2, 0.7
    r.use_border, r.use_crop_to_border = True, True
    crop = read_png(bpy, render_still(bpy, scene, tmp_path / "crop.png"))
    assert crop.shape == (60, 80, 4)  # Blender's size: rows 24-84, columns 40-120
    assert np.array_equal(crop, full[24:84, 40:120])
    r.use_crop_to_border = False
    border = read_png(bpy, render_still(bpy, scene, tmp_path / "border.png"))
    assert border.shape == full.shape
    assert np.array_equal(border[24:84, 40:120], full[24:84, 40:120])
    outside = np.ones(border.shape[:2], bool)
    outside[24:84, 40:120] = False
    assert border[outside][:, 3].max() == 0


def test_builtin_preset_operator_sets_the_panel(bpy):
    scene = new_scene(bpy)
    scene.cubist.pass_depth = True
    bpy.ops.cubist.apply_preset(name="Voronoi Facets")
    c = scene.cubist
    assert (c.preset, c.faceting, c.discontinuity, c.palette) == ("ANALYTIC", "VORONOI", 110.0, "OCHRE_GREY")
    bpy.ops.cubist.apply_preset(name="Plain")
    assert (c.preset, c.faceting, c.discontinuity, c.palette, c.border_width) == ("PLAIN", "NONE", 0.0, "NONE", 0.0)
    bpy.ops.cubist.apply_preset(name="Braque")
    assert (c.preset, c.faceting, c.palette, c.colors, c.ambiguity) == ("BRAQUE", "PLANES", "OLIVE", 8, 0.0)
    bpy.ops.cubist.apply_preset(name="Thesis")
    assert (c.preset, c.faceting, c.framing, c.aim_min_coverage) == ("THESIS", "SEGMENT", "FIT", 0.0)
    assert c.spp == 1 and c.pass_depth  # sampling and passes are not part of a look


def test_user_presets_save_and_load(bpy):
    scene = new_scene(bpy)
    scene.cubist.faceting, scene.cubist.discontinuity, scene.cubist.ambiguity = "PATCH", 77.0, 123.0
    scene.cubist.pass_depth = True
    assert bpy.ops.cubist.preset_add(name="My Look") == {"FINISHED"}
    path = Path(bpy.utils.preset_find("My Look", "cubist", display_name=True))
    try:
        assert "cubist.discontinuity = 77.0" in path.read_text()
        bpy.ops.cubist.apply_preset(name="Plain")
        assert scene.cubist.faceting == "NONE"
        bpy.ops.script.execute_preset(filepath=str(path), menu_idname="CUBIST_MT_presets")
        assert (scene.cubist.faceting, scene.cubist.discontinuity, scene.cubist.ambiguity) == ("PATCH", 77.0, 123.0)
        assert scene.cubist.pass_depth  # presets are looks: passes are not part of them
    finally:
        path.unlink()


def test_missing_binary_is_an_error_and_writes_nothing(bpy, engine, tmp_path):
    scene = new_scene(bpy)
    prefs = bpy.context.preferences.addons["blender_addon"].preferences
    saved = prefs.binary_path
    prefs.binary_path = str(tmp_path / "no" / "cubist")
    try:
        with pytest.raises(RuntimeError, match="cubist binary not found at"):
            render_still(bpy, scene, tmp_path / "x.png")
    finally:
        prefs.binary_path = saved
    assert not (tmp_path / "x.png").exists()


def test_renderer_error_reaches_the_user(bpy, engine, tmp_path):
    scene = new_scene(bpy)
    scene.cubist.camera = "PLANAR"
    scene.cubist.ambiguity = 200.0
    with pytest.raises(RuntimeError, match="ambiguity.*impossible for the planar camera"):
        render_still(bpy, scene, tmp_path / "x.png")
    assert not (tmp_path / "x.png").exists()
    # The session's renderer answered with the error (no process exit code: it keeps serving).
    assert engine.last_run["server"] and engine.last_run["error"].startswith("invalid setting `ambiguity`")


def test_empty_scene_is_an_error(bpy, tmp_path):
    scene = new_scene(bpy)
    for ob in list(scene.objects):
        if ob.type == "MESH":
            bpy.data.objects.remove(ob)
    with pytest.raises(RuntimeError, match="nothing to render"):
        render_still(bpy, scene, tmp_path / "x.png")
    assert not (tmp_path / "x.png").exists()


def test_a_mesh_without_faces_gets_the_renderers_message(bpy, tmp_path):
    scene = new_scene(bpy)
    for ob in list(scene.objects):
        if ob.type == "MESH":
            bpy.data.objects.remove(ob)
    me = bpy.data.meshes.new("Points")
    me.from_pydata([(0, 0, 0), (1, 0, 0), (0, 1, 0)], [], [])
    scene.collection.objects.link(bpy.data.objects.new("Points", me))
    with pytest.raises(RuntimeError, match="Cubist: the exported scene: the scene has no triangles to render"):
        render_still(bpy, scene, tmp_path / "x.png")
    assert not (tmp_path / "x.png").exists()


def test_cancel_kills_the_renderer_and_leaves_no_temp_files(bpy, engine, tmp_path):
    # Blender's cancel (Esc) as test_break() would report it: once the renderer is under way.
    engine.cancel_hook = lambda: engine.last_run.get("progress_lines", 0) > 0
    try:
        scene = new_scene(bpy, 640, 480)
        scene.cubist.spp = 64  # seconds of work: long enough to be cancelled mid-way
        before = cubist_temp_dirs()
        render_still(bpy, scene, tmp_path / "x.png")
    finally:
        engine.cancel_hook = None
    assert engine.last_run.get("cancelled"), engine.last_run
    # The session's renderer stopped that render: nothing runs or waits; it stays for the next.
    client = sys.modules["blender_addon.server"].current()
    assert client is not None and client.pid == engine.last_run["server"]
    stats = client.stats()
    assert stats["running"] is None and stats["queued"] == 0, stats
    assert not engine.last_run["workspace"].exists()
    assert cubist_temp_dirs() - before == set()
    # Nothing of the renderer's reached the result. (Blender still saves the empty result
    # here because a simulated cancel is not Blender's own Esc, which stops the job unsaved.)
    if (tmp_path / "x.png").exists():
        assert not read_png(bpy, tmp_path / "x.png").any(), "a partial picture was delivered"


# ---------------------------------------------------------------------------------------------
# Animation: moving camera and object, static facets


def animated_scene(bpy, layout_dir: Path, faceting="VORONOI"):
    scene = new_scene(bpy, 64, 48)
    scene.frame_start, scene.frame_end = 1, 3
    cam = scene.camera
    for frame, x in ((1, -1.0), (3, 1.0)):
        cam.location.x = x
        cam.keyframe_insert("location", index=0, frame=frame)
    cube = scene.objects["Cube"]
    for frame, z in ((1, -0.3), (3, 0.6)):
        cube.location.z = z
        cube.keyframe_insert("location", index=2, frame=frame)
    c = scene.cubist
    c.faceting = faceting
    if faceting == "VORONOI":
        c.facet_count = 12
        c.grid_cells = 4
        c.discontinuity = 100.0
    c.static_facets = True
    c.layout_folder = str(layout_dir)
    return scene


def render_animation(bpy, scene, out_dir: Path, layout_hashes: list, ext="png"):
    def snapshot(scene_, *args):
        layouts = sorted(Path(scene_.cubist.layout_folder).glob("*.facets.json"))
        layout_hashes.append({p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in layouts})

    bpy.app.handlers.render_post.append(snapshot)
    try:
        scene.render.filepath = str(out_dir / "frame_####")
        bpy.ops.render.render(animation=True)
    finally:
        bpy.app.handlers.render_post.remove(snapshot)
    return {f: out_dir / f"frame_{f:04d}.{ext}" for f in range(scene.frame_start, scene.frame_end + 1)}


def test_animation_renders_every_frame_with_one_layout(bpy, engine, tmp_path):
    scene = animated_scene(bpy, tmp_path / "layouts")
    engine.history.clear()
    hashes = []
    frames = render_animation(bpy, scene, tmp_path / "out", hashes)
    images = {f: read_png(bpy, p) for f, p in frames.items()}
    # Three different pictures: the camera and the cube move.
    for a, b in ((1, 2), (2, 3), (1, 3)):
        assert np.abs(images[a] - images[b]).max() > 0.1, f"frames {a} and {b} are the same picture"
    runs = [h for h in engine.history if h["frame"] in frames]
    assert [h["frame"] for h in runs] == [1, 2, 3]
    positions = [tuple(round(v, 4) for v in h["settings"]["camera_position"]) for h in runs]
    assert len(set(positions)) == 3, f"the camera did not move in the export: {positions}"
    # Static facets: frame 1 computes and saves the layout, frames 2 and 3 load that file.
    layout = runs[0]["settings"].get("save_facets")
    assert layout, "frame 1 did not ask the renderer to save the layout"
    assert [h["settings"].get("facets") for h in runs[1:]] == [layout, layout], [h["warnings"] for h in runs]
    assert Path(layout).is_file(), "the renderer did not write the facet layout"
    assert len(hashes) == 3 and hashes[0] == hashes[1] == hashes[2] and hashes[0], hashes


@pytest.mark.parametrize("faceting", ["VORONOI", "SEGMENT"])
def test_frame_chunks_match_one_run(bpy, engine, tmp_path, faceting):
    """Frames 2-3 rendered alone (another process or farm machine, no layout yet) equal the
    same frames of a 1-3 run: the chunk computes the layout on frame 1 first."""
    scene = animated_scene(bpy, tmp_path / "layouts_full", faceting)
    full = render_animation(bpy, scene, tmp_path / "full", [])
    scene = animated_scene(bpy, tmp_path / "layouts_chunk", faceting)
    # A farm chunk: `blender -b file.blend -E CUBIST -s 2 -e 3 -a` moves the frame range start.
    scene.frame_start, scene.frame_end = 2, 3
    chunk = render_animation(bpy, scene, tmp_path / "chunk", [])
    full_layouts = sorted((tmp_path / "layouts_full").glob("*.facets.json"))
    chunk_layouts = sorted((tmp_path / "layouts_chunk").glob("*.facets.json"))
    assert full_layouts and [p.name for p in full_layouts] == [p.name for p in chunk_layouts]
    assert full_layouts[0].read_bytes() == chunk_layouts[0].read_bytes()
    for f in (2, 3):
        assert np.array_equal(read_png(bpy, full[f]), read_png(bpy, chunk[f])), f"frame {f} differs"


def test_static_segment_facets_stay_while_the_picture_moves(bpy, engine, tmp_path):
    """Segment facets (computed from the layout frame's pre-render; the planes default does the same):
    every frame has the same facets, down to each pixel's facet id, while the camera and the
    cube move through them."""
    scene = animated_scene(bpy, tmp_path / "layouts", faceting="SEGMENT")
    assert scene.cubist.preset == "ANALYTIC" and scene.cubist.faceting == "SEGMENT"
    scene.cubist.pass_facet_ids = True
    use_multilayer_exr(scene)
    engine.history.clear()
    hashes = []
    frames = render_animation(bpy, scene, tmp_path / "out", hashes, ext="exr")
    runs = [h for h in engine.history if h["frame"] in frames]
    assert [h["settings"]["faceting"] for h in runs] == ["segment"] * 3
    assert [bool(h["settings"].get("save_facets")) for h in runs] == [True, False, False]
    assert len(hashes) == 3 and hashes[0] == hashes[1] == hashes[2] and hashes[0], hashes
    layer = bpy.context.view_layer.name
    ch = {f: exr_channels(p) for f, p in frames.items()}
    ids = [ch[f][f"{layer}.Facet Index.X"] for f in frames]
    assert len(np.unique(ids[0])) >= 4, np.unique(ids[0])
    assert all(np.array_equal(ids[0], i) for i in ids[1:]), "the facets moved between frames"
    rgb = [np.stack([ch[f][f"{layer}.Combined.{c}"] for c in "RGB"]) for f in frames]
    for a, b in ((0, 1), (1, 2), (0, 2)):
        assert np.abs(rgb[a] - rgb[b]).max() > 0.1, f"frames {a + 1} and {b + 1} are the same picture"


def test_segment_layout_follows_what_the_layout_frame_shows(bpy, engine, tmp_path):
    """A Segment layout is reused while the layout frame shows the same thing; a camera or an
    object moved there gives new facets (on the next render, whatever its frame); painterly
    changes keep them."""
    scene = new_scene(bpy)
    c = scene.cubist
    c.layout_folder = str(tmp_path / "layouts")
    c.faceting = "SEGMENT"
    assert c.static_facets
    layout_bytes = lambda: Path(engine.last_run["layout"]).read_bytes()  # noqa: E731

    render_still(bpy, scene, tmp_path / "1.png")
    assert "save_facets" in engine.last_run["settings"]
    first = layout_bytes()
    c.palette = "GREY"
    render_still(bpy, scene, tmp_path / "2.png")
    assert "facets" in engine.last_run["settings"] and "save_facets" not in engine.last_run["settings"]
    assert layout_bytes() == first

    scene.camera.location.x += 0.6
    render_still(bpy, scene, tmp_path / "3.png")
    assert "save_facets" in engine.last_run["settings"], "the camera moved: the layout is stale"
    moved = layout_bytes()
    assert moved != first

    # From another frame: the layout frame is checked, and the layout computed there again.
    scene.objects["Cube"].location.z += 0.5
    scene.frame_set(5)
    render_still(bpy, scene, tmp_path / "5.png")
    assert engine.last_run["prepass"] == 1 and engine.last_run["settings"]["facets"] == engine.last_run["layout"]
    assert layout_bytes() != moved
    render_still(bpy, scene, tmp_path / "5b.png")
    assert engine.last_run["prepass"] is None  # unchanged since: reused
    assert np.array_equal(read_png(bpy, tmp_path / "5.png"), read_png(bpy, tmp_path / "5b.png"))


def test_a_layout_file_of_the_users_is_used_for_every_frame(bpy, engine, tmp_path):
    scene = animated_scene(bpy, tmp_path / "layouts")
    render_still(bpy, scene, tmp_path / "first.png")
    saved = engine.last_run["settings"]["save_facets"]
    own = tmp_path / "mine.facets.json"
    own.write_bytes(Path(saved).read_bytes())
    scene.cubist.layout_file = str(own)
    scene.frame_set(3)
    render_still(bpy, scene, tmp_path / "third.png")
    sent = engine.last_run["settings"]
    assert sent["facets"] == str(own) and "save_facets" not in sent, sent
    assert engine.last_run["layout"] is None  # no layout of the add-on's


def test_saliency_cache_follows_the_panel(bpy, engine, tmp_path):
    # A fresh session's renderer: one that computed these meshes' saliency in an earlier test
    # keeps it in memory and has nothing to write to a cache.
    sys.modules["blender_addon.server"].shutdown()
    scene = new_scene(bpy)  # Segment faceting: mesh saliency is computed
    scene.cubist.layout_folder = str(tmp_path / "layouts")
    render_still(bpy, scene, tmp_path / "a.png")
    cache = tmp_path / "layouts" / "saliency"
    assert engine.last_run["settings"]["saliency_cache"] == str(cache)
    assert any(cache.iterdir()), "no saliency was cached"
    scene.cubist.saliency_cache = str(tmp_path / "elsewhere")
    sys.modules["blender_addon.server"].shutdown()
    render_still(bpy, scene, tmp_path / "b.png")
    assert any((tmp_path / "elsewhere").iterdir())
    scene.cubist.use_saliency_cache = False
    render_still(bpy, scene, tmp_path / "c.png")
    assert "saliency_cache" not in engine.last_run["settings"]
    # The cache saves time only: the same picture.
    assert np.array_equal(read_png(bpy, tmp_path / "a.png"), read_png(bpy, tmp_path / "c.png"))


def test_recompute_layout_removes_the_saved_layout(bpy, engine, tmp_path):
    scene = animated_scene(bpy, tmp_path / "layouts")
    path = engine.current_layout_path(scene)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("{}")
    bpy.ops.cubist.recompute_layout()
    assert not path.exists()


# ---------------------------------------------------------------------------------------------
# Render passes


def png16_grey(path: Path) -> np.ndarray:
    """A 16-bit greyscale PNG as (h, w) integers, rows top-down: decoded here (zlib and the
    PNG filters), independently of Blender's image loading the add-on uses."""
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    pos, idat, ihdr = 8, b"", None
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        pos += 12 + n
        if kind == b"IHDR":
            ihdr = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
    w, h, depth, colour_type, _, _, interlace = ihdr
    assert (depth, colour_type, interlace) == (16, 0, 0), ihdr
    raw, stride, bpp = zlib.decompress(idat), 2 * w, 2
    rows, prev = [], [0] * stride
    for y in range(h):
        f, line = raw[y * (stride + 1)], raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)]
        cur = [0] * stride
        for x in range(stride):
            a = cur[x - bpp] if x >= bpp else 0
            b, c = prev[x], (prev[x - bpp] if x >= bpp else 0)
            if f == 0:
                pred = 0
            elif f == 1:
                pred = a
            elif f == 2:
                pred = b
            elif f == 3:
                pred = (a + b) // 2
            else:
                pa, pb, pc = abs(b - c), abs(a - c), abs(a + b - 2 * c)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
            cur[x] = (line[x] + pred) & 0xFF
        rows.append(cur)
        prev = cur
    return np.array(rows, dtype=np.uint8).view(">u2").astype(np.int64)


def test_passes_reach_the_render_result(bpy, engine, exports, tmp_path):
    """Every pass arrives in Blender's render result (compositor, multilayer EXR) with the
    renderer's values: saliency 0-1, facet ids as exact integers, the rest as data colours."""
    scene = new_scene(bpy)
    for toggle in ("pass_saliency", "pass_facet_ids", "pass_facets", "pass_segments", "pass_objects",
                   "pass_normals", "pass_depth"):
        setattr(scene.cubist, toggle, True)
    use_multilayer_exr(scene)
    scene.render.filepath = str(tmp_path / "passes.exr")
    bpy.ops.render.render(write_still=True)
    ch = exr_channels(tmp_path / "passes.exr")
    layer = bpy.context.view_layer.name
    mapping = sys.modules["blender_addon.mapping"]
    for _toggle, _name, bname, channels, chan_id, _kind in mapping.PASSES:
        for c in (chan_id if channels == 3 else "X"):
            assert f"{layer}.{bname}.{c}" in ch, sorted(ch)
    # The same passes from the CLI on the same scene and settings.
    glb = exports / f"frame_{scene.frame_current:04d}.glb"
    cli_render(tmp_path, glb, tmp_path / "cli.png", engine.last_run["settings_json"])
    exr = lambda name: ch[f"{layer}.{name}"][::-1]  # noqa: E731 (EXR rows run top-down, Blender's bottom-up)
    depth = read_png(bpy, tmp_path / "cli.depth.png")[..., 0]
    assert np.abs(exr("Cubist Depth.X") - depth).max() < 1e-6
    assert depth.std() > 0.05  # not an empty pass
    for bname, name in (("Object Colors", "objects"), ("Cubist Normal", "normals"), ("Facets", "facets"),
                        ("Segments", "segments")):
        png = read_png(bpy, tmp_path / f"cli.{name}.png")
        for i, c in enumerate("RGB"):
            assert np.abs(exr(f"{bname}.{c}") - png[..., i]).max() < 1e-6, (bname, c)
    saliency = read_png(bpy, tmp_path / "cli.saliency.png")[..., 0]
    assert np.abs(exr("Saliency.X") - saliency).max() < 1e-6 and saliency.max() > 0.5
    # Facet ids: the 16-bit PNG decoded here, top-down like the EXR's rows.
    ids = ch[f"{layer}.Facet Index.X"]
    expected = png16_grey(tmp_path / "cli.facet-ids.png")
    assert np.array_equal(ids, expected.astype(np.float32)), np.abs(ids - expected).max()
    assert len(np.unique(expected)) >= 4


# ---------------------------------------------------------------------------------------------
# Packaging


EXTENSION_SCRIPT = r"""
import json, os, sys, tempfile
os.environ["BLENDER_USER_RESOURCES"] = tempfile.mkdtemp(prefix="cubist-blender-ext-")
import bpy
zip_path, out = sys.argv[1], sys.argv[2]
res = bpy.ops.extensions.package_install_files(filepath=zip_path, repo="user_default", enable_on_install=True)
pkg = "bl_ext.user_default.cubist"
runner = sys.modules[pkg + ".runner"]
binary = str(runner.find_binary(""))
bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
scene = bpy.context.scene
bpy.ops.mesh.primitive_monkey_add()
cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
scene.collection.objects.link(cam)
cam.location = (0, -5, 0); cam.rotation_euler = (1.5708, 0, 0)
scene.camera = cam
scene.render.engine = "CUBIST"
scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 32, 24, 100
scene.cubist.spp = 1
scene.render.filepath = out
bpy.ops.render.render(write_still=True)
print("RESULT " + json.dumps({"install": sorted(res), "enabled": pkg in bpy.context.preferences.addons,
                              "binary": binary, "written": os.path.isfile(out)}))
"""


def test_extension_zip_installs_and_renders_with_its_bundled_binary(cubist_binary, tmp_path):
    r = subprocess.run([sys.executable, str(ROOT / "scripts" / "build_addon.py"), "--binary", str(cubist_binary),
                        "--out", str(tmp_path / "dist")], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    zip_path = Path(r.stdout.strip().splitlines()[-1])
    assert zip_path.name.startswith("cubist-") and zip_path.suffix == ".zip"
    # Blender's own strict manifest validation (what `blender --command extension validate` runs).
    import importlib.util

    bpy_dir = Path(importlib.util.find_spec("bpy").origin).parent
    validator = next(bpy_dir.glob("*/scripts/addons_core/bl_pkg/cli/blender_ext.py"))
    for source in (ROOT / "blender_addon", zip_path):
        v = subprocess.run([sys.executable, str(validator), "validate", str(source)], capture_output=True, text=True)
        assert v.returncode == 0 and "Success" in v.stdout, f"{source}: {v.stdout}{v.stderr}"
    script = tmp_path / "install.py"
    script.write_text(EXTENSION_SCRIPT)
    env = dict(os.environ, PATH="/usr/bin:/bin")  # no cubist on PATH: the bundled one must be used
    env.pop("BLENDER_USER_RESOURCES", None)
    r = subprocess.run([sys.executable, str(script), str(zip_path), str(tmp_path / "ext.png")],
                       capture_output=True, text=True, env=env, timeout=300)
    line = next((ln for ln in r.stdout.splitlines() if ln.startswith("RESULT ")), None)
    assert line, f"{r.stdout[-2000:]}\n{r.stderr[-3000:]}"
    res = json.loads(line[len("RESULT "):])
    assert res["install"] == ["FINISHED"] and res["enabled"], res
    assert "/extensions/user_default/cubist/bin/" in res["binary"].replace(os.sep, "/"), res
    assert res["written"], r.stderr[-3000:]
