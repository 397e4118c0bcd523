"""Runs the `cubist` binary for the add-on: finds it, builds its settings and arguments, runs
it with progress and cancel, and plans the facet layout reuse across frames.

No bpy here, on purpose: everything that can go wrong between Blender and the renderer is
decided in this module, and its tests run in plain Python (tests/python/test_runner.py).
The binary's contract: `cubist render SCENE -o OUT.png --config SETTINGS.json --progress lines`
prints `PROGRESS <fraction> <stage>` lines on stderr, `warning: ...` lines, and on failure one
`error: <message>` line, exiting 1 (failure) or 2 (bad usage or setting).
"""

from __future__ import annotations

import hashlib
import math
import json
import os
import queue
import re
import shutil
import stat
import struct
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterable, Mapping, Optional

ADDON_DIR = Path(__file__).resolve().parent
BINARY_NAME = "cubist.exe" if sys.platform == "win32" else "cubist"

# Every key of `Settings` in src/settings.rs (the JSON the binary accepts; unknown keys are
# an error there). tests/python/test_runner.py checks this list against settings.rs.
SETTINGS_KEYS = frozenset(
    """preset width height spp seed camera ambiguity framing focus_distance camera_position
    camera_target camera_up camera_size fill shadows background transparent exposure faceting
    facet_map facets save_facets facet_count grid_cells patch_count occlusion segments
    thresholds superpixels weight_colour weight_normal weight_depth weight_object weight_saliency
    imprecision discontinuity neighborhood facet_projection facet_fov border_width
    border_strength silhouette_width silhouette_strength palette palette_image colors gradients
    chiaroscuro saliency_method saliency_cache passes""".split()
)
# Keys that only save time (the picture is the same without them): left out, rather than
# refused, for a binary that does not know them (`settings_for_binary`).
OPTIONAL_KEYS = frozenset({"saliency_cache"})

# Settings that decide a facet layout (besides the pre-render, for segment faceting): a
# change of any of them gives a new layout file name, so a stale layout is never reused.
LAYOUT_KEYS = ("faceting", "facet_map", "facet_count", "grid_cells", "patch_count", "occlusion", "segments",
               "thresholds", "superpixels", "weight_colour", "weight_normal", "weight_depth", "weight_object",
               "weight_saliency", "saliency_method", "seed")

# Renderer stages in pipeline order with their rough share of a frame's time, for one
# progress bar that only moves forward. Unknown stages keep the bar where it is.
# Names as src/pipeline.rs and src/main.rs report them (`--progress lines`).
STAGE_WEIGHTS = (
    ("loading", 0.05),
    ("pre-render", 0.30),
    ("saliency", 0.15),
    ("faceting", 0.20),
    ("imprecision", 0.05),
    ("re-trace", 0.15),
    ("paint", 0.05),
    ("writing", 0.05),
)


class CubistError(Exception):
    """A failure to show the user as it is: `str(error)` is one line."""


class BinaryNotFound(CubistError):
    pass


class SettingError(CubistError):
    """A panel value the renderer cannot take (caught before running it)."""


class RendererError(CubistError):
    """The renderer exited with an error; the message is its one-line `error:` text."""

    def __init__(self, message: str, returncode: int):
        super().__init__(message)
        self.returncode = returncode


class Cancelled(CubistError):
    def __init__(self):
        super().__init__("render cancelled")


# ---------------------------------------------------------------------------------------------
# Finding the binary


def _is_executable(path: Path) -> bool:
    return path.is_file() and os.access(path, os.X_OK)


def _make_executable(path: Path) -> bool:
    """Zip extraction (Blender's extension installer) drops the executable bit: restore it."""
    if _is_executable(path):
        return True
    if not path.is_file():
        return False
    try:
        path.chmod(path.stat().st_mode | stat.S_IXUSR | stat.S_IXGRP | stat.S_IXOTH)
    except OSError:
        return False
    return _is_executable(path)


def binary_candidates(preference: str = "", addon_dir: Path = ADDON_DIR,
                      path_env: Optional[str] = None) -> list[tuple[str, Path]]:
    """Where the binary is looked for, in order: (description, path)."""
    out: list[tuple[str, Path]] = []
    if preference:
        p = Path(os.path.expanduser(preference))
        out.append(("add-on preferences", p / BINARY_NAME if p.is_dir() else p))
    found = shutil.which(BINARY_NAME, path=path_env if path_env is not None else os.environ.get("PATH", ""))
    if found:
        out.append(("PATH", Path(found)))
    out.append(("bundled with the add-on", addon_dir / "bin" / BINARY_NAME))
    out.append(("next to the add-on", addon_dir / BINARY_NAME))
    # A development checkout: blender_addon/ sits in the project, the build in target/release.
    for parent in list(addon_dir.parents)[:3]:
        out.append(("project build", parent / "target" / "release" / BINARY_NAME))
    return out


