#!/usr/bin/env python3
"""Blind pair judging of two looks (docs/look/README.md, "How it was judged").

`setup` renders every scene with a new and an old `cubist` binary and writes the pairs a judge
sees: OUT/pair-NN-A.png and OUT/pair-NN-B.png, the scenes in a seeded order, the new picture A
in exactly half the pairs (a seeded choice of which). On pairs that differ by little a judge
often favours one letter; with the sides balanced that preference cannot tilt the totals. The
key (which scene and which side is new) and the renders under their real names go to KEY and
its folder, which must lie outside OUT: the judges are told to open OUT only.

`decode` reads each judge's OUT/scores-JUDGE.txt, one line a pair, `NN scoreA scoreB | ...`,
and prints per judge the pairs the new look won, lost and tied, the medians, how often the
judge preferred A and B, and each scene's two scores.

Usage:
  blind_pairs.py setup NEW_BIN OLD_BIN OUT KEY --scenes DIR NAME... [--seed S] [--size WxH]
                 [--new-env K=V]... [-- extra args for the new binary]
  blind_pairs.py decode OUT KEY JUDGE...
"""

import argparse
import json
import os
import pathlib
import random
import shutil
import statistics
import subprocess
import sys


def assign(scenes, seed):
    """The pairs: [(number "NN", scene, side of the new picture "A" or "B")], the scenes in a
    seeded order, the new picture A in exactly half of them (one more or less for an odd
    count, by the seed)."""
    rng = random.Random(seed)
    order = list(scenes)
    rng.shuffle(order)
    new_a = [i < len(order) // 2 for i in range(len(order))]
    if len(order) % 2:
        new_a[-1] = rng.random() < 0.5
    rng.shuffle(new_a)
    return [(f"{n:02d}", s, "A" if a else "B") for n, (s, a) in enumerate(zip(order, new_a), 1)]


def parse_scores(text):
    """{"NN": (scoreA, scoreB)} from a judge's lines `NN scoreA scoreB | ...`; other lines are
    skipped."""
    scores = {}
    for line in text.splitlines():
        parts = line.split("|")[0].split()
        if len(parts) < 3 or not parts[0].isdigit():
            continue
        try:
            scores[f"{int(parts[0]):02d}"] = (float(parts[1]), float(parts[2]))
        except ValueError:
            continue
    return scores


def tally(key, scores):
    """One judge's scores against the key: won, lost, equal (for the new look), the medians
    of the new and old scores, how often A and B scored higher, and per pair (scene, new, old)."""
    won = lost = equal = prefer_a = prefer_b = 0
    rows = []
    for number, pair in sorted(key.items()):
        if number not in scores:
            continue
        a, b = scores[number]
        new, old = (a, b) if pair["new"] == "A" else (b, a)
        won += new > old
        lost += new < old
        equal += new == old
        prefer_a += a > b
        prefer_b += b > a
        rows.append((pair["scene"], new, old))
    median = (lambda v: statistics.median(v) if v else float("nan"))
    return {
        "won": won, "lost": lost, "equal": equal,
        "median_new": median([r[1] for r in rows]), "median_old": median([r[2] for r in rows]),
        "prefer_a": prefer_a, "prefer_b": prefer_b, "rows": rows,
    }


def render(binary, scene, out, size, extra, env):
    w, h = size
    cmd = [binary, "render", str(scene), "-o", str(out), "--width", str(w), "--height", str(h),
           "--progress", "none", *extra]
    r = subprocess.run(cmd, env=env, capture_output=True, text=True)
    if r.returncode:
        sys.exit(f"blind_pairs: {' '.join(cmd)} failed: {r.stderr.strip()}")


def setup(a):
    out, key_path = pathlib.Path(a.out).resolve(), pathlib.Path(a.key).resolve()
    if out == key_path.parent or out in key_path.parents:
        sys.exit("blind_pairs: the key must lie outside the judges' folder")
    renders = key_path.parent / (key_path.stem + "-renders")
    out.mkdir(parents=True, exist_ok=True)
    renders.mkdir(parents=True, exist_ok=True)
    env_new = dict(os.environ)
    for kv in a.new_env:
        k, _, v = kv.partition("=")
        env_new[k] = v
    w, _, h = a.size.partition("x")
    size = (int(w), int(h))
    pairs = assign(a.names, a.seed)
    for _, scene, _ in pairs:
        glb = pathlib.Path(a.scenes) / f"{scene}.glb"
        render(a.new_bin, glb, renders / f"{scene}-new.png", size, a.extra, env_new)
        render(a.old_bin, glb, renders / f"{scene}-old.png", size, [], dict(os.environ))
    key = {}
    for number, scene, new_side in pairs:
        old_side = "B" if new_side == "A" else "A"
        shutil.copy(renders / f"{scene}-new.png", out / f"pair-{number}-{new_side}.png")
        shutil.copy(renders / f"{scene}-old.png", out / f"pair-{number}-{old_side}.png")
        key[number] = {"scene": scene, "new": new_side}
    key_path.write_text(json.dumps(key, indent=1))
    print(f"{len(pairs)} pairs in {out}; key {key_path}")


def decode(a):
    key = json.loads(pathlib.Path(a.key).read_text())
    for judge in a.judges:
        path = pathlib.Path(a.out) / f"scores-{judge}.txt"
        t = tally(key, parse_scores(path.read_text()))
        print(f"{judge}: won {t['won']} lost {t['lost']} equal {t['equal']}; median new "
              f"{t['median_new']} old {t['median_old']}; preferred A {t['prefer_a']}, B {t['prefer_b']}")
        for scene, new, old in t["rows"]:
            print(f"  {scene:20s} new {new:4.1f} old {old:4.1f}")


def main(argv):
    extra = []
    if "--" in argv:
        i = argv.index("--")
        argv, extra = argv[:i], argv[i + 1:]
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="command", required=True)
    s = sub.add_parser("setup")
    s.add_argument("new_bin")
    s.add_argument("old_bin")
    s.add_argument("out")
    s.add_argument("key")
    s.add_argument("--scenes", required=True)
    s.add_argument("names", nargs="+")
    s.add_argument("--seed", type=int, default=1)
    s.add_argument("--size", default="960x720")
    s.add_argument("--new-env", action="append", default=[])
    d = sub.add_parser("decode")
    d.add_argument("out")
    d.add_argument("key")
    d.add_argument("judges", nargs="+")
    a = p.parse_args(argv)
    if a.command == "setup":
        a.extra = extra
        setup(a)
    else:
        decode(a)


if __name__ == "__main__":
    main(sys.argv[1:])
