"""Running the renderer: its argv, the files it writes, the process with progress and cancel,
and the temporary workspace of one render.

The binary's contract: `cubist render SCENE -o OUT.png --config SETTINGS.json --progress lines`
prints `PROGRESS <fraction> <stage>` lines on stderr, `warning: ...` lines, and on failure one
`error: <message>` line, exiting 1 (failure) or 2 (bad usage or setting).
"""

from __future__ import annotations

import queue
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Optional

from .errors import BinaryNotFound, Cancelled, CubistError, RendererError, temp_folder_error
from .progress import parse_line


def build_argv(binary: Path, scene: Path, output: Path, config: Path) -> list[str]:
    return [str(binary), "render", str(scene), "-o", str(output), "--config", str(config), "--progress", "lines"]


def pass_path(output: Path, name: str) -> Path:
    """Where the renderer writes a pass: `<stem>.<pass>.png` beside the output."""
    return output.with_name(f"{output.stem}.{name}.png")


@dataclass
class RunResult:
    warnings: list[str] = field(default_factory=list)
    seconds: float = 0.0


def popen_platform_args() -> dict:
    """No console window flashing up for each render on Windows."""
    if sys.platform == "win32":
        return {"creationflags": getattr(subprocess, "CREATE_NO_WINDOW", 0)}
    return {}


def _stop(proc: subprocess.Popen, grace: float = 2.0) -> None:
    """Terminate, then kill if it has not exited within `grace` seconds."""
    if proc.poll() is not None:
        return
    try:
        proc.terminate()
        proc.wait(timeout=grace)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
    except OSError:
        pass


def run(argv: list[str], on_progress: Callable[[str, float], None] = lambda s, f: None,
        should_cancel: Callable[[], bool] = lambda: False, poll: float = 0.05,
        on_start: Callable[[subprocess.Popen], None] = lambda p: None) -> RunResult:
    """Runs the renderer to completion. Progress callbacks and cancel checks happen on the
    calling thread (Blender's API must not be called from elsewhere); a reader thread only
    moves stderr lines into a queue. Raises Cancelled (after the process is gone),
    RendererError with the renderer's message, or BinaryNotFound."""
    t0 = time.monotonic()
    try:
        proc = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                text=True, encoding="utf-8", errors="replace", bufsize=1, **popen_platform_args())
    except FileNotFoundError:
        raise BinaryNotFound(f"cubist binary not found: {argv[0]}") from None
    except PermissionError:
        raise BinaryNotFound(f"cubist binary is not executable: {argv[0]}") from None
    except OSError as e:  # e.g. a binary for another platform: "Exec format error"
        raise BinaryNotFound(f"cannot run the cubist binary {argv[0]}: {e.strerror}") from None
    on_start(proc)
    lines: "queue.Queue[Optional[str]]" = queue.Queue()

    def pump():
        assert proc.stderr is not None
        for line in proc.stderr:
            lines.put(line)
        lines.put(None)

    reader = threading.Thread(target=pump, name="cubist-stderr", daemon=True)
    reader.start()
    result = RunResult()
    errors: list[str] = []
    other: list[str] = []
    eof = False
    try:
        while True:
            if should_cancel():
                _stop(proc)
                raise Cancelled()
            try:
                item = lines.get(timeout=poll)
            except queue.Empty:
                if eof and proc.poll() is not None:
                    break
                continue
            if item is None:
                eof = True
                continue
            ln = parse_line(item)
            if ln.kind == "progress":
                on_progress(ln.text, ln.fraction)
            elif ln.kind == "error":
                errors.append(ln.text)
            elif ln.kind == "warning":
                result.warnings.append(ln.text)
            elif ln.text.strip():
                other.append(ln.text.strip())
        rc = proc.wait()
    except BaseException:
        _stop(proc)
        raise
    finally:
        reader.join(timeout=1.0)
        if proc.stderr is not None:
            proc.stderr.close()
    result.seconds = time.monotonic() - t0
    if rc != 0:
        if errors:
            message = errors[-1]
        elif other:
            # clap's usage errors and panics do not start with `error: ` on every line.
            message = other[-1]
        else:
            message = f"cubist exited with code {rc}"
        raise RendererError(message, rc)
    return result


class Workspace:
    """A temporary directory for one render's files (scene, settings, image, passes),
    removed on exit whatever happened: success, error or cancel."""

    def __init__(self, prefix: str = "cubist-render-"):
        self.prefix = prefix
        self.path: Optional[Path] = None

    def __enter__(self) -> Path:
        try:
            self.path = Path(tempfile.mkdtemp(prefix=self.prefix))
        except OSError as e:
            raise CubistError(temp_folder_error(e)) from None
        return self.path

    def __exit__(self, *exc) -> None:
        if self.path is not None:
            shutil.rmtree(self.path, ignore_errors=True)
