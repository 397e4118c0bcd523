#!/usr/bin/env python3
"""Writes the Blender add-on's renderer data from the renderer itself:

- blender_addon/renderer_schema.json: what `cubist settings --schema` prints (every setting's
  type, default, range or choices, unit, help and group; the stages; the presets). The panel's
  properties, keys, tooltips, enum values and stage names are built from it.
- blender_addon/renderer_presets.json: for every preset, what `cubist settings --preset NAME`
  prints. The panel's defaults and presets are read from it.

    python3 scripts/sync_addon_presets.py            # after changing a setting or a preset
    python3 scripts/sync_addon_presets.py --check    # exit 1 if a file differs (tests, build)

Uses target/release/cubist (`cargo build --release` first) or --binary PATH.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PRESETS_FILE = ROOT / "blender_addon" / "renderer_presets.json"
SCHEMA_FILE = ROOT / "blender_addon" / "renderer_schema.json"
DEFAULT_BINARY = ROOT / "target" / "release" / ("cubist.exe" if sys.platform == "win32" else "cubist")


def _run(binary: Path, *args: str) -> str:
    r = subprocess.run([str(binary), *args], capture_output=True, text=True, timeout=60)
    if r.returncode != 0:
        raise SystemExit(f"error: `{binary} {' '.join(args)}` failed: {r.stderr.strip() or r.returncode}")
    return r.stdout


def binary_schema(binary: Path) -> dict:
    """What `cubist settings --schema` prints."""
    return json.loads(_run(binary, "settings", "--schema"))


def preset_names(binary: Path) -> list[str]:
    """The presets the binary offers, in its order (from its schema)."""
    return [p["name"] for p in binary_schema(binary)["presets"]]


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


def schema_differences(expected: dict, actual: dict) -> list[str]:
    """Human-readable differences between two schemas (empty when equal)."""
    out = []
    for part in sorted(set(expected) | set(actual)):
        e, a = expected.get(part), actual.get(part)
        if e == a:
            continue
        if part == "settings" and isinstance(e, list) and isinstance(a, list):
            ek, ak = {f["key"]: f for f in e}, {f["key"]: f for f in a}
            for key in sorted(set(ek) | set(ak)):
                if ek.get(key) != ak.get(key):
                    where = "differs" if key in ek and key in ak else f"is only in the {'binary' if key in ek else 'file'}"
                    out.append(f"schema: setting {key} {where}")
            if [f["key"] for f in e] != [f["key"] for f in a] and not out:
                out.append("schema: the settings' order differs")
        else:
            out.append(f"schema: {part} differs")
    return out


def dumps(table: dict) -> str:
    """The table as JSON with one setting per line (lists kept on their line: easy diffs)."""
    presets = []
    for name, settings in table.items():
        lines = [f"    {json.dumps(k)}: {json.dumps(v)}" for k, v in settings.items()]
        presets.append(f"  {json.dumps(name)}: {{\n" + ",\n".join(lines) + "\n  }")
    return "{\n" + ",\n".join(presets) + "\n}\n"


def dumps_schema(schema: dict) -> str:
    """The schema as JSON, one setting per line."""
    parts = []
    for key, value in schema.items():
        if isinstance(value, list):
            items = ",\n".join(f"    {json.dumps(v, ensure_ascii=False)}" for v in value)
            parts.append(f"  {json.dumps(key)}: [\n{items}\n  ]")
        else:
            parts.append(f"  {json.dumps(key)}: {json.dumps(value)}")
    return "{\n" + ",\n".join(parts) + "\n}\n"


def _read(path: Path):
    try:
        return json.loads(path.read_text(encoding="utf-8")), None
    except (OSError, ValueError) as e:
        return None, f"{path}: {e}"


def check(binary: Path, path: Path = PRESETS_FILE, schema_path: Path = SCHEMA_FILE) -> list[str]:
    """Differences between the files and the binary (empty when both are current)."""
    out = []
    current, err = _read(path)
    out += [err] if err else differences(binary_presets(binary), current)
    schema, err = _read(schema_path)
    out += [err] if err else schema_differences(binary_schema(binary), schema)
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--binary", type=Path, default=DEFAULT_BINARY)
    ap.add_argument("--check", action="store_true", help="only compare; exit 1 when a file is stale")
    args = ap.parse_args()
    if not args.binary.is_file():
        print(f"error: {args.binary} not found (cargo build --release, or --binary PATH)", file=sys.stderr)
        return 1
    if args.check:
        diff = check(args.binary)
        for d in diff:
            print(d, file=sys.stderr)
        if diff:
            print(f"{PRESETS_FILE.relative_to(ROOT)} or {SCHEMA_FILE.relative_to(ROOT)} is stale: run "
                  "python3 scripts/sync_addon_presets.py", file=sys.stderr)
        return 1 if diff else 0
    schema = binary_schema(args.binary)
    SCHEMA_FILE.write_text(dumps_schema(schema), encoding="utf-8")
    table = binary_presets(args.binary)
    PRESETS_FILE.write_text(dumps(table), encoding="utf-8")
    print(f"wrote {SCHEMA_FILE.relative_to(ROOT)} ({len(schema['settings'])} settings, "
          f"{len(schema['stages'])} stages) and {PRESETS_FILE.relative_to(ROOT)}: {', '.join(table)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
