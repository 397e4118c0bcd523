"""The release workflow (.github/workflows/release.yml): valid for GitHub (its workflow JSON
schema, through check-jsonschema's vendored copy), clean under actionlint (with shellcheck for
its scripts), and building what users need: one zip per platform Blender users have, each
with its own binary, plus the zip without a renderer, attached to a release on a version tag.

The tools come from requirements-test.txt (bash scripts/setup-python.sh installs them)."""

import re
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from addon_support import ROOT, cubist_binary  # noqa: F401 (fixture)

from blender_addon import runner

WORKFLOW = ROOT / ".github" / "workflows" / "release.yml"
BIN = Path(sys.executable).parent

# Rust's target for each Blender platform the release builds.
TARGETS = {
    "linux-x64": "x86_64-unknown-linux-gnu",
    "windows-x64": "x86_64-pc-windows-msvc",
    "macos-arm64": "aarch64-apple-darwin",
    "macos-x64": "x86_64-apple-darwin",
}


def tool(name: str) -> Path:
    path = BIN / name
    if not path.is_file():
        pytest.fail(f"{name} is missing from {BIN}: run bash scripts/setup-python.sh (requirements-test.txt)")
    return path


def workflow() -> dict:
    from ruamel.yaml import YAML  # check-jsonschema's YAML reader

    return YAML(typ="safe").load(WORKFLOW.read_text(encoding="utf-8"))


def test_workflow_follows_githubs_schema():
    r = subprocess.run([str(tool("check-jsonschema")), "--builtin-schema", "vendor.github-workflows", str(WORKFLOW)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr
    assert "ok -- validation done" in r.stdout


def test_the_schema_check_catches_a_broken_workflow(tmp_path):
    """The check above can fail: a job without `runs-on` is refused."""
    broken = tmp_path / "broken.yml"
    broken.write_text(WORKFLOW.read_text(encoding="utf-8").replace("    runs-on: ubuntu-22.04\n    steps:",
                                                                    "    steps:", 1))
    r = subprocess.run([str(tool("check-jsonschema")), "--builtin-schema", "vendor.github-workflows", str(broken)],
                       capture_output=True, text=True)
    assert r.returncode == 1, r.stdout + r.stderr


def test_workflow_passes_actionlint_and_shellcheck():
    r = subprocess.run([str(tool("actionlint")), "-shellcheck", str(tool("shellcheck")), str(WORKFLOW)],
                       capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 0, r.stdout + r.stderr


def test_actionlint_catches_a_shell_mistake(tmp_path):
    """actionlint runs shellcheck on the `run:` scripts: an unquoted glob count is reported."""
    broken = tmp_path / "release.yml"
    broken.write_text(WORKFLOW.read_text(encoding="utf-8").replace('"${#zips[@]}" -ne 5', '$(ls dist/*.zip | wc -l) -ne 5'))
    r = subprocess.run([str(tool("actionlint")), "-shellcheck", str(tool("shellcheck")), str(broken)],
                       capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 1 and "shellcheck" in r.stdout, r.stdout + r.stderr


def test_every_platform_gets_its_own_zip_and_binary():
    wf = workflow()
    build = wf["jobs"]["build"]
    matrix = build["strategy"]["matrix"]["include"]
    assert {m["platform"] for m in matrix} == set(runner.RELEASE_PLATFORMS) == set(TARGETS)
    for m in matrix:
        assert m["target"] == TARGETS[m["platform"]], m
        assert m["exe"] == (".exe" if m["platform"].startswith("windows") else ""), m
    steps = {s.get("name", s.get("uses")): s for s in build["steps"]}
    assert steps["Build the renderer"]["run"] == (
        "cargo build --release --locked --bin cubist --target ${{ matrix.target }}")
    assert build["env"]["BINARY"] == "target/${{ matrix.target }}/release/cubist${{ matrix.exe }}"
    assert steps["Build the add-on zip"]["run"] == (
        'python scripts/build_addon.py --platform ${{ matrix.platform }} --binary "$BINARY" --out dist')
    assert "--no-binary" in wf["jobs"]["no-renderer"]["steps"][-2]["run"]
    # A release only from a version tag, with the permission to write it, after every zip.
    assert wf["on"]["push"]["tags"] == ["v*"]
    release = wf["jobs"]["release"]
    assert release["if"] == "startsWith(github.ref, 'refs/tags/v')"
    assert release["permissions"] == {"contents": "write"} and wf["permissions"] == {"contents": "read"}
    assert set(release["needs"]) == {"build", "no-renderer"}
    assert "gh release create" in release["steps"][-1]["run"]


def test_the_build_step_makes_the_linux_zip(cubist_binary, tmp_path):
    """The workflow's zip command, with the linux-x64 matrix values, run here."""
    wf = workflow()
    run = next(s["run"] for s in wf["jobs"]["build"]["steps"] if s.get("name") == "Build the add-on zip")
    argv = run.replace("${{ matrix.platform }}", "linux-x64").replace('"$BINARY"', str(cubist_binary))
    argv = argv.replace("--out dist", f"--out {tmp_path}").split()
    assert argv[0] == "python"
    if runner.platform_tag() != "linux-x64":
        pytest.skip(f"this machine is {runner.platform_tag()}: the linux-x64 build step needs a Linux binary")
    r = subprocess.run([sys.executable, *argv[1:]], capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 0, r.stderr
    zip_path = Path(r.stdout.strip().splitlines()[-1])
    assert re.fullmatch(r"cubist-\d+\.\d+\.\d+-linux-x64\.zip", zip_path.name)
    with zipfile.ZipFile(zip_path) as z:
        assert 'platforms = ["linux-x64"]' in z.read("blender_manifest.toml").decode()
        assert "bin/cubist" in z.namelist()
