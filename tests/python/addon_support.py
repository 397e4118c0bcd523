"""Fixtures and helpers of the add-on tests (imported by them, not a conftest.py, so other
suites in tests/python keep their own): the release binary (built when missing or stale),
headless Blender (bpy) with a throw-away user folder, the add-on enabled from this checkout."""

import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
BINARY = ROOT / "target" / "release" / ("cubist.exe" if sys.platform == "win32" else "cubist")

# Blender writes its user configuration here instead of ~/.config/blender (BLENDER_USER_RESOURCES).
# Set before anything imports bpy.
os.environ.setdefault("BLENDER_USER_RESOURCES", tempfile.mkdtemp(prefix="cubist-blender-user-"))

if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


def require_windowed_blender(tools, what: str, install: str) -> None:
    """Skips `what` (saying so on stderr) when any of `tools` is not installed, or fails it
    when CUBIST_REQUIRE_UI_TEST=1 (.ci/run installs them and requires the windowed tests)."""
    missing = [tool for tool in tools if shutil.which(tool) is None]
    if not missing:
        return
    message = f"{what} skipped: {', '.join(missing)} not installed ({install}; .ci/run does it)"
    if os.environ.get("CUBIST_REQUIRE_UI_TEST") == "1":
        pytest.fail(message.replace("skipped", "required (CUBIST_REQUIRE_UI_TEST=1)"))
    print(f"\nSKIP: {message}", file=sys.stderr)
    pytest.skip(message)


def run_windowed_blender(driver: Path, base: Path, cubist_binary: Path, label: str, extra_args=(),
                         out: Path = None) -> dict:
    """Runs `driver` in a windowed Blender under Xvfb with factory settings and its own user
    configuration (not the machine's preferences) and temporary directory (`base/tmp`, to check
    nothing is left there; xvfb-run keeps its own in the system's); the driver writes
    `base/out/results.json`. Returns the process, the results, the two folders and the log."""
    out, tmp = out or base / "out", base / "tmp"
    tmp.mkdir()
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTHON")}
    env.pop("BLENDER_USER_RESOURCES", None)
    env["BLENDER_USER_CONFIG"] = str(base / "config")
    # Python's debug allocator aborts on any Python allocation made without the GIL, which
    # otherwise corrupts the heap silently and crashes much later (user_input.py tells the case
    # it caught); the fault handler prints every thread's Python stack on a crash. Blender reads
    # them with --python-use-system-env, so no other PYTHON* variable is passed on.
    env["PYTHONMALLOC"] = "debug"
    env["PYTHONFAULTHANDLER"] = "1"
    t0 = time.monotonic()
    proc = subprocess.run(["xvfb-run", "-a", "-s", "-screen 0 1280x1024x24", "env", f"TMPDIR={tmp}", "blender",
                           "--factory-startup", "--python-use-system-env", "--python", str(driver), "--",
                           str(ROOT), str(out),
                           str(cubist_binary), *extra_args],
                          capture_output=True, text=True, env=env, timeout=1200)
    seconds = time.monotonic() - t0
    log = proc.stdout + proc.stderr
    (base / "blender.log").write_text(log)
    results_file = out / "results.json"
    assert results_file.is_file(), f"Blender ended (exit {proc.returncode}) without results:\n{log[-4000:]}"
    results = json.loads(results_file.read_text())
    print(f"\nwindowed Blender {results['blender']}{label}: {seconds:.0f} s, log {base / 'blender.log'}",
          file=sys.stderr)
    return {"proc": proc, "results": results, "out": out, "tmp": tmp, "log": log}


@pytest.fixture(scope="session")
def cubist_binary() -> Path:
    """The release binary. `cargo build --release` is a no-op (about a second) when
    `cargo test --release` already built it, and builds it on a fresh clone."""
    r = subprocess.run(["cargo", "build", "--release", "--locked", "--bin", "cubist"], cwd=ROOT,
                       capture_output=True, text=True)
    assert r.returncode == 0, f"cargo build --release failed:\n{r.stderr[-3000:]}"
    assert BINARY.is_file()
    return BINARY


@pytest.fixture(scope="session")
def bpy_module():
    import bpy

    return bpy


@pytest.fixture(scope="session")
def addon(bpy_module, cubist_binary):
    """The add-on enabled from this checkout as a legacy add-on (module `blender_addon`),
    with the binary path set in its preferences."""
    import addon_utils

    mod = addon_utils.enable("blender_addon", default_set=True, persistent=True)
    assert mod is not None, "addon_utils.enable('blender_addon') failed"
    prefs = bpy_module.context.preferences.addons["blender_addon"].preferences
    prefs.binary_path = str(cubist_binary)
    yield sys.modules["blender_addon"]


@pytest.fixture
def bpy(addon, bpy_module):
    """bpy, with the add-on enabled (what the add-on's tests take)."""
    return bpy_module


def new_scene(bpy, width=64, height=48, engine="CUBIST"):
    """An empty factory scene with a camera looking at a monkey and a cube, a sun, a grey
    world, and colour management that round-trips 8-bit sRGB exactly (Standard view transform)."""
    # Not read_factory_settings: it resets the preferences and so disables the add-on.
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_monkey_add(location=(0, 0, 0))
    bpy.ops.mesh.primitive_cube_add(size=0.8, location=(1.4, 0.5, -0.3))
    cam_data = bpy.data.cameras.new("Camera")
    cam = bpy.data.objects.new("Camera", cam_data)
    scene.collection.objects.link(cam)
    cam.location = (0.0, -6.0, 0.5)
    cam.rotation_euler = (1.4908, 0.0, 0.0)  # about 85 degrees: looking along +Y, slightly down
    scene.camera = cam
    sun_data = bpy.data.lights.new("Sun", "SUN")
    sun = bpy.data.objects.new("Sun", sun_data)
    sun.rotation_euler = (0.6, 0.2, 0.4)
    scene.collection.objects.link(sun)
    world = bpy.data.worlds.new("World")
    world.color = (0.3, 0.35, 0.4)
    if bpy.app.version < (5, 0, 0):
        world.use_nodes = True  # always on (and deprecated) from Blender 5
    scene.world = world
    r = scene.render
    r.engine = engine
    r.resolution_x, r.resolution_y, r.resolution_percentage = width, height, 100
    r.dither_intensity = 0.0
    r.image_settings.file_format = "PNG"
    r.image_settings.color_mode = "RGBA"
    r.image_settings.color_depth = "8"
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    if engine == "CUBIST":
        scene.cubist.spp = 1
    return scene


def read_png(bpy, path):
    """Pixels of a PNG as a float array (h, w, 4), rows bottom-up, no colour management."""
    import numpy as np

    img = bpy.data.images.load(str(path), check_existing=False)
    try:
        img.colorspace_settings.name = "Non-Color"
        w, h = img.size
        px = np.empty(w * h * 4, dtype=np.float32)
        img.pixels.foreach_get(px)
    finally:
        bpy.data.images.remove(img)
    return px.reshape(h, w, 4)
