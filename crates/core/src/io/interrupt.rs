//! A signal that ends the process while a file is being written leaves no
//! partial file: Ctrl-C (SIGINT), SIGTERM, a closed terminal (SIGHUP),
//! `Ctrl-\` (SIGQUIT), SIGUSR1/2, the timers (SIGALRM, SIGVTALRM,
//! SIGPROF) and the CPU-time and file-size limits (SIGXCPU, SIGXFSZ): the
//! signals that end a process by default and come from outside it
//! ([`SIGNALS`]). SIGPIPE is not among them: Rust's runtime ignores it, so
//! a write to a closed pipe is an error the writer reports. SIGKILL cannot
//! be caught; nothing can clean up after it.
//!
//! Outputs are written to a temporary file and renamed into
//! place ([`super::write_atomically`]), so an interrupted write would
//! leave only that temporary file behind: [`install`] sets a signal
//! handler that unlinks every temporary file being written ([`pending`]
//! registers one) and exits with 128 + the signal's number, as a shell
//! reports a process killed by it. Before any file is written (a render
//! still tracing) the process simply ends: nothing was written.
//!
//! The handler does only what a signal handler may (POSIX's
//! async-signal-safe `unlink` and `_exit`, atomic loads): the paths are
//! C strings parked in a fixed table of atomic pointers. A registered
//! path's few bytes are not freed when its write ends (the handler might be
//! reading it at that instant); a process leaks one path per file written.

use std::ffi::CString;
use std::path::Path;
use std::ptr::null_mut;
use std::sync::atomic::{AtomicBool, AtomicPtr, Ordering::SeqCst};

const SLOTS: usize = 32;

static PENDING: [AtomicPtr<libc::c_char>; SLOTS] = [const { AtomicPtr::new(null_mut()) }; SLOTS];

/// Whether the first SIGINT only raises [`REQUESTED`] ([`defer`]).
static DEFER: AtomicBool = AtomicBool::new(false);
/// Set by a deferred SIGINT.
static REQUESTED: AtomicBool = AtomicBool::new(false);

extern "C" fn on_signal(sig: libc::c_int) {
    if sig == libc::SIGINT && DEFER.load(SeqCst) && !REQUESTED.swap(true, SeqCst) {
        return;
    }
    for slot in &PENDING {
        let p = slot.load(SeqCst);
        if !p.is_null() {
            // SAFETY: a non-null slot holds a pointer from
            // `CString::into_raw` (in `pending`), which is never freed: a
            // live NUL-terminated path. `unlink` is async-signal-safe.
            unsafe {
                libc::unlink(p);
            }
        }
    }
    // SAFETY: `_exit` takes no pointer, is async-signal-safe, and ends the
    // process without running anything else (no destructor, no atexit
    // handler) that could meet the state the signal interrupted.
    unsafe { libc::_exit(128 + sig) }
}

/// The signals [`install`] handles.
pub const SIGNALS: [libc::c_int; 11] = [
    libc::SIGINT,
    libc::SIGTERM,
    libc::SIGHUP,
    libc::SIGQUIT,
    libc::SIGUSR1,
    libc::SIGUSR2,
    libc::SIGALRM,
    libc::SIGVTALRM,
    libc::SIGPROF,
    libc::SIGXCPU,
    libc::SIGXFSZ,
];

/// Install the handler for [`SIGNALS`] (once per process; the CLI does it
/// at start).
pub fn install() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let handler = on_signal as extern "C" fn(libc::c_int) as libc::sighandler_t;
        for sig in SIGNALS {
            // SAFETY: `handler` is an `extern "C" fn(c_int)`, the type
            // `signal` expects, and it only reads atomics and calls
            // async-signal-safe functions (`unlink`, `_exit`), as a handler
            // must.
            unsafe { libc::signal(sig, handler) };
        }
    });
}

/// While the returned guard lives, the first SIGINT does not end the
/// process but makes [`requested`] true (see the module docs); a second
/// one ends it. Dropping the guard restores the immediate exit.
pub fn defer() -> Deferred {
    REQUESTED.store(false, SeqCst);
    DEFER.store(true, SeqCst);
    Deferred(())
}

/// Whether a deferred SIGINT has arrived since [`defer`].
pub fn requested() -> bool {
    REQUESTED.load(SeqCst)
}

/// The guard of [`defer`].
pub struct Deferred(());

impl Drop for Deferred {
    fn drop(&mut self) {
        DEFER.store(false, SeqCst);
    }
}

/// A temporary file being written: unlinked if a signal ends the process
/// before the guard is dropped.
pub struct Pending(Option<usize>);

/// Register `path` as being written. With every slot taken (more than 32
/// files written at once) the file is simply not registered.
pub fn pending(path: &Path) -> Pending {
    use std::os::unix::ffi::OsStrExt;
    let Ok(c) = CString::new(path.as_os_str().as_bytes()) else {
        return Pending(None);
    };
    let raw = c.into_raw();
    for (i, slot) in PENDING.iter().enumerate() {
        if slot
            .compare_exchange(null_mut(), raw, SeqCst, SeqCst)
            .is_ok()
        {
            return Pending(Some(i));
        }
    }
    // SAFETY: `raw` came from `CString::into_raw` above and no slot took
    // it (every exchange failed), so nothing else holds it: reclaimed once.
    drop(unsafe { CString::from_raw(raw) });
    Pending(None)
}

impl Drop for Pending {
    fn drop(&mut self) {
        if let Some(i) = self.0 {
            PENDING[i].store(null_mut(), SeqCst);
        }
    }
}
