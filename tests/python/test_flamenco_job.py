"""The Flamenco job type (farm/flamenco/cubist_render.js).

- `compileJob` runs in node against tests/python/flamenco_standin.js, a STAND-IN for the
  Flamenco Manager's job compiler API (`author`, `frameChunker`, `path`...) that records the
  tasks and commands; the stand-in's frame chunker is first checked against Flamenco's own
  test cases, and the job type's settings against Flamenco's OpenAPI schema.
- The guard and the layout setup the tasks run are tested in headless Blender (bpy 5.0.1):
  with the add-on enabled the guard passes, without it (or without a renderer) Blender exits
  with code 1 and a clear message; two tasks run as two workers share one facet layout.
  Blender's command line is emulated there (bpy is a module, without one); with a `blender`
  executable on PATH (Debian's 3.4 in CI), the real command line runs the guard too.
"""

import json
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from addon_support import ROOT, addon, bpy_module, cubist_binary, new_scene  # noqa: F401 (fixtures)
from ship_support import SCENE_PY, node  # noqa: F401 (fixture)

JOB_SCRIPT = ROOT / "farm" / "flamenco" / "cubist_render.js"
STANDIN = ROOT / "tests" / "python" / "flamenco_standin.js"

# Flamenco's OpenAPI schema (pkg/api/flamenco-openapi.yaml): AvailableJobSetting's enums.
SETTING_TYPES = {"string", "int32", "float", "bool"}
SETTING_SUBTYPES = {"file_path", "dir_path", "file_name", "hashed_file_path"}
SETTING_VISIBILITY = {"visible", "hidden", "submission", "web"}
SETTING_FIELDS = {"key", "type", "subtype", "choices", "propargs", "description", "label", "default", "eval",
                  "evalInfo", "visible", "required", "editable"}


def compile_job(node, tmp_path, script=JOB_SCRIPT, **settings):
    base = {"frames": "1-10", "chunk_size": 4, "render_output_root": "/render", "add_path_components": 0,
            "render_output_path": "/render/shot/{timestamp}/######", "blendfile": "/farm/shot.flamenco.blend",
            "format": "PNG", "scene": "Scene", "static_facets": True, "layout_frame": 1}
    base.update(settings)
    job = tmp_path / "job.json"
    job.write_text(json.dumps({"name": "shot", "settings": base, "created": "2026-03-04T05:06:07"}))
    r = subprocess.run([node, str(STANDIN), str(script), str(job)], capture_output=True, text=True, timeout=60)
    assert r.returncode in (0, 3), r.stderr
    return json.loads(r.stdout)


def args_of(task):
    (command,) = task["commands"]
    assert command["name"] == "blender-render"
    return command["parameters"]["args"]


# ---------------------------------------------------------------------------------------------
# The stand-in and the job type's declaration


def test_the_standin_chunks_frames_as_flamenco_does(node, tmp_path):
    """Flamenco's own cases for its frame chunker (js_globals_test.go), through the stand-in."""
    script = tmp_path / "chunks.js"
    script.write_text(textwrap.dedent("""
        const JOB_TYPE = {label: "chunks", settings: []};
        function compileJob(job) {
            for (const chunk of frameChunker(job.settings.frames, job.settings.chunk_size)) {
                job.addTask(author.Task(chunk, "misc"));
            }
        }
    """))
    expected = ["1-4", "5-8", "9,10,20,21", "22-25", "40"]
    for frames in ("1..10,20..25,40,3..8", "1-10,20-25,40", " 1  .. 10,\t20..25\n,40   "):
        out = compile_job(node, tmp_path, script, frames=frames, chunk_size=4)
        assert [t["name"] for t in out["tasks"]] == expected, frames
    assert [t["name"] for t in compile_job(node, tmp_path, script, frames="47", chunk_size=4)["tasks"]] == ["47"]
    assert [t["name"] for t in compile_job(node, tmp_path, script, frames="1-3", chunk_size=3)["tasks"]] == ["1-3"]
    assert "1 10" in compile_job(node, tmp_path, script, frames=" 1 10", chunk_size=4)["error"]


