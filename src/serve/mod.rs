//! `cubist serve`: a long-running renderer speaking JSON lines, one request per
//! line on stdin, one reply per line on stdout (docs/serve.md has every field). It keeps a
//! `pipeline::Session`, so a request re-runs only the stages its changes invalidate.
//!
//! Threads: this one reads requests and answers `cancel`, `stats` and `shutdown` at once; a
//! worker renders the queued `render` requests in order, so a `cancel` reaches a running render
//! (its progress's cancel flag, read by the trace loop and between stages); a watchdog ends the
//! server when its parent process dies (Unix: the parent id changes; elsewhere stdin's end is
//! the signal, as it is on Unix when the parent closes its end). `shutdown` and EOF on stdin
//! end the server once the renders asked before are done (`cancel` first to drop them); the
//! parent's death cancels them. The server writes only the outputs it is asked for (atomically: a temporary
//! file beside each, renamed once complete, removed on failure) and no other file. A
//! background render runs on threads of a lower CPU priority (`background`).

mod background;
mod protocol;

use std::collections::VecDeque;
use std::io::{BufRead, Read, Write};
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

use serde_json::{Map, Value, json};

pub use protocol::{BadRequest, Command, MAX_LINE, RenderRequest, Request, parse};

use crate::error::{Error, Result};
use crate::output::{Outputs, pass_path};
use crate::pipeline::params::load_options;
use crate::pipeline::{Session, Stage};
use crate::progress::Progress;
use crate::settings::Settings;

/// Renders waiting behind the running one at most; more are refused (bounded memory).
pub const MAX_QUEUED: usize = 64;

/// How the server is set up (`cubist serve`'s flags).
#[derive(Clone, Debug)]
pub struct Options {
    /// Bytes the kept stage outputs may use (`Session::with_budget`).
    pub budget: u64,
    /// How often the watchdog looks at the parent process.
    pub parent_poll: Duration,
    /// The parent's process id, when the caller knows it (`--parent`): a parent gone before
    /// the server started is then noticed too. None: the parent at start.
    pub parent: Option<u32>,
}

impl Default for Options {
    fn default() -> Self {
        Options { budget: crate::pipeline::DEFAULT_BUDGET, parent_poll: Duration::from_millis(500), parent: None }
    }
}

/// One queued render.
struct Job {
    id: Value,
    request: RenderRequest,
    cancel: Arc<AtomicBool>,
}

/// What the reader, the worker and the watchdog share.
struct Shared {
    state: Mutex<State>,
    wake: Condvar,
    out: Mutex<Box<dyn Write + Send>>,
}

#[derive(Default)]
struct State {
    queue: VecDeque<Job>,
    /// The running render's id and cancel flag.
    running: Option<(Value, Arc<AtomicBool>)>,
    /// Cancel everything and end (the parent died, nobody reads the replies).
    stopping: bool,
    /// End once the queue is empty (`shutdown`, end of stdin).
    draining: bool,
    /// The session's stats after the last render, and the number of renders done.
    stats: Value,
    served: u64,
}

impl Shared {
    /// Writes one reply line. A reader that went away ends the server (nobody to serve).
    fn reply(&self, reply: &Value) {
        let mut line = reply.to_string();
        line.push('\n');
        let ok = match self.out.lock() {
            Ok(mut out) => out.write_all(line.as_bytes()).and_then(|()| out.flush()).is_ok(),
            Err(_) => false,
        };
        if !ok {
            self.stop();
        }
    }

    fn state(&self) -> std::sync::MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Tells the worker to end once the queued renders are done.
    fn finish(&self) {
        self.state().draining = true;
        self.wake.notify_all();
    }

    /// Cancels the running render and every queued one (they reply `cancelled`), and tells
    /// the worker to end.
    fn stop(&self) {
        let drained = {
            let mut st = self.state();
            st.stopping = true;
            if let Some((_, flag)) = &st.running {
                flag.store(true, Ordering::Relaxed);
            }
            st.queue.drain(..).collect::<Vec<_>>()
        };
        self.wake.notify_all();
        for job in drained {
            self.reply(&protocol::error_reply(&job.id, "cancelled", true));
        }
    }
}

