"""The extension zip users install, in every Blender release the add-on supports headless: the
zip from scripts/build_addon.py installed with Blender's own extension install
(`bpy.ops.extensions.package_install_files`) into bpy 4.2 LTS, 4.5 LTS and 5.0, each in its
own venv (scripts/setup-bpy-matrix.sh; 5.0 is .venv's), then in each: F12 from a worker
thread (where the interface runs render()), Render Animation over three frames with a moving
camera, cancel, a missing binary reported on F12 and in the panel, every pass reaching the
compositor's Render Layers node, and the uninstall leaving no file, module, handler or
process behind. tests/blender_install/driver.py does the work in each Blender; the three run
at once (about 30 s together).

The windowed Blender (Debian's 3.4.1) has its own tests (test_blender_ui.py and the others
under tests/blender_ui/); Blender 5.1 and later (Python 3.13) are covered by the add-on being
pure Python (test_addon_pure_python.py)."""

import importlib.util
import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest

from addon_support import ROOT, cubist_binary  # noqa: F401 (fixture)

DRIVER = ROOT / "tests" / "blender_install" / "driver.py"
PASS_NAMES = ("Saliency", "Facets", "Facet Index", "Segments", "Object Colors", "Cubist Normal", "Cubist Depth")


def pinned(requirements: Path) -> list:
    return re.findall(r"(?m)^bpy==(\S+)", requirements.read_text())


def releases() -> dict:
    """Blender version -> the python whose bpy it is (None: its venv is not set up)."""
    out = {}
    for version in pinned(ROOT / "requirements-bpy-matrix.txt"):
        python = ROOT / f".venv-bpy{''.join(version.split('.')[:2])}" / "bin" / "python"
        out[version] = python if python.is_file() else None
    (main,) = pinned(ROOT / "requirements-test.txt")
    out[main] = Path(sys.executable) if importlib.util.find_spec("bpy") else None
    return out


RELEASES = releases()