def test_the_standin_offers_nothing_of_nodes(node, tmp_path):
    """A job type using node's `require` fails here, as it would in the Manager."""
    script = tmp_path / "node.js"
    script.write_text('const JOB_TYPE = {label: "x", settings: []};\n'
                      'function compileJob(job) { require("fs"); }\n')
    assert "require is not defined" in compile_job(node, tmp_path, script)["error"]


def test_job_type_settings_follow_flamencos_schema(node, tmp_path):
    job_type = compile_job(node, tmp_path)["job_type"]
    assert job_type["label"] == "Cubist Render"
    keys = [s["key"] for s in job_type["settings"]]
    assert len(keys) == len(set(keys))
    assert {"frames", "chunk_size", "render_output_root", "render_output_path", "blendfile", "format", "scene",
            "layout_folder", "static_facets", "layout_frame"} <= set(keys)
    for s in job_type["settings"]:
        assert set(s) <= SETTING_FIELDS, s
        assert s["type"] in SETTING_TYPES, s
        assert s.get("subtype", "file_path") in SETTING_SUBTYPES, s
        assert s.get("visible", "visible") in SETTING_VISIBILITY, s
        if "evalInfo" in s:
            assert set(s["evalInfo"]) == {"showLinkButton", "description"}, s
        if "eval" in s:  # a Python expression the Flamenco add-on evaluates at submission
            compile(s["eval"], s["key"], "eval")


def test_the_evals_read_the_cubist_panel(node, tmp_path, addon, bpy_module):
    """The settings the job type evaluates in the submitter's Blender (the Flamenco add-on
    runs each `eval` there) read the Cubist panel as the add-on defines it."""
    bpy = bpy_module
    scene = new_scene(bpy)
    scene.cubist.faceting, scene.cubist.static_facets, scene.cubist.layout_frame = "VORONOI", True, 7
    evals = {s["key"]: s["eval"] for s in compile_job(node, tmp_path)["job_type"]["settings"] if "eval" in s}
    names = {"C": bpy.context, "bpy": bpy}
    assert {k: eval(evals[k], names) for k in ("static_facets", "layout_frame", "format", "scene")} == {
        "static_facets": True, "layout_frame": 7, "format": scene.render.image_settings.file_format,
        "scene": scene.name}
    for change in ({"static_facets": False}, {"faceting": "NONE"}, {"layout_file": "/mine.json"}):
        for k, v in change.items():
            setattr(scene.cubist, k, v)
        assert not eval(evals["static_facets"], names), change
        scene.cubist.faceting, scene.cubist.static_facets, scene.cubist.layout_file = "VORONOI", True, ""
    # Facets that follow the scene share the Layout Frame's layout and follow data, Static
    # Facets or not.
    scene.cubist.static_facets, scene.cubist.facet_motion = False, "FOLLOW"
    assert eval(evals["static_facets"], names)


# ---------------------------------------------------------------------------------------------
# compileJob


def test_chunks_render_cubist_frames_after_the_guard(node, tmp_path):
    out = compile_job(node, tmp_path, frames="1-10", chunk_size=4, layout_frame=1)
    settings = out["settings"]
    assert settings["render_output_path"] == "/render/shot/2026-03-04_050607/######"
    assert settings["layout_folder"] == "/render/shot/2026-03-04_050607/cubist-layout"
    tasks = out["tasks"]
    assert [t["name"] for t in tasks] == ["render-1-4", "render-5-8", "render-9,10"]
    assert [t["type"] for t in tasks] == ["blender"] * 3
    assert [t["commands"][0]["totalStepCount"] for t in tasks] == [4, 4, 2]
    for task, frames in zip(tasks, ("1..4", "5..8", "9,10")):
        params = task["commands"][0]["parameters"]
        assert (params["exe"], params["exeArgs"], params["argsBefore"], params["blendfile"]) == (
            "{blender}", "{blenderArgs}", [], "/farm/shot.flamenco.blend")
        args = args_of(task)
        # Blender handles its arguments in order: the exit code is set before the guard runs,
        # the guard and the engine come before anything renders.
        assert args[:4] == ["--scene", "Scene", "--python-exit-code", "1"]
        assert args[4] == "--python-expr" and "bl_rna_get_subclass_py('CUBIST')" in args[5]
        assert args[6:8] == ["--engine", "CUBIST"]
        assert args[8] == "--python-expr" and "cubist.layout_folder" in args[9]
        assert args[10:] == ["--render-output", "/render/shot/2026-03-04_050607/######", "--render-format", "PNG",
                             "--render-frame", frames, "--", "--cubist-layout-folder",
                             "/render/shot/2026-03-04_050607/cubist-layout"]
        # Flamenco expands `{name}` in every argument: the Python has no braces.
        assert "{" not in args[5] and "{" not in args[9]
    # The chunk with the Layout Frame saves the layout; the others wait for it.
    assert [t["dependencies"] for t in tasks] == [[], ["render-1-4"], ["render-1-4"]]