/// Serves requests from `input` until `shutdown`, EOF or the parent's death, writing replies
/// to `output`. Returns once the worker has finished.
pub fn serve(input: impl BufRead, output: Box<dyn Write + Send>, options: Options) -> Result<()> {
    let shared =
        Arc::new(Shared { state: Mutex::new(State::default()), wake: Condvar::new(), out: Mutex::new(output) });
    let worker = {
        let shared = shared.clone();
        let budget = options.budget;
        std::thread::Builder::new()
            .name("cubist-render".into())
            .spawn(move || work(&shared, Session::new().with_budget(budget)))
            .map_err(|e| Error::Internal(format!("cannot start the render thread: {e}")))?
    };
    watch_parent(shared.clone(), options.parent, options.parent_poll);
    let shutdown = read_requests(input, &shared);
    shared.finish();
    let _ = worker.join();
    // Last: after the replies of the renders before it.
    if let Some(id) = shutdown {
        shared.reply(&json!({ "id": id, "ok": true }));
    }
    Ok(())
}

/// Reads and dispatches request lines until EOF, a stop or `shutdown` (then its id).
fn read_requests(mut input: impl BufRead, shared: &Shared) -> Option<Value> {
    let mut buf = Vec::new();
    loop {
        if shared.state().stopping {
            return None;
        }
        buf.clear();
        let n = match Read::take(&mut input, MAX_LINE as u64 + 1).read_until(b'\n', &mut buf) {
            Ok(n) => n,
            Err(_) => return None,
        };
        if n == 0 {
            return None; // EOF: the parent closed its end
        }
        if buf.len() > MAX_LINE && buf.last() != Some(&b'\n') {
            // Skip the rest of the over-long line.
            let mut rest = Vec::new();
            loop {
                rest.clear();
                match Read::take(&mut input, 1 << 16).read_until(b'\n', &mut rest) {
                    Ok(0) | Err(_) => break,
                    Ok(_) if rest.last() == Some(&b'\n') => break,
                    Ok(_) => {}
                }
            }
            shared.reply(&protocol::error_reply(
                &Value::Null,
                &format!("request line longer than {MAX_LINE} bytes: refused"),
                false,
            ));
            continue;
        }
        let line = String::from_utf8_lossy(&buf);
        let line = line.trim();
        if line.is_empty() {
            continue;
        }
        match parse(line) {
            Err(BadRequest { id, message }) => shared.reply(&protocol::error_reply(&id, &message, false)),
            Ok(Request { id, command: Command::Shutdown }) => return Some(id),
            Ok(Request { id, command }) => dispatch(shared, id, command),
        }
    }
}

/// Handles one request other than `shutdown`.
fn dispatch(shared: &Shared, id: Value, command: Command) {
    match command {
        Command::Render(request) => {
            let mut st = shared.state();
            if st.queue.len() >= MAX_QUEUED {
                drop(st);
                shared.reply(&protocol::error_reply(
                    &id,
                    &format!("{MAX_QUEUED} renders are waiting already: cancel some first"),
                    false,
                ));
            } else {
                st.queue.push_back(Job { id, request, cancel: Arc::new(AtomicBool::new(false)) });
                drop(st);
                shared.wake.notify_all();
            }
        }
        Command::Cancel(target) => {
            let mut cancelled = Vec::new();
            let drained: Vec<Job> = {
                let mut st = shared.state();
                if let Some((rid, flag)) = &st.running
                    && target.as_ref().is_none_or(|t| t == rid)
                {
                    flag.store(true, Ordering::Relaxed);
                    cancelled.push(rid.clone());
                }
                let (gone, kept): (Vec<Job>, Vec<Job>) =
                    st.queue.drain(..).partition(|j| target.as_ref().is_none_or(|t| *t == j.id));
                st.queue = kept.into();
                gone
            };
            // The queued ones answer first, then the cancel; the running one answers when
            // its render stops.
            for job in drained {
                cancelled.push(job.id.clone());
                shared.reply(&protocol::error_reply(&job.id, "cancelled", true));
            }
            shared.reply(&json!({ "id": id, "ok": true, "cancelled": cancelled }));
        }
        Command::Stats => {
            let st = shared.state();
            let mut stats = st.stats.clone();
            if !stats.is_object() {
                stats = json!({});
            }
            stats["served"] = json!(st.served);
            stats["running"] = st.running.as_ref().map_or(Value::Null, |(id, _)| id.clone());
            stats["queued"] = json!(st.queue.len());
            drop(st);
            shared.reply(&json!({ "id": id, "ok": true, "stats": stats }));
        }
        Command::Shutdown => unreachable!("read_requests ends the server"),
    }
}

