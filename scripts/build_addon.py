#!/usr/bin/env python3
"""Builds the installable Blender extension: dist/cubist-<version>-<platform>.zip with
blender_manifest.toml at its root (its `platforms` set to this machine's) and the release
`cubist` binary inside (bin/cubist), so users install one file and press F12.

    python3 scripts/build_addon.py                 # cargo build --release, then zip
    python3 scripts/build_addon.py --binary PATH   # zip a binary built elsewhere (a CI matrix)
    python3 scripts/build_addon.py --platform windows-x64 --binary cubist.exe

Install: Blender > Edit > Preferences > Get Extensions > Install from Disk, or headless
`bpy.ops.extensions.package_install_files(filepath=ZIP, repo="user_default", enable_on_install=True)`.
"""

from __future__ import annotations

import argparse
import platform
import re
import shutil
import stat
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
ADDON = ROOT / "blender_addon"

# Blender's platform tags for extensions.
PLATFORMS = {
    ("linux", "x86_64"): "linux-x64",
    ("linux", "amd64"): "linux-x64",
    ("linux", "aarch64"): "linux-arm64",
    ("darwin", "arm64"): "macos-arm64",
    ("darwin", "x86_64"): "macos-x64",
    ("win32", "amd64"): "windows-x64",
    ("win32", "x86_64"): "windows-x64",
    ("win32", "arm64"): "windows-arm64",
}


def current_platform() -> str:
    key = (sys.platform, platform.machine().lower())
    if key not in PLATFORMS:
        raise SystemExit(f"error: no Blender platform tag for {key[0]}/{key[1]}; pass --platform")
    return PLATFORMS[key]


def _this_platform():
    try:
        return current_platform()
    except SystemExit:
        return None


def manifest_for(platform_tag: str) -> tuple[str, str]:
    """The manifest text with `platforms` set, and the version."""
    text = (ADDON / "blender_manifest.toml").read_text(encoding="utf-8")
    version = tomllib.loads(text)["version"]
    text = re.sub(r"(?m)^platforms\s*=.*\n", "", text)
    # Top-level keys must come before the first [table].
    head, sep, tail = text.partition("\n[")
    head = head.rstrip("\n") + f'\n\nplatforms = ["{platform_tag}"]\n'
    text = head + (sep + tail if sep else "")
    tomllib.loads(text)  # still valid TOML
    return text, version


def addon_files() -> list[Path]:
    return sorted(p for p in ADDON.rglob("*") if p.is_file() and "__pycache__" not in p.parts
                  and p.suffix not in {".pyc", ".pyo"} and p.name != "blender_manifest.toml"
                  and p.parts[len(ADDON.parts)] != "bin")


def stripped(binary: Path, out_dir: Path) -> bytes:
    """The binary without its debug line tables (a third of the size), when `strip` is here."""
    strip = shutil.which("strip")
    if strip is None or binary.suffix == ".exe":
        return binary.read_bytes()
    tmp = out_dir / ".cubist-stripped.tmp"
    try:
        r = subprocess.run([strip, "-o", str(tmp), str(binary)], capture_output=True)
        return tmp.read_bytes() if r.returncode == 0 else binary.read_bytes()
    finally:
        tmp.unlink(missing_ok=True)


def build(binary: Path, platform_tag: str, out_dir: Path) -> Path:
    manifest, version = manifest_for(platform_tag)
    out_dir.mkdir(parents=True, exist_ok=True)
    out = out_dir / f"cubist-{version}-{platform_tag}.zip"
    exe_name = "cubist.exe" if platform_tag.startswith("windows") else "cubist"
    tmp = out.with_suffix(".zip.tmp")
    with zipfile.ZipFile(tmp, "w", compression=zipfile.ZIP_DEFLATED) as z:
        z.writestr("blender_manifest.toml", manifest)
        for p in addon_files():
            z.write(p, p.relative_to(ADDON).as_posix())
        info = zipfile.ZipInfo(f"bin/{exe_name}", date_time=(2020, 1, 1, 0, 0, 0))
        info.compress_type = zipfile.ZIP_DEFLATED
        info.external_attr = (stat.S_IFREG | 0o755) << 16  # executable where the unzipper honours it
        z.writestr(info, stripped(binary, out_dir))
    tmp.replace(out)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--binary", type=Path, help="the cubist binary to bundle (default: cargo build --release)")
    ap.add_argument("--platform", help="Blender platform tag (default: this machine's)")
    ap.add_argument("--out", type=Path, default=ROOT / "dist", help="output folder (default: dist/)")
    args = ap.parse_args(argv)
    tag = args.platform or current_platform()
    binary = args.binary
    if binary is None:
        subprocess.run(["cargo", "build", "--release", "--locked", "--bin", "cubist"], cwd=ROOT, check=True)
        binary = ROOT / "target" / "release" / ("cubist.exe" if sys.platform == "win32" else "cubist")
    if not binary.is_file():
        print(f"error: {binary}: no such binary", file=sys.stderr)
        return 1
    # The add-on's panel, defaults and presets come from renderer_schema.json and
    # renderer_presets.json: they must be the bundled binary's (a binary for another platform
    # cannot run here; the tests check the files against this checkout's build).
    if args.platform is None or args.platform == _this_platform():
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        from sync_addon_presets import check

        diff = check(binary)
        if diff:
            print("error: blender_addon/renderer_presets.json or renderer_schema.json differs from the binary "
                  "(run python3 scripts/sync_addon_presets.py):\n  " + "\n  ".join(diff), file=sys.stderr)
            return 1
    out = build(binary, tag, args.out)
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
