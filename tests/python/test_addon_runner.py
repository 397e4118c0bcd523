"""The add-on's bpy-free part (runner, mapping, presets), tested in plain Python: finding the
binary, the settings contract with src/settings.rs, argv, progress and error parsing, cancel,
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


def settings_rs_keys():
    text = (ROOT / "src" / "settings.rs").read_text()
    body = text[text.index("pub struct Settings {"):]
    body = body[:body.index("\n}\n")]
    return set(re.findall(r"^\s*pub (\w+):", body, re.M))


def test_settings_keys_match_settings_rs():
    """Every key the renderer accepts is known to the add-on and vice versa (a renamed or
    added setting must reach the panel)."""
    assert runner.SETTINGS_KEYS == settings_rs_keys()


def default_facts(**kw):
    return mapping.SceneFacts(width=kw.pop("width", 64), height=kw.pop("height", 48), frame=kw.pop("frame", 1), **kw)


def test_panel_defaults_cover_every_setting_the_panel_owns():
    s = mapping.settings_from_panel(dict(presets.DEFAULTS), default_facts())
    # The keys the add-on does not send from the panel: camera frame (no camera here), files
    # it decides per frame (layout), paths left empty, and the focus (none without a camera).
    not_sent = {"camera_position", "camera_target", "camera_up", "focus_distance", "camera_size", "facets",
                "save_facets", "facet_map", "palette_image"}
    assert set(s) == runner.SETTINGS_KEYS - not_sent


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
    r, _ = run_cli(cubist_binary, s, tmp_path)
    assert r.returncode == 0, f"preset {name}: {r.stderr}"


def test_presets_only_set_panel_properties():
    for name in presets.BUILTIN:
        assert set(presets.preset_values(name)) <= set(presets.DEFAULTS), name


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
    ("facet_projection", "LINEAR", "facet_projection", "linear"),
    ("border_width", 5.0, "border_width", 5.0),
    ("palette", "BLUE_PERIOD", "palette", "blue-period"),
    ("colors", 12, "colors", 12),
    ("gradients", 0.4, "gradients", 0.4),
    ("chiaroscuro", 0.2, "chiaroscuro", 0.2),
    ("shadows", False, "shadows", False),
    ("pass_facet_ids", True, "passes", ["facet-ids"]),
    ("camera_size", 2.5, "camera_size", 2.5),
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
    assert mapping.settings_from_panel(panel, default_facts(camera=cam))["ambiguity"] == 140.0


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


def test_preference_path_wins_and_a_wrong_one_is_reported(tmp_path):
    exe = make_exe(tmp_path / "custom" / runner.BINARY_NAME, "print('hi')\n")
    assert runner.find_binary(str(exe), addon_dir=tmp_path / "addon", path_env="") == exe
    assert runner.find_binary(str(exe.parent), addon_dir=tmp_path / "addon", path_env="") == exe
    with pytest.raises(runner.BinaryNotFound, match="not found at .*nowhere.*add-on preferences"):
        runner.find_binary(str(tmp_path / "nowhere" / "cubist"), addon_dir=tmp_path / "addon", path_env="")


def test_path_then_bundled_then_project_build(tmp_path):
    addon = tmp_path / "proj" / "blender_addon"
    addon.mkdir(parents=True)
    with pytest.raises(runner.BinaryNotFound, match="cubist binary not found: set its path"):
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


def test_newer_settings_are_sent_only_to_binaries_that_know_them(tmp_path):
    old = make_exe(tmp_path / "old" / "cubist", "print('  --facet-count <N>')\n")
    new = make_exe(tmp_path / "new" / "cubist", "print('  --facet-count <N>\\n  --saliency-cache <DIR>')\n")
    assert not runner.binary_supports(old, "saliency_cache")
    assert runner.binary_supports(new, "saliency_cache")


def test_binary_capability_detection(cubist_binary):
    assert runner.binary_supports(cubist_binary, "facet_count")
    assert runner.binary_supports(cubist_binary, "save_facets")
    assert not runner.binary_supports(cubist_binary, "no_such_setting")


# ---------------------------------------------------------------------------------------------
# Facet layouts across frames


def test_saliency_is_needed_exactly_when_the_renderer_computes_it():
    base = {"faceting": "none", "imprecision": "saliency", "discontinuity": 0.0, "passes": []}
    assert not runner.needs_saliency(base)
    assert not runner.needs_saliency(dict(base, discontinuity=100.0))  # no facets to re-aim
    assert runner.needs_saliency(dict(base, faceting="voronoi", discontinuity=100.0))
    assert not runner.needs_saliency(dict(base, faceting="voronoi", discontinuity=100.0, imprecision="random"))
    assert runner.needs_saliency(dict(base, faceting="segment"))
    assert runner.needs_saliency(dict(base, passes=["saliency"]))


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


def test_layout_file_name_follows_the_facet_settings_only():
    base = {"faceting": "voronoi", "facet_count": 150, "seed": 0, "width": 1920, "height": 1080,
            "camera_position": [0, 0, 5], "discontinuity": 100}
    key = runner.layout_key(base)
    assert runner.layout_key(dict(base, camera_position=[1, 2, 3], discontinuity=50)) == key
    assert runner.layout_key(dict(base, width=960, height=540)) == key  # a 50% preview shares it
    assert runner.layout_key(dict(base, facet_count=100)) != key
    assert runner.layout_key(dict(base, seed=1)) != key
    assert runner.layout_key(dict(base, width=1080, height=1920)) != key
    assert runner.layout_key(base, layout_frame=1001) != key
    assert runner.layout_path(Path("/x"), "Scene 1/a", base).name == f"Scene_1_a.{key}.facets.json"


def test_settings_json_is_what_the_binary_reads(tmp_path):
    p = tmp_path / "s.json"
    runner.write_settings(p, runner.clean_settings({"spp": 2, "facets": Path("/a/b.json"), "seed": None,
                                                    "background": (0.1, 0.2, 0.3)}))
    assert json.loads(p.read_text()) == {"spp": 2, "facets": "/a/b.json", "background": [0.1, 0.2, 0.3]}
