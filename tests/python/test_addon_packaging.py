"""The add-on zips (scripts/build_addon.py): one per platform with that platform's binary and
`platforms` in its manifest, the zip without a renderer, a binary for the wrong platform
refused; and in headless Blender (bpy 5.0.1): a zip for another platform refused by Blender's
installer, the zip without a renderer saying so in the panel and on F12 (naming the
preference), then rendering once a binary of one's own is set there."""

import json
import os
import re
import stat
import struct
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from addon_support import ROOT, cubist_binary  # noqa: F401 (fixture)
from ship_support import SCENE_PY, validate_extension

from blender_addon import runner

sys.path.insert(0, str(ROOT / "scripts"))
import build_addon  # noqa: E402

BUILD = [sys.executable, str(ROOT / "scripts" / "build_addon.py")]
PREF = "Preferences > Add-ons > Cubist > Cubist Binary"


def fake_binary(tag: str) -> bytes:
    """The first bytes of an executable for `tag`, as its linker writes them."""
    if tag.startswith("linux"):
        machine = {"linux-x64": 0x3E, "linux-arm64": 0xB7}[tag]
        return b"\x7fELF\x02\x01\x01" + bytes(11) + struct.pack("<H", machine) + bytes(64)
    if tag.startswith("windows"):
        machine = {"windows-x64": 0x8664, "windows-arm64": 0xAA64}[tag]
        head = bytearray(b"MZ" + bytes(0x3A) + struct.pack("<I", 0x80) + bytes(0x40))
        return bytes(head) + b"PE\0\0" + struct.pack("<H", machine) + bytes(64)
    cpu = {"macos-x64": 0x01000007, "macos-arm64": 0x0100000C}[tag]
    return b"\xcf\xfa\xed\xfe" + struct.pack("<I", cpu) + bytes(64)


@pytest.mark.parametrize("tag", build_addon.PLATFORMS)
def test_binary_platform_reads_each_header(tag):
    assert build_addon.binary_platform(fake_binary(tag)) == tag


def test_binary_platform_of_the_real_build_and_of_non_binaries(cubist_binary):
    assert build_addon.binary_platform(cubist_binary.read_bytes()[:4096]) == runner.platform_tag()
    for junk in (b"", b"#!/bin/sh\necho cubist\n", b"MZ" + bytes(100), b"\x7fELF\x02\x01\x01" + bytes(11) + b"\x03\x00"):
        assert build_addon.binary_platform(junk) is None


def build(*args):
    return subprocess.run([*BUILD, *map(str, args)], capture_output=True, text=True, cwd=ROOT)


@pytest.mark.parametrize("tag", runner.RELEASE_PLATFORMS)
def test_each_platform_zip_carries_its_binary_and_platform(cubist_binary, tmp_path, tag):
    """This machine's zip with the real build (its presets are checked against the add-on's);
    the others with the first bytes of a build for them (the header is what the build reads)."""
    if tag == runner.platform_tag():
        binary = cubist_binary
    else:
        binary = tmp_path / "cubist-build"
        binary.write_bytes(fake_binary(tag))
    r = build("--platform", tag, "--binary", binary, "--out", tmp_path / "dist")
    assert r.returncode == 0, r.stderr
    zip_path = Path(r.stdout.strip().splitlines()[-1])
    version = runner.manifest_field(runner.ADDON_DIR, "version")
    assert zip_path.name == f"cubist-{version}-{tag}.zip"
    exe = "bin/cubist.exe" if tag.startswith("windows") else "bin/cubist"
    with zipfile.ZipFile(zip_path) as z:
        names = set(z.namelist())
        manifest = z.read("blender_manifest.toml").decode()
        assert f'\nplatforms = ["{tag}"]\n' in manifest
        if binary != cubist_binary:  # the real one is stripped of its debug tables
            assert z.read(exe) == binary.read_bytes()
        assert build_addon.binary_platform(z.read(exe)[:4096]) == tag
        assert stat.S_IMODE(z.getinfo(exe).external_attr >> 16) == 0o755
        assert [n for n in names if n.startswith("bin/")] == [exe]
    # Every file of the add-on, the runner package included, and nothing compiled.
    sources = {p.relative_to(runner.ADDON_DIR).as_posix() for p in runner.ADDON_DIR.rglob("*.py")
               if "__pycache__" not in p.parts}
    assert {"runner/__init__.py", "runner/binary.py", "runner/process.py"} <= sources <= names
    assert not [n for n in names if "__pycache__" in n or n.endswith(".pyc")]
    v = validate_extension(zip_path)
    assert v.returncode == 0 and "Success" in v.stdout, v.stdout + v.stderr