/// The worker: renders queued jobs in order until told to stop.
fn work(shared: &Shared, mut session: Session) {
    shared.state().stats = stats_json(&session);
    loop {
        let job = {
            let mut st = shared.state();
            loop {
                if st.stopping {
                    return;
                }
                if let Some(job) = st.queue.pop_front() {
                    st.running = Some((job.id.clone(), job.cancel.clone()));
                    break job;
                }
                if st.draining {
                    return;
                }
                st = shared.wake.wait(st).unwrap_or_else(|e| e.into_inner());
            }
        };
        // A background render runs on the lowered pool (background.rs), the rest on the global one.
        let pool = if job.request.background { background::pool() } else { None };
        let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| match pool {
            Some(pool) => pool.install(|| render(&mut session, &job)),
            None => render(&mut session, &job),
        }));
        let reply = match outcome {
            Ok(Ok(reply)) => reply,
            Ok(Err(Error::Cancelled)) => protocol::error_reply(&job.id, "cancelled", true),
            Ok(Err(e)) => protocol::error_reply(&job.id, &e.to_string(), false),
            Err(panic) => {
                // A bug of ours: say so, and start again from nothing (a stage may have been
                // left half done).
                session.reset();
                let what = panic
                    .downcast_ref::<&str>()
                    .map(|s| s.to_string())
                    .or_else(|| panic.downcast_ref::<String>().cloned())
                    .unwrap_or_else(|| "panic".into());
                protocol::error_reply(&job.id, &format!("internal error: {what}"), false)
            }
        };
        {
            let mut st = shared.state();
            st.running = None;
            st.served += 1;
            st.stats = stats_json(&session);
        }
        shared.reply(&reply);
    }
}

fn stats_json(session: &Session) -> Value {
    serde_json::to_value(session.stats()).unwrap_or_else(|_| json!({}))
}

/// Output image formats, by the output's extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    Png,
    /// 8-bit RGBA rows, top row first, nothing else (width and height are in the reply).
    Rgba,
}

fn format_of(path: &Path) -> Result<Format> {
    match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
        Some("png") => Ok(Format::Png),
        Some("rgba") => Ok(Format::Rgba),
        _ => Err(Error::Setting {
            key: "output",
            message: format!("{}: the output must be .png or .rgba (raw 8-bit RGBA)", path.display()),
        }),
    }
}

