"""The add-on's client of `cubist serve` (blender_addon/serve_client.py) without Blender: a real
server process, requests from several threads, replies matched by id, pictures equal to
`cubist render`'s, progress, cancel, errors, a server that dies, an older binary without
`serve`, and nothing left behind on close."""

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from addon_support import ROOT, cubist_binary  # noqa: F401 (fixture)

from blender_addon import pngio
from blender_addon.runner import Cancelled
from blender_addon.serve_client import ServeClient, ServerError, ServerGone, read_rgba, wait_all

SMALL = {"width": 64, "height": 48, "spp": 1}


def cli(binary, settings, out: Path, tmp: Path, scene=None) -> np.ndarray:
    cfg = tmp / f"{out.stem}.json"
    cfg.write_text(__import__("json").dumps(settings))
    argv = [str(binary), "render", "-o", str(out), "--config", str(cfg)]
    if scene is not None:
        argv.insert(2, str(scene))
    r = subprocess.run(argv, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return pngio.read(out)


@pytest.fixture
def client(cubist_binary):
    c = ServeClient(cubist_binary)
    yield c
    c.close()


def test_client_imports_without_bpy():
    code = ("import sys; sys.path.insert(0, %r); import blender_addon.serve_client; "
            "assert 'bpy' not in sys.modules; print('ok')" % str(ROOT))
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0 and r.stdout.strip() == "ok", r.stderr


def test_renders_match_the_cli_and_keep_what_does_not_change(client, cubist_binary, tmp_path):
    out = client.workspace / "a.png"
    reply = client.render(SMALL, out)
    assert reply["ok"] and reply["reused"] == [] and out.is_file()
    assert np.array_equal(pngio.read(out), cli(cubist_binary, SMALL, tmp_path / "a.png", tmp_path))
    # A painterly change: only paint runs; the raw output holds the same pixels a PNG would.
    paint = {**SMALL, "border_width": 3.0}
    raw = client.workspace / "b.rgba"
    reply = client.render(paint, raw)
    assert reply["reused"][:5] == ["pre-render", "saliency", "faceting", "imprecision", "re-trace"], reply
    expected = cli(cubist_binary, paint, tmp_path / "b.png", tmp_path)
    assert np.array_equal(read_rgba(raw, reply["width"], reply["height"]), expected)
    stats = client.stats()
    assert stats["scene"] == "<default scene>" and stats["served"] == 2


def test_requests_from_several_threads_get_their_own_replies(client):
    results = {}

    def one(i):
        s = {**SMALL, "border_width": float(i)}
        results[i] = client.render(s, client.workspace / f"t{i}.rgba")

    threads = [threading.Thread(target=one, args=(i,)) for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(120)
    assert sorted(results) == [0, 1, 2, 3]
    assert len({r["id"] for r in results.values()}) == 4
    assert all(r["output"].endswith(f"t{i}.rgba") for i, r in results.items())


def test_progress_and_cancel(client):
    seen = []
    reply = client.render({**SMALL, "width": 200, "height": 150}, client.workspace / "p.png",
                          on_progress=lambda stage, f: seen.append(stage))
    assert reply["ok"] and "pre-render" in seen
    # A long render, cancelled once under way: Cancelled within seconds, and the client works on.
    started = []
    t0 = time.monotonic()
    with pytest.raises(Cancelled):
        client.render({"width": 1200, "height": 1200, "spp": 4}, client.workspace / "long.png",
                      on_progress=lambda stage, f: started.append(time.monotonic()),
                      should_cancel=lambda: bool(started))
    assert started and time.monotonic() - started[0] < 20
    assert not (client.workspace / "long.png").exists()
    assert client.render(SMALL, client.workspace / "after.png")["ok"]
    assert time.monotonic() - t0 < 120


def test_errors_are_one_line_and_the_server_keeps_serving(client):
    with pytest.raises(ServerError, match="unknown key `widht`"):
        client.render({"widht": 3}, client.workspace / "x.png")
    with pytest.raises(ServerError, match="missing.glb"):
        client.render(SMALL, client.workspace / "x.png", scene=client.workspace / "missing.glb")
    with pytest.raises(ServerError, match=r"\.png or \.rgba"):
        client.render(SMALL, client.workspace / "x.jpg")
    assert client.render(SMALL, client.workspace / "ok.png")["ok"]


def test_a_server_that_dies_answers_every_request_with_an_error(cubist_binary):
    c = ServeClient(cubist_binary)
    try:
        pending = c.render_request({"width": 1500, "height": 1500, "spp": 8}, c.workspace / "big.png")
        time.sleep(0.3)
        os.kill(c.pid, signal.SIGKILL)
        reply = pending.wait(30)
        assert reply is not None and reply["ok"] is False and reply.get("gone"), reply
        assert "ended" in reply["error"]
        with pytest.raises(ServerGone):
            c.render(SMALL, c.workspace / "x.png")
        assert not c.alive()
    finally:
        c.close()
    assert not c.workspace.exists()


def test_close_ends_the_server_and_removes_the_workspace(cubist_binary):
    c = ServeClient(cubist_binary)
    pending = c.render_request({"width": 1200, "height": 1200, "spp": 4}, c.workspace / "big.png")
    time.sleep(0.2)
    t0 = time.monotonic()
    c.close()
    assert time.monotonic() - t0 < 10
    assert c.proc.poll() is not None
    assert not c.workspace.exists()
    assert wait_all([pending], 10)
    assert pending.reply["ok"] is False
    c.close()  # twice is fine


def test_a_binary_without_serve_is_named(tmp_path):
    old = tmp_path / "cubist"
    old.write_text("#!/bin/sh\necho \"error: unrecognized subcommand 'serve'\" >&2\nexit 2\n")
    old.chmod(0o755)
    c = ServeClient(old)
    try:
        with pytest.raises(ServerGone, match="no `serve` command"):
            deadline = time.monotonic() + 10
            while c.alive() and time.monotonic() < deadline:
                time.sleep(0.05)
            time.sleep(0.2)  # the stderr reader
            c.render(SMALL, c.workspace / "x.png")
    finally:
        c.close()


def test_a_missing_binary_is_a_one_line_error(tmp_path):
    import tempfile

    before = set(Path(tempfile.gettempdir()).glob("cubist-serve-*"))
    with pytest.raises(ServerGone, match="cannot start"):
        ServeClient(tmp_path / "nope")
    assert set(Path(tempfile.gettempdir()).glob("cubist-serve-*")) == before


def test_a_server_that_stops_answering_is_killed_not_waited_for(tmp_path, monkeypatch):
    """A server that reads requests and never answers (not even `stats`, which a rendering
    server answers at once): the wait ends with ServerHung after SILENCE + ANSWER_WITHIN, and
    the process is gone."""
    from blender_addon import serve_client
    from blender_addon.serve_client import ServerHung

    monkeypatch.setattr(serve_client, "SILENCE", 0.5)
    monkeypatch.setattr(serve_client, "ANSWER_WITHIN", 0.5)
    sleeper = tmp_path / "cubist"
    sleeper.write_text("#!/bin/sh\nexec sleep 600\n")
    sleeper.chmod(0o755)
    c = ServeClient(sleeper)
    try:
        t0 = time.monotonic()
        with pytest.raises(ServerHung, match="stopped answering"):
            c.render(SMALL, c.workspace / "x.png")
        assert time.monotonic() - t0 < 5
        c.proc.wait(5)
        assert not c.alive()
    finally:
        c.close()
    assert not c.workspace.exists()


def test_a_slow_render_is_not_taken_for_a_hung_server(client, monkeypatch):
    """A render longer than SILENCE without progress lines: the server answers `stats`."""
    from blender_addon import serve_client

    monkeypatch.setattr(serve_client, "SILENCE", 0.05)
    monkeypatch.setattr(serve_client, "ANSWER_WITHIN", 2.0)
    reply = client.render({"width": 500, "height": 400, "spp": 4}, client.workspace / "slow.rgba")
    assert reply["ok"]


def test_f12_on_the_sessions_renderer_shows_a_preview_first(cubist_binary, tmp_path):
    """serve_render: the preview (a quarter of the size, one sample) comes before the picture,
    which is `cubist render`'s; a killed server is an error and the next render starts another."""
    from blender_addon import serve_render, server
    from blender_addon.runner import RendererError

    settings = {"width": 160, "height": 120, "spp": 2}
    seen = []
    try:
        outcome = serve_render.render(cubist_binary, None, tmp_path, settings, lambda s, f: seen.append(f),
                                      lambda: False, on_preview=lambda px: seen.append(px.shape))
        # The preview came before the picture's progress got anywhere.
        i = seen.index((30, 40, 4))
        assert all(f == 0.0 for f in seen[:i]) and all(isinstance(f, float) for f in seen[i + 1:]), seen[:5]
        assert (outcome.width, outcome.height) == (160, 120)
        expected = cli(cubist_binary, settings, tmp_path / "cli.png", tmp_path)
        assert np.array_equal(read_rgba(outcome.image, 160, 120), expected)
        first = server.current()
        # Killed during a render: an error naming the signal.
        threading.Timer(0.5, lambda: os.kill(first.pid, signal.SIGKILL)).start()
        with pytest.raises(RendererError, match="killed by signal 9"):
            serve_render.render(cubist_binary, None, tmp_path, {"width": 1500, "height": 1500, "spp": 8},
                                lambda s, f: None, lambda: False)
        # The next render starts another server.
        again = serve_render.render(cubist_binary, None, tmp_path, settings, lambda s, f: None, lambda: False)
        assert again.pid != first.pid and np.array_equal(read_rgba(again.image, 160, 120), expected)
    finally:
        server.shutdown()
    assert server.current() is None


def test_the_preview_is_left_out_when_the_picture_is_expected_soon(cubist_binary, tmp_path, monkeypatch):
    """serve_render.wants_preview: after a picture, the steps a change reaches at what they cost
    then decide; another scene or a new renderer (nothing kept) is unknown: a preview."""
    from blender_addon import serve_render, server

    monkeypatch.setattr(serve_render, "PREVIEW_WORTH", 0.5)
    settings = {"width": 320, "height": 240, "spp": 2}
    digest = "scene-a"
    try:
        assert serve_render.wants_preview(digest, settings)  # nothing known yet
        serve_render.render(cubist_binary, None, tmp_path, settings, lambda s, f: None, lambda: False, digest=digest)
        seconds = serve_render._costs[(320, 240)].seconds
        assert set(seconds) == set(serve_render.STEPS) and seconds["pre-render"] > 0.0, seconds
        # Nothing changed: nothing to run (the encoding at most).
        assert serve_render.expected_seconds(digest, settings) <= seconds["encode"] + 1e-9
        # A painterly change reaches paint and encode; a camera change everything.
        paint = {**settings, "border_width": 9.0}
        assert serve_render.expected_seconds(digest, paint) == pytest.approx(seconds["paint"] + seconds["encode"])
        camera = {**settings, "ambiguity": 120.0}
        assert serve_render.expected_seconds(digest, camera) == pytest.approx(sum(seconds.values()))
        # Where the layout goes is no change.
        assert serve_render.expected_seconds(digest, {**settings, "save_facets": str(tmp_path / "l.json")}) == \
            serve_render.expected_seconds(digest, settings)
        monkeypatch.setattr(serve_render, "PREVIEW_WORTH", seconds["paint"] + seconds["encode"] + 1.0)
        assert not serve_render.wants_preview(digest, paint)
        assert serve_render.wants_preview("scene-b", paint)
        # A new renderer keeps nothing: not known.
        server.shutdown()
        assert serve_render.expected_seconds(digest, settings) is None
    finally:
        server.shutdown()


def test_picture_conversion_is_blenders_png_decoding():
    """picture.result_rect: sRGB to linear, premultiplied, bottom-up, the region cut out."""
    from blender_addon import picture

    px = np.zeros((2, 3, 4), np.uint8)
    px[0, 0] = (255, 128, 0, 255)  # top left
    px[1, 2] = (255, 255, 255, 51)  # bottom right, 20% alpha
    rect = picture.result_rect(px, (0, 0, 3, 2)).reshape(2, 3, 4)
    assert rect[1, 0] == pytest.approx([1.0, 0.2158605, 0.0, 1.0], abs=1e-6)  # top row is last
    assert rect[0, 2] == pytest.approx([0.2, 0.2, 0.2, 0.2])
    assert picture.result_rect(px, (2, 0, 1, 1)).tolist() == rect[0, 2:3].reshape(1, 4).tolist()
    big = picture.upscale(px, 6, 4)
    assert big.shape == (4, 6, 4) and (big[:2, :2] == px[0, 0]).all() and (big[2:, 4:] == px[1, 2]).all()
    # The preview: converted small, then blown up, the same as converting the blown-up picture.
    for region in ((0, 0, 6, 4), (1, 1, 4, 2)):
        assert np.array_equal(picture.preview_rect(px, 6, 4, region), picture.result_rect(big, region))