def test_a_binary_for_another_platform_is_refused(cubist_binary, tmp_path):
    here = runner.platform_tag()
    other = "windows-x64" if here != "windows-x64" else "linux-x64"
    r = build("--platform", other, "--binary", cubist_binary, "--out", tmp_path)
    assert r.returncode == 1
    assert f"is a {here} binary, not a {other} one" in r.stderr, r.stderr
    script = tmp_path / "cubist.sh"
    script.write_text("#!/bin/sh\n")
    r = build("--platform", other, "--binary", script, "--out", tmp_path)
    assert r.returncode == 1 and f"is not a binary Blender runs, not a {other} one" in r.stderr, r.stderr
    assert not list(tmp_path.glob("*.zip"))


def test_usage_errors(tmp_path):
    here = runner.platform_tag()
    other = "windows-x64" if here != "windows-x64" else "linux-x64"
    r = build("--platform", other, "--out", tmp_path)
    assert r.returncode == 2 and f"--platform {other} needs --binary" in r.stderr, r.stderr
    r = build("--no-binary", "--platform", here, "--out", tmp_path)
    assert r.returncode == 2 and "--no-binary takes neither" in r.stderr, r.stderr
    r = build("--platform", "amiga-m68k", "--out", tmp_path)
    assert r.returncode == 2 and "invalid choice" in r.stderr, r.stderr
    assert not list(tmp_path.glob("*.zip"))


def no_renderer_zip(tmp_path) -> Path:
    r = build("--no-binary", "--out", tmp_path / "dist")
    assert r.returncode == 0, r.stderr
    return Path(r.stdout.strip().splitlines()[-1])


def test_the_zip_without_a_renderer(tmp_path):
    zip_path = no_renderer_zip(tmp_path)
    assert zip_path.name == f"cubist-{runner.manifest_field(runner.ADDON_DIR, 'version')}-no-renderer.zip"
    with zipfile.ZipFile(zip_path) as z:
        assert not re.search(r"(?m)^platforms\s*=", z.read("blender_manifest.toml").decode())
        assert not [n for n in z.namelist() if n.startswith("bin/")]
        assert "runner/binary.py" in z.namelist()
    v = validate_extension(zip_path)
    assert v.returncode == 0 and "Success" in v.stdout, v.stdout + v.stderr


# ---------------------------------------------------------------------------------------------
# In Blender (bpy 5.0.1), each in a fresh process with its own user folder.

BLENDER_SCRIPT = r"""
import json, os, sys, tempfile, traceback
os.environ["BLENDER_USER_RESOURCES"] = tempfile.mkdtemp(prefix="cubist-blender-pkg-")
import bpy

zip_path, out, binary = sys.argv[1], sys.argv[2], sys.argv[3]
res = {}
try:
    res["install"] = sorted(bpy.ops.extensions.package_install_files(filepath=zip_path, repo="user_default",
                                                                       enable_on_install=True))
except Exception as e:
    res["install_error"] = str(e)
pkg = "bl_ext.user_default.cubist"
res["enabled"] = pkg in bpy.context.preferences.addons
if res["enabled"]:
    ui = sys.modules[pkg + ".ui"]
    preferences = sys.modules[pkg + ".preferences"]
    prefs = bpy.context.preferences.addons[pkg].preferences

    class Layout:
        # Records the labels a panel draws (no UI in background mode).
        def __init__(self):
            self.labels = []
        def label(self, text="", icon="NONE", **kw):
            self.labels.append((icon, text))
        def prop(self, *a, **kw):
            pass
        def __getattr__(self, name):
            # column, row, box, split, operator...: sub-layouts record into the same list.
            return lambda *a, **kw: self

    def drawn(cls, **attrs):
        layout = Layout()
        cls.draw(type("Fake", (), dict(attrs, layout=layout))(), bpy.context)
        return layout.labels

    def f12():
        scene = cubist_scene(bpy)
        scene.render.filepath = out
        try:
            bpy.ops.render.render(write_still=True)
            return None
        except RuntimeError as e:
            return str(e)

    res["panel"] = drawn(ui.CUBIST_PT_render)
    res["preferences"] = drawn(preferences.CubistPreferences, binary_path="")
    res["f12_error"] = f12()
    res["written"] = os.path.isfile(out)
    prefs.binary_path = binary
    res["preferences_set"] = drawn(preferences.CubistPreferences, binary_path=binary)
    res["f12_error_set"] = f12()
    res["written_set"] = os.path.isfile(out)
    res["panel_set"] = drawn(ui.CUBIST_PT_render)
print("RESULT " + json.dumps(res))
"""