@pytest.fixture(scope="module")
def runs(cubist_binary, tmp_path_factory):
    """Every release's driver results, run in parallel, by version."""
    base = tmp_path_factory.mktemp("blender_versions")
    r = subprocess.run([sys.executable, str(ROOT / "scripts" / "build_addon.py"), "--binary", str(cubist_binary),
                        "--out", str(base / "dist")], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    zip_path = Path(r.stdout.strip().splitlines()[-1])
    procs = {}
    t0 = time.monotonic()
    for version, python in RELEASES.items():
        if python is None:
            continue
        folder = base / version
        for sub in ("resources", "tmp", "out"):
            (folder / sub).mkdir(parents=True)
        env = dict(os.environ, BLENDER_USER_RESOURCES=str(folder / "resources"), TMPDIR=str(folder / "tmp"),
                   PATH="/usr/bin:/bin")  # the bundled renderer, not one on PATH
        log = open(folder / "driver.log", "w")
        procs[version] = (subprocess.Popen([str(python), "-X", "faulthandler", str(DRIVER), str(zip_path),
                                            str(folder / "out")], stdout=log, stderr=subprocess.STDOUT, env=env),
                          folder, log)
    out = {}
    for version, (proc, folder, log) in procs.items():
        try:
            proc.wait(timeout=600)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        log.close()
        results = folder / "out" / "results.json"
        out[version] = {"returncode": proc.returncode, "folder": folder,
                        "log": (folder / "driver.log").read_text(errors="replace"),
                        **(json.loads(results.read_text()) if results.is_file() else {"steps": {}})}
    print(f"\nextension install in bpy {', '.join(procs)}: {time.monotonic() - t0:.0f} s", file=sys.stderr)
    return out


def run_of(runs, version) -> dict:
    if RELEASES[version] is None:
        message = (f"bpy {version}: no venv (bash scripts/setup-bpy-matrix.sh, or scripts/setup-python.sh for "
                   f"the bpy of requirements-test.txt)")
        if os.environ.get("CUBIST_REQUIRE_UI_TEST") == "1":
            pytest.fail(message + "; required on CI (CUBIST_REQUIRE_UI_TEST=1)")
        pytest.skip(message)
    run = runs[version]
    assert run["returncode"] == 0 and run.get("done"), f"driver ended with {run['returncode']}:\n{run['log'][-4000:]}"
    return run


def step(runs, version, name) -> dict:
    s = run_of(runs, version)["steps"].get(name)
    assert s is not None, f"step {name} did not run"
    assert "exception" not in s, s.get("traceback") or s["exception"]
    return s


def test_every_release_has_its_venv_pinned():
    """The matrix is 4.2 LTS, 4.5 LTS and 5.0, each pinned once."""
    lines = sorted(".".join(v.split(".")[:2]) for v in RELEASES)
    assert lines == ["4.2", "4.5", "5.0"], RELEASES


@pytest.mark.parametrize("version", RELEASES)
def test_the_zip_installs_with_blenders_own_extension_install(runs, version):
    run = run_of(runs, version)
    assert run["blender"] == version  # the venv holds the release it is named for
    s = step(runs, version, "install")
    assert s["operator"] == ["FINISHED"] and s["enabled"] and s["engine"], s
    assert s["files_before"] == []
    assert "extensions/user_default/cubist/bin/cubist" in s["installed"], s["installed"]


@pytest.mark.parametrize("version", RELEASES)
def test_f12_from_a_worker_thread_paints(runs, version):
    s = step(runs, version, "f12_on_a_thread")
    assert s["error"] is None and s["last_error"] is None, s
    assert s["size"] == [64, 48] and s["colours"] > 30, s  # a painting, not a blank result


def test_every_release_paints_the_same_picture(runs):
    """Same scene, same renderer: the same pixels from every Blender (the export agrees; the
    PNG files differ only in the metadata each Blender writes)."""
    from blender_addon import pngio

    pictures = {v: pngio.read(r["folder"] / "out" / "f12.png").astype(int) for v, r in runs.items()
                if (r["folder"] / "out" / "f12.png").is_file()}
    if len(pictures) < 2:
        pytest.skip(f"only {', '.join(pictures) or 'no release'} rendered")
    first, *others = pictures
    for v in others:
        diff = abs(pictures[v] - pictures[first]).max()
        assert diff == 0, f"bpy {v} and {first} differ by {diff}/255"


@pytest.mark.parametrize("version", RELEASES)
def test_render_animation_follows_the_moving_camera(runs, version):
    s = step(runs, version, "animation_on_a_thread")
    assert s["error"] is None and s["frames"] == [1, 2, 3], s
    assert s["written"] == ["frame_0001.png", "frame_0002.png", "frame_0003.png"]
    for f in ("1", "2", "3"):
        assert s["camera_sent"][f] == pytest.approx(s["camera_expected"][f], abs=1e-4), f
    shas = [sha for _colours, sha in s["pictures"].values()]
    assert len(set(shas)) == 3, "two frames are the same picture: the camera did not move"


@pytest.mark.parametrize("version", RELEASES)
def test_cancel_stops_the_renderer(runs, version):
    s = step(runs, version, "cancel")
    assert s["cancelled"] and s["error"] is None, s
    # The session's renderer stopped that render and nothing else of the add-on's runs.
    assert s["server"] and s["renderer_running"] is None and s["renderer_queued"] == 0, s
    assert [pid for pid, _cmd in s["children"]] in ([], [s["server_pid"]]), s
    assert s["seconds_to_stop"] < 10 and not s["workspace_left"], s


@pytest.mark.parametrize("version", RELEASES)
def test_a_missing_binary_is_an_error_on_f12_and_in_the_panel(runs, version):
    s = step(runs, version, "missing_binary")
    pref = "Preferences > Add-ons > Cubist > Cubist Binary"
    assert s["error"] and f"Cubist: cubist binary not found at {s['missing']}" in s["error"], s
    assert pref in s["error"] and not s["written"], s
    text = " ".join(t for _icon, t in s["panel"])
    assert s["panel"][0][0] == "ERROR" and "cubist binary not found" in text and pref in text, s["panel"]


@pytest.mark.parametrize("version", RELEASES)
def test_every_pass_reaches_the_compositors_render_layers_node(runs, version):
    s = step(runs, version, "passes_reach_the_compositor")
    assert s["error"] is None, s
    assert tuple(s["blender_pass_names"]) == PASS_NAMES
    for name in PASS_NAMES:
        assert s["sockets"].get(name) is True, f"no enabled '{name}' output on Render Layers: {s['sockets']}"
        spread = s["spread"][name]
        assert spread and None not in spread and max(spread) > 0.1, f"pass '{name}' is empty or missing: {spread}"


@pytest.mark.parametrize("version", RELEASES)
def test_uninstall_leaves_nothing_behind(runs, version):
    s = step(runs, version, "uninstall")
    assert s["operator"] == ["FINISHED"] and not s["enabled"] and not s["engine"], s
    assert s["files_left"] == [], "files of the add-on left in the user resources"
    assert s["temp_left"] == [], "cubist files left in the temporary folder"
    assert s["children"] == [], "processes left running"
    assert s["handlers"] == [], "handlers left registered"
    assert s["modules_left"] == [], "modules left imported"
