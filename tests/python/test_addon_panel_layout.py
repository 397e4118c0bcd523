"""The Cubist panels are laid out from the settings schema (blender_addon/panel_layout.py, plain
Python): every setting the panel owns reaches exactly one panel, in the schema's order within
its group; the per-key rules name real values; ui.py has no line of its own per setting; and
the tooltips carry the schema's range and unit. Drawing them in Blender is
test_addon_blender.py's `test_every_panel_draws_existing_properties`."""

import re
from types import SimpleNamespace

import pytest

from addon_support import ROOT, cubist_binary  # noqa: F401 (fixture)

from blender_addon import panel_layout, presets, schema


def panel_keys():
    """Every Cubist value on a sub-panel, in order, with its panel."""
    out = []
    for spec in panel_layout.PANELS:
        for _group, items in panel_layout.panel_items(spec):
            out += [(spec.ident, item.key) for item in items if item.source is None]
    return out


def test_every_schema_group_has_a_panel():
    placed = [g for spec in panel_layout.PANELS for g in spec.groups] + list(panel_layout.ROOT_GROUPS)
    assert len(placed) == len(set(placed)), "a group on two panels"
    for group in {f["group"] for f in schema.SETTINGS.values()}:
        keys = [k for k, f in schema.SETTINGS.items() if f["group"] == group]
        if all(k in presets.BLENDER_KEYS for k in keys):
            assert group not in placed or any(k in panel_layout.BLENDER_PROPERTY for k in keys), group
            continue
        assert group in placed, f"schema group {group!r} is on no panel"
    parents = {spec.ident for spec in panel_layout.PANELS}
    assert all(spec.parent in parents for spec in panel_layout.PANELS if spec.parent)


def test_every_setting_the_panel_owns_reaches_exactly_one_panel():
    keys = [k for _panel, k in panel_keys()]
    root = [item.key for g in panel_layout.ROOT_GROUPS for item in panel_layout.group_items(g)]
    assert root == ["preset"]
    assert len(keys) == len(set(keys)), sorted(k for k in keys if keys.count(k) > 1)
    # Every panel value: each settings key Blender does not decide, each pass, each add-on property.
    assert set(keys) | set(root) == set(presets.DEFAULTS), set(presets.DEFAULTS) ^ (set(keys) | set(root))
    for key, field in schema.SETTINGS.items():
        if key in presets.BLENDER_KEYS:
            continue
        if field["type"] == "array" and field.get("items") == "enum":
            assert set(presets.PASS_TOGGLES) <= set(keys)
        else:
            assert key in keys or key in root, key


def test_within_a_panel_the_schemas_order():
    order = list(schema.SETTINGS)
    for spec in panel_layout.PANELS:
        for _group, items in panel_layout.panel_items(spec):
            settings = [i.key for i in items if i.key in schema.SETTINGS]
            assert settings == sorted(settings, key=order.index), spec.ident


def test_the_rules_name_real_values():
    keys = {k for _panel, k in panel_keys()}
    for table in (panel_layout.SHOWN, panel_layout.ACTIVE, panel_layout.HEADINGS, panel_layout.MANUAL_START):
        assert set(table) <= keys, set(table) - keys
    assert set(panel_layout.MANUAL_START) == set(panel_layout.AUTO_KEYS)
    assert set(panel_layout.GROUP_ACTIVE) <= {g for spec in panel_layout.PANELS for g in spec.groups}
    # The settings the renderer may choose: ambiguity, fill and the camera's size.
    assert set(panel_layout.AUTO_KEYS) == {"ambiguity", "fill", "camera_size"}