def test_the_layout_chunk_runs_first_wherever_the_layout_frame_is(node, tmp_path):
    tasks = compile_job(node, tmp_path, frames="1-10", chunk_size=4, layout_frame=6)["tasks"]
    assert [t["name"] for t in tasks] == ["render-5-8", "render-1-4", "render-9,10"]
    assert [t["dependencies"] for t in tasks] == [[], ["render-5-8"], ["render-5-8"]]
    tasks = compile_job(node, tmp_path, frames="1-4,20-21", chunk_size=4, layout_frame=20)["tasks"]
    assert [(t["name"], t["dependencies"]) for t in tasks] == [("render-20,21", []), ("render-1-4", ["render-20,21"])]


def test_a_layout_frame_outside_the_range_is_rendered_on_its_own(node, tmp_path):
    out = compile_job(node, tmp_path, frames="51-58", chunk_size=4, layout_frame=1, layout_folder="/shared/layouts")
    tasks = out["tasks"]
    assert [(t["name"], t["dependencies"]) for t in tasks] == [
        ("cubist-layout-frame-1", []), ("render-51-54", ["cubist-layout-frame-1"]),
        ("render-55-58", ["cubist-layout-frame-1"])]
    args = args_of(tasks[0])
    assert args[args.index("--render-frame") + 1] == "1"
    # Its picture goes beside the layout, not among the job's frames.
    assert args[args.index("--render-output") + 1] == "/shared/layouts/layout-frame/######"
    assert out["settings"]["layout_folder"] == "/shared/layouts"
    for task in tasks:
        assert args_of(task)[-2:] == ["--cubist-layout-folder", "/shared/layouts"]


def test_without_static_facets_chunks_do_not_wait(node, tmp_path):
    tasks = compile_job(node, tmp_path, frames="1-6", chunk_size=2, static_facets=False, layout_frame=40)["tasks"]
    assert [(t["name"], t["dependencies"]) for t in tasks] == [("render-1,2", []), ("render-3,4", []),
                                                                ("render-5,6", [])]


def test_bad_jobs_are_refused_with_a_reason(node, tmp_path):
    assert "renders images, not \"FFMPEG\"" in compile_job(node, tmp_path, format="FFMPEG")["error"]
    assert "chunk_size must be at least 1" in compile_job(node, tmp_path, chunk_size=0)["error"]
    assert "no render_output_path" in compile_job(node, tmp_path, render_output_path="")["error"]


# ---------------------------------------------------------------------------------------------
# The guard and the layout setup in Blender (bpy 5.0.1)

