"""An unsaved file's layouts live in a per-session temporary folder (engine.unsaved_folder):
they must go when the file closes (another file loads) or Blender quits, not pile up in the
system's temporary directory."""

import os
import subprocess
import sys
import textwrap

import pytest

from addon_support import ROOT, addon, bpy, bpy_module, cubist_binary, new_scene  # noqa: F401


@pytest.fixture
def engine(addon):
    return sys.modules["blender_addon.engine"]


def test_unsaved_layouts_go_when_another_file_loads(bpy, engine, tmp_path):
    scene = new_scene(bpy)
    assert not bpy.data.filepath
    folder = engine.unsaved_folder()
    scene.render.filepath = str(tmp_path / "still.png")
    bpy.ops.render.render(write_still=True)
    assert (tmp_path / "still.png").is_file()
    assert folder.is_dir() and any(folder.iterdir()), "F12 on an unsaved file keeps its layout in the unsaved folder"
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    assert not folder.exists()


def test_unsaved_layouts_go_when_blender_quits(cubist_binary, tmp_path):
    script = textwrap.dedent(f"""
        import os, sys
        sys.path.insert(0, {str(ROOT / "tests" / "python")!r})
        import bpy
        import addon_support, addon_utils
        addon_utils.enable("blender_addon", default_set=True, persistent=True)
        bpy.context.preferences.addons["blender_addon"].preferences.binary_path = {str(cubist_binary)!r}
        scene = addon_support.new_scene(bpy)
        scene.render.filepath = {str(tmp_path / "still.png")!r}
        bpy.ops.render.render(write_still=True)
        folder = sys.modules["blender_addon.engine"].unsaved_folder()
        print("FOLDER", folder, folder.is_dir() and any(folder.iterdir()), flush=True)
    """)
    env = {**os.environ, "BLENDER_USER_RESOURCES": str(tmp_path / "user")}
    r = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 0, r.stderr[-3000:]
    line = next(line for line in r.stdout.splitlines() if line.startswith("FOLDER "))
    _, path, filled = line.split(" ")
    assert filled == "True", "the render kept its layout in the unsaved folder"
    assert not os.path.exists(path), f"{path} outlived Blender"
