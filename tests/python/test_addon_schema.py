"""The add-on's renderer data (`renderer_schema.json` = `cubist settings --schema`): current,
and the only source of the panel's keys, types, defaults, ranges, tooltips, enum items, pass
names and stage names."""

import json
import subprocess
import sys

import pytest

from addon_support import ROOT, addon, bpy, bpy_module, cubist_binary, new_scene  # noqa: F401 (fixtures)

from blender_addon import mapping, presets, runner, schema


def test_schema_file_is_the_binarys(cubist_binary):
    r = subprocess.run([str(cubist_binary), "settings", "--schema"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout) == schema.SCHEMA
    r = subprocess.run([sys.executable, str(ROOT / "scripts" / "sync_addon_presets.py"), "--check", "--binary",
                        str(cubist_binary)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr


def test_a_stale_schema_is_named(cubist_binary, tmp_path):
    sys.path.insert(0, str(ROOT / "scripts"))
    try:
        import sync_addon_presets
    finally:
        sys.path.pop(0)
    stale = json.loads(schema.SCHEMA_FILE.read_text())
    stale["settings"] = [f for f in stale["settings"] if f["key"] != "weight_saliency"]
    stale["settings"][1]["help"] = "changed"
    path = tmp_path / "schema.json"
    path.write_text(json.dumps(stale))
    diff = sync_addon_presets.check(cubist_binary, schema_path=path)
    assert "schema: setting weight_saliency is only in the binary" in diff, diff
    assert "schema: setting width differs" in diff, diff


def test_the_panel_owns_every_setting_blender_does_not_decide():
    # Every key is the schema's; the runner's hand-kept list agrees (until it reads the schema).
    assert schema.SETTINGS_KEYS == runner.SETTINGS_KEYS
    for key, field in schema.SETTINGS.items():
        if key in presets.BLENDER_KEYS:
            continue
        if field["type"] == "array" and field.get("items") == "enum":
            # (The motion pass, 16-bit RGBA, is for the command line's animation frames only.)
            names = [v for v, _ in schema.choices(key) if schema.pass_format(v) != "rgba16"]
            assert sorted(presets.PASS_TOGGLES.values()) == sorted(names)
            continue
        assert key in presets.DEFAULTS, key
    assert presets.ENUM_KEYS == tuple(
        k for k, f in schema.SETTINGS.items() if f["type"] == "enum" and k not in presets.BLENDER_KEYS
    )
    assert set(mapping.PLAIN_KEYS) <= set(schema.SETTINGS)
    # Defaults are the renderer's: the analytic preset's values as the panel shows them.
    assert presets.DEFAULTS["discontinuity"] == schema.default("discontinuity")
    assert presets.DEFAULTS["segments"] == presets.format_number_list(schema.default("segments"))
    # The cubist angle is chosen per scene (compose): the panel's automatic 0; the pinhole's is 60.
    assert presets.DEFAULTS["ambiguity"] == 0.0 and schema.automatic("ambiguity", "auto") is None
    assert schema.automatic("ambiguity", "perspective") == 60.0


def test_every_setting_is_a_panel_property_or_a_key_the_addon_maps():
    # Each schema key is on the panel (the passes as one toggle each) or in the add-on's own
    # list of keys it maps from Blender's scene (the saliency cache is both: a folder on the
    # panel, a path per scene): a new setting cannot go unseen.
    toggles = set(presets.PASS_TOGGLES)
    for key, field in schema.SETTINGS.items():
        if field["type"] == "array" and field.get("items") == "enum":
            on_panel = bool(toggles) and toggles <= set(presets.DEFAULTS)
        else:
            on_panel = key in presets.DEFAULTS
        assert on_panel or key in presets.BLENDER_KEYS, key
    assert presets.BLENDER_KEYS <= schema.SETTINGS_KEYS, sorted(presets.BLENDER_KEYS - schema.SETTINGS_KEYS)
    # The frame range is Blender's (one frame a process): not on the panel, never sent.
    assert "frames" in presets.BLENDER_KEYS and "frames" not in presets.DEFAULTS
    for frame in (1, 7):
        facts = mapping.SceneFacts(width=64, height=48, frame=frame)
        assert "frames" not in mapping.settings_from_panel(dict(presets.DEFAULTS), facts)


def test_passes_are_the_renderers():
    names = [name for _toggle, name, *_ in mapping.PASSES]
    assert names == [v for v, _ in schema.choices("passes") if schema.pass_format(v) != "rgba16"]
    for _toggle, name, _bname, channels, _chan, kind in mapping.PASSES:
        grey = schema.pass_format(name).startswith("grey")
        assert (channels, kind) == ((1, "VALUE") if grey else (3, "COLOR")), name


def test_progress_stages_are_the_schemas(cubist_binary, tmp_path):
    """The stages the binary reports are the schema's, in its order, and the add-on's progress
    bar knows each (runner.STAGE_WEIGHTS, built from schema.STAGES)."""
    r = subprocess.run([str(cubist_binary), "render", "--width", "40", "--height", "30", "--spp", "1", "-o",
                        str(tmp_path / "o.png"), "--progress", "lines"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    seen = []
    for ln in r.stderr.splitlines():
        if ln.startswith("PROGRESS ") and (not seen or seen[-1] != ln.split(" ", 2)[2]):
            seen.append(ln.split(" ", 2)[2])
    assert seen == [s for s in schema.STAGES if s in seen], seen
    assert set(schema.STAGES) - {"done"} == {name for name, _ in runner.STAGE_WEIGHTS}


def test_the_renderer_says_which_stages_run(cubist_binary, tmp_path):
    """`cubist settings --stages` says when mesh saliency is computed (the add-on keeps no copy
    of that rule): only for saliency re-aiming of facets, Segment facets and the passes that
    show saliency; a loaded layout replaces the segmentation, re-aiming still needs saliency."""
    base = {"faceting": "none", "imprecision": "saliency", "discontinuity": 0.0, "passes": []}
    cases = [(base, False), (dict(base, discontinuity=100.0), False),
             (dict(base, faceting="voronoi", discontinuity=100.0), True),
             (dict(base, faceting="voronoi", discontinuity=100.0, imprecision="random"), False),
             (dict(base, faceting="segment"), True), (dict(base, passes=["saliency"]), True),
             (dict(base, passes=["facets"]), True)]
    for s, expected in cases:
        cfg = tmp_path / "s.json"
        cfg.write_text(json.dumps(s))
        r = subprocess.run([str(cubist_binary), "settings", "--stages", "--config", str(cfg)], capture_output=True,
                           text=True)
        assert r.returncode == 0, r.stderr
        assert ("saliency" in json.loads(r.stdout)) == expected, s


# ---------------------------------------------------------------------------------------------
# In Blender


def test_properties_are_built_from_the_schema(bpy):
    scene = new_scene(bpy)
    rna = scene.cubist.bl_rna.properties
    for key, f in schema.SETTINGS.items():
        if key in presets.BLENDER_KEYS or f["type"] == "array" and f.get("items") == "enum":
            continue
        p = rna[key]
        assert p.description.startswith(f["help"]), key
        if f["type"] == "enum" and key != "preset":
            assert [i.identifier for i in p.enum_items] == [presets.enum_id(v) for v, _ in schema.choices(key)]
            assert [i.description for i in p.enum_items] == [h for _, h in schema.choices(key)]
        if f["type"] in ("integer", "number") and "min" in f:
            assert p.hard_min >= f["min"] - 1e-6, key
            if f["min_exclusive"] and not f["nullable"]:
                assert p.hard_min > f["min"], key
            if f.get("max") is not None:
                assert p.hard_max <= f["max"] + 1e-3, key
                if f["max_exclusive"]:
                    assert p.hard_max < f["max"], key
    for toggle, name in presets.PASS_TOGGLES.items():
        assert rna[toggle].description.startswith(dict(schema.choices("passes"))[name])
    # Units and sliders follow the schema: scene units are lengths, [0, 1] ranges factors.
    assert rna["camera_size"].unit == "LENGTH" and rna["border_strength"].subtype == "FACTOR"
