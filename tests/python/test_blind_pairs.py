"""scripts/blind_pairs.py: balanced sides, the key kept out of the judges' folder, and the
decoding of the judges' scores; `setup` end to end with stand-in binaries."""

import importlib.util
import json
import pathlib
import stat
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "scripts" / "blind_pairs.py"
spec = importlib.util.spec_from_file_location("blind_pairs", SCRIPT)
bp = importlib.util.module_from_spec(spec)
spec.loader.exec_module(bp)

SCENES = [f"scene{k}" for k in range(12)]


@pytest.mark.parametrize("count", [12, 11, 2, 1])
def test_sides_are_balanced_and_every_scene_is_paired_once(count):
    for seed in range(20):
        pairs = bp.assign(SCENES[:count], seed)
        assert sorted(s for _, s, _ in pairs) == sorted(SCENES[:count])
        assert [n for n, _, _ in pairs] == [f"{k:02d}" for k in range(1, count + 1)]
        new_a = sum(side == "A" for _, _, side in pairs)
        assert count // 2 <= new_a <= (count + 1) // 2, (seed, new_a)


def test_the_assignment_follows_the_seed():
    assert bp.assign(SCENES, 7) == bp.assign(SCENES, 7)
    assert len({tuple(bp.assign(SCENES, s)) for s in range(10)}) > 1


def test_scores_are_parsed_and_other_lines_skipped():
    text = "01 4.5 5 | a violin | B keeps the scroll\nnotes\n2 3 3 | a cat | equal\n03 x 4 | bad\n"
    assert bp.parse_scores(text) == {"01": (4.5, 5.0), "02": (3.0, 3.0)}


def test_a_judge_who_always_prefers_b_does_not_tilt_balanced_totals():
    key = {f"{k:02d}": {"scene": f"s{k}", "new": "A" if k % 2 else "B"} for k in range(1, 13)}
    scores = {n: (4.0, 4.5) for n in key}
    t = bp.tally(key, scores)
    assert (t["won"], t["lost"], t["equal"]) == (6, 6, 0)
    assert (t["prefer_a"], t["prefer_b"]) == (0, 12)
    assert t["median_new"] == t["median_old"] == 4.25


def test_tally_reads_each_side_from_the_key():
    key = {"01": {"scene": "cat", "new": "B"}, "02": {"scene": "pipe", "new": "A"}}
    t = bp.tally(key, {"01": (4.0, 5.0), "02": (3.0, 3.0)})
    assert (t["won"], t["lost"], t["equal"]) == (1, 0, 1)
    assert t["rows"] == [("cat", 5.0, 4.0), ("pipe", 3.0, 3.0)]


def stand_in(path, colour):
    """A stand-in for `cubist render SCENE -o OUT ...`: writes a one-colour PNG."""
    path.write_text(
        f"#!{sys.executable}\n"
        "import sys\nfrom PIL import Image\n"
        "out = sys.argv[sys.argv.index('-o') + 1]\n"
        f"Image.new('RGB', (4, 3), {colour!r}).save(out)\n"
    )
    path.chmod(path.stat().st_mode | stat.S_IEXEC)
    return path


def test_setup_writes_pairs_and_keeps_the_key_apart(tmp_path):
    pytest.importorskip("PIL")
    from PIL import Image

    new = stand_in(tmp_path / "new", (200, 0, 0))
    old = stand_in(tmp_path / "old", (0, 0, 200))
    scenes = tmp_path / "scenes"
    scenes.mkdir()
    names = ["cat", "pipe", "hammer", "bird"]
    out, key = tmp_path / "judges", tmp_path / "keys" / "r1.json"
    run = [sys.executable, str(SCRIPT), "setup", str(new), str(old), str(out), str(key),
           "--scenes", str(scenes), *names, "--seed", "3", "--size", "4x3"]
    subprocess.run(run, check=True, capture_output=True)
    assert sorted(p.name for p in out.iterdir()) == sorted(
        f"pair-{k:02d}-{s}.png" for k in range(1, 5) for s in "AB")
    pairs = json.loads(key.read_text())
    assert sum(p["new"] == "A" for p in pairs.values()) == 2
    for number, pair in pairs.items():
        red = Image.open(out / f"pair-{number}-{pair['new']}.png").getpixel((0, 0))
        assert red == (200, 0, 0), (number, pair)
    # The key inside the judges' folder is refused, with nothing written there.
    bad = subprocess.run(run[:6] + [str(out / "key.json")] + run[7:], capture_output=True, text=True)
    assert bad.returncode != 0 and "outside" in bad.stderr
    assert not (out / "key.json").exists()
