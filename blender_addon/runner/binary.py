"""Finding the `cubist` binary and asking it which settings it knows."""

from __future__ import annotations

import json
import os
import re
import shutil
import stat
import subprocess
import sys
from pathlib import Path
from typing import Mapping, Optional

from .errors import BinaryNotFound, CubistError
from .process import popen_platform_args
from .settings import OPTIONAL_KEYS, SETTINGS_KEYS

# blender_addon/ (this file is blender_addon/runner/binary.py).
ADDON_DIR = Path(__file__).resolve().parents[1]
BINARY_NAME = "cubist.exe" if sys.platform == "win32" else "cubist"


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


# Blender's extension platform names (`platforms` in blender_manifest.toml), made as Blender
# makes them (bl_pkg's `platform_from_this_system`): `platform.system()` and
# `platform.machine()`, lower case, with these replacements.
_SYSTEM_NAMES = {"darwin": "macos"}
_MACHINE_NAMES = {"x86_64": "x64", "amd64": "x64", "aarch64": "arm64", "aarch32": "arm32"}
# What the release builds (.github/workflows/release.yml): one zip with its binary each.
RELEASE_PLATFORMS = ("windows-x64", "linux-x64", "macos-arm64", "macos-x64")
PREFERENCE = "Preferences > Add-ons > Cubist > Cubist Binary"


def platform_tag(system: Optional[str] = None, machine: Optional[str] = None) -> str:
    """This machine's Blender platform name, e.g. linux-x64, macos-arm64, windows-x64."""
    import platform

    system = (system if system is not None else platform.system()).lower()
    machine = (machine if machine is not None else platform.machine()).lower()
    return f"{_SYSTEM_NAMES.get(system, system)}-{_MACHINE_NAMES.get(machine, machine)}"


def executable_name(tag: str) -> str:
    return "cubist.exe" if tag.startswith("windows") else "cubist"


def manifest_field(addon_dir: Path, key: str):
    """A top-level string or list of strings of the add-on's blender_manifest.toml (None when
    absent). A regular expression, not tomllib: Blender 3.x builds (Python 3.10, no tomllib) load
    the add-on as a legacy add-on too; the build writes these lines itself."""
    try:
        text = (addon_dir / "blender_manifest.toml").read_text(encoding="utf-8")
    except OSError:
        return None
    m = re.search(rf'(?m)^{re.escape(key)}\s*=\s*(\[[^\]]*\]|"[^"]*")', text)
    if m is None:
        return None
    value = m.group(1)
    if value.startswith("["):
        return re.findall(r'"([^"]*)"', value)
    return value[1:-1]


def bundled_platforms(addon_dir: Path = ADDON_DIR) -> list:
    """The platforms this copy of the add-on was built for (the zip's manifest `platforms`);
    empty for a build without a binary or the source folder."""
    return list(manifest_field(addon_dir, "platforms") or [])


def missing_platform_binary(addon_dir: Path = ADDON_DIR, tag: Optional[str] = None) -> Optional[str]:
    """Why this copy of the add-on has no renderer for this platform (None when it has one):
    a zip for other platforms (only a legacy install lets it in: Blender's extension
    installer refuses it), or a build without a binary (the source folder, the no-renderer zip)."""
    tag = tag or platform_tag()
    platforms = bundled_platforms(addon_dir)
    if platforms and tag not in platforms:
        return f"this Cubist add-on is the {', '.join(platforms)} build: it carries no renderer for this {tag} Blender"
    if not (addon_dir / "bin" / executable_name(tag)).is_file() and not (addon_dir / executable_name(tag)).is_file():
        return f"this Cubist add-on carries no renderer for {tag}"
    return None


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
    # A zip for another platform (installed as a legacy add-on) may hold a `bin/cubist` that
    # cannot run here (Linux's on macOS): never picked.
    platforms = bundled_platforms(addon_dir)
    if not platforms or platform_tag() in platforms:
        out.append(("bundled with the add-on", addon_dir / "bin" / BINARY_NAME))
        out.append(("next to the add-on", addon_dir / BINARY_NAME))
    # A development checkout: blender_addon/ sits in the project, the build in target/release.
    for parent in list(addon_dir.parents)[:3]:
        out.append(("project build", parent / "target" / "release" / BINARY_NAME))
    return out


_VERSION_CACHE: dict = {}


