"""The add-on's bpy-free part (runner, mapping, presets), tested in plain Python: finding the
binary, the settings contract with src/settings.rs and the binary (`cubist settings`), the
panel defaults and presets against the renderer's, argv, progress and error parsing, cancel,
temporary files, the facet layout plan, the Blender camera mapping."""

import json
import math
import os
import re
import stat
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from addon_support import ROOT, cubist_binary  # noqa: F401 (fixture)
from ship_support import bpy_extension_cli  # noqa: F401 (fixture)

from blender_addon import mapping, presets, runner


# ---------------------------------------------------------------------------------------------
# bpy-free


def test_runner_mapping_presets_import_without_bpy():
    code = ("import sys; sys.path.insert(0, %r); import blender_addon.runner, blender_addon.mapping, "
            "blender_addon.presets; assert 'bpy' not in sys.modules, 'bpy was imported'; print('ok')" % str(ROOT))
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0 and r.stdout.strip() == "ok", r.stderr


# ---------------------------------------------------------------------------------------------
# The settings contract


def test_settings_keys_match_the_renderer(cubist_binary):
    """Every key the renderer accepts is known to the add-on and vice versa (a renamed or
    added setting must reach the panel): the schema the add-on reads lists the keys of the
    renderer's settings, as `cubist settings` prints them."""
    assert runner.SETTINGS_KEYS == set(binary_settings(cubist_binary))


def settings_rs_presets():
    text = (ROOT / "src" / "settings.rs").read_text()
    body = text[text.index("    Preset {"):]
    body = body[:body.index("\n    }\n")]
    return re.findall(r'= "([a-z-]+)"', body)


def binary_settings(binary, *args):
    r = subprocess.run([str(binary), "settings", *args], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout)


def effective(settings):
    """Resolved settings as the renderer uses them, nulls dropped (the panel's automatic 0,
    e.g. the convergence angle the renderer chooses per scene, is sent as null)."""
    return {k: v for k, v in settings.items() if v is not None}


def default_facts(**kw):
    return mapping.SceneFacts(width=kw.pop("width", 64), height=kw.pop("height", 48), frame=kw.pop("frame", 1), **kw)


def test_panel_defaults_cover_every_setting_the_panel_owns():
    s = mapping.settings_from_panel(dict(presets.DEFAULTS), default_facts())
    # The keys the add-on does not send from the panel: camera frame (no camera here), files
    # it decides per frame (layout), paths left empty, and the focus (none without a camera).
    # `ambiguity`, `fill` and `camera_size` are automatic (0 in the panel, null in the
    # settings); the engine adds the saliency cache folder. The frame range is Blender's (one
    # frame a process): never sent.
    not_sent = {"camera_position", "camera_target", "camera_up", "focus_distance", "camera_size", "fill", "facets",
                "save_facets", "facet_map", "palette_image", "saliency_cache", "ambiguity", "frames"}
    assert set(s) == runner.SETTINGS_KEYS - not_sent


# ---------------------------------------------------------------------------------------------
# Defaults and presets: the renderer's own


