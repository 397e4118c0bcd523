//! Background renders (a request's `"background": true`, such as a client's render ahead of
//! its user's request): run on a thread pool of their own whose threads run at a lower CPU
//! priority, so the client's interface keeps the cores while they work. The pool is as wide as
//! the global one, and a render gives the same pixels at any thread count. Only these threads
//! are lowered: an unprivileged process cannot raise a priority again, so every other render
//! keeps the global pool at the process's priority.

use std::sync::OnceLock;

/// The background threads' nice value (Linux; a thread already lower keeps its own). At nice 10
/// a busy thread gets about a tenth of a core that a nice 0 thread also wants.
pub const NICE: i32 = 10;

/// The pool, made on first use; None if its threads cannot be started.
pub fn pool() -> Option<&'static rayon::ThreadPool> {
    static POOL: OnceLock<Option<rayon::ThreadPool>> = OnceLock::new();
    POOL.get_or_init(|| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(rayon::current_num_threads())
            .thread_name(|i| format!("cubist-background-{i}"))
            .start_handler(|_| {
                lower_this_thread();
            })
            .build()
            .ok()
    })
    .as_ref()
}

/// Lowers the calling thread's CPU priority to `NICE`; false where the platform has no
/// per-thread priority this knows (the thread then runs as the others).
pub fn lower_this_thread() -> bool {
    #[cfg(target_os = "linux")]
    {
        // A Linux thread's nice value is its own: get/setpriority on its thread id.
        let tid = this_thread_id();
        // SAFETY: plain system calls on this thread's own id, no memory passed.
        unsafe {
            let now = libc::getpriority(libc::PRIO_PROCESS, tid);
            now >= NICE || libc::setpriority(libc::PRIO_PROCESS, tid, NICE) == 0
        }
    }
    #[cfg(not(target_os = "linux"))]
    {
        false
    }
}

#[cfg(target_os = "linux")]
fn this_thread_id() -> libc::id_t {
    // SAFETY: gettid takes no arguments and cannot fail.
    unsafe { libc::syscall(libc::SYS_gettid) as libc::id_t }
}

#[cfg(all(test, target_os = "linux"))]
mod tests {
    use super::*;

    fn nice() -> i32 {
        // SAFETY: as in lower_this_thread.
        unsafe { libc::getpriority(libc::PRIO_PROCESS, this_thread_id()) }
    }

    #[test]
    fn background_threads_run_lower_and_the_caller_keeps_its_priority() {
        let own = nice();
        let pool = pool().expect("the background pool starts");
        let theirs: Vec<i32> = pool.broadcast(|_| nice());
        assert_eq!(theirs.len(), rayon::current_num_threads());
        assert!(theirs.iter().all(|&n| n == NICE.max(own)), "{theirs:?} (caller at {own})");
        assert_eq!(nice(), own);
    }
}