def binary_version(binary: Path) -> str:
    """`cubist --version`'s line (e.g. `cubist 0.1.0`), cached per binary file version;
    raises BinaryNotFound, naming the preference, when the file does not run as the renderer
    (built for another platform, not cubist at all, broken)."""
    st = binary.stat()
    key = (str(binary), st.st_mtime, st.st_size)
    if key not in _VERSION_CACHE:
        try:
            r = subprocess.run([str(binary), "--version"], capture_output=True, text=True, timeout=30,
                               **popen_platform_args())
        except subprocess.TimeoutExpired:
            raise BinaryNotFound(f"{binary} did not answer `--version` within 30 s: is it the cubist renderer? "
                                 f"(fix or clear {PREFERENCE})") from None
        except OSError as e:
            raise BinaryNotFound(f"{binary} does not run on this {platform_tag()} machine ({e.strerror}): set "
                                 f"{PREFERENCE} to a cubist built for it") from None
        line = (r.stdout.strip().splitlines() or [""])[0]
        if r.returncode != 0 or not line.startswith("cubist "):
            said = line or (r.stderr.strip().splitlines() or [f"exit code {r.returncode}"])[-1]
            raise BinaryNotFound(f"{binary} is not the cubist renderer (`--version` gave: {said[:80]}): fix or "
                                 f"clear {PREFERENCE}")
        _VERSION_CACHE[key] = line
    return _VERSION_CACHE[key]


def locate_binary(preference: str = "", addon_dir: Path = ADDON_DIR,
                  path_env: Optional[str] = None) -> tuple[str, Path]:
    """(where it was found, the `cubist` binary): the preference path when set (checked
    with `--version`; no fallback, so a wrong path is reported rather than silently
    replaced), else PATH, the add-on's own (bin/), the project build."""
    candidates = binary_candidates(preference, addon_dir, path_env)
    if preference:
        source, p = candidates[0]
        if not p.is_file():
            raise BinaryNotFound(f"cubist binary not found at {p}: fix or clear {PREFERENCE}")
        if not _make_executable(p):
            raise BinaryNotFound(f"{p} is not executable (and cannot be made so): fix or clear {PREFERENCE}")
        binary_version(p)
        return source, p
    for source, p in candidates:
        if source == "bundled with the add-on" or source == "next to the add-on":
            if _make_executable(p):
                return source, p
        elif _is_executable(p):
            return source, p
    tag = platform_tag()
    why = missing_platform_binary(addon_dir, tag) or "this Cubist add-on has no renderer"
    version = manifest_field(addon_dir, "version")
    zip_name = f"cubist-{version}-{tag}.zip" if version else f"the {tag} zip"
    offer = f"install {zip_name}" if tag in RELEASE_PLATFORMS else "no release zip is made for it"
    raise BinaryNotFound(f"cubist binary not found: {why} ({offer}): build cubist (cargo build --release) and set "
                         f"its path in {PREFERENCE}, or put it on PATH")


def find_binary(preference: str = "", addon_dir: Path = ADDON_DIR, path_env: Optional[str] = None) -> Path:
    """The `cubist` binary (see `locate_binary`)."""
    return locate_binary(preference, addon_dir, path_env)[1]


_KEYS_CACHE: dict[tuple[str, float, int], frozenset] = {}
# How long `cubist settings` may take: it answers at once.
ANSWER_SECONDS = 10.0


def binary_keys(binary: Path) -> frozenset:
    """The settings keys this binary accepts, cached per binary file version: the keys of
    `cubist settings` (every key, resolved), else, for binaries older than that subcommand,
    the flags of `cubist render --help` (every setting has a mirrored flag)."""
    st = binary.stat()
    key = (str(binary), st.st_mtime, st.st_size)
    if key not in _KEYS_CACHE:
        keys: frozenset = frozenset()
        try:
            r = subprocess.run([str(binary), "settings"], capture_output=True, text=True, timeout=ANSWER_SECONDS,
                               **popen_platform_args())
            data = json.loads(r.stdout) if r.returncode == 0 else None
            if isinstance(data, dict):
                keys = frozenset(data)
        except subprocess.TimeoutExpired:
            # `cubist settings` prints a table and exits at once: a binary that does not is
            # hung, and would hang the render too.
            raise BinaryNotFound(f"{binary} did not answer `settings` within {ANSWER_SECONDS:.0f} s: is it the "
                                 f"cubist renderer? (fix or clear {PREFERENCE})") from None
        except (OSError, subprocess.SubprocessError, ValueError):
            pass
        if not keys:
            try:
                r = subprocess.run([str(binary), "render", "--help"], capture_output=True, text=True, timeout=30,
                                   **popen_platform_args())
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
