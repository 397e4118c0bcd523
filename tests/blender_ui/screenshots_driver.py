"""Takes the screenshots of docs/blender.md in a windowed Blender under Xvfb, for
scripts/blender-screenshots.sh: the Cubist panel at the Properties editor's default width, the
viewport in Rendered shading, and an F12 result. Run as the windowed tests run Blender:

    blender --factory-startup --python tests/blender_ui/screenshots_driver.py -- ROOT OUT BINARY

Each screenshot is the whole X screen (ImageMagick's `import -window root`) with the rectangle
of the part shown (X coordinates, from the top left) in OUT/shots.json; the script crops them.
From a `bpy.app.timers` generator, as the other windowed drivers; F12 is a key press
(user_input.py says why)."""

import json
import subprocess
import sys
import time
from pathlib import Path

import bpy

ARGS = sys.argv[sys.argv.index("--") + 1:]
ROOT, OUT, BINARY = Path(ARGS[0]), Path(ARGS[1]), ARGS[2]
OUT.mkdir(parents=True, exist_ok=True)
sys.path.insert(0, str(ROOT / "tests" / "blender_ui"))
import stepper  # noqa: E402
import user_input  # noqa: E402

shots: dict = {}


def log(msg):
    print(f"[screenshots] {msg}", flush=True)


def area_of(kind):
    screen = bpy.context.window_manager.windows[0].screen
    return max((a for a in screen.areas if a.type == kind), key=lambda a: a.width * a.height)


def snap(name, area):
    """The whole screen now, and where `area` is on it."""
    window = bpy.context.window_manager.windows[0]
    path = OUT / f"{name}.full.png"
    subprocess.run(["import", "-window", "root", str(path)], check=True)
    # Blender counts rows from the window's bottom, X from the top.
    shots[name] = {"file": path.name, "box": [area.x, window.height - (area.y + area.height),
                                              area.x + area.width, window.height - area.y]}
    log(f"{name}: {shots[name]}")


def redraw(seconds=1.0):
    for window in bpy.context.window_manager.windows:
        for area in window.screen.areas:
            area.tag_redraw()
    t0 = time.monotonic()
    while time.monotonic() - t0 < seconds:
        yield 0.1


def setup_scene():
    """The factory scene with a monkey above the cube, Cubist at 800 x 600."""
    import addon_utils

    sys.path.insert(0, str(ROOT))
    assert addon_utils.enable("blender_addon", default_set=True, persistent=True) is not None
    bpy.context.preferences.addons["blender_addon"].preferences.binary_path = BINARY
    user_input.install()
    bpy.context.preferences.view.render_display_type = "AREA"  # the result in the main window
    scene = bpy.context.scene
    monkey = bpy.data.objects.new("Suzanne", bpy.data.meshes.new("Suzanne"))
    scene.collection.objects.link(monkey)
    import bmesh

    bm = bmesh.new()
    bmesh.ops.create_monkey(bm)
    bm.to_mesh(monkey.data)
    bm.free()
    monkey.location = (0.0, 0.0, 2.1)
    monkey.scale = (1.2, 1.2, 1.2)
    scene.render.engine = "CUBIST"  # as the Render Engine menu does
    r = scene.render
    # Larger than the camera frame on screen: the viewport scales the picture down to the frame.
    r.resolution_x, r.resolution_y, r.resolution_percentage = 800, 600, 100
    scene.cubist.layout_folder = str(OUT / "layouts")
    props = area_of("PROPERTIES")
    props.spaces[0].context = "RENDER"


def main():
    setup_scene()
    yield 1.0  # the message bus (the colour notice) is handled by the event loop
    user_input.focus_main_window()  # the click also closes the splash screen
    yield from redraw()
    snap("panel", area_of("PROPERTIES"))

    view = area_of("VIEW_3D")
    space = view.spaces[0]
    space.shading.type = "RENDERED"
    space.overlay.show_extras = False  # no light and camera outlines over the painting
    space.region_3d.view_perspective = "CAMERA"  # through the scene's camera, as F12 sees it
    t0 = time.monotonic()
    while time.monotonic() - t0 < 40:  # the full-size image (1/4, 1/2, then full)
        yield 1.0
    yield from redraw()
    snap("viewport", view)
    space.shading.type = "SOLID"
    yield from redraw(2.0)

    started = yield from user_input.press_render()
    log(f"F12: {started}")
    while bpy.app.is_job_running("RENDER"):
        yield 0.2
    yield from redraw(2.0)
    snap("f12", area_of("IMAGE_EDITOR"))


stepper.run(main, shots, lambda: (OUT / "shots.json").write_text(json.dumps(shots, indent=1)), log,
            user_input.quit_blender)
