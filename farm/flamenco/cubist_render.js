// SPDX-License-Identifier: MIT OR Apache-2.0
//
// Flamenco job type "Cubist Render": renders a .blend's frames with the Cubist engine on a
// Flamenco farm. Install: copy this file into the `scripts/` folder beside the
// `flamenco-manager` executable and restart the Manager (docs/blender.md, "Render farms").
//
// Follows Flamenco's job compiler API (Manager internal/manager/job_compilers: `JOB_TYPE`,
// `compileJob(job)`, `author.Task`, `author.Command`, `frameChunker`, `frameCount`, `path`),
// and its built-in `simple_blender_render.js` for the render output path and frame chunks.
//
// What it adds for Cubist:
// - Every render command first runs a guard (`--python-exit-code 1 --python-expr GUARD`):
//   Blender renders with EEVEE, silently, a .blend whose engine is not registered, and the
//   task would report success. The guard fails the task instead, with a one-line reason,
//   when the worker's Blender has no Cubist engine or the add-on finds no renderer for it.
// - The facet layout (static facets) lives in one folder on shared storage, the same for
//   every task, so every chunk reuses the Layout Frame's layout. The chunk that renders the
//   Layout Frame (or, when the frame range leaves it out, a task rendering that frame alone)
//   runs first and saves the layout; the other chunks depend on it and load the layout.

const JOB_TYPE = {
    label: "Cubist Render",
    description: "Render frames with the Cubist engine, one facet layout for every chunk",
    settings: [
        // Settings for artists to determine:
        { key: "frames", type: "string", required: true,
          eval: "f'{C.scene.frame_start}-{C.scene.frame_end}'",
          evalInfo: { showLinkButton: true, description: "Scene frame range" },
          description: "Frame range to render. Examples: '47', '1-30', '3, 5-10, 47-327'" },
        { key: "chunk_size", type: "int32", default: 1, propargs: { min: 1 }, visible: "submission",
          description: "Number of frames to render in one Blender render task" },

        // render_output_root + add_path_components determine the value of render_output_path.
        { key: "render_output_root", type: "string", subtype: "dir_path", required: true, visible: "submission",
          description: "Base directory of where render output is stored. Will have some job-specific parts appended to it" },
        { key: "add_path_components", type: "int32", required: true, default: 0, propargs: { min: 0, max: 32 },
          visible: "submission",
          description: "Number of path components of the current blend file to use in the render output path" },
        { key: "render_output_path", type: "string", subtype: "file_path", editable: false,
          eval: "str(Path(abspath(settings.render_output_root), last_n_dir_parts(settings.add_path_components), jobname, '{timestamp}', '######'))",
          description: "Final file path of where render output will be saved" },

        // Cubist's facet layout: on storage every worker sees.
        { key: "layout_folder", type: "string", subtype: "dir_path", required: false, visible: "submission",
          description: "Folder for the facet layout and the saliency cache, on storage every worker sees. " +
                       "Empty: a cubist-layout folder beside the rendered frames" },

        // Automatically evaluated settings:
        { key: "blendfile", type: "string", required: true, description: "Path of the Blend file to render", visible: "web" },
        { key: "format", type: "string", required: true, eval: "C.scene.render.image_settings.file_format", visible: "web" },
        { key: "scene", type: "string", required: true, eval: "C.scene.name", visible: "web",
          description: "Name of the scene to render" },
        { key: "static_facets", type: "bool", required: false, visible: "web",
          eval: "(C.scene.cubist.static_facets or C.scene.cubist.facet_motion == 'FOLLOW') and " +
                "C.scene.cubist.faceting != 'NONE' and not C.scene.cubist.layout_file",
          description: "Whether the frames share one facet layout (the Cubist panel's Static Facets, or " +
                       "Facet Motion Follow: facets carried from the Layout Frame's)" },
        { key: "layout_frame", type: "int32", required: false, default: 1, visible: "web",
          eval: "C.scene.cubist.layout_frame",
          description: "The frame the shared facet layout is computed on (the Cubist panel's Layout Frame)" },
    ]
};

// Formats that would make Blender write a video: one task per chunk cannot do that.
const videoFormats = ["FFMPEG", "AVI_RAW", "AVI_JPEG"];

// Run before the render: fails the task (Blender exits with code 1 through
// --python-exit-code) unless the Cubist engine is registered and its add-on finds a renderer
// for this worker. No braces in the Python: Flamenco expands `{variable}` in command arguments.
const GUARD_PY = [
    "import bpy, sys",
    "engine = bpy.types.RenderEngine.bl_rna_get_subclass_py('CUBIST')",
    "if engine is None:",
    "    raise RuntimeError('Cubist: this worker has no Cubist render engine (Blender ' + bpy.app.version_string + '): install and enable the Cubist add-on on every worker; without it Blender would silently render EEVEE frames')",
    "package = engine.__module__.rpartition('.')[0]",
    "addon = bpy.context.preferences.addons.get(package)",  // None when enabled by --addons
    "preference = addon.preferences.binary_path if addon is not None and addon.preferences is not None else ''",
    "binary = sys.modules[package + '.runner'].find_binary(bpy.path.abspath(preference) if preference else '')",
    "print('Cubist: render engine ready, renderer ' + str(binary))",
].join("\n");

