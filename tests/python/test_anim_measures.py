"""scripts/anim_measures.py on made-up frames whose answer is known: a textured square moving
two pixels right over a still background, its paint either carried with it or left on the
screen; then the whole script on frames and passes the renderer wrote."""

import importlib.util
import json
import pathlib
import subprocess
import sys

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
spec = importlib.util.spec_from_file_location("anim_measures", ROOT / "scripts" / "anim_measures.py")
am = importlib.util.module_from_spec(spec)
spec.loader.exec_module(am)

SIZE = 48
SHIFT = 2


def frame(x0, texture, offset):
    """A frame with the square's left edge at x0, its paint `texture` read from column
    `offset` on: moving SHIFT pixels right from the previous frame and on to the next."""
    obj = np.zeros((SIZE, SIZE), np.int64)
    img = np.full((SIZE, SIZE, 3), 90.0)
    mot = np.zeros((SIZE, SIZE, 4))
    obj[12:36, x0:x0 + 20] = 1
    img[12:36, x0:x0 + 20] = texture[12:36, offset:offset + 20]
    mot[obj == 1] = [SHIFT, 0, SHIFT, 0]
    return {"img": img, "obj": obj, "nrm": np.zeros((SIZE, SIZE, 3)), "mot": mot,
            "ids": obj.copy()}


@pytest.fixture
def texture():
    return np.random.default_rng(7).uniform(40, 220, (SIZE, SIZE, 3))


def test_paint_carried_with_the_surface_is_coherent(texture):
    # The paint moves with the square: the warp undoes the move exactly (whole pixels).
    r = am.pair(frame(10, texture, 10), frame(10 + SHIFT, texture, 10))
    assert r["coherence"] < 1e-9 and r["coherence_floor"] < 1e-9
    assert r["flicker"] == 0 and r["far_bg_changed"] == 0 and r["pops"] == 0
    assert r["moving_px"] > 300


def test_paint_left_on_the_screen_is_not(texture):
    # The square moves but its paint stays where it was on the screen (a shower door): warping
    # along the motion makes the frames differ more than not warping them.
    r = am.pair(frame(10, texture, 10), frame(10 + SHIFT, texture, 10 + SHIFT))
    assert r["coherence"] > 1, r
    assert r["coherence_floor"] < 1e-9


def test_the_floor_counts_the_warps_blend(texture):
    # Moved by a pixel and a half, paint carried exactly still reads above 0 through the warp.
    a, b = frame(10, texture, 10), frame(11, texture, 10)
    for f in (a, b):
        f["mot"][f["obj"] == 1] = [1.5, 0, 1.5, 0]
    r = am.pair(a, b)
    assert r["coherence_floor"] > 0.05, r


def test_the_residual_is_split_by_where_it_is(texture):
    # The square is two planes (its left and right halves), its paint carried exactly, except
    # two columns either side of the plane edge, repainted: the residual is all at the edge.
    a, b = frame(10, texture, 10), frame(10 + SHIFT, texture, 10)
    for f, x0 in ((a, 10), (b, 10 + SHIFT)):
        f["ids"][12:36, x0 + 10:x0 + 20] = 2
    b["img"][17:31, 10 + SHIFT + 9:10 + SHIFT + 11] += 30
    r = am.pair(a, b)
    parts = r["coherence_outline"] + r["coherence_edges"] + r["coherence_inside"]
    assert abs(parts - r["coherence"]) < 1e-9, r
    assert r["coherence_edges"] > 0 and r["coherence_outline"] == 0 and r["coherence_inside"] == 0, r
    # The shower door: the residual everywhere on the square, outline and inside alike.
    r = am.pair(frame(10, texture, 10), frame(10 + SHIFT, texture, 10 + SHIFT))
    assert r["coherence_outline"] > 0 and r["coherence_inside"] > 0 and r["coherence_edges"] == 0, r
    assert abs(r["coherence_outline"] + r["coherence_inside"] - r["coherence"]) < 1e-9


def test_the_plain_render_says_what_the_light_changes(texture):
    # The square's light rises between the frames (its surface turned to the light) in the
    # painting and in the unpainted render alike, the paint carried exactly: the residual is
    # the render's own, and the painting adds nothing to it.
    def lit(f, gain):
        f["img"][f["obj"] == 1] *= gain
        return f

    a, b = frame(10, texture, 10), lit(frame(10 + SHIFT, texture, 10), 1.2)
    r = am.pair(a, b)
    assert r["coherence"] > 0.1, r
    own = am.against_plain(r, a, b)
    assert own["coherence_plain"] == r["coherence"] and own["coherence_excess"] == 0
    # Paint left on the screen over the same unpainted render: all of the excess is the paint's.
    door = am.pair(frame(10, texture, 10), lit(frame(10 + SHIFT, texture, 10 + SHIFT), 1.2))
    assert am.against_plain(door, a, b)["coherence_excess"] > 0.5, door


def test_the_script_reads_the_renderers_frames(cubist_bin, tmp_path):
    # Two frames of the built-in still life on a turntable, with every pass the script reads.
    args = [str(cubist_bin), "render", "--width", "64", "--height", "48", "--frames", "1-2", "--orbit", "5",
            "--pass", "objects", "--pass", "normals", "--pass", "facet-ids", "--pass", "motion",
            "-o", str(tmp_path / "f_##.png")]
    subprocess.run(args, check=True, capture_output=True)
    out = subprocess.run([sys.executable, str(ROOT / "scripts" / "anim_measures.py"), str(tmp_path / "f_##.png"),
                          "1", "2", "--json"], check=True, capture_output=True, text=True).stdout
    mean = json.loads(out)["mean"]
    assert set(mean) >= {"flicker", "coherence", "coherence_floor", "coherence_edges", "pops", "changed"}
    assert mean["far_bg_changed"] == 0
    assert 0 <= mean["coherence_floor"] <= mean["coherence"] + 0.05
    # Against the same frames unpainted.
    plain = [*args[:-2], "--preset", "plain", "-o", str(tmp_path / "p_##.png")]
    subprocess.run(plain, check=True, capture_output=True)
    out = subprocess.run([sys.executable, str(ROOT / "scripts" / "anim_measures.py"), str(tmp_path / "f_##.png"),
                          "1", "2", "--plain", str(tmp_path / "p_##.png"), "--json"],
                         check=True, capture_output=True, text=True).stdout
    mean = json.loads(out)["mean"]
    assert abs(mean["coherence"] - mean["coherence_plain"] - mean["coherence_excess"]) < 1e-9
