"""A client of `cubist serve` (docs/serve.md): one server process, requests sent from any
thread, replies matched to them by id.

The add-on keeps one per Blender session (server.py), shared by F12, Render Animation and the
viewport. No bpy
here, on purpose: tests/python/test_addon_serve.py runs it in plain Python against the real
binary.

Images come back as files the server writes in this client's workspace: `.rgba` (raw 8-bit
RGBA rows, top row first) for the viewport, `.png` for F12. A file, not shared memory: the
server writes it atomically and only then replies, the reader needs no synchronisation beyond
the reply, nothing platform-specific is involved (no named segments to leak if a process dies:
the workspace is one temporary folder, removed on close), and at viewport sizes the copy costs
a millisecond or two (BENCHMARKS.md), far below a render.
"""

from __future__ import annotations

import collections
import itertools
import json
import os
import shutil
import subprocess
import tempfile
import threading
import time
from pathlib import Path
from typing import Callable, Optional

import numpy as np

from .runner.errors import Cancelled, CubistError, temp_folder_error
from .runner.process import _stop, popen_platform_args
from .runner.progress import parse_line


class ServerError(CubistError):
    """The server answered a request with an error (one line)."""


class ServerGone(CubistError):
    """The server process ended (or never started): requests cannot be answered."""


class ServerHung(ServerGone):
    """The server stopped answering (not even `stats`, which it answers at once while it
    renders): it was killed."""


# A request waiting this long without a sign of life from the server (a reply, a progress or
# other stderr line) sends `stats`; a server that does not answer that within ANSWER_WITHIN is
# hung. `stats` is answered at once even while a render runs (docs/serve.md), so a slow render
# is never taken for a hung server.
SILENCE = 5.0
ANSWER_WITHIN = 10.0
# A render asked to stop that has not within this long is killed (the next render starts
# another server): Esc must end the render job promptly, and some stages check the cancel flag
# only between their steps (seen: more than 15 s on a loaded machine, 1280 x 960, 64 samples).
CANCEL_GRACE = 3.0


class Pending:
    """A request sent, its reply to come."""

    def __init__(self, request_id: int):
        self.id = request_id
        self._event = threading.Event()
        self.reply: Optional[dict] = None

    def done(self) -> bool:
        return self._event.is_set()

    def wait(self, timeout: Optional[float] = None) -> Optional[dict]:
        """The reply, or None if it did not come within `timeout` seconds."""
        self._event.wait(timeout)
        return self.reply

    def _set(self, reply: dict) -> None:
        self.reply = reply
        self._event.set()


def read_rgba(path: Path, width: int, height: int) -> np.ndarray:
    """A raw `.rgba` output as a (height, width, 4) uint8 array, top row first."""
    data = np.fromfile(str(path), dtype=np.uint8)
    if data.size != width * height * 4:
        raise CubistError(f"{path.name} holds {data.size} bytes, expected {width}x{height}x4")
    return data.reshape(height, width, 4)