def find_binary(preference: str = "", addon_dir: Path = ADDON_DIR, path_env: Optional[str] = None) -> Path:
    """The `cubist` binary: the preference path when set (no fallback, so a wrong path is
    reported rather than silently replaced), else PATH, the add-on's folder, the project build."""
    candidates = binary_candidates(preference, addon_dir, path_env)
    if preference:
        source, p = candidates[0]
        if _make_executable(p):
            return p
        raise BinaryNotFound(f"cubist binary not found at {p} (set in the add-on preferences)")
    for source, p in candidates:
        if source == "bundled with the add-on" or source == "next to the add-on":
            if _make_executable(p):
                return p
        elif _is_executable(p):
            return p
    raise BinaryNotFound(
        "cubist binary not found: set its path in Preferences > Add-ons > Cubist, put it on PATH, "
        "or install the add-on zip that bundles it"
    )


_KEYS_CACHE: dict[tuple[str, float, int], frozenset] = {}


def binary_keys(binary: Path) -> frozenset:
    """The settings keys this binary accepts, cached per binary file version: the keys of
    `cubist settings` (every key, resolved), else, for binaries older than that subcommand,
    the flags of `cubist render --help` (every setting has a mirrored flag)."""
    st = binary.stat()
    key = (str(binary), st.st_mtime, st.st_size)
    if key not in _KEYS_CACHE:
        keys: frozenset = frozenset()
        try:
            r = subprocess.run([str(binary), "settings"], capture_output=True, text=True, timeout=30,
                               **_popen_platform_args())
            data = json.loads(r.stdout) if r.returncode == 0 else None
            if isinstance(data, dict):
                keys = frozenset(data)
        except (OSError, subprocess.SubprocessError, ValueError):
            pass
        if not keys:
            try:
                r = subprocess.run([str(binary), "render", "--help"], capture_output=True, text=True, timeout=30,
                                   **_popen_platform_args())
                flags = re.findall(r"--([a-z][a-z0-9-]*)", r.stdout + r.stderr)
                keys = frozenset("passes" if f == "pass" else f.replace("-", "_") for f in flags) & SETTINGS_KEYS
            except (OSError, subprocess.SubprocessError):
                pass
        _KEYS_CACHE[key] = keys
    return _KEYS_CACHE[key]


def binary_supports(binary: Path, key: str) -> bool:
    """Whether this binary accepts the setting `key`."""
    return key in binary_keys(binary)


def settings_for_binary(binary: Path, settings: Mapping[str, object]) -> dict:
    """`settings` for this binary: optional keys it does not know are left out; any other
    unknown key is an error saying the binary is older than the add-on (a binary set in the
    preferences), rather than the renderer's bare `unknown key`."""
    known = binary_keys(binary)
    if not known:
        return dict(settings)  # could not ask: let the renderer judge
    out = {k: v for k, v in settings.items() if k in known or k not in OPTIONAL_KEYS}
    unknown = sorted(k for k in out if k not in known)
    if unknown:
        raise CubistError(f"the cubist binary {binary} does not know the setting(s) {', '.join(unknown)}: it is "
                          "older than this add-on (use the bundled one: clear Preferences > Add-ons > Cubist > "
                          "Cubist Binary)")
    return out


# ---------------------------------------------------------------------------------------------
# Settings


def f32_decimal(v: float) -> float:
    """The shortest decimal that is the same 32-bit float as `v`. Blender keeps float
    properties in 32 bits, so a typed 0.85 reads back as 0.8500000238418579; the renderer
    reads 64-bit numbers, and gets what was typed (as from `--border-strength 0.85`)."""
    v = float(v)
    if not math.isfinite(v):
        return v
    try:
        bits = struct.pack("<f", v)
    except OverflowError:
        return v
    x = struct.unpack("<f", bits)[0]
    for digits in range(1, 10):
        d = float(f"{x:.{digits}g}")
        if struct.pack("<f", d) == bits:
            return d
    return x


def parse_number_list(text: str, key: str, kind: type = float) -> list:
    """'5, 30, 120' -> [5, 30, 120]; the error names the field."""
    parts = [p for p in text.replace(";", ",").replace(" ", ",").split(",") if p]
    if not parts:
        raise SettingError(f"{key}: give one or more numbers separated by commas")
    out = []
    for p in parts:
        try:
            v = kind(p)
        except ValueError:
            noun = "a whole number" if kind is int else "a number"
            raise SettingError(f"{key}: `{p}` is not {noun}") from None
        out.append(v)
    return out


