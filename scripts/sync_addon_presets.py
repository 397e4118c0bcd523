#!/usr/bin/env python3
"""Writes blender_addon/renderer_presets.json from the renderer: for every preset, what
`cubist settings --preset NAME` prints. The add-on's panel defaults and presets are read from
that file, so they are the renderer's own values.

    python3 scripts/sync_addon_presets.py            # after changing a preset or a setting
    python3 scripts/sync_addon_presets.py --check    # exit 1 if the file differs (tests, build)

Uses target/release/cubist (`cargo build --release` first) or --binary PATH.
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PRESETS_FILE = ROOT / "blender_addon" / "renderer_presets.json"
DEFAULT_BINARY = ROOT / "target" / "release" / ("cubist.exe" if sys.platform == "win32" else "cubist")


def _run(binary: Path, *args: str) -> str:
    r = subprocess.run([str(binary), *args], capture_output=True, text=True, timeout=60)
    if r.returncode != 0:
        raise SystemExit(f"error: `{binary} {' '.join(args)}` failed: {r.stderr.strip() or r.returncode}")
    return r.stdout


def preset_names(binary: Path) -> list[str]:
    """The presets the binary offers, from clap's short help: `[possible values: a, b]`."""
    text = _run(binary, "settings", "-h")
    m = re.search(r"--preset <PRESET>.*?\[possible values: ([^\]]+)\]", text, re.S)
    if not m:
        raise SystemExit(f"error: `{binary} settings -h` lists no presets")
    return [n.strip() for n in m.group(1).split(",")]


def binary_presets(binary: Path) -> dict:
    """{preset: the resolved settings of `cubist settings --preset NAME`}, in the binary's order."""
    return {name: json.loads(_run(binary, "settings", "--preset", name)) for name in preset_names(binary)}


def differences(expected: dict, actual: dict) -> list[str]:
    """Human-readable differences between two preset tables (empty when equal)."""
    out = []
    for name in sorted(set(expected) | set(actual)):
        if name not in actual:
            out.append(f"preset {name}: missing from the file")
        elif name not in expected:
            out.append(f"preset {name}: not a preset of the binary")
        else:
            e, a = expected[name], actual[name]
            for k in sorted(set(e) | set(a)):
                if e.get(k, "<absent>") != a.get(k, "<absent>"):
                    out.append(f"preset {name}: {k} = {a.get(k, '<absent>')!r} in the file, "
                               f"{e.get(k, '<absent>')!r} in the binary")
    return out


def dumps(table: dict) -> str:
    """The table as JSON with one setting per line (lists kept on their line: easy diffs)."""
    presets = []
    for name, settings in table.items():
        lines = [f"    {json.dumps(k)}: {json.dumps(v)}" for k, v in settings.items()]
        presets.append(f"  {json.dumps(name)}: {{\n" + ",\n".join(lines) + "\n  }")
    return "{\n" + ",\n".join(presets) + "\n}\n"


def check(binary: Path, path: Path = PRESETS_FILE) -> list[str]:
    """Differences between the file and the binary (empty when the file is current)."""
    try:
        current = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as e:
        return [f"{path}: {e}"]
    return differences(binary_presets(binary), current)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--binary", type=Path, default=DEFAULT_BINARY)
    ap.add_argument("--check", action="store_true", help="only compare; exit 1 when the file is stale")
    args = ap.parse_args()
    if not args.binary.is_file():
        print(f"error: {args.binary} not found (cargo build --release, or --binary PATH)", file=sys.stderr)
        return 1
    if args.check:
        diff = check(args.binary)
        for d in diff:
            print(d, file=sys.stderr)
        if diff:
            print(f"{PRESETS_FILE.relative_to(ROOT)} is stale: run python3 scripts/sync_addon_presets.py",
                  file=sys.stderr)
        return 1 if diff else 0
    table = binary_presets(args.binary)
    PRESETS_FILE.write_text(dumps(table), encoding="utf-8")
    print(f"wrote {PRESETS_FILE.relative_to(ROOT)}: {', '.join(table)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