class ServeClient:
    """One `cubist serve` process and its temporary workspace (where outputs go)."""

    _ids = itertools.count(1)

    def __init__(self, binary: Path, cache_mib: Optional[int] = None, nice: int = 0):
        """Starts `binary serve`. `nice` > 0 (POSIX) lowers its CPU priority: the viewport's
        server then yields the cores to Blender's interface when both want them."""
        self.binary = Path(binary)
        try:
            self.workspace = Path(tempfile.mkdtemp(prefix="cubist-serve-"))
        except OSError as e:
            raise ServerGone(temp_folder_error(e)) from None
        argv = [str(self.binary), "serve", "--parent", str(os.getpid())]
        if cache_mib is not None:
            argv += ["--cache-memory", str(int(cache_mib))]
        extra = dict(popen_platform_args())
        if nice > 0 and hasattr(os, "nice"):
            extra["preexec_fn"] = lambda: os.nice(nice)
        try:
            self.proc = subprocess.Popen(argv, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                         stderr=subprocess.PIPE, text=True, encoding="utf-8",
                                         errors="replace", bufsize=1, **extra)
        except OSError as e:
            shutil.rmtree(self.workspace, ignore_errors=True)
            raise ServerGone(f"cannot start `{self.binary} serve`: {e.strerror or e}") from None
        self._lock = threading.Lock()  # stdin and the pending table
        self._pending: dict[int, Pending] = {}
        self._stderr_tail: list[str] = []
        self._progress: Optional[Callable[[str, float], None]] = None
        # Progress lines read, for the waiting thread to report (await_reply): callbacks run on
        # the thread that waits (Blender's render thread), never on the reader thread.
        self._progress_lines: collections.deque = collections.deque(maxlen=1000)
        self._closed = False
        self.heard = time.monotonic()  # the last line read from the server (stdout or stderr)
        self._reader = threading.Thread(target=self._read_replies, name="cubist-serve-replies", daemon=True)
        self._reader.start()
        self._err_reader = threading.Thread(target=self._read_stderr, name="cubist-serve-stderr", daemon=True)
        self._err_reader.start()

    # ---------------------------------------------------------------------- process

    @property
    def pid(self) -> int:
        return self.proc.pid

    def alive(self) -> bool:
        return not self._closed and self.proc.poll() is None

    def _gone_message(self) -> str:
        code = self.proc.poll()
        # The last line it said, not a progress line cut short by its death.
        said = next((ln for ln in reversed(self._stderr_tail) if ln.strip() and not ln.startswith("PROGRESS")), "")
        if said.startswith("error: "):
            said = said[len("error: "):]
        if "unrecognized subcommand" in said or "unexpected argument" in said:
            return f"{self.binary} has no `serve` command: it is older than the add-on"
        if code is not None and code < 0:
            what = f"the cubist renderer ended (killed by signal {-code})"
        elif code is not None:
            what = f"the cubist renderer ended (exit code {code})"
        else:
            what = "the cubist renderer is closed"
        return f"{what}: {said}" if said else what

    def _read_replies(self) -> None:
        assert self.proc.stdout is not None
        try:
            for line in self.proc.stdout:
                self.heard = time.monotonic()
                try:
                    reply = json.loads(line)
                except ValueError:
                    continue
                rid = reply.get("id") if isinstance(reply, dict) else None
                with self._lock:
                    pending = self._pending.pop(rid, None) if isinstance(rid, int) else None
                if pending is not None:
                    pending._set(reply)
        except (OSError, ValueError):  # closed by close()
            pass
        # The process ended (or is ending: its exit code, when it comes soon, says how): every
        # request still waiting gets an error reply.
        try:
            self.proc.wait(timeout=2.0)
        except subprocess.TimeoutExpired:
            pass
        message = self._gone_message()
        with self._lock:
            waiting, self._pending = list(self._pending.values()), {}
        for p in waiting:
            p._set({"id": p.id, "ok": False, "error": message, "gone": True})

    def _read_stderr(self) -> None:
        assert self.proc.stderr is not None
        try:
            for line in self.proc.stderr:
                self.heard = time.monotonic()
                ln = parse_line(line)
                if ln.kind == "progress":
                    if self._progress is not None:
                        self._progress_lines.append((ln.text, ln.fraction))
                else:
                    self._stderr_tail.append(line.rstrip("\n"))
                    del self._stderr_tail[:-20]
        except (OSError, ValueError):  # closed by close()
            pass

    # ---------------------------------------------------------------------- requests

    def request(self, cmd: str, **fields) -> Pending:
        """Sends one request; its reply comes to the returned Pending. A server that is gone
        answers at once with `ok: false`."""
        rid = next(self._ids)
        pending = Pending(rid)
        line = json.dumps({"id": rid, "cmd": cmd, **fields}) + "\n"
        with self._lock:
            if not self.alive():
                pending._set({"id": rid, "ok": False, "error": self._gone_message(), "gone": True})
                return pending
            self._pending[rid] = pending
            try:
                assert self.proc.stdin is not None
                self.proc.stdin.write(line)
                self.proc.stdin.flush()
            except (OSError, ValueError):
                self._pending.pop(rid, None)
                pending._set({"id": rid, "ok": False, "error": self._gone_message(), "gone": True})
        return pending

    def set_progress(self, callback: Optional[Callable[[str, float], None]]) -> None:
        """Where the `PROGRESS` lines of requests that ask for them go (one render job at a
        time asks: F12 or a frame of an animation), called by `await_reply` on the thread that
        waits; None: nowhere."""
        self._progress_lines.clear()
        self._progress = callback

    def _report_progress(self) -> None:
        cb = self._progress
        while self._progress_lines:
            stage, fraction = self._progress_lines.popleft()
            if cb is not None:
                cb(stage, fraction)

    def render_request(self, settings: dict, output: Path, scene: Optional[Path] = None,
                       passes: Optional[list] = None, progress: bool = False, background: bool = False) -> Pending:
        """`background`: on the server's lower-priority threads (a render ahead of the user)."""
        fields: dict = {"scene": str(scene) if scene is not None else None, "settings": settings,
                        "output": str(output)}
        if passes is not None:
            fields["passes"] = list(passes)
        if progress:
            fields["progress"] = True
        if background:
            fields["background"] = True
        return self.request("render", **fields)

    def render(self, settings: dict, output: Path, scene: Optional[Path] = None, passes: Optional[list] = None,
               on_progress: Optional[Callable[[str, float], None]] = None,
               should_cancel: Callable[[], bool] = lambda: False, poll: float = 0.05) -> dict:
        """Renders and waits (F12: on the render thread), reporting the server's progress and
        cancelling when `should_cancel()` turns true (raises Cancelled once the server has
        stopped). Raises ServerError with the server's message, ServerGone."""
        self.set_progress(on_progress)
        try:
            pending = self.render_request(settings, output, scene, passes, progress=on_progress is not None)
            reply = self.await_reply(pending, should_cancel, poll)
        finally:
            self._progress = None
        return self.check(reply)

    def await_reply(self, pending: Pending, should_cancel: Callable[[], bool] = lambda: False,
                    poll: float = 0.05) -> dict:
        """Waits for `pending`'s reply, sending `cancel` once `should_cancel()` turns true. A
        server silent for SILENCE seconds is asked for `stats`; one that does not answer within
        ANSWER_WITHIN is killed (raises ServerHung), and one that has not stopped CANCEL_GRACE
        seconds after the cancel too (raises Cancelled): never waits for ever."""
        # Time is counted only while this thread runs: a host that keeps Python waiting (Blender
        # drawing for seconds on a loaded machine, holding the interpreter) starves the reader
        # threads too, and their silence then says nothing about the server.
        last = time.monotonic()
        heard = self.heard
        silent = cancelled_for = probe_for = 0.0
        cancelled = False
        probe = None
        while pending.wait(poll) is None:
            self._report_progress()
            now = time.monotonic()
            step = now - last if now - last < 1.0 else poll
            last = now
            if self.heard != heard:
                heard, silent = self.heard, 0.0
            else:
                silent += step
            if not cancelled and should_cancel():
                self.cancel(pending.id)
                cancelled = True
            elif cancelled:
                cancelled_for += step
            if probe is not None:
                probe_for += step
                if probe.done():
                    probe = None
            if probe is None and silent > SILENCE:
                probe, probe_for, silent = self.request("stats"), 0.0, 0.0
            if cancelled_for > CANCEL_GRACE:
                self.kill()
                raise Cancelled()
            if probe is not None and probe_for > ANSWER_WITHIN:
                self.kill()
                raise ServerHung(f"the cubist renderer stopped answering (nothing for {SILENCE + probe_for:.0f} s): "
                                 f"it was stopped; the next render starts it again")
        self._report_progress()
        return pending.reply or {}

    def check(self, reply: dict) -> dict:
        """The reply if it succeeded; raises Cancelled, ServerGone or ServerError otherwise."""
        if reply.get("ok"):
            return reply
        if reply.get("cancelled"):
            raise Cancelled()
        message = str(reply.get("error") or "the cubist server failed")
        raise (ServerGone if reply.get("gone") else ServerError)(message)

    def cancel(self, target: Optional[int] = None) -> Pending:
        fields = {"target": target} if target is not None else {}
        return self.request("cancel", **fields)

    def stats(self, timeout: float = 10.0) -> dict:
        reply = self.request("stats").wait(timeout)
        if reply is None:
            raise ServerError("the cubist server did not answer `stats`")
        return self.check(reply)["stats"]

    def kill(self) -> None:
        """Ends the server at once (SIGKILL): it is hung. Requests waiting get an error reply;
        `close()` still removes the workspace."""
        try:
            self.proc.kill()
        except OSError:
            pass

    def close(self, timeout: float = 5.0) -> None:
        """Cancels what runs, ends the server (killing it if it does not end within
        `timeout`) and removes the workspace. Safe to call twice, from any thread."""
        with self._lock:
            if self._closed:
                return
            self._closed = True
        try:
            if self.proc.poll() is None and self.proc.stdin is not None:
                for line in ('{"id": null, "cmd": "cancel"}\n', '{"id": null, "cmd": "shutdown"}\n'):
                    self.proc.stdin.write(line)
                self.proc.stdin.flush()
                self.proc.stdin.close()
        except (OSError, ValueError):
            pass
        t0 = time.monotonic()
        while self.proc.poll() is None and time.monotonic() - t0 < timeout:
            time.sleep(0.01)
        _stop(self.proc)
        for stream in (self.proc.stdout, self.proc.stderr):
            try:
                if stream is not None:
                    stream.close()
            except OSError:
                pass
        shutil.rmtree(self.workspace, ignore_errors=True)


def wait_all(pendings, timeout: float) -> bool:
    """Whether every Pending got its reply within `timeout` seconds (tests)."""
    end = time.monotonic() + timeout
    return all(p.wait(max(0.0, end - time.monotonic())) is not None for p in pendings)


__all__ = ["Pending", "ServeClient", "ServerError", "ServerGone", "ServerHung", "read_rgba", "wait_all"]
