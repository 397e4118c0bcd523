"""F12 on the session's renderer, and Blender surviving whatever the renderer does, in the
interactive UI: a windowed Blender (Debian's 3.4.1) under Xvfb driven by
tests/blender_ui/host_driver.py through one session of steps (its docstring lists them): the
first F12 at 1920 x 1080 once render ahead prepared it (the same picture as without render
ahead), F12 again after one panel change, F12 on a new renderer with its coarse preview, Render
Animation reusing what did not change; the renderer killed during F12 and during the viewport's
render; fifty panel edits in five seconds; a renderer that stops answering, a binary for
another platform, one that is not executable; the temporary folder full and read-only; a
truncated and a garbage facet layout beside the .blend; File > New and Ctrl+Q during F12.

Every step ends with Blender writing to its scene from the main thread and its main loop
running; after Blender has quit, no renderer process and no temporary folder of the add-on is
left. Times are printed (BENCHMARKS.md has the figures), never asserted.

Needs `blender`, `xvfb-run` and `xdotool` (.ci/run installs them); the full and read-only
temporary folder step needs a tmpfs it mounts (root), and says so when it cannot."""

import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from addon_support import ROOT, cubist_binary, require_windowed_blender, run_windowed_blender  # noqa: F401

DRIVER = ROOT / "tests" / "blender_ui" / "host_driver.py"
TOOLS = {"blender": "blender", "xvfb-run": "xvfb", "xdotool": "xdotool"}


def alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    try:
        return Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0] != "Z"
    except OSError:
        return False


@pytest.fixture(scope="module")
def ui(cubist_binary, tmp_path_factory):
    """The driver's run. Blender 3.4 can get its process-wide 'no writes to datablocks' flag
    stuck after a render (host_driver.WRITE_LOCK, a Blender bug no add-on can reset): the driver
    then stops and the steps left, the stuck one first, run in a new Blender (at most 3 reruns)."""
    require_windowed_blender(TOOLS, "windowed Blender host test", "apt-get install blender xvfb xauth xdotool")
    base = tmp_path_factory.mktemp("blender_host")
    tiny = base / "tiny"
    tiny.mkdir()
    mounted = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1m", "tmpfs", str(tiny)],
                             capture_output=True, text=True).returncode == 0
    steps, locks, logs, remaining, run = {}, [], [], "", None
    try:
        for attempt in range(4):
            (base / f"run{attempt}").mkdir()
            run = run_windowed_blender(DRIVER, base / f"run{attempt}", cubist_binary, " (host)",
                                       extra_args=(str(tiny) if mounted else "-", remaining))
            steps.update(run["results"]["steps"])
            logs.append(run["log"])
            lock = run["results"].get("write_lock")
            if lock is None:
                break
            locks.append(lock)
            remaining = ",".join(run["results"]["remaining"])
    finally:
        if mounted:
            subprocess.run(["umount", "-l", str(tiny)], capture_output=True)
    run["results"]["steps"] = steps
    run["log"] = "\n".join(logs)
    run["mounted"] = mounted
    if locks:
        print(f"\nBlender 3.4's write flag got stuck {len(locks)} time(s): {locks}", file=sys.stderr)
    return run


def step(ui, name):
    s = ui["results"]["steps"].get(name)
    assert s is not None, f"step {name} did not run: {ui['results'].get('failure')}"
    after = s.get("after", {})
    # Blender is still itself: the main thread writes to the scene, the main loop runs (three
    # passes of it; under a loaded machine's software OpenGL a pass can take seconds).
    assert after.get("write") == "ok" and after.get("ticks", 0) >= 3 and after["seconds"] < 30, (name, after)
    return s


def ok(f12):
    return f12["operator"] == ["RUNNING_MODAL"] and f12["error"] is None and not f12["cancelled"]


def test_host_blender_runs_every_step_and_quits(ui):
    r = ui["results"]
    assert r["background"] is False
    assert "failure" not in r, r.get("failure")
    assert r["done"], ui["log"][-3000:]
    # Blender exits with 1 when it quits during a render (its 'break' flag), never from a signal.
    assert ui["proc"].returncode in (0, 1), ui["log"][-3000:]
    assert "Segmentation fault" not in ui["log"] and "Writing: " not in ui["log"]
    assert "Fatal Python error" not in ui["log"], ui["log"][-3000:]
    print(f"\nhost steps (s): {r['step_seconds']}", file=sys.stderr)