def clean_settings(values: Mapping[str, object], extra_keys: Iterable[str] = ()) -> dict:
    """The settings JSON object: None values dropped (the renderer's default applies), keys
    checked against the contract so a typo fails here, in a test, not in a user's render."""
    allowed = SETTINGS_KEYS | set(extra_keys)
    unknown = sorted(k for k in values if k not in allowed)
    if unknown:
        raise SettingError(f"unknown setting(s) {', '.join(unknown)}")
    out = {}
    for k, v in values.items():
        if v is None:
            continue
        if isinstance(v, Path):
            v = str(v)
        elif isinstance(v, tuple):
            v = list(v)
        out[k] = v
    return out


def write_settings(path: Path, settings: Mapping[str, object]) -> None:
    path.write_text(json.dumps(settings, indent=2, sort_keys=True), encoding="utf-8")


def build_argv(binary: Path, scene: Path, output: Path, config: Path) -> list[str]:
    return [str(binary), "render", str(scene), "-o", str(output), "--config", str(config), "--progress", "lines"]


def pass_path(output: Path, name: str) -> Path:
    """Where the renderer writes a pass: `<stem>.<pass>.png` beside the output."""
    return output.with_name(f"{output.stem}.{name}.png")


# ---------------------------------------------------------------------------------------------
# Facet layouts across frames (static facets, SPEC "Animation")


def layout_key(settings: Mapping[str, object], layout_frame: int = 1) -> str:
    """A short hash of the settings that decide a layout, of the frame it is computed on,
    and of the image's aspect ratio (the layout is resolution-independent, so a 50% preview
    and the final share it)."""
    w, h = settings.get("width", 800), settings.get("height", 600)
    data = {k: settings.get(k) for k in LAYOUT_KEYS}
    data["layout_frame"] = int(layout_frame)
    data["aspect"] = round(float(w) / float(h), 4)
    text = json.dumps(data, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:10]


def layout_path(folder: Path, scene_name: str, settings: Mapping[str, object], layout_frame: int = 1) -> Path:
    safe = "".join(c if c.isalnum() or c in "-_" else "_" for c in scene_name) or "scene"
    return folder / f"{safe}.{layout_key(settings, layout_frame)}.facets.json"


def uses_layout(settings: Mapping[str, object]) -> bool:
    """Whether the add-on manages a layout file for these settings: faceted, and no layout
    file of the user's (`facets`) already given."""
    return settings.get("faceting", "none") != "none" and not settings.get("facets")


def needs_saliency(settings: Mapping[str, object]) -> bool:
    """Whether the renderer computes mesh saliency for these settings (mirrors
    `Settings::needs_saliency` in src/settings.rs): only then is a saliency cache useful."""
    faceting = settings.get("faceting", "none")
    faceted = faceting != "none" or bool(settings.get("facets"))
    reaims = (settings.get("imprecision", "saliency") == "saliency" and faceted
              and float(settings.get("discontinuity", 0.0)) > 0.0)
    segments = faceting == "segment" and not settings.get("facets")
    passes = settings.get("passes", [])
    return reaims or segments or "saliency" in passes or "facets" in passes


@dataclass
class LayoutPlan:
    """What a frame's render does with the shared layout file: `settings` renders the frame
    (with `facets` = load the layout, or `save_facets` = compute and save it). When
    `prepass_frame` is set, the layout is first computed on that frame with
    `layout_prepass(...)`: a chunk of an animation that does not start on the layout frame
    must still get the layout frame's layout, or two farm machines would compute different ones."""

    settings: dict
    prepass_frame: Optional[int] = None


def plan_layout(settings: Mapping[str, object], layout: Optional[Path], frame: int, layout_frame: int,
                current: Optional[bool] = None) -> LayoutPlan:
    """`current`: whether the saved layout is still the layout frame's (`layout_is_current`);
    None: whenever the file exists."""
    s = dict(settings)
    if layout is None or not uses_layout(s):
        return LayoutPlan(s)
    if current is None:
        current = layout.is_file()
    if current:
        s["facets"] = str(layout)
        return LayoutPlan(s)
    if frame == layout_frame:
        s["save_facets"] = str(layout)
        return LayoutPlan(s)
    s["facets"] = str(layout)
    return LayoutPlan(s, prepass_frame=layout_frame)