def run_in_blender(tmp_path, zip_path, binary="") -> dict:
    script = tmp_path / "blender_script.py"
    script.write_text(SCENE_PY + BLENDER_SCRIPT)
    env = dict(os.environ, PATH="/usr/bin:/bin")  # no cubist on PATH
    env.pop("BLENDER_USER_RESOURCES", None)
    r = subprocess.run([sys.executable, str(script), str(zip_path), str(tmp_path / "f12.png"), str(binary)],
                       capture_output=True, text=True, env=env, timeout=300)
    line = next((ln for ln in r.stdout.splitlines() if ln.startswith("RESULT ")), None)
    assert line, f"{r.stdout[-2000:]}\n{r.stderr[-3000:]}"
    res = json.loads(line[len("RESULT "):])
    res["output"] = r.stdout + r.stderr
    return res


def test_blender_refuses_a_zip_for_another_platform(tmp_path):
    here = runner.platform_tag()
    other = "macos-arm64" if here != "macos-arm64" else "linux-x64"
    binary = tmp_path / "cubist-build"
    binary.write_bytes(fake_binary(other))
    r = build("--platform", other, "--binary", binary, "--out", tmp_path / "dist")
    assert r.returncode == 0, r.stderr
    res = run_in_blender(tmp_path, Path(r.stdout.strip().splitlines()[-1]))
    # Blender's installer reports it (as an ERROR line; the operator itself still "finishes").
    assert not res["enabled"], res
    assert f"This platform ({here}) isn't one of ({other})" in res["output"], res["output"][-3000:]


def text_of(labels):
    return " ".join(text for _icon, text in labels)


def test_a_zip_without_a_renderer_says_so_and_takes_the_users_binary(cubist_binary, tmp_path):
    res = run_in_blender(tmp_path, no_renderer_zip(tmp_path), cubist_binary)
    assert res["install"] == ["FINISHED"] and res["enabled"], res
    here = runner.platform_tag()
    # The panel says so, in full (wrapped over several labels, the first with the error icon)...
    said = f"this Cubist add-on carries no renderer for {here}"
    assert said in text_of(res["panel"]) and PREF in text_of(res["panel"]), res["panel"]
    assert res["panel"][0][0] == "ERROR" and len(res["panel"]) > 1
    assert said in text_of(res["preferences"]), res["preferences"]
    # ...F12 is a clear error naming the preference, and writes nothing...
    assert f"Cubist: cubist binary not found: {said}" in res["f12_error"] and PREF in res["f12_error"], res
    assert not res["written"]
    # ...and a binary of one's own, set in the preferences, renders.
    assert res["preferences_set"][0] == ["CHECKMARK", f"Using {cubist_binary} "
                                         f"({runner.binary_version(cubist_binary)}, add-on preferences)"]
    # No error left in the panel (the colour-management notice and the preset's name remain).
    assert "ERROR" not in [icon for icon, _ in res["panel_set"]], res["panel_set"]
    assert res["f12_error_set"] is None and res["written_set"], res