STAGES = {"pre-render", "saliency", "faceting", "imprecision", "re-trace", "anti-aliasing", "paint"}


def png_pixels(path):
    sys.path.insert(0, str(ROOT / "blender_addon"))
    import pngio

    return pngio.read(path)


def test_f12_after_an_idle_wait_hands_back_the_picture_rendered_ahead(ui):
    s = step(ui, "speed")
    first, cold = s["first"], s["cold"]
    assert ui["results"]["size"] == [1920, 1080, 100]
    assert ok(first) and ok(cold), (first, cold)
    assert first["prepared"]["ok"], first["prepared"]
    # F12 used the prepared job: no preview, every stage kept, the picture converted ahead.
    assert first["ahead"] == "ready" and first["preview"] is False and first["ahead_picture"], first
    assert not STAGES & set(first["timings"]), first["timings"]
    # The same picture as F12 without render ahead, on a renderer that kept nothing.
    assert cold["ahead"] is None and cold["reused"] == [] and cold["server"] != first["server"], cold
    # Both pictures reached the Render Result (saved within the driver's wait).
    assert first["saved_tries"] and cold["saved_tries"], (first["saved_tries"], cold["saved_tries"])
    assert np.array_equal(png_pixels(ui["out"] / "first.png"), png_pixels(ui["out"] / "cold.png"))
    marks = dict(first["timeline"])
    print(f"\nfirst F12 at 1920x1080, rendered ahead: {first['seconds']} s from the key (render() began "
          f"{first['job_started']} s after it; {first['timeline']}); the prepare: {first['prepared']}", file=sys.stderr)
    assert marks["exported"] < marks["reply"] < marks["delivered"], first["timeline"]


def test_f12_shows_a_preview_then_the_picture_on_the_sessions_renderer(ui):
    s = step(ui, "speed")
    cold, again = s["cold"], s["again"]
    assert ok(again), again
    assert again["server"] == s["first"]["server"]
    marks = dict(cold["timeline"])
    # The coarse preview reached the Render Result before the picture did.
    assert cold["preview"] is True, cold
    assert marks["exported"] < marks["preview shown"] < marks["reply"] < marks["delivered"], cold["timeline"]
    assert cold["preview_timings"] is not None
    # What the renderer chose for the panel's Auto values, for the panel to show (compose keeps
    # the subject within a narrow cone of the focal centre, at most 160 deg).
    assert 0.0 < cold["chosen"]["ambiguity"] <= 160.0, cold["chosen"]
    # One panel value changed: what it does not reach is reused.
    assert {"pre-render", "saliency"} <= set(again["reused"]), again["reused"]
    # With render ahead, F12 a second after the change finds that picture under way or done.
    again_ahead = s["again_ahead"]
    assert ok(again_ahead) and again_ahead["ahead"] in ("ready", "running"), again_ahead
    print(f"\nF12 without render ahead at 1920x1080: {cold['seconds']} s from the key (preview "
          f"{cold['preview_seconds']:.2f} s after render() began; {cold['timeline']}); again after one change "
          f"(render ahead off): {again['seconds']} s ({again['timeline']}, preview {again['preview']}); with render "
          f"ahead: {again_ahead['seconds']} s ({again_ahead['ahead']}, {again_ahead['timeline']})", file=sys.stderr)


def test_render_animation_frames_reuse_what_did_not_change(ui):
    anim = step(ui, "speed")["animation"]
    assert ok(anim) and anim["written"] == ["frame_0001.png", "frame_0002.png", "frame_0003.png"], anim
    frames = anim["frames"]
    assert [f["frame"] for f in frames] == [1, 2, 3] and not any(f["error"] for f in frames), frames
    for f in frames[1:]:
        # Only the camera moved: the placed triangles, so the BVH and every mesh's saliency, are kept.
        assert f["scene"]["bvh_rebuilt"] is False and f["scene"]["meshes_changed"] == 0, f["scene"]


def test_renderer_killed_during_f12_is_an_error_and_the_next_f12_works(ui):
    s = step(ui, "kill_f12")
    k = s["killed"]
    assert "killed by signal 9" in (k["error"] or ""), k
    assert not k["pid_alive"] and k["job_ended_after"] < 30, k
    assert ok(s["next_f12"]) and s["next_f12"]["server"] != k["pid"], s["next_f12"]


