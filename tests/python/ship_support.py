"""Helpers of the packaging, release and farm tests: Blender's own extension tool from the bpy
wheel (its manifest validator and platform names), and node for the Flamenco job type."""

import importlib.util
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from addon_support import ROOT  # noqa: F401 (re-exported; also puts ROOT on sys.path)


def blender_ext_path() -> Path:
    """bl_pkg's command-line tool inside the bpy wheel (`blender --command extension` runs it)."""
    spec = importlib.util.find_spec("bpy")
    if spec is None or spec.origin is None:
        pytest.skip("bpy is not installed (bash scripts/setup-python.sh installs it): Blender's extension tool "
                    "comes from its wheel")
    found = sorted(Path(spec.origin).parent.glob("*/scripts/addons_core/bl_pkg/cli/blender_ext.py"))
    assert found, f"no bl_pkg/cli/blender_ext.py in the bpy wheel at {Path(spec.origin).parent}"
    return found[0]


@pytest.fixture(scope="session")
def bpy_extension_cli():
    """Blender's blender_ext.py as a module (a stand-alone script: importing it runs nothing)."""
    path = blender_ext_path()
    spec = importlib.util.spec_from_file_location("cubist_tests_blender_ext", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def validate_extension(source: Path) -> subprocess.CompletedProcess:
    """Blender's strict manifest validation of a folder or zip (`blender --command extension validate`)."""
    return subprocess.run([sys.executable, str(blender_ext_path()), "validate", str(source)], capture_output=True,
                          text=True)


@pytest.fixture(scope="session")
def node() -> str:
    path = shutil.which("node")
    if path is None:
        pytest.skip("node is not installed: the Flamenco job type's compileJob is run in node "
                    "(Debian: apt-get install nodejs)")
    return path


# Python for the Blender subprocesses of these tests (bpy 5.0.1 or a `blender` executable, 3.4
# included): prepended to their scripts. A monkey seen by a camera, the Cubist engine, a small
# frame, one sample.
SCENE_PY = """
def cubist_scene(bpy, width=32, height=24):
    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_monkey_add()
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(cam)
    cam.location = (0, -5, 0)
    cam.rotation_euler = (1.5708, 0, 0)
    scene.camera = cam
    scene.render.engine = "CUBIST"
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = width, height, 100
    scene.cubist.spp = 1
    return scene
"""