# Runs a task's Blender arguments (those after the .blend) in bpy, as Blender's command line
# does: in order, `--python-expr` run as `__main__` code, an exception ending the process with
# the `--python-exit-code` code, then the engine, the output and the frames. An argument it
# does not know is an error, so the emulation cannot quietly skip one.
WORKER = r"""
import json, os, sys, tempfile, traceback
os.environ["BLENDER_USER_RESOURCES"] = tempfile.mkdtemp(prefix="cubist-flamenco-worker-")
import bpy
import addon_utils

spec = json.loads(sys.argv[1])
if spec.get("addon"):
    sys.path.insert(0, spec["root"])
    assert addon_utils.enable("blender_addon", default_set=True, persistent=True) is not None
    if spec.get("binary_path") is not None:
        bpy.context.preferences.addons["blender_addon"].preferences.binary_path = spec["binary_path"]
if spec.get("make_blend"):
    scene = cubist_scene(bpy, 40, 30)
    scene.cubist.faceting = "VORONOI"
    scene.cubist.layout_folder = "//cubist"  # the artist's: the job replaces it
    scene.frame_start, scene.frame_end = 1, 4
    bpy.ops.wm.save_as_mainfile(filepath=spec["make_blend"])
    sys.exit(0)

bpy.ops.wm.open_mainfile(filepath=spec["blendfile"])
args = spec["args"]
sys.argv = ["blender", "-b", spec["blendfile"], *args]
exit_code = 0
i = 0
while i < len(args) and args[i] != "--":
    a, v = args[i], args[i + 1]
    scene = bpy.context.scene
    if a == "--scene":
        assert scene.name == v, (scene.name, v)
    elif a == "--python-exit-code":
        exit_code = int(v)
    elif a == "--python-expr":
        try:
            exec(compile(v, "<string>", "exec"), {"__name__": "__main__"})
        except Exception:
            traceback.print_exc()
            if exit_code:
                print("Error: script failed, expr: '%s', exiting." % v, file=sys.stderr)
                sys.exit(exit_code)
    elif a == "--engine":
        scene.render.engine = v
    elif a == "--render-output":
        scene.render.filepath = v
    elif a == "--render-format":
        scene.render.image_settings.file_format = v
    elif a == "--render-frame":
        for part in v.split(","):
            first, _, last = part.partition("..")
            scene.frame_start, scene.frame_end = int(first), int(last or first)
            bpy.ops.render.render(animation=True)
    else:
        print("emulator: unknown argument " + a, file=sys.stderr)
        sys.exit(9)
    i += 2
engine = sys.modules.get("blender_addon.engine")
history = [{k: e.get(k) for k in ("frame", "layout", "prepass", "error")} | {"facets": (e.get("settings") or {}).get("facets"), "save_facets": (e.get("settings") or {}).get("save_facets")} for e in (engine.history if engine else [])]
print("RESULT " + json.dumps({"history": history, "layout_folder": bpy.context.scene.cubist.layout_folder}))
"""


def worker(tmp_path, **spec):
    script = tmp_path / "worker.py"
    script.write_text(SCENE_PY + WORKER)
    env = dict(os.environ, PATH="/usr/bin:/bin")
    env.pop("BLENDER_USER_RESOURCES", None)
    spec.setdefault("root", str(ROOT))
    r = subprocess.run([sys.executable, str(script), json.dumps(spec)], capture_output=True, text=True, env=env,
                       timeout=600)
    line = next((ln for ln in r.stdout.splitlines() if ln.startswith("RESULT ")), None)
    return r, (json.loads(line[len("RESULT "):]) if line else None)


@pytest.fixture(scope="module")
def farm(node, cubist_binary, tmp_path_factory):
    """A .blend saved with the Cubist engine, and its job compiled for a shared folder."""
    tmp = tmp_path_factory.mktemp("farm")
    blend = tmp / "shot.blend"
    r, _ = worker(tmp, addon=True, make_blend=str(blend))
    assert r.returncode == 0 and blend.is_file(), r.stderr[-3000:]
    out = compile_job(node, tmp, frames="1-4", chunk_size=2, layout_frame=1, blendfile=str(blend),
                      render_output_path=str(tmp / "frames" / "######"), layout_folder=str(tmp / "shared-layout"))
    return {"tmp": tmp, "blend": blend, "job": out}


def run_task(farm, task, **spec):
    return worker(farm["tmp"], blendfile=str(farm["blend"]), args=args_of(task), **spec)


def test_without_the_addon_the_guard_fails_the_task(farm):
    r, res = run_task(farm, farm["job"]["tasks"][0], addon=False)
    assert r.returncode == 1, r.stderr[-3000:]
    assert "RuntimeError: Cubist: this worker has no Cubist render engine (Blender 5.0.1): install and enable the " \
           "Cubist add-on on every worker" in r.stderr
    assert res is None and not (farm["tmp"] / "frames").exists()  # nothing rendered, with EEVEE or else


def test_without_a_renderer_the_guard_fails_the_task(farm, tmp_path):
    r, res = run_task(farm, farm["job"]["tasks"][0], addon=True, binary_path=str(tmp_path / "no" / "cubist"))
    assert r.returncode == 1, r.stderr[-3000:]
    assert "BinaryNotFound: cubist binary not found at" in r.stderr and "Cubist Binary" in r.stderr
    assert res is None and not (farm["tmp"] / "frames").exists()


