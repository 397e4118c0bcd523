#!/usr/bin/env python3
"""Builds the installable Blender extension: dist/cubist-<version>-<platform>.zip with
blender_manifest.toml at its root (its `platforms` set to the binary's platform) and the
release `cubist` binary inside (bin/cubist, bin/cubist.exe on Windows), so users install one
file and press F12. One zip per platform: Blender's extension installer refuses a zip whose
`platforms` does not name the running Blender's platform.

    python3 scripts/build_addon.py                 # cargo build --release, then zip
    python3 scripts/build_addon.py --binary PATH   # zip a binary built elsewhere (a CI matrix)
    python3 scripts/build_addon.py --platform windows-x64 --binary cubist.exe
    python3 scripts/build_addon.py --no-binary     # cubist-<version>-no-renderer.zip, no `platforms`:
                                                   # for users who build cubist themselves

Install: Blender > Edit > Preferences > Get Extensions > Install from Disk, or headless
`bpy.ops.extensions.package_install_files(filepath=ZIP, repo="user_default", enable_on_install=True)`.
"""

from __future__ import annotations

import argparse
import re
import shutil
import stat
import struct
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
ADDON = ROOT / "blender_addon"
sys.path.insert(0, str(ROOT))
from blender_addon.runner.binary import executable_name, platform_tag  # noqa: E402 (bpy-free)

# Blender's extension platform names (docs.blender.org/manual, Extensions > Manifest).
PLATFORMS = ("windows-x64", "windows-arm64", "linux-x64", "linux-arm64", "macos-x64", "macos-arm64")
NO_BINARY = "no-renderer"


def current_platform() -> str:
    tag = platform_tag()
    if tag not in PLATFORMS:
        raise SystemExit(f"error: no Blender extension platform for this machine ({tag}); pass --platform")
    return tag


def binary_platform(head: bytes):
    """The Blender platform a binary runs on, from its header (None: not an executable we
    know). A zip for macos-arm64 holding a Linux build would install and never render, so the
    build refuses it. Read by hand: two fields of three well-documented headers (ELF e_machine,
    PE Machine after the e_lfanew offset, Mach-O cputype) do not need a parsing library."""
    if head[:4] == b"\x7fELF":
        machine = struct.unpack_from("<H" if head[5] == 1 else ">H", head, 18)[0]
        return {0x3E: "linux-x64", 0xB7: "linux-arm64"}.get(machine)
    if head[:2] == b"MZ" and len(head) >= 0x40:
        pe = struct.unpack_from("<I", head, 0x3C)[0]
        if head[pe:pe + 4] == b"PE\0\0":
            machine = struct.unpack_from("<H", head, pe + 4)[0]
            return {0x8664: "windows-x64", 0xAA64: "windows-arm64"}.get(machine)
        return None
    if head[:4] in (b"\xcf\xfa\xed\xfe", b"\xce\xfa\xed\xfe"):  # Mach-O, little-endian
        cputype = struct.unpack_from("<I", head, 4)[0]
        return {0x01000007: "macos-x64", 0x0100000C: "macos-arm64"}.get(cputype)
    return None


def manifest_for(tag: str | None) -> tuple[str, str]:
    """The manifest text with `platforms` set (left out for a zip without a binary: it then
    installs anywhere), and the version."""
    text = (ADDON / "blender_manifest.toml").read_text(encoding="utf-8")
    version = tomllib.loads(text)["version"]
    text = re.sub(r"(?m)^platforms\s*=.*\n", "", text)
    if tag is not None:
        # Top-level keys must come before the first [table].
        head, sep, tail = text.partition("\n[")
        head = head.rstrip("\n") + f'\n\nplatforms = ["{tag}"]\n'
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


def build(binary: Path | None, tag: str | None, out_dir: Path) -> Path:
    """The zip for `tag` with `binary` inside, or without either (`None`, `None`)."""
    manifest, version = manifest_for(tag)
    out_dir.mkdir(parents=True, exist_ok=True)
    out = out_dir / f"cubist-{version}-{tag or NO_BINARY}.zip"
    tmp = out.with_suffix(".zip.tmp")
    with zipfile.ZipFile(tmp, "w", compression=zipfile.ZIP_DEFLATED) as z:
        z.writestr("blender_manifest.toml", manifest)
        for p in addon_files():
            z.write(p, p.relative_to(ADDON).as_posix())
        if binary is not None:
            info = zipfile.ZipInfo(f"bin/{executable_name(tag)}", date_time=(2020, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = (stat.S_IFREG | 0o755) << 16  # executable where the unzipper honours it
            z.writestr(info, stripped(binary, out_dir))
    tmp.replace(out)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--binary", type=Path, help="the cubist binary to bundle (default: cargo build --release)")
    ap.add_argument("--platform", choices=PLATFORMS, help="Blender platform of the binary (default: this machine's)")
    ap.add_argument("--no-binary", action="store_true",
                    help="a zip without a renderer, for any platform (users set their own build in the preferences)")
    ap.add_argument("--out", type=Path, default=ROOT / "dist", help="output folder (default: dist/)")
    args = ap.parse_args(argv)
    if args.no_binary:
        if args.binary or args.platform:
            ap.error("--no-binary takes neither --binary nor --platform")
        print(build(None, None, args.out))
        return 0
    tag = args.platform or current_platform()
    binary = args.binary
    if binary is None:
        if tag != platform_tag():
            ap.error(f"--platform {tag} needs --binary (this machine builds {platform_tag()})")
        subprocess.run(["cargo", "build", "--release", "--locked", "--bin", "cubist"], cwd=ROOT, check=True)
        binary = ROOT / "target" / "release" / executable_name(tag)
    if not binary.is_file():
        print(f"error: {binary}: no such binary", file=sys.stderr)
        return 1
    with open(binary, "rb") as f:
        found = binary_platform(f.read(4096))
    if found != tag:
        print(f"error: {binary} is {'a ' + found if found else 'not a'} binary{'' if found else ' Blender runs'}, "
              f"not a {tag} one", file=sys.stderr)
        return 1
    # The add-on's panel, defaults and presets come from renderer_schema.json and
    # renderer_presets.json: they must be the bundled binary's (a binary for another platform
    # cannot run here; the tests check the files against this checkout's build).
    if tag == platform_tag():
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        from sync_addon_presets import check

        try:
            diff = check(binary)
        except OSError as e:
            print(f"error: cannot run {binary} to check its presets: {e.strerror}", file=sys.stderr)
            return 1
        if diff:
            print("error: blender_addon/renderer_presets.json or renderer_schema.json differs from the binary "
                  "(run python3 scripts/sync_addon_presets.py):\n  " + "\n  ".join(diff), file=sys.stderr)
            return 1
    print(build(binary, tag, args.out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
