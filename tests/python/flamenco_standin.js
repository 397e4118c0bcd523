// A STAND-IN for Flamenco Manager's job compiler environment, to run a job type's
// `compileJob(job)` in node and record the tasks and commands it authors. It is not Flamenco:
// it mirrors, for the tests, what the Manager gives a job compiler script (Flamenco
// internal/manager/job_compilers: author.go, js_globals.go, js_path.go, scripts.go):
//   - globals `print`, `alert`, `frameChunker`, `frameCount`, `formatTimestampLocal`,
//     `shellSplit`, and the modules `author`, `path`, `process` -- and nothing of node's
//     (no `require`, no `console`), so a script leaning on node fails here as in the Manager;
//   - `author.Task(name, type)` (both required), `author.Command(name, parameters, steps)`,
//     `task.addCommand`, `task.addDependency`, `job.addTask` (which stores a copy of the task,
//     as the Go `AuthoredJob.AddTask` appends `*at`: what is added to a task afterwards is lost).
//
// Usage: node flamenco_standin.js JOB_SCRIPT.js JOB.json
//   JOB.json: {"name": ..., "settings": {...}, "created": ISO time}
// Prints one JSON object: {"job_type": JOB_TYPE, "settings": settings after compileJob,
// "tasks": [{name, type, priority, commands: [{name, parameters, totalStepCount}],
// dependencies: [task names]}], "log": [printed lines]}; or {"error": message} and exits 3
// when compileJob throws (the Manager then refuses the job).
"use strict";

const fs = require("fs");
const nodePath = require("path");
const vm = require("vm");

const [scriptPath, jobPath] = process.argv.slice(2);
const jobIn = JSON.parse(fs.readFileSync(jobPath, "utf8"));
const log = [];

// js_globals.go: frameRangeExplode / frameRangeMerge / jsFrameChunker.
function explode(range) {
    const frames = new Set();
    const text = range.split("..").join("-");
    for (const part of text.split(",")) {
        const ends = part.split("-");
        const nums = ends.map((s) => {
            const t = s.trim();
            if (!/^[+-]?\d+$/.test(t)) {
                throw new Error(`invalid range "${text}": ${part}`);
            }
            return parseInt(t, 10);
        });
        if (nums.length === 1) {
            frames.add(nums[0]);
        } else if (nums.length === 2) {
            for (let f = nums[0]; f <= nums[1]; f++) frames.add(f);
        } else {
            throw new Error(`invalid range "${text}": ${part}`);
        }
    }
    return Array.from(frames).sort((a, b) => a - b);
}

function merge(frames) {
    const ranges = [];
    const add = (a, b) => {
        if (a === b) ranges.push(`${a}`);
        else if (a + 1 === b) ranges.push(`${a}`, `${b}`);
        else ranges.push(`${a}-${b}`);
    };
    let start = frames[0];
    let prev = frames[0];
    for (const f of frames) {
        if (f > prev + 1) {
            add(start, prev);
            start = f;
        }
        prev = f;
    }
    add(start, prev);
    return ranges.join(",");
}

function frameChunker(range, chunkSize) {
    range = String(range).trim();
    if (range.length === 0) throw new Error(`invalid range "${range}": empty range`);
    if (!(chunkSize >= 1)) throw new Error(`invalid chunk size, must be positive number: ${chunkSize}`);
    const frames = explode(range);
    const chunks = [];
    for (let i = 0; i < frames.length; i += chunkSize) {
        chunks.push(merge(frames.slice(i, i + chunkSize)));
    }
    return chunks;
}

// crosspath (pkg/crosspath): forward slashes, whatever the platform.
const slash = (p) => String(p).split("\\").join("/");
const pathModule = {
    basename: (p) => nodePath.posix.basename(slash(p)),
    dirname: (p) => {
        const s = slash(p);
        const i = s.lastIndexOf("/");
        return i < 0 ? "." : i === 0 ? "/" : s.slice(0, i);
    },
    join: (...parts) => nodePath.posix.join(...parts.map(slash)),
    stem: (p) => {
        const b = nodePath.posix.basename(slash(p));
        return b.slice(0, b.length - nodePath.posix.extname(b).length);
    },
};

let taskCount = 0;
const author = {
    Task(name, type) {
        name = String(name || "").trim();
        type = String(type || "").trim();
        if (!name) throw new Error("author.Task(name, type): name is required");
        if (!type) throw new Error("author.Task(name, type): type is required");
        taskCount += 1;
        return {
            uuid: `task-${taskCount}`, name, type, priority: 50, commands: [], dependencies: [],
            addCommand(cmd) { this.commands.push({ ...cmd }); },
            addDependency(task) { this.dependencies.push(task); },
        };
    },
    Command(name, parameters, totalStepCount) {
        return { name, parameters: JSON.parse(JSON.stringify(parameters)), totalStepCount: totalStepCount || 0 };
    },
};

const job = {
    name: jobIn.name || "job",
    settings: { ...jobIn.settings },
    created: new Date(jobIn.created || "2026-01-02T03:04:05Z"),
    tasks: [],
    addTask(task) {
        this.tasks.push({ ...task, commands: task.commands.slice(), dependencies: task.dependencies.slice() });
    },
};

const pad = (n) => String(n).padStart(2, "0");
const sandbox = {
    print: (...args) => log.push(args.map(String).join(" ")),
    alert: (...args) => log.push("ALERT " + args.map(String).join(" ")),
    frameChunker,
    frameCount: (range) => explode(range).length,
    formatTimestampLocal: (d) => `${d.getFullYear()}-${pad(d.getMonth() + 1)}-${pad(d.getDate())}_` +
        `${pad(d.getHours())}${pad(d.getMinutes())}${pad(d.getSeconds())}`,
    shellSplit: (s) => String(s).trim().split(/\s+/),
    author,
    path: pathModule,
    process: { cwd: () => "/", platform: "linux" },
};
const context = vm.createContext(sandbox);
vm.runInContext(fs.readFileSync(scriptPath, "utf8"), context, { filename: scriptPath });

let error = null;
try {
    vm.runInContext("compileJob", context)(job);
} catch (e) {
    error = e instanceof Error ? e.message : String(e);
}
if (error !== null) {
    process.stdout.write(JSON.stringify({ error, log }) + "\n");
    process.exit(3);
}
const byUuid = new Map(job.tasks.map((t) => [t.uuid, t.name]));
const tasks = job.tasks.map((t) => ({
    name: t.name, type: t.type, priority: t.priority, commands: t.commands,
    dependencies: t.dependencies.map((d) => byUuid.get(d.uuid) || `(not added: ${d.name})`),
}));
const jobType = JSON.parse(JSON.stringify(vm.runInContext("JOB_TYPE", context)));
process.stdout.write(JSON.stringify({ job_type: jobType, settings: job.settings, tasks, log }) + "\n");