def test_renderer_presets_file_is_the_binarys(cubist_binary):
    """blender_addon/renderer_presets.json (where the panel's defaults and presets come from)
    is what this checkout's binary prints: a changed default or preset fails here until
    `python3 scripts/sync_addon_presets.py` is run."""
    sys.path.insert(0, str(ROOT / "scripts"))
    try:
        import sync_addon_presets
    finally:
        sys.path.pop(0)
    assert sync_addon_presets.check(cubist_binary) == []
    r = subprocess.run([sys.executable, str(ROOT / "scripts" / "sync_addon_presets.py"), "--check", "--binary",
                        str(cubist_binary)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr


def test_presets_are_the_renderers_presets():
    names = settings_rs_presets()
    assert names and set(names) == set(presets.RENDERER_PRESETS) == set(presets.PRESET_LABELS)
    assert presets.DEFAULTS["preset"] == "ANALYTIC"
    # Every renderer preset is in the menu, then the variants.
    assert list(presets.BUILTIN)[:len(names)] == [presets.PRESET_LABELS[n][0] for n in presets.PRESET_LABELS]


def test_an_untouched_panel_sends_cubist_renders_defaults(cubist_binary):
    """F12 with an untouched panel renders what `cubist render` renders: the panel's
    defaults, through the mapping, are the binary's resolved defaults (at the binary's
    default size, without a Blender camera or world)."""
    panel = dict(presets.DEFAULTS, use_world_background=False)
    sent = mapping.settings_from_panel(panel, default_facts(width=800, height=600))
    assert sent == effective(binary_settings(cubist_binary))


@pytest.mark.parametrize("name", list(presets.PRESET_LABELS))
def test_each_preset_sends_the_binarys_preset(cubist_binary, name):
    """Choosing a preset in the panel sends exactly `cubist render --preset NAME`'s settings,
    whatever the panel held before (every look value is set)."""
    panel = dict(presets.DEFAULTS, use_world_background=False)
    panel.update(discontinuity=3.0, palette="GREY", faceting="PATCH", weight_depth=2.0, fill=0.5, colors=9)
    panel.update(presets.renderer_preset_values(name))
    sent = mapping.settings_from_panel(panel, default_facts(width=800, height=600))
    assert sent == effective(binary_settings(cubist_binary, "--preset", name))


@pytest.mark.parametrize("name", ["analytic", "grisaille", "plain"])
def test_panel_settings_render_the_presets_picture(cubist_binary, tmp_path, name):
    """The same picture both ways: the panel's values are the preset's, its automatic 0s
    sent as null."""
    panel = dict(presets.DEFAULTS, use_world_background=False, spp=1)
    panel.update(presets.renderer_preset_values(name))
    sent = mapping.settings_from_panel(panel, default_facts(width=72, height=54))
    r, ours = run_cli(cubist_binary, sent, tmp_path)
    assert r.returncode == 0, r.stderr
    theirs = tmp_path / "theirs.png"
    r = subprocess.run([str(cubist_binary), "render", "--preset", name, "--width", "72", "--height", "54", "--spp",
                        "1", "-o", str(theirs)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert ours.read_bytes() == theirs.read_bytes()


def test_panel_from_settings_knows_every_key():
    s = dict(presets.RENDERER_PRESETS["braque"])
    assert presets.panel_from_settings(s)["palette"] == "OLIVE"
    with pytest.raises(runner.CubistError, match="does not know: new_knob"):
        presets.panel_from_settings(dict(s, new_knob=1))
    del s["fill"]
    with pytest.raises(runner.CubistError, match="missing: fill"):
        presets.panel_from_settings(s)
    # Automatic values are the panel's 0; lists become the text fields.
    p = presets.panel_from_settings(dict(s, fill=0.7, camera_size=None, thresholds=[0, 0.05, 0.125]))
    assert (p["fill"], p["camera_size"], p["thresholds"]) == (0.7, 0.0, "0, 0.05, 0.125")


def test_floats_are_sent_as_typed():
    """Blender keeps float properties in 32 bits: the panel's 0.85 reads back as
    0.8500000238418579, and is sent as 0.85."""
    import struct

    as_blender = lambda v: struct.unpack("<f", struct.pack("<f", v))[0]  # noqa: E731
    for typed in (0.85, 0.3, 0.05, 140.0, 1e-7, 123.456, 0.9, 2.5e6, 0.0):
        assert runner.f32_decimal(as_blender(typed)) == typed
    assert runner.f32_decimal(float("inf")) == float("inf")
    panel = dict(presets.DEFAULTS, border_strength=as_blender(0.85), thresholds="0, 0.05, 0.08",
                 background=tuple(as_blender(c) for c in (0.62, 0.56, 0.46)), use_world_background=False)
    s = mapping.settings_from_panel(panel, default_facts())
    assert s["border_strength"] == 0.85 and s["background"] == [0.62, 0.56, 0.46]


def run_cli(binary, settings, tmp_path, scene=None):
    cfg = tmp_path / "s.json"
    runner.write_settings(cfg, settings)
    out = tmp_path / "o.png"
    argv = [str(binary), "render"] + ([str(scene)] if scene else []) + ["-o", str(out), "--config", str(cfg)]
    return subprocess.run(argv, capture_output=True, text=True), out


def test_the_renderer_accepts_the_panel_defaults(cubist_binary, tmp_path):
    s = mapping.settings_from_panel(dict(presets.DEFAULTS), default_facts())
    r, out = run_cli(cubist_binary, s, tmp_path)
    assert r.returncode == 0, r.stderr
    assert out.is_file()


@pytest.mark.parametrize("name", list(presets.BUILTIN))
def test_the_renderer_accepts_every_builtin_preset(cubist_binary, tmp_path, name):
    panel = dict(presets.DEFAULTS)
    panel.update(presets.preset_values(name))
    s = mapping.settings_from_panel(panel, default_facts())
    runner.write_settings(tmp_path / "s.json", s)
    r = subprocess.run([str(cubist_binary), "settings", "--config", str(tmp_path / "s.json")], capture_output=True,
                       text=True)
    assert r.returncode == 0, f"preset {name}: {r.stderr}"
    assert effective(json.loads(r.stdout)) == s


def test_presets_set_every_look_value_and_nothing_else():
    for name in presets.BUILTIN:
        assert set(presets.preset_values(name)) == set(presets.LOOK_KEYS), name
    assert presets.preset_values("Voronoi Facets")["faceting"] == "VORONOI"
    # Sampling, passes, files and the scene's own choices are not part of a look; the ground
    # colour is.
    for key in ("spp", "seed", "pass_depth", "layout_folder", "use_world_background"):
        assert key not in presets.LOOK_KEYS
    assert "background" in presets.LOOK_KEYS


@pytest.mark.parametrize("prop,value,key,expected", [
    ("spp", 9, "spp", 9),
    ("seed", 7, "seed", 7),
    ("camera", "PLANAR", "camera", "planar"),
    ("ambiguity", 120.0, "ambiguity", 120.0),
    ("framing", "CENTRE", "framing", "centre"),
    ("faceting", "VORONOI", "faceting", "voronoi"),
    ("facet_count", 40, "facet_count", 40),
    ("segments", "4, 20", "segments", [4, 20]),
    ("thresholds", "0.1 0.2 0.3", "thresholds", [0.1, 0.2, 0.3]),
    ("imprecision", "RANDOM", "imprecision", "random"),
    ("discontinuity", 120.0, "discontinuity", 120.0),
    ("faceting", "NONE", "faceting", "none"),
    ("facet_projection", "LINEAR", "facet_projection", "linear"),
    ("border_width", 5.0, "border_width", 5.0),
    ("palette", "BLUE_PERIOD", "palette", "blue-period"),
    ("silhouette_width", 7.0, "silhouette_width", 7.0),
    ("colors", 12, "colors", 12),
    ("gradients", 0.4, "gradients", 0.4),
    ("chiaroscuro", 0.2, "chiaroscuro", 0.2),
    ("plane_light", 0.4, "plane_light", 0.4),
    ("border_style", "SYMMETRIC", "border_style", "symmetric"),
    ("brushwork", 0.5, "brushwork", 0.5),
    ("stroke_length", 40.0, "stroke_length", 40.0),
    ("canvas_grain", 0.3, "canvas_grain", 0.3),
    ("shadows", True, "shadows", True),
    ("light_steps", 2, "light_steps", 2),
    ("view_turn", 30.0, "view_turn", 30.0),
    ("pass_facet_ids", True, "passes", ["facet-ids"]),
    ("camera_size", 2.5, "camera_size", 2.5),
    ("fill", 0.6, "fill", 0.6),
    ("superpixels", 400, "superpixels", 400),
    ("weight_colour", 2.0, "weight_colour", 2.0),
    ("weight_normal", 0.25, "weight_normal", 0.25),
    ("weight_depth", 1.5, "weight_depth", 1.5),
    ("weight_object", 1.0, "weight_object", 1.0),
    ("weight_saliency", 0.0, "weight_saliency", 0.0),
    ("saliency_method", "CLUSTERED", "saliency_method", "clustered"),
    ("layout_file", "/a/layout.json", "facets", "/a/layout.json"),
    ("preset", "BRAQUE", "preset", "braque"),
    ("exposure", 1.5, "exposure", 1.5),
    ("neighborhood", 10.0, "neighborhood", 10.0),
])
def test_a_panel_change_changes_the_settings(prop, value, key, expected):
    base = mapping.settings_from_panel(dict(presets.DEFAULTS), default_facts())
    panel = dict(presets.DEFAULTS)
    panel[prop] = value
    s = mapping.settings_from_panel(panel, default_facts())
    assert s[key] == expected
    assert base.get(key) != expected
    assert {k: v for k, v in s.items() if k != key} == {k: v for k, v in base.items() if k != key}


def test_animated_seed_adds_the_frame():
    panel = dict(presets.DEFAULTS, seed=5, animate_seed=True)
    assert mapping.settings_from_panel(panel, default_facts(frame=12))["seed"] == 17
    panel["animate_seed"] = False
    assert mapping.settings_from_panel(panel, default_facts(frame=12))["seed"] == 5


def test_bad_segment_text_is_a_clear_error():
    panel = dict(presets.DEFAULTS, segments="5, thirty")
    with pytest.raises(runner.SettingError, match="Segments: `thirty` is not a whole number"):
        mapping.settings_from_panel(panel, default_facts())


def test_unknown_keys_are_refused_before_running():
    with pytest.raises(runner.SettingError, match="unknown setting"):
        runner.clean_settings({"spp": 1, "sppp": 2})


def test_world_background_and_transparency():
    panel = dict(presets.DEFAULTS)
    s = mapping.settings_from_panel(panel, default_facts(background=[0.2, 0.3, -1.0], transparent=True))
    assert s["background"] == [0.2, 0.3, 0.0] and s["transparent"] is True
    panel["use_world_background"] = False
    s = mapping.settings_from_panel(panel, default_facts(background=[0.2, 0.3, 0.4]))
    assert s["background"] == pytest.approx(list(presets.DEFAULTS["background"]))


# ---------------------------------------------------------------------------------------------
# The Blender camera


def camera_at(location, forward_blender, up_blender, **kw):
    """A camera matrix from a position, view direction and up (Blender coordinates)."""
    def unit(v):
        n = math.sqrt(sum(x * x for x in v))
        return [x / n for x in v]

    f, u = unit(forward_blender), unit(up_blender)
    r = [f[1] * u[2] - f[2] * u[1], f[2] * u[0] - f[0] * u[2], f[0] * u[1] - f[1] * u[0]]
    # Columns: local X = right, local Y = up, local Z = -forward.
    m = [[r[i], u[i], -f[i], location[i]] for i in range(3)] + [[0, 0, 0, 1]]
    return mapping.CameraFacts(matrix_world=m, **kw)


def test_blender_camera_maps_to_gltf_axes():
    cam = camera_at((1.0, -6.0, 2.0), (0, 1, 0), (0, 0, 1))
    s = mapping.settings_from_panel(dict(presets.DEFAULTS), default_facts(camera=cam))
    assert s["camera_position"] == pytest.approx([1.0, 2.0, 6.0])  # (x, z, -y)
    direction = [t - p for t, p in zip(s["camera_target"], s["camera_position"])]
    assert direction == pytest.approx([0.0, 0.0, -1.0])  # Blender +Y is glTF -Z
    assert s["camera_up"] == pytest.approx([0.0, 1.0, 0.0])  # Blender +Z is glTF +Y
    assert "focus_distance" not in s  # no depth of field: framing decides


def test_focus_object_distance_along_the_view_gives_the_focal_centre():
    cam = camera_at((0.0, -6.0, 0.0), (0, 1, 0), (0, 0, 1), focus_object_location=(3.0, 1.5, 0.0))
    s = mapping.settings_from_panel(dict(presets.DEFAULTS), default_facts(camera=cam))
    assert s["focus_distance"] == pytest.approx(7.5)
    assert s["camera_target"] == pytest.approx([0.0, 0.0, -1.5])
    off = mapping.settings_from_panel(dict(presets.DEFAULTS, use_camera_focus=False), default_facts(camera=cam))
    assert "focus_distance" not in off


def test_dof_focus_distance_counts_only_when_dof_is_on():
    cam = camera_at((0.0, -6.0, 0.0), (0, 1, 0), (0, 0, 1), use_dof=True, focus_distance=4.0)
    assert mapping.settings_from_panel(dict(presets.DEFAULTS), default_facts(camera=cam))["focus_distance"] == 4.0
    cam.use_dof = False
    assert "focus_distance" not in mapping.settings_from_panel(dict(presets.DEFAULTS), default_facts(camera=cam))


def test_focus_object_behind_the_camera_is_ignored_with_a_warning():
    cam = camera_at((0.0, -6.0, 0.0), (0, 1, 0), (0, 0, 1), focus_object_location=(0.0, -9.0, 0.0))
    facts = default_facts(camera=cam)
    s = mapping.settings_from_panel(dict(presets.DEFAULTS), facts)
    assert "focus_distance" not in s and "behind the camera" in facts.warnings[0]


def test_perspective_uses_blenders_vertical_field_of_view():
    cam = camera_at((0, -6, 0), (0, 1, 0), (0, 0, 1), lens=50.0, sensor_width=36.0)
    panel = dict(presets.DEFAULTS, camera="PERSPECTIVE")
    s = mapping.settings_from_panel(panel, default_facts(camera=cam, width=1920, height=1080))
    # Horizontal fov 2 atan(18/50) = 39.6 deg; vertical = 2 atan(18/50 * 1080/1920) = 22.9 deg.
    assert s["ambiguity"] == pytest.approx(math.degrees(2 * math.atan(18 / 50 * 1080 / 1920)))
    # Portrait: AUTO fit puts the sensor width on the vertical side.
    s = mapping.settings_from_panel(panel, default_facts(camera=cam, width=1080, height=1920))
    assert s["ambiguity"] == pytest.approx(math.degrees(2 * math.atan(18 / 50)))
    panel["use_camera_lens"] = False
    assert "ambiguity" not in mapping.settings_from_panel(panel, default_facts(camera=cam))  # the renderer's 60
    panel["ambiguity"] = 75.0
    assert mapping.settings_from_panel(panel, default_facts(camera=cam))["ambiguity"] == 75.0


def test_orthographic_uses_the_ortho_scale_and_sends_no_angle():
    cam = camera_at((0, -6, 0), (0, 1, 0), (0, 0, 1), type="ORTHO", ortho_scale=8.0)
    panel = dict(presets.DEFAULTS, camera="ORTHOGRAPHIC")
    s = mapping.settings_from_panel(panel, default_facts(camera=cam, width=200, height=100))
    assert s["camera_size"] == pytest.approx(4.0) and "ambiguity" not in s


def test_render_size_truncates_like_blender():
    assert mapping.render_size(1920, 1080, 50) == (960, 540)
    assert mapping.render_size(101, 51, 50) == (50, 25)
    assert mapping.render_size(1, 1, 1) == (1, 1)


def test_blender_relative_paths():
    assert mapping.absolute("//maps/a.png", Path("/proj")) == str(Path("/proj/maps/a.png"))
    assert mapping.absolute("", Path("/proj")) is None


# ---------------------------------------------------------------------------------------------
# Finding the binary


def make_exe(path: Path, body: str, executable=True) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(f"#!{sys.executable}\n" + textwrap.dedent(body))
    mode = path.stat().st_mode
    path.chmod(mode | stat.S_IXUSR if executable else mode & ~(stat.S_IXUSR | stat.S_IXGRP | stat.S_IXOTH))
    return path


FAKE_CUBIST = """
    import sys
    if sys.argv[1:] == ["--version"]:
        print("cubist 9.9.9")
"""

# The first bytes of an arm64 Mach-O executable (magic, cputype CPU_TYPE_ARM64): a binary
# for another platform, which the kernel refuses to run here.
MACHO_ARM64 = bytes.fromhex("cffaedfe0c000001") + bytes(24)

PREF = "Preferences > Add-ons > Cubist > Cubist Binary"


def test_preference_path_wins_and_a_wrong_one_is_reported(tmp_path):
    exe = make_exe(tmp_path / "custom" / runner.BINARY_NAME, FAKE_CUBIST)
    # Used first, even with a bundled binary and one on PATH.
    addon = tmp_path / "addon"
    make_exe(addon / "bin" / runner.BINARY_NAME, FAKE_CUBIST)
    on_path = make_exe(tmp_path / "pathdir" / runner.BINARY_NAME, FAKE_CUBIST)
    assert runner.find_binary(str(exe), addon_dir=addon, path_env=str(on_path.parent)) == exe
    assert runner.locate_binary(str(exe.parent), addon_dir=addon, path_env="") == ("add-on preferences", exe)
    assert runner.binary_version(exe) == "cubist 9.9.9"
    # Each wrong path is named, with the preference to fix, and never replaced by another binary.
    with pytest.raises(runner.BinaryNotFound, match=f"cubist binary not found at .*nowhere.*fix or clear {PREF}"):
        runner.find_binary(str(tmp_path / "nowhere" / "cubist"), addon_dir=addon, path_env=str(on_path.parent))
    (tmp_path / "empty").mkdir()
    with pytest.raises(runner.BinaryNotFound, match=r"not found at .*empty[/\\]cubist"):
        runner.find_binary(str(tmp_path / "empty"), addon_dir=addon, path_env="")
    other = make_exe(tmp_path / "other" / "cubist", "print('hello')\n")
    with pytest.raises(runner.BinaryNotFound,
                       match=f"is not the cubist renderer .`--version` gave: hello.: fix or clear {PREF}"):
        runner.find_binary(str(other), addon_dir=addon, path_env="")
    broken = make_exe(tmp_path / "broken" / "cubist", "import sys; print('boom', file=sys.stderr); sys.exit(3)\n")
    with pytest.raises(runner.BinaryNotFound, match="is not the cubist renderer .`--version` gave: boom"):
        runner.find_binary(str(broken), addon_dir=addon, path_env="")


@pytest.mark.skipif(sys.platform == "win32", reason="Windows reports a foreign binary differently")
def test_a_preferred_binary_for_another_platform_is_reported(tmp_path):
    foreign = tmp_path / "mac" / "cubist"
    foreign.parent.mkdir()
    foreign.write_bytes(MACHO_ARM64)
    foreign.chmod(0o755)
    with pytest.raises(runner.BinaryNotFound,
                       match=f"does not run on this {runner.platform_tag()} machine .*: set {PREF} to a cubist built"):
        runner.find_binary(str(foreign), addon_dir=tmp_path / "addon", path_env="")
    # And if one is run anyway, it is a clear error, not an OSError from deep inside.
    with pytest.raises(runner.BinaryNotFound, match="cannot run the cubist binary .*mac"):
        runner.run([str(foreign), "render"])


def test_platform_names_are_blenders():
    assert runner.platform_tag("Linux", "x86_64") == "linux-x64"
    assert runner.platform_tag("Linux", "aarch64") == "linux-arm64"
    assert runner.platform_tag("Darwin", "arm64") == "macos-arm64"
    assert runner.platform_tag("Darwin", "x86_64") == "macos-x64"
    assert runner.platform_tag("Windows", "AMD64") == "windows-x64"
    assert runner.platform_tag("Windows", "ARM64") == "windows-arm64"
    assert runner.executable_name("windows-x64") == "cubist.exe" and runner.executable_name("macos-x64") == "cubist"


def test_this_machines_platform_is_the_one_blender_names(bpy_extension_cli):
    """The add-on's name for this machine is the one Blender's extension installer checks a
    zip's `platforms` against (bl_pkg's own function, from the bpy wheel)."""
    assert runner.platform_tag() == bpy_extension_cli.platform_from_this_system()


def test_a_zip_for_another_platform_says_so(tmp_path):
    """A zip for another platform (only a legacy install lets it in) holds a `bin/cubist`
    that cannot run here: never picked, and the message says which zip to get and names the
    preference for a binary of one's own."""
    here = runner.platform_tag()
    other = "macos-arm64" if here != "macos-arm64" else "linux-x64"
    addon = tmp_path / "cubist"
    make_exe(addon / "bin" / runner.BINARY_NAME, FAKE_CUBIST)
    (addon / "blender_manifest.toml").write_text(f'id = "cubist"\nversion = "1.2.3"\n\nplatforms = ["{other}"]\n')
    assert runner.bundled_platforms(addon) == [other]
    assert runner.manifest_field(addon, "version") == "1.2.3"
    assert runner.missing_platform_binary(addon) == (f"this Cubist add-on is the {other} build: it carries no "
                                                     f"renderer for this {here} Blender")
    message = (f"cubist binary not found: this Cubist add-on is the {other} build: it carries no renderer for this "
               f"{here} Blender (install cubist-1.2.3-{here}.zip): build cubist (cargo build --release) and set its "
               f"path in {PREF}, or put it on PATH")
    with pytest.raises(runner.BinaryNotFound) as e:
        runner.find_binary("", addon_dir=addon, path_env="")
    if here in runner.RELEASE_PLATFORMS:
        assert str(e.value) == message
    else:
        assert "(no release zip is made for it)" in str(e.value)
    # The zip for this platform: its binary is used.
    (addon / "blender_manifest.toml").write_text(f'id = "cubist"\nversion = "1.2.3"\n\nplatforms = ["{here}"]\n')
    assert runner.missing_platform_binary(addon) is None
    assert runner.locate_binary("", addon_dir=addon, path_env="") == ("bundled with the add-on",
                                                                       addon / "bin" / runner.BINARY_NAME)


def test_path_then_bundled_then_project_build(tmp_path):
    addon = tmp_path / "proj" / "blender_addon"
    addon.mkdir(parents=True)
    with pytest.raises(runner.BinaryNotFound, match=f"cubist binary not found: this Cubist add-on carries no "
                       f"renderer for {runner.platform_tag()} .*set its path in {PREF}, or put it on PATH"):
        runner.find_binary("", addon_dir=addon, path_env="")
    project = make_exe(tmp_path / "proj" / "target" / "release" / runner.BINARY_NAME, "")
    assert runner.find_binary("", addon_dir=addon, path_env="") == project
    # Bundled in the extension zip: extraction loses the executable bit, which is restored.
    bundled = make_exe(addon / "bin" / runner.BINARY_NAME, "", executable=False)
    assert runner.find_binary("", addon_dir=addon, path_env="") == bundled
    assert os.access(bundled, os.X_OK)
    on_path = make_exe(tmp_path / "pathdir" / runner.BINARY_NAME, "")
    assert runner.find_binary("", addon_dir=addon, path_env=str(on_path.parent)) == on_path


def test_the_real_checkout_finds_its_own_build(cubist_binary):
    found = runner.find_binary("", path_env="")
    assert found.resolve() == cubist_binary.resolve()


# ---------------------------------------------------------------------------------------------
# argv, output lines, progress


def test_argv_follows_the_binary_contract(tmp_path):
    argv = runner.build_argv(Path("/b/cubist"), tmp_path / "s.glb", tmp_path / "o.png", tmp_path / "c.json")
    assert argv == ["/b/cubist", "render", str(tmp_path / "s.glb"), "-o", str(tmp_path / "o.png"), "--config",
                    str(tmp_path / "c.json"), "--progress", "lines"]
    assert runner.pass_path(tmp_path / "o.png", "facet-ids") == tmp_path / "o.facet-ids.png"


def test_parse_lines():
    p = runner.parse_line("PROGRESS 0.2500 pre-render\n")
    assert (p.kind, p.fraction, p.text) == ("progress", 0.25, "pre-render")
    assert runner.parse_line("PROGRESS 1.7 x").fraction == 1.0
    assert runner.parse_line("PROGRESS abc x").kind == "other"
    e = runner.parse_line("error: invalid setting `spp`: must be at least 1")
    assert (e.kind, e.text) == ("error", "invalid setting `spp`: must be at least 1")
    assert runner.parse_line("warning: camera up vector is parallel").kind == "warning"


def test_progress_only_moves_forward_within_its_span():
    t = runner.ProgressTracker(0.5, 1.0)
    seq = [("loading", 0.0), ("loading", 1.0), ("pre-render", 0.5), ("pre-render", 1.0), ("unknown", 0.1),
           ("writing", 0.0), ("pre-render", 0.2), ("done", 1.0)]
    values = [t.update(s, f) for s, f in seq]
    assert values == sorted(values)
    assert values[0] == 0.5 and values[-1] == 1.0 and all(0.5 <= v <= 1.0 for v in values)


# ---------------------------------------------------------------------------------------------
# Running: errors, cancel, temporary files


def test_run_streams_progress_and_warnings(tmp_path):
    exe = make_exe(tmp_path / "fake", """
        import sys
        for f in (0.0, 0.5, 1.0):
            print(f"PROGRESS {f} pre-render", file=sys.stderr, flush=True)
        print("warning: something odd", file=sys.stderr)
    """)
    seen = []
    res = runner.run([str(exe)], on_progress=lambda s, f: seen.append((s, f)))
    assert seen == [("pre-render", 0.0), ("pre-render", 0.5), ("pre-render", 1.0)]
    assert res.warnings == ["something odd"]


def test_a_renderer_error_carries_its_message(tmp_path):
    exe = make_exe(tmp_path / "fake", """
        import sys
        print("PROGRESS 0.1 loading", file=sys.stderr)
        print("error: scene.glb: the scene has no triangles to render", file=sys.stderr)
        sys.exit(1)
    """)
    with pytest.raises(runner.RendererError, match="the scene has no triangles to render") as e:
        runner.run([str(exe)])
    assert e.value.returncode == 1


def test_a_crash_without_an_error_line_still_says_something(tmp_path):
    exe = make_exe(tmp_path / "fake", "import sys; sys.exit(101)\n")
    with pytest.raises(runner.RendererError, match="exited with code 101"):
        runner.run([str(exe)])


def test_a_missing_executable_is_binary_not_found(tmp_path):
    with pytest.raises(runner.BinaryNotFound, match="not found"):
        runner.run([str(tmp_path / "nope")])


def test_real_binary_bad_setting_is_a_usage_error(cubist_binary, tmp_path):
    cfg = tmp_path / "c.json"
    runner.write_settings(cfg, {"spp": 0})
    with pytest.raises(runner.RendererError, match=r"invalid setting `spp`: must be at least 1") as e:
        # No scene: the built-in still life; the setting fails before anything is rendered.
        runner.run([str(cubist_binary), "render", "-o", str(tmp_path / "o.png"), "--config", str(cfg),
                    "--progress", "lines"])
    assert e.value.returncode == 2
    assert not (tmp_path / "o.png").exists()


def test_cancel_terminates_the_process(tmp_path):
    exe = make_exe(tmp_path / "slow", """
        import sys, time
        print("PROGRESS 0.0 pre-render", file=sys.stderr, flush=True)
        time.sleep(60)
    """)
    procs = []
    seen = []
    t0 = time.monotonic()
    with pytest.raises(runner.Cancelled):
        runner.run([str(exe)], on_progress=lambda s, f: seen.append(s), should_cancel=lambda: bool(seen),
                   on_start=procs.append)
    assert time.monotonic() - t0 < 10
    assert procs[0].poll() is not None, "the renderer still runs after cancel"


def test_cancel_kills_a_process_that_ignores_terminate(tmp_path):
    exe = make_exe(tmp_path / "stubborn", """
        import signal, sys, time
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
        print("PROGRESS 0.0 pre-render", file=sys.stderr, flush=True)
        time.sleep(60)
    """)
    if sys.platform == "win32":
        pytest.skip("no SIGTERM on Windows: terminate() is already a kill")
    procs, seen = [], []
    with pytest.raises(runner.Cancelled):
        runner.run([str(exe)], on_progress=lambda s, f: seen.append(s), should_cancel=lambda: bool(seen),
                   on_start=procs.append)
    assert procs[0].poll() is not None


def test_workspace_is_removed_on_error(tmp_path):
    with pytest.raises(RuntimeError):
        with runner.Workspace() as ws:
            (ws / "scene.glb").write_bytes(b"x")
            raise RuntimeError("boom")
    assert not ws.exists()


def test_settings_for_an_older_binary(tmp_path):
    """A binary set in the preferences may predate settings the add-on sends: time-saving
    keys are left out, others are a clear error rather than the renderer's `unknown key`."""
    # Before `cubist settings`: only `render --help` tells the keys.
    old = make_exe(tmp_path / "old" / "cubist", """
        import sys
        if sys.argv[1:2] == ["settings"]:
            print("error: unrecognized subcommand 'settings'", file=sys.stderr); sys.exit(2)
        print('  --facet-count <N>\\n  --spp <SPP>\\n  --pass <PASS>')
    """)
    new = make_exe(tmp_path / "new" / "cubist", """
        import json, sys
        print(json.dumps({"facet_count": 150, "spp": 4, "passes": [], "saliency_cache": None, "fill": None}))
    """)
    assert runner.binary_keys(old) == {"facet_count", "spp", "passes"}
    assert runner.binary_keys(new) == {"facet_count", "spp", "passes", "saliency_cache", "fill"}
    assert not runner.binary_supports(old, "saliency_cache") and runner.binary_supports(new, "saliency_cache")
    s = {"spp": 1, "passes": ["depth"], "saliency_cache": "/c"}
    assert runner.settings_for_binary(old, s) == {"spp": 1, "passes": ["depth"]}
    assert runner.settings_for_binary(new, s) == s
    with pytest.raises(runner.CubistError, match=r"does not know the setting\(s\) fill: it is older than this add-on"):
        runner.settings_for_binary(old, dict(s, fill=0.5))


def test_the_real_binary_knows_every_key(cubist_binary):
    assert runner.binary_keys(cubist_binary) == runner.SETTINGS_KEYS
    s = mapping.settings_from_panel(dict(presets.DEFAULTS), default_facts())
    assert runner.settings_for_binary(cubist_binary, s) == s


def test_progress_stages_are_the_binarys(cubist_binary, tmp_path):
    """Every stage the renderer reports has its share of the progress bar (a renamed stage
    would freeze the bar)."""
    r = subprocess.run([str(cubist_binary), "render", "--width", "48", "--height", "36", "--spp", "1", "--faceting",
                        "voronoi", "-o", str(tmp_path / "o.png"), "--progress", "lines"], capture_output=True,
                       text=True)
    assert r.returncode == 0, r.stderr
    stages = {ln.split(" ", 2)[2] for ln in r.stderr.splitlines() if ln.startswith("PROGRESS ")}
    assert {"pre-render", "saliency", "faceting", "imprecision", "paint"} <= stages, stages
    assert stages - {name for name, _ in runner.STAGE_WEIGHTS} <= {"done"}


# ---------------------------------------------------------------------------------------------
# Facet layouts across frames



def test_layout_plan(tmp_path):
    s = {"faceting": "voronoi", "width": 64, "height": 48, "passes": ["saliency"]}
    layout = tmp_path / "l.json"
    first = runner.plan_layout(s, layout, frame=1, layout_frame=1)
    assert first.settings["save_facets"] == str(layout) and first.prepass_frame is None
    chunk = runner.plan_layout(s, layout, frame=51, layout_frame=1)
    assert chunk.prepass_frame == 1 and chunk.settings["facets"] == str(layout)
    pre = runner.layout_prepass(s, layout)
    assert pre["save_facets"] == str(layout) and pre["passes"] == [] and "facets" not in pre
    layout.write_text("{}")
    later = runner.plan_layout(s, layout, frame=51, layout_frame=1)
    assert later.settings["facets"] == str(layout) and later.prepass_frame is None
    assert "save_facets" not in later.settings
    none = runner.plan_layout(dict(s, faceting="none"), layout, 3, 1)
    assert "facets" not in none.settings and "save_facets" not in none.settings
    assert runner.plan_layout(s, None, 3, 1).settings == s
    # The user's own layout file: used as it is, for every frame.
    assert not runner.uses_layout(dict(s, facets="/mine.png"))
    # A saved layout that is no longer the layout frame's: computed again, there.
    stale_here = runner.plan_layout(s, layout, frame=1, layout_frame=1, current=False)
    assert stale_here.settings["save_facets"] == str(layout) and "facets" not in stale_here.settings
    stale_there = runner.plan_layout(s, layout, frame=7, layout_frame=1, current=False)
    assert stale_there.prepass_frame == 1 and stale_there.settings["facets"] == str(layout)


def test_layout_source_follows_the_layout_frames_view(tmp_path):
    glb = tmp_path / "scene.glb"
    glb.write_bytes(b"glTF scene at the layout frame")
    base = {"camera_position": [0, 1, 6], "camera_target": [0, 1, 5], "spp": 4, "palette": "ochre", "width": 800,
            "height": 600}
    src = runner.layout_source(glb, base)
    # Painterly settings and the size (a preview shares the final's layout) do not matter...
    assert runner.layout_source(glb, dict(base, palette="grey", width=400, height=300, border_width=3)) == src
    # ...the camera and the scene do.
    assert runner.layout_source(glb, dict(base, camera_position=[0, 1, 7])) != src
    assert runner.layout_source(glb, dict(base, fill=0.5)) != src
    glb.write_bytes(b"glTF scene with the cube moved")
    assert runner.layout_source(glb, base) != src

    layout = tmp_path / "l.facets.json"
    assert not runner.layout_is_current(layout, src)
    layout.write_text("{}")
    assert runner.layout_is_current(layout, None)  # Voronoi, Patch: the view does not matter
    assert not runner.layout_is_current(layout, src)  # no recorded source: stale
    runner.record_source(layout, src)
    assert runner.layout_is_current(layout, src) and not runner.layout_is_current(layout, "other")
    runner.forget_source(layout)
    assert not runner.layout_is_current(layout, src)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["l.facets.json", "scene.glb"]


def test_layout_file_name_follows_the_facet_settings_only():
    base = {"faceting": "voronoi", "facet_count": 150, "seed": 0, "width": 1920, "height": 1080,
            "camera_position": [0, 0, 5], "discontinuity": 100}
    key = runner.layout_key(base)
    assert runner.layout_key(dict(base, camera_position=[1, 2, 3], discontinuity=50)) == key
    assert runner.layout_key(dict(base, width=960, height=540)) == key  # a 50% preview shares it
    assert runner.layout_key(dict(base, facet_count=100)) != key
    assert runner.layout_key(dict(base, seed=1)) != key
    for k, v in (("superpixels", 300), ("weight_object", 1.0), ("thresholds", [0, 0.1]), ("segments", [4])):
        assert runner.layout_key(dict(base, **{k: v})) != key, k
    assert runner.layout_key(dict(base, width=1080, height=1920)) != key
    assert runner.layout_key(base, layout_frame=1001) != key
    assert runner.layout_path(Path("/x"), "Scene 1/a", base).name == f"Scene_1_a.{key}.facets.json"


def test_settings_json_is_what_the_binary_reads(tmp_path):
    p = tmp_path / "s.json"
    runner.write_settings(p, runner.clean_settings({"spp": 2, "facets": Path("/a/b.json"), "seed": None,
                                                    "background": (0.1, 0.2, 0.3)}))
    assert json.loads(p.read_text()) == {"spp": 2, "facets": "/a/b.json", "background": [0.1, 0.2, 0.3]}