def test_renderer_killed_during_the_viewport_is_shown_and_the_view_recovers(ui):
    s = step(ui, "kill_viewport")
    assert "killed by signal 9" in s["error"], s
    assert not s["pid_alive"] and s["recovered"]["server"] != s["pid"], s
    assert ok(s["next_f12"]), s["next_f12"]


def test_fifty_panel_edits_while_the_viewport_renders_the_last_wins(ui):
    s = step(ui, "fifty_edits")
    # The fifty edits are due over five seconds; a main loop slowed by the machine applies the
    # last ones a little later, several at a pass, as the interface does with queued events.
    assert s["drawn_width"] == s["last"] and s["edits_seconds"] < 15.0, s
    # Nothing queues up: each edit cancels the request before it.
    assert max(s["queued_samples"]) <= 2 and s["queued_after"] == 0, s
    # One job per pass of Blender's main loop that saw edits (a slow loop gathers several), each
    # at most its three progressive requests: the requests never outnumber what the edits need.
    c = s["counts"]
    assert 1 <= c["jobs"] <= 50 and c["requests"] <= 3 * c["jobs"], c
    print(f"\nfifty edits: {c['jobs']} jobs, {c['requests']} requests, {c['cancelled']} cancelled, last edit applied "
          f"after {s['edits_seconds']} s, drawn {s['settled_after']} s after the first; queue {s['queued_samples']}",
          file=sys.stderr)


def test_a_renderer_that_stops_answering_times_out_with_an_error(ui):
    s = step(ui, "bad_binaries")
    stalled = s["stalled"]
    assert "stopped answering" in (stalled["error"] or ""), stalled
    assert stalled["seconds"] < 40 and stalled["server"] and not stalled["server_alive"], stalled
    # The interface kept running while F12 waited (a 20 ms heartbeat: its longest gap).
    assert stalled["gap"][0] < 5.0 and stalled["gap"][1] >= 3, stalled["gap"]
    print(f"\nstalled renderer: error after {stalled['seconds']} s; main loop's longest gap meanwhile "
          f"{stalled['gap'][0]} s ({stalled['gap'][1]} ticks)", file=sys.stderr)


def test_a_binary_for_another_platform_or_not_executable_is_an_error(ui):
    s = step(ui, "bad_binaries")
    assert "does not run on this" in (s["other_platform"]["error"] or ""), s["other_platform"]
    assert "Cubist Binary" in (s["not_executable"]["error"] or ""), s["not_executable"]
    assert ok(s["again"]), s["again"]


def test_a_full_or_read_only_temp_folder_is_an_error(ui):
    s = ui["results"]["steps"]["temp_folder"]
    if not ui["mounted"]:
        pytest.skip(f"temp folder step skipped: {s.get('skipped')}")
    s = step(ui, "temp_folder")
    assert "No space left on device" in (s["full"]["error"] or ""), s["full"]
    assert s["full"]["left"] == ["filler"], s["full"]  # nothing of the add-on's left in it
    assert "Read-only file system" in (s["read_only"]["error"] or ""), s["read_only"]
    assert ok(s["again"]), s["again"]


def test_a_truncated_or_garbage_layout_file_is_computed_again(ui):
    s = step(ui, "broken_layout")
    assert ok(s["first"]) and s["layouts"], s
    for what in ("truncated", "garbage", "again"):
        assert ok(s[what]), (what, s[what])
    for what in ("truncated", "garbage"):
        assert any("could not be read" in w for w in s[what]["warnings"]), (what, s[what]["warnings"])
    assert not any("could not be read" in w for w in s["again"]["warnings"] or []), s["again"]


def test_file_new_during_f12_stops_it_and_leaves_nothing(ui):
    s = step(ui, "new_file")
    assert s["cancelled"] and s["error"] is None and s["job_ended_after"] < 30, s
    assert not [t for t in s["temp"] if t.startswith(("cubist-render-", "cubist-unsaved-"))], s["temp"]


def test_quitting_during_f12_leaves_no_process_and_no_folder(ui):
    q = ui["results"]["steps"]["quit"]
    assert any(t.startswith("cubist-unsaved-") or t.startswith("cubist-render-") for t in q["temp"]), q
    deadline = time.monotonic() + 5
    while alive(q["server_pid"]) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not alive(q["server_pid"]), f"cubist serve {q['server_pid']} outlived Blender"
    assert sorted(p.name for p in ui["tmp"].glob("cubist-*")) == []
