"""Colour management in headless Blender (bpy 5.0.1): with factory settings (the
AgX view transform) F12 saves the renderer's own colours; a scene whose colour management the
user set is left as set, and the Cubist panel warns and offers the fix; passes stay data."""

import subprocess
import sys

import numpy as np
import pytest

from addon_support import BINARY, addon, bpy, bpy_module, cubist_binary  # noqa: F401
from test_addon_blender import FakeLayout, exr_channels, use_multilayer_exr


@pytest.fixture
def engine(addon):
    return sys.modules["blender_addon.engine"]


@pytest.fixture
def exports(engine, tmp_path):
    folder = tmp_path / "exports"
    engine.keep_exports = folder
    yield folder
    engine.keep_exports = None


def factory_scene(bpy):
    """What a new user has: Blender's factory settings (colour management, dither, output
    format untouched), a monkey, a camera, a sun."""
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    scene = bpy.context.scene
    assert scene.view_settings.view_transform == "AgX"
    assert scene.render.image_settings.file_format == "PNG"
    bpy.ops.mesh.primitive_monkey_add()
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(cam)
    cam.location, cam.rotation_euler = (0.0, -5.0, 0.4), (1.5, 0.0, 0.0)
    scene.camera = cam
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.rotation_euler = (0.6, 0.2, 0.4)
    scene.collection.objects.link(sun)
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 96, 72, 100
    return scene


def choose_cubist(scene):
    """What the user does: Render Engine > Cubist (and 1 sample, to keep the test short)."""
    scene.render.engine = "CUBIST"
    scene.cubist.spp = 1


def f12(bpy, scene, path):
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)
    return path


def cli_picture(tmp_path, exports, name="cli.png"):
    out = tmp_path / name
    r = subprocess.run([str(BINARY), "render", str(exports / "frame_0001.glb"), "-o", str(out), "--config",
                        str(exports / "settings_0001.json")], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return out


def pixels(path):
    return sys.modules["blender_addon.pngio"].read(path).astype(np.int32)


def panel_labels(bpy, scene):
    ui = sys.modules["blender_addon.ui"]
    drawn = []
    panel = type("P", (), {"layout": FakeLayout(drawn)})()
    ui.CUBIST_PT_render.draw(panel, bpy.context)
    return [d[len("label:"):] for d in drawn if d.startswith("label:")]


def test_factory_settings_f12_saves_the_renderers_colours(bpy, engine, exports, tmp_path):
    scene = factory_scene(bpy)
    choose_cubist(scene)
    saved = pixels(f12(bpy, scene, tmp_path / "f12.png"))
    cli = pixels(cli_picture(tmp_path, exports))
    assert saved.shape == cli.shape
    assert np.abs(saved - cli).max() <= 1, f"max difference {np.abs(saved - cli).max()}/255"
    # Done by the add-on, said in the panel, undoable there.
    assert scene.view_settings.view_transform == "Standard"
    assert scene.cubist_colour.switched_from == "AgX"
    labels = panel_labels(bpy, scene)
    assert "was AgX" in " ".join(labels), labels  # wrapped over several labels
    # The test can fail: the same picture through AgX is far from the renderer's.
    assert bpy.ops.cubist.restore_view_transform() == {"FINISHED"}
    assert scene.view_settings.view_transform == "AgX"
    agx = pixels(f12(bpy, scene, tmp_path / "agx.png"))
    assert np.abs(agx - cli)[..., :3].mean() > 3, "AgX did not change the picture: the check above proves nothing"
    # Restored by the user: left as AgX from now on, with the warning.
    assert scene.view_settings.view_transform == "AgX"
    assert "The view transform AgX changes the painting's colours" in " ".join(panel_labels(bpy, scene))


@pytest.mark.parametrize("setting", ["view_transform", "look", "exposure"])
def test_colours_the_user_set_are_left_with_a_warning(bpy, engine, tmp_path, setting):
    scene = factory_scene(bpy)
    v = scene.view_settings
    if setting == "view_transform":
        v.view_transform = "Filmic"
    elif setting == "look":
        v.look = "AgX - Punchy"
    else:
        v.exposure = 0.5
    before = (v.view_transform, v.look, v.exposure)
    choose_cubist(scene)
    f12(bpy, scene, tmp_path / "f12.png")
    assert (v.view_transform, v.look, v.exposure) == before
    assert scene.cubist_colour.switched_from == ""
    labels = panel_labels(bpy, scene)
    assert "the painting's colours" in " ".join(labels) and "change" in " ".join(labels), labels
    # The one-click fix.
    assert bpy.ops.cubist.painting_colours() == {"FINISHED"}
    assert (v.view_transform, v.look, v.exposure, v.gamma) == ("Standard", "None", 0.0, 1.0)
    assert "painting's colours" not in " ".join(panel_labels(bpy, scene))


def test_passes_stay_data_under_the_users_view_transform(bpy, engine, exports, tmp_path):
    """Passes in a multilayer EXR hold the renderer's values whatever the view transform."""
    scene = factory_scene(bpy)
    scene.view_settings.view_transform = "Filmic"
    scene.view_settings.look = "Medium High Contrast"
    choose_cubist(scene)
    scene.cubist.pass_depth = scene.cubist.pass_normals = True
    use_multilayer_exr(scene)
    f12(bpy, scene, tmp_path / "passes.exr")
    assert scene.view_settings.view_transform == "Filmic"
    ch = exr_channels(tmp_path / "passes.exr")
    cli_picture(tmp_path, exports)
    layer = bpy.context.view_layer.name  # EXR and pngio rows both run top-down
    depth = pixels(tmp_path / "cli.depth.png")[..., 0] / 255.0
    assert np.abs(ch[f"{layer}.Cubist Depth.X"] - depth).max() < 1e-6
    normals = pixels(tmp_path / "cli.normals.png") / 255.0
    for i, c in enumerate("RGB"):
        assert np.abs(ch[f"{layer}.Cubist Normal.{c}"] - normals[..., i]).max() < 1e-6
    assert depth.std() > 0.05
