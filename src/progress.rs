//! Progress of a render's stages, reported through a callback the front end chooses
//! (an indicatif bar in a terminal, `PROGRESS` lines for the Blender add-on, nothing), and
//! the way back: a cancel flag a front end may raise (`cubist serve`'s `cancel`), which the
//! trace loop reads between rows and the pipeline between stages.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use crate::error::{Error, Result};

/// A sink for (stage name, fraction of that stage done in [0, 1]).
pub type Sink = Box<dyn Fn(&str, f64) + Send + Sync>;

pub struct Progress {
    sink: Option<Sink>,
    stage: Mutex<(String, u64)>,
    done: AtomicU64,
    last_report: Mutex<Instant>,
    cancel: Option<Arc<AtomicBool>>,
}

impl Progress {
    pub fn new(sink: Sink) -> Progress {
        Progress {
            sink: Some(sink),
            stage: Mutex::new((String::new(), 1)),
            done: AtomicU64::new(0),
            last_report: Mutex::new(Instant::now()),
            cancel: None,
        }
    }

    /// Reports nothing.
    pub fn silent() -> Progress {
        Progress {
            sink: None,
            stage: Mutex::new((String::new(), 1)),
            done: AtomicU64::new(0),
            last_report: Mutex::new(Instant::now()),
            cancel: None,
        }
    }

    /// This progress, cancelled once `flag` is raised (by another thread).
    pub fn with_cancel(mut self, flag: Arc<AtomicBool>) -> Progress {
        self.cancel = Some(flag);
        self
    }

    /// Whether the run was cancelled: long loops stop early (their output is then thrown away).
    #[inline]
    pub fn cancelled(&self) -> bool {
        self.cancel.as_ref().is_some_and(|c| c.load(Ordering::Relaxed))
    }

    /// `Err(Cancelled)` once the run was cancelled: checked after each stage, so nothing a
    /// cancelled loop left half done is ever used or kept.
    pub fn check(&self) -> Result<()> {
        if self.cancelled() { Err(Error::Cancelled) } else { Ok(()) }
    }

    /// Starts a stage of `total` units of work.
    pub fn begin(&self, name: &str, total: u64) {
        if let Ok(mut s) = self.stage.lock() {
            *s = (name.to_string(), total.max(1));
        }
        self.done.store(0, Ordering::Relaxed);
        if let Some(sink) = &self.sink {
            sink(name, 0.0);
        }
    }

    /// Adds `n` units done; reports at most ~10 times a second.
    pub fn add(&self, n: u64) {
        let done = self.done.fetch_add(n, Ordering::Relaxed) + n;
        let Some(sink) = &self.sink else { return };
        let Ok(mut last) = self.last_report.try_lock() else {
            return;
        };
        if last.elapsed().as_millis() < 100 {
            return;
        }
        *last = Instant::now();
        if let Ok(s) = self.stage.lock() {
            sink(&s.0, (done as f64 / s.1 as f64).min(1.0));
        }
    }

    /// Marks the current stage complete.
    pub fn finish(&self) {
        if let (Some(sink), Ok(s)) = (&self.sink, self.stage.lock()) {
            sink(&s.0, 1.0);
        }
    }
}