def test_workers_with_the_addon_share_one_layout(farm):
    """The layout task (frames 1-2, the Layout Frame 1) saves the layout in the job's shared
    folder; the next chunk, another process as on another machine, loads it: no pre-pass."""
    first, second = farm["job"]["tasks"]
    assert second["dependencies"] == [first["name"]]
    shared = farm["tmp"] / "shared-layout"
    r, res = run_task(farm, first, addon=True)
    assert r.returncode == 0, r.stderr[-3000:]
    assert "Cubist: render engine ready, renderer " in r.stdout
    assert res["layout_folder"] == str(shared)
    layouts = sorted(shared.glob("*.facets.json"))
    assert len(layouts) == 1, sorted(shared.iterdir())
    assert [(h["frame"], h["save_facets"], h["facets"], h["prepass"], h["error"]) for h in res["history"]] == [
        (1, str(layouts[0]), None, None, None), (2, None, str(layouts[0]), None, None)]
    r, res = run_task(farm, second, addon=True)
    assert r.returncode == 0, r.stderr[-3000:]
    assert [(h["frame"], h["facets"], h["prepass"], h["error"]) for h in res["history"]] == [
        (3, str(layouts[0]), None, None), (4, str(layouts[0]), None, None)]
    assert sorted(p.name for p in (farm["tmp"] / "frames").iterdir()) == ["000001.png", "000002.png",
                                                                         "000003.png", "000004.png"]
    assert sorted(shared.glob("*.facets.json")) == layouts


# ---------------------------------------------------------------------------------------------
# The real command line, where a Blender executable is installed

BLENDER_SAVE = SCENE_PY + r"""
import bpy, sys
cubist_scene(bpy)
bpy.ops.wm.save_as_mainfile(filepath=sys.argv[-1])
"""


@pytest.fixture(scope="module")
def blender_cli(tmp_path_factory):
    exe = shutil.which("blender")
    if exe is None:
        pytest.skip("no `blender` executable on PATH (Debian: apt-get install blender): the real command line "
                    "is not run; the emulated one above is")
    tmp = tmp_path_factory.mktemp("blender-cli")
    (tmp / "scripts" / "addons").mkdir(parents=True)
    (tmp / "scripts" / "addons" / "cubist").symlink_to(ROOT / "blender_addon", target_is_directory=True)
    env = dict(os.environ, BLENDER_USER_SCRIPTS=str(tmp / "scripts"))
    (tmp / "save.py").write_text(BLENDER_SAVE)
    blend = tmp / "shot.blend"
    r = subprocess.run([exe, "-b", "--factory-startup", "--addons", "cubist", "--python", str(tmp / "save.py"), "--",
                        str(blend)], capture_output=True, text=True, env=env, timeout=300)
    assert r.returncode == 0 and blend.is_file(), r.stdout[-2000:] + r.stderr[-2000:]
    return {"exe": exe, "tmp": tmp, "env": env, "blend": blend}


def test_the_real_command_line_runs_the_guard(node, blender_cli, cubist_binary):
    tmp = blender_cli["tmp"]
    out = compile_job(node, tmp, frames="1", chunk_size=1, blendfile=str(blender_cli["blend"]),
                      render_output_path=str(tmp / "frames" / "######"), layout_folder=str(tmp / "shared"))
    args = args_of(out["tasks"][0])
    base = [blender_cli["exe"], "-b", "--factory-startup"]
    # No add-on on this worker: code 1, the reason, no frame.
    r = subprocess.run([*base, str(blender_cli["blend"]), *args], capture_output=True, text=True,
                       env=blender_cli["env"], timeout=300)
    assert r.returncode == 1, r.stdout[-2000:] + r.stderr[-2000:]
    assert "Cubist: this worker has no Cubist render engine" in r.stdout + r.stderr
    assert not (tmp / "frames").exists()
    # With the add-on: the guard passes and the job's layout folder is set before rendering.
    r = subprocess.run([*base, "--addons", "cubist", str(blender_cli["blend"]), *args], capture_output=True,
                       text=True, env=blender_cli["env"], timeout=300)
    said = r.stdout + r.stderr
    assert f"Cubist: render engine ready, renderer {cubist_binary}" in said, said[-3000:]
    assert f"Cubist: facet layout folder {tmp / 'shared'}" in said, said[-3000:]
    assert "this worker has no Cubist render engine" not in said
