"""Shared fixtures: the repository root, the release `cubist` binary (built when missing),
the shared test data (tests using it skip when it is absent) and eval/ on sys.path."""

import os
import pathlib
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "eval"))


def shared_dir():
    return pathlib.Path(os.environ.get("CUBIST_SHARED", ROOT.parent / "shared"))


@pytest.fixture(scope="session")
def cubist_bin():
    """Path of the release binary; `cargo build --release --locked` when it is not built yet."""
    env = os.environ.get("CUBIST_BIN")
    if env:
        return pathlib.Path(env)
    path = ROOT / "target" / "release" / "cubist"
    if not path.exists():
        subprocess.run(["cargo", "build", "--release", "--locked", "--bin", "cubist"], cwd=ROOT, check=True)
    return path


@pytest.fixture(scope="session")
def models_dir():
    d = shared_dir() / "models"
    if not d.is_dir():
        pytest.skip(f"{d} is absent (shared test data is not part of a fresh clone)")
    return d