// Points the scene's layout folder at the job's shared folder, given after `--` (as its own
// argument, so Flamenco's path variables apply to it on every worker platform). The
// saliency cache follows it (empty Cache Folder: `saliency/` in the layout folder).
const SETUP_PY = [
    "import bpy, sys",
    "args = sys.argv[sys.argv.index('--') + 1:]",
    "cubist = bpy.context.scene.cubist",
    "cubist.layout_folder = args[args.index('--cubist-layout-folder') + 1]",
    "cubist.saliency_cache = ''",
    "print('Cubist: facet layout folder ' + cubist.layout_folder)",
].join("\n");

function compileJob(job) {
    print("Cubist Render job submitted");
    const settings = job.settings;
    if (videoFormats.indexOf(settings.format) >= 0) {
        throw `Cubist Render renders images, not "${settings.format}": choose an image format in Output Properties`;
    }
    if (!(settings.chunk_size >= 1)) {
        throw `chunk_size must be at least 1, not ${settings.chunk_size}`;
    }

    const renderOutput = renderOutputPath(job);
    // Show the actually-used paths when the job is looked at later.
    settings.render_output_path = renderOutput;
    const renderDir = path.dirname(renderOutput);
    const layoutFolder = settings.layout_folder || path.join(renderDir, "cubist-layout");
    settings.layout_folder = layoutFolder;

    // A Go slice in the Manager (goja): walked with for-of only, as the built-in scripts do.
    const chunks = frameChunker(settings.frames, settings.chunk_size);
    const output = path.join(renderDir, path.basename(renderOutput));
    const tasks = [];
    let layoutTask = null;
    const layoutFrame = Math.trunc(settings.layout_frame === undefined ? 1 : settings.layout_frame);
    for (const chunk of chunks) {
        const task = renderTask(`render-${chunk}`, settings, chunk, output, layoutFolder);
        if (settings.static_facets && layoutTask === null && chunkHasFrame(chunk, layoutFrame)) {
            layoutTask = task;
        }
        tasks.push(task);
    }

    if (settings.static_facets) {
        if (layoutTask === null) {
            // Out of the range: render the Layout Frame on its own, beside the layout.
            layoutTask = renderTask(`cubist-layout-frame-${layoutFrame}`, settings, `${layoutFrame}`,
                                    path.join(layoutFolder, "layout-frame", "######"), layoutFolder);
        } else {
            tasks.splice(tasks.indexOf(layoutTask), 1);
        }
        tasks.unshift(layoutTask);  // first in the list, as it runs first
        for (const task of tasks) {
            if (task !== layoutTask) {
                task.addDependency(layoutTask);
            }
        }
    }
    for (const task of tasks) {
        job.addTask(task);
    }
}

function renderTask(name, settings, chunk, output, layoutFolder) {
    const task = author.Task(name, "blender");
    let args = [];
    if (settings.scene) {
        args = args.concat(["--scene", settings.scene]);
    }
    args = args.concat([
        "--python-exit-code", "1",  // before the scripts it applies to
        "--python-expr", GUARD_PY,
        "--engine", "CUBIST",  // a Cubist job renders with Cubist, whatever the .blend was saved with
        "--python-expr", SETUP_PY,
        "--render-output", output,
        "--render-format", settings.format,
        "--render-frame", chunk.replaceAll("-", ".."),  // Blender's frame range notation
        "--", "--cubist-layout-folder", layoutFolder,
    ]);
    task.addCommand(author.Command("blender-render", {
        exe: "{blender}",
        exeArgs: "{blenderArgs}",
        argsBefore: [],
        blendfile: settings.blendfile,
        args: args,
    }, frameCount(chunk)));
    return task;
}

// Whether a chunk from frameChunker ("1-4", "9,10,20,21", "40") holds `frame`.
function chunkHasFrame(chunk, frame) {
    return chunk.split(",").some((part) => {
        const ends = part.split("-").map((s) => parseInt(s, 10));
        return ends.length === 1 ? ends[0] === frame : ends[0] <= frame && frame <= ends[1];
    });
}

// The render output path with `{timestamp}` replaced (as simple_blender_render.js does).
function renderOutputPath(job) {
    const p = job.settings.render_output_path;
    if (!p) {
        throw "no render_output_path setting!";
    }
    return p.replace(/{([^}]+)}/g, (match, group0) => {
        switch (group0) {
        case "timestamp":
            return formatTimestampLocal(job.created);
        default:
            return match;
        }
    });
}