/// Runs one render request: the scene, the settings, the session's render, the files.
fn render(session: &mut Session, job: &Job) -> Result<Value> {
    let t0 = Instant::now();
    let req = &job.request;
    let format = format_of(&req.output)?;
    let mut settings = Settings::from_layers(Some((Path::new("<request>"), req.settings.clone())), Map::new())?;
    if settings.frames.is_some() {
        return Err(Error::setting("frames", "a request renders one frame: leave `frames` out"));
    }
    if let Some(passes) = &req.passes {
        settings.passes = passes.clone();
        settings.validate()?;
    }
    crate::pipeline::params::check_still_passes(&settings)?;
    // The layout is saved with the images, all or nothing, not by the render.
    let save_facets = settings.save_facets.take();
    let progress = if req.progress {
        Progress::new(Box::new(|stage, f| {
            let _ = writeln!(std::io::stderr(), "PROGRESS {f:.4} {stage}");
        }))
    } else {
        Progress::silent()
    };
    let progress = progress.with_cancel(job.cancel.clone());
    progress.begin(Stage::Loading.name(), 1);
    let t = Instant::now();
    let scene = session.load_scene_with(req.scene.as_deref(), load_options(&settings))?;
    let load = t.elapsed();
    progress.check()?;
    let frame = session.render(&settings, &progress)?;
    progress.begin(Stage::Writing.name(), 1);
    let t = Instant::now();
    // The image, its passes and the saved layout: all written, or none (README "Security"),
    // unsynced: the client reads them at once (`Outputs::transient`).
    let mut outputs = Outputs::transient();
    match format {
        Format::Png => outputs.png(&req.output, &frame.image)?,
        Format::Rgba => outputs.add(&req.output, |f| f.write_all(frame.image.as_raw()).map_err(|e| e.to_string()))?,
    }
    let mut passes = Map::new();
    for (pass, img) in &frame.passes {
        let p = pass_path(&req.output, pass.as_str());
        outputs.png(&p, img)?;
        passes.insert(pass.as_str().into(), json!(p));
    }
    for (pass, img) in &frame.passes16 {
        let p = pass_path(&req.output, pass.as_str());
        outputs.png16(&p, img)?;
        passes.insert(pass.as_str().into(), json!(p));
    }
    if let Some(path) = &save_facets {
        let (w, h) = (frame.image.width(), frame.image.height());
        let (layout, map, _) =
            session.facets(w, h).ok_or_else(|| Error::Internal("the render's facet layout is missing".into()))?;
        crate::facets::io::add_to(&mut outputs, path, layout, map)?;
    }
    outputs.commit()?;
    let write = t.elapsed();
    progress.begin(Stage::Done.name(), 1);
    progress.finish();
    let mut timings = Map::new();
    timings.insert("load".into(), json!(load.as_secs_f64()));
    for (name, d) in &frame.timings.0 {
        let v = timings.get(*name).and_then(Value::as_f64).unwrap_or(0.0) + d.as_secs_f64();
        timings.insert((*name).into(), json!(v));
    }
    timings.insert("write".into(), json!(write.as_secs_f64()));
    timings.insert("total".into(), json!(t0.elapsed().as_secs_f64()));
    Ok(json!({
        "id": job.id,
        "ok": true,
        "output": req.output,
        "width": frame.image.width(),
        "height": frame.image.height(),
        "passes": passes,
        "timings": timings,
        "reused": frame.reused,
        "scene": scene,
        "warnings": frame.warnings,
        "camera": frame.camera,
    }))
}

/// Ends the server when the process that started it is gone (Unix: this process is given to
/// another parent). Elsewhere the end of stdin, which a dead parent's pipe gives, does it.
fn watch_parent(shared: Arc<Shared>, parent: Option<u32>, every: Duration) {
    #[cfg(unix)]
    {
        let parent = parent.unwrap_or_else(std::os::unix::process::parent_id);
        let _ = std::thread::Builder::new().name("cubist-parent-watch".into()).spawn(move || {
            let mut first = true;
            loop {
                if !std::mem::take(&mut first) {
                    std::thread::sleep(every);
                }
                if shared.state().stopping {
                    return;
                }
                if std::os::unix::process::parent_id() != parent {
                    // Cancel, let the worker finish its writes, then end the process: the
                    // reader is blocked on stdin and cannot be woken otherwise.
                    shared.stop();
                    let t = Instant::now();
                    while shared.state().running.is_some() && t.elapsed() < Duration::from_secs(10) {
                        std::thread::sleep(Duration::from_millis(20));
                    }
                    std::process::exit(0);
                }
            }
        });
    }
    #[cfg(not(unix))]
    {
        let _ = (shared, parent, every);
    }
}
