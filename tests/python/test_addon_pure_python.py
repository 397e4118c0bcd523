"""The add-on is pure Python, so one zip serves every Blender, including 5.1 and later, whose
Python 3.13 these machines cannot install (the headless matrix stops at bpy 5.0.1): no compiled
module ships in it, and it imports only Python's standard library (less what Python 3.13 removed),
Blender's own modules and the numpy every Blender bundles; its relative imports all resolve.
A compiled import (a .so built for 3.11) or a module Python 3.13 dropped would fail at enable
there, unseen by every other test."""

import ast
import sys
import zipfile
from pathlib import Path

import pytest

from addon_support import ROOT

ADDON = ROOT / "blender_addon"
COMPILED = {".so", ".pyd", ".dll", ".dylib", ".pyc", ".pyo"}
# Blender's Python modules (its API, math, GPU drawing, bundled add-on helpers) and the numpy
# it bundles in every release. Not `bgl` (removed in Blender 5.0).
BLENDER_MODULES = {"bpy", "bpy_extras", "bpy_types", "gpu", "gpu_extras", "mathutils", "bmesh", "blf", "bl_math",
                   "bl_ui", "bl_operators", "addon_utils", "idprop", "imbuf", "numpy"}
# Standard modules Python 3.12 and 3.13 removed (PEP 594 and the distutils/imp removals).
REMOVED_BY_313 = {"aifc", "asynchat", "asyncore", "audioop", "cgi", "cgitb", "chunk", "crypt", "distutils", "imghdr",
                  "imp", "lib2to3", "mailcap", "msilib", "nis", "nntplib", "ossaudiodev", "pipes", "smtpd", "sndhdr",
                  "spwd", "sunau", "telnetlib", "uu", "xdrlib"}
STDLIB = set(sys.stdlib_module_names) - REMOVED_BY_313


def sources():
    return sorted(p for p in ADDON.rglob("*.py") if "__pycache__" not in p.parts)


def test_no_compiled_file_in_the_addon_or_its_zip(tmp_path):
    shipped = [p for p in ADDON.rglob("*") if p.is_file() and "__pycache__" not in p.parts]
    assert [p for p in shipped if p.suffix in COMPILED] == []
    sys.path.insert(0, str(ROOT / "scripts"))
    try:
        import build_addon
    finally:
        sys.path.pop(0)
    zip_path = build_addon.build(None, None, tmp_path)
    with zipfile.ZipFile(zip_path) as z:
        names = z.namelist()
    assert [n for n in names if Path(n).suffix in COMPILED or "__pycache__" in n] == []
    assert len([n for n in names if n.endswith(".py")]) == len(sources())


@pytest.mark.parametrize("path", sources(), ids=lambda p: p.relative_to(ADDON).as_posix())
def test_imports_only_the_standard_library_and_blenders_modules(path):
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path), feature_version=(3, 11))
    package = path.parent
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            tops = [alias.name.split(".")[0] for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0:
            tops = [node.module.split(".")[0]]
        elif isinstance(node, ast.ImportFrom):
            # Relative: the module (or, for `from . import x`, each x) is a file of the add-on.
            base = package
            for _ in range(node.level - 1):
                base = base.parent
            assert ADDON in (base, *base.parents), f"{path.name}:{node.lineno}: import above the add-on"
            targets = [node.module] if node.module else [a.name for a in node.names]
            for t in targets:
                target = base.joinpath(*t.split("."))
                assert target.with_suffix(".py").is_file() or (target / "__init__.py").is_file(), \
                    f"{path.name}:{node.lineno}: {'.' * node.level}{t} is not a module of the add-on"
            continue
        else:
            continue
        for top in tops:
            assert top in STDLIB or top in BLENDER_MODULES or top.startswith("bl_"), \
                f"{path.relative_to(ADDON)}:{node.lineno}: imports {top}, neither Python 3.13's standard " \
                "library nor Blender's"