# Settings that decide the pre-render a Segment layout is computed from (besides the layout
# frame's scene itself). Not the size: the layout is resolution-independent (its aspect ratio
# is in the file name), so a 50% preview and the final share it.
PRERENDER_KEYS = ("camera", "ambiguity", "framing", "focus_distance", "camera_position", "camera_target",
                  "camera_up", "camera_size", "fill", "shadows", "background", "exposure", "spp")


def layout_source(scene_file: Path, settings: Mapping[str, object]) -> str:
    """What a Segment layout was computed from: a hash of the layout frame's exported scene
    and of the settings that shape its pre-render. A layout whose recorded source differs is
    stale (the camera, an object, a light or a material moved or changed on the layout frame)."""
    h = hashlib.sha256()
    with open(scene_file, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    view = {k: settings.get(k) for k in PRERENDER_KEYS}
    h.update(json.dumps(view, sort_keys=True, default=str).encode())
    return h.hexdigest()


def source_path(layout: Path) -> Path:
    return layout.with_name(layout.name + ".source")


def layout_is_current(layout: Path, source: Optional[str]) -> bool:
    """Whether the saved layout can be reused: it exists and, when its source matters
    (`source` given: Segment faceting), was computed from that source."""
    if not layout.is_file():
        return False
    if source is None:
        return True
    try:
        return source_path(layout).read_text(encoding="utf-8").strip() == source
    except OSError:
        return False


def forget_source(layout: Path) -> None:
    """Before the layout is computed again: until the new source is recorded, it is stale."""
    source_path(layout).unlink(missing_ok=True)


def record_source(layout: Path, source: str) -> None:
    """After the renderer saved the layout: what it was computed from (written atomically)."""
    p = source_path(layout)
    tmp = p.with_name(f".{p.name}.{os.getpid()}.tmp")
    tmp.write_text(source + "\n", encoding="utf-8")
    os.replace(tmp, p)


def layout_prepass(settings: Mapping[str, object], layout: Path) -> dict:
    """The settings of the render that only computes and saves the layout (on the layout
    frame, with that frame's camera): no passes, the image is discarded."""
    s = dict(settings)
    s.pop("facets", None)
    s["save_facets"] = str(layout)
    s["passes"] = []
    return s


# ---------------------------------------------------------------------------------------------
# Progress


@dataclass
class Line:
    kind: str  # "progress", "error", "warning" or "other"
    text: str = ""
    fraction: float = 0.0


def parse_line(line: str) -> Line:
    line = line.rstrip("\r\n")
    if line.startswith("PROGRESS "):
        parts = line.split(" ", 2)
        try:
            f = float(parts[1])
        except (IndexError, ValueError):
            return Line("other", line)
        return Line("progress", parts[2] if len(parts) > 2 else "", min(max(f, 0.0), 1.0))
    if line.startswith("error: "):
        return Line("error", line[len("error: "):])
    if line.startswith("warning: "):
        return Line("warning", line[len("warning: "):])
    return Line("other", line)


class ProgressTracker:
    """Maps (stage, fraction of stage) onto one forward-only fraction in [lo, hi], the part
    of the frame's progress bar this run owns (a layout pre-pass takes the first part)."""

    def __init__(self, lo: float = 0.0, hi: float = 1.0):
        self.lo, self.hi = lo, hi
        self.total = sum(w for _, w in STAGE_WEIGHTS)
        self.value = 0.0
        self.stage = ""

    def update(self, stage: str, fraction: float) -> float:
        self.stage = stage
        done = 0.0
        for name, w in STAGE_WEIGHTS:
            if name == stage:
                self.value = max(self.value, (done + w * fraction) / self.total)
                break
            done += w
        else:
            if stage == "done":
                self.value = 1.0
        return self.lo + (self.hi - self.lo) * self.value


# ---------------------------------------------------------------------------------------------
# Running


@dataclass
class RunResult:
    warnings: list[str] = field(default_factory=list)
    seconds: float = 0.0


def _popen_platform_args() -> dict:
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
                                text=True, encoding="utf-8", errors="replace", bufsize=1, **_popen_platform_args())
    except FileNotFoundError:
        raise BinaryNotFound(f"cubist binary not found: {argv[0]}") from None
    except PermissionError:
        raise BinaryNotFound(f"cubist binary is not executable: {argv[0]}") from None
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
        self.path = Path(tempfile.mkdtemp(prefix=self.prefix))
        return self.path

    def __exit__(self, *exc) -> None:
        if self.path is not None:
            shutil.rmtree(self.path, ignore_errors=True)
