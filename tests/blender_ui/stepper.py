"""The windowed drivers' one stepper: a driver's steps are a generator run from a
`bpy.app.timers` callback on Blender's main thread, as a user's actions come between passes of
the interface's main loop. Each value the generator yields is the seconds until its next step.
When it ends or fails (the traceback goes to `results["failure"]`), the results are written and
Blender is made to quit: by Ctrl+Q as a user quits (user_input.py), with the operator as a
fallback, or by the operator directly.
"""

import os
import sys
import traceback

import bpy

import user_input


def run(main, results: dict, write_results, log, finish, first_interval: float = 2.0,
        persistent: bool = False) -> None:
    """Steps `main()` from a timer starting `first_interval` seconds from now (`persistent`:
    the timer survives File > New); at the end `write_results()`, then `finish()`."""
    steps = None

    def tick():
        nonlocal steps
        try:
            if steps is None:
                steps = main()
            return next(steps)
        except StopIteration:
            pass
        except BaseException:
            results["failure"] = traceback.format_exc()
            log(results["failure"])
        write_results()
        finish()
        return None

    bpy.app.timers.register(tick, first_interval=first_interval, persistent=persistent)


def quit_by_keys(override, log, fallback_after: float = 30.0):
    """A `finish`: Ctrl+Q (a render or the add-on's threads may still run: no operator with an
    override then, user_input.py), and the operator with `override()`'s context if Blender has
    not quit `fallback_after` seconds later, so the test never waits for its timeout."""

    def finish():
        user_input.quit_blender()
        bpy.app.timers.register(fallback, first_interval=fallback_after)

    def fallback():
        log(f"Ctrl+Q did not quit Blender in {fallback_after:.0f} s: quitting with the operator")
        with bpy.context.temp_override(**override()):
            bpy.ops.wm.quit_blender()

    return finish


def quit_by_operator(override, log, exit_code: int):
    """A `finish`: the quit operator in `override()`'s context; when Blender refuses it (its write
    guard stuck: docs/blender.md), the process leaves with `exit_code`, its results written."""

    def finish():
        try:
            with bpy.context.temp_override(**override()):
                bpy.ops.wm.quit_blender()
        except Exception:  # noqa: BLE001 - whatever Blender raises, leave rather than hang
            log(f"quit_blender failed: exiting\n{traceback.format_exc()}")
            sys.stdout.flush()
            os._exit(exit_code)

    return finish


__all__ = ["quit_by_keys", "quit_by_operator", "run"]