def test_rules_on_a_panel_state():
    c = SimpleNamespace(**{k: v for k, v in presets.DEFAULTS.items()})
    scene = SimpleNamespace(world=None)
    c.camera, c.faceting, c.layout_file = "AUTO", "VORONOI", ""
    assert panel_layout.shown("facet_count", c, scene) and not panel_layout.shown("planes", c, scene)
    assert panel_layout.shown("ambiguity", c, scene) and not panel_layout.shown("camera_size", c, scene)
    c.layout_file = "mine.facets.json"
    assert panel_layout.shown("facet_motion", c, scene) and not panel_layout.shown("layout_frame", c, scene)
    c.framing = "CENTRE"
    assert not panel_layout.active("fill", c, scene)
    c.framing = "COMPOSE"
    assert panel_layout.active("fill", c, scene)
    assert panel_layout.active("background", c, scene)  # no world: the colour is used


def test_ui_has_no_line_per_setting():
    source = (ROOT / "blender_addon" / "ui.py").read_text()
    literal = re.findall(r"\.prop\(\s*\w+\s*,\s*[\"']", source)
    assert literal == [], "ui.py names a property by hand: lay it out through panel_layout.py"
    for key in schema.SETTINGS:
        assert f'"{key}"' not in source or key in ("preset",), f"ui.py names setting {key}"


def test_chosen_values_read_with_their_unit():
    assert panel_layout.format_chosen("ambiguity", 159.61) == "159.6\N{DEGREE SIGN}"
    assert panel_layout.format_chosen("fill", 0.94) == "0.94"
    assert panel_layout.format_chosen("camera_size", 3.5) == "3.5 scene units"


@pytest.mark.parametrize("key", [k for k, f in schema.SETTINGS.items() if f["type"] in ("integer", "number")
                                 and k not in presets.BLENDER_KEYS])
def test_every_number_tooltip_gives_its_range_and_unit(key):
    from blender_addon.panel_layout import tooltip

    field = schema.SETTINGS[key]
    text = tooltip(field)
    assert text.startswith(field["help"])
    assert re.search(r"\b(from|at least|above)\b", text, re.IGNORECASE), text
    if field.get("unit"):
        assert field["unit"] in text[len(field["help"]):], text
    if key in panel_layout.AUTO_KEYS:
        assert ". Auto: " in text, text


def test_what_the_renderer_chose_is_read_from_its_report(cubist_binary, tmp_path):
    """The renderer's own report (`--verbose`) gives the angle it chose for an automatic
    Ambiguity: the panel's "Auto" shows it after a render."""
    import subprocess

    from blender_addon import chosen

    r = subprocess.run([str(cubist_binary), "render", "--width", "40", "--height", "30", "--spp", "1", "-o",
                        str(tmp_path / "o.png"), "--verbose"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    found = chosen.from_report(r.stderr)
    assert set(found) == {"ambiguity"} and 0 < found["ambiguity"] <= 360, r.stderr
    assert f"{found['ambiguity']:.1f} deg" in r.stderr
    assert chosen.from_report("scene: x.glb\nwarning: nothing\n") == {}


def test_every_preset_has_its_thumbnail_from_its_picture():
    """The preset grid's pictures (blender_addon/previews/) are docs/presets/'s, reduced by
    scripts/preset_thumbnails.py: one per preset, small, not stale."""
    import io
    import sys

    import numpy as np
    from PIL import Image

    sys.path.insert(0, str(ROOT / "scripts"))
    try:
        import preset_thumbnails
    finally:
        sys.path.pop(0)
    previews = ROOT / "blender_addon" / "previews"
    assert sorted(p.stem for p in previews.glob("*.png")) == sorted(schema.PRESETS)
    for name in schema.PRESETS:
        shipped = previews / f"{name}.png"
        assert shipped.stat().st_size < 64_000, shipped
        with Image.open(shipped) as im:
            have = np.asarray(im.convert("RGB"), dtype=np.int32)
        with Image.open(io.BytesIO(preset_thumbnails.thumbnail(ROOT / "docs" / "presets" / f"{name}.png"))) as im:
            want = np.asarray(im.convert("RGB"), dtype=np.int32)
        assert have.shape == want.shape == (120, 160, 3)
        assert np.abs(have - want).max() <= 2, f"{name}: stale (run scripts/preset_thumbnails.py)"
