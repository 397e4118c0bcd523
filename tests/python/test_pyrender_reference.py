"""Independent reference for `cubist faces`: pyrender rasterises face ids through the very
camera cubist reports (position, orientation, field of view or view height, resolution), and
the visible-face counts must agree within 1% of the face count.

Both sides sample pixel centres: cubist at --spp 1, pyrender with multisampling off
(see eval/faceid.py). Beyond the count, the two *sets* of visible faces must also agree
within 1% of the face count, so agreement cannot come from compensating errors.
"""

import json
import subprocess

import pytest

import faceid

VIEWS = ["perspective:60", "perspective:90", "perspective:120", "orthographic"]


def cubist_views(cubist_bin, scene, *extra):
    args = [str(cubist_bin), "faces", str(scene), "--json", "--ids", "--spp", "1"]
    for v in VIEWS:
        args += ["--view", v]
    out = subprocess.run(args + list(extra), capture_output=True, text=True, check=True).stdout
    return json.loads(out)["rows"]


def compare(cubist_bin, scene, *extra):
    renderer = faceid.FaceIdRenderer(faceid.load_mesh(scene))
    try:
        report = []
        for row in cubist_views(cubist_bin, scene, *extra):
            ours = set(row["ids"])
            ref = renderer.visible(row["view"])
            assert len(ours) == row["visible"]
            total = row["total"]
            assert total == len(renderer.mesh.faces)
            count_diff = abs(len(ours) - len(ref))
            set_diff = len(ours ^ ref)
            report.append((row["camera"], row["angle"], len(ours), len(ref), set_diff))
            assert len(ref) > 0.05 * total, f"pyrender saw almost nothing: {row['view']}"
            assert count_diff <= 0.01 * total, f"{scene.name} {row['camera']} {row['angle']}: cubist {len(ours)}, pyrender {len(ref)} of {total}"
            assert set_diff <= 0.01 * total, f"{scene.name} {row['camera']} {row['angle']}: {set_diff} faces seen by only one of them"
        return report
    finally:
        renderer.close()


@pytest.fixture(scope="module")
def icosphere(tmp_path_factory):
    return faceid.icosphere_glb(tmp_path_factory.mktemp("sphere") / "sphere_1280.glb")


def test_icosphere_default_framing(cubist_bin, icosphere):
    report = compare(cubist_bin, icosphere, "--width", "512", "--height", "512")
    counts = {(c, a): ours for c, a, ours, _, _ in report}
    # pyrender's figures, measured on this machine, for this sphere and framing (the outline fills 90%).
    assert counts[("perspective", 60.0)] == pytest.approx(340, abs=13)
    assert counts[("orthographic", None)] == pytest.approx(624, abs=13)


def test_icosphere_off_axis_non_square(cubist_bin, icosphere):
    # An oblique camera and a wide image check orientation, aspect and pixel-centre mapping.
    compare(
        cubist_bin,
        icosphere,
        *("--width", "640", "--height", "360", "--camera-position", "1.5,1.2,2.4", "--camera-target", "0.1,-0.05,0"),
    )


def test_icosphere_tall_image_and_fill(cubist_bin, icosphere):
    compare(cubist_bin, icosphere, "--width", "300", "--height", "700", "--fill", "0.6", "--camera-up", "0.3,1,0")


@pytest.mark.parametrize("name", ["sphere_1280", "bunny_2k", "venus_11k"])
def test_table41_models(cubist_bin, models_dir, name):
    path = models_dir / f"{name}.glb"
    if not path.exists():
        pytest.skip(f"{path} is absent")
    compare(cubist_bin, path, "--width", "512", "--height", "512")


def test_models_off_axis(cubist_bin, models_dir):
    path = models_dir / "bunny_2k.glb"
    if not path.exists():
        pytest.skip(f"{path} is absent")
    compare(cubist_bin, path, "--width", "800", "--height", "600", "--camera-position", "-2,1,2.5")
