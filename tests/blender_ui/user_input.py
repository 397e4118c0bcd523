"""F12, Ctrl+F12, Esc, Numpad 0 and Ctrl+Q as a user presses them, for the windowed drivers: X key events sent
with xdotool (XTEST) to Blender's main window and handled by Blender's own keymap.

Why not `bpy.ops.render.render('INVOKE_DEFAULT')` inside `bpy.context.temp_override`: Blender
3.4 runs an operator called from Python with the GIL released, and with an override it looks
the context up in the override's Python dict (`PyDict_GetItemString`) on the main thread
without the GIL, while the render job the operator has just started runs the add-on's
`render()` in Python on the render thread. That corrupted Python's heap: segmentation faults
in Python's garbage collector in about one run in three, and under `PYTHONMALLOC=debug`
"Python memory allocator called without holding the GIL" in 5 runs of 6, the main thread inside
`render.render`. A user's F12 has no Python override. So renders are started here by key,
and an operator with an override is only called while no render job runs (drivers that keep
add-on threads running, such as the viewport's, must not call operators with an override
while those run either).

The render result is kept in Blender's window (Preferences > Interface > Render In: Keep User
Interface) so that keys always reach the main window: a render window would open under the
pointer and take the next key, with its own scene."""

import subprocess
import time

import bpy

# Render jobs started (render_init handler, called once per F12 or Render Animation job).
_jobs_started: list = []


@bpy.app.handlers.persistent
def _job_started(*_args):
    _jobs_started.append(time.monotonic())


def install():
    """Keeps renders in the main window and counts render jobs; call once at setup."""
    bpy.context.preferences.view.render_display_type = "NONE"
    if _job_started not in bpy.app.handlers.render_init:
        bpy.app.handlers.render_init.append(_job_started)


def _xdotool(*args) -> str:
    return subprocess.run(["xdotool", *args], check=True, capture_output=True, text=True).stdout.strip()


def _main_window_id() -> str:
    """Blender's main window: the largest visible window named Blender."""
    best = None
    for wid in _xdotool("search", "--onlyvisible", "--name", "Blender").split():
        geometry = _xdotool("getwindowgeometry", "--shell", wid)
        size = dict(line.split("=", 1) for line in geometry.splitlines() if "=" in line)
        area = int(size.get("WIDTH", 0)) * int(size.get("HEIGHT", 0))
        if best is None or area > best[0]:
            best = (area, wid)
    if best is None:
        raise RuntimeError("no visible Blender window for the key press")
    return best[1]


def focus_main_window():
    """Keyboard focus on Blender's main window, and one click on the status bar's empty middle:
    until the window has had a button event, Blender under Xvfb (no window manager) ignores key
    presses."""
    wid = _main_window_id()
    _xdotool("windowfocus", "--sync", wid)
    window = bpy.context.window_manager.windows[0]
    _xdotool("mousemove", str(window.width // 2), str(window.height - 8))
    _xdotool("click", "1")


def press(keys: str, focus=True, area=None):
    """One key press (xdotool's names: "F12", "ctrl+F12", "Escape", "KP_0") with the pointer over
    the middle of `area` (for a region's keymap, such as the 3D view's Numpad 0), or of the
    main window. Keys during a render (Esc) go without the focusing click: the status bar then
    shows the job's progress and cancel button."""
    if focus:
        focus_main_window()
    window = bpy.context.window_manager.windows[0]
    x0, y0, w, h = (area.x, area.y, area.width, area.height) if area else (0, 0, window.width, window.height)
    # Blender counts rows from the bottom, X from the top.
    _xdotool("mousemove", str(x0 + w // 2), str(window.height - (y0 + h // 2)))
    _xdotool("key", keys)


def quit_blender():
    """Ctrl+Q as a user quits (Blender's quit prompt switched off): with add-on threads still
    running, the quit operator must not be called with an override (see above)."""
    bpy.context.preferences.view.use_save_prompt = False
    press("ctrl+q")


def press_render(animation=False, timeout=60.0):
    """F12 (Ctrl+F12 for an animation), then yields to Blender's event loop (a timer's generator)
    until the render job has begun; returns ["RUNNING_MODAL"], as the operator answers, or
    ["NOT STARTED"] if no job began within `timeout` seconds."""
    jobs = len(_jobs_started)
    press("ctrl+F12" if animation else "F12")
    t0 = time.monotonic()
    while len(_jobs_started) == jobs and not bpy.app.is_job_running("RENDER"):
        if time.monotonic() - t0 > timeout:
            return ["NOT STARTED"]
        yield 0.02
    return ["RUNNING_MODAL"]
