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
