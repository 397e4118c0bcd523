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
                               **popen_platform_args())
            data = json.loads(r.stdout) if r.returncode == 0 else None
            if isinstance(data, dict):
                keys = frozenset(data)
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
