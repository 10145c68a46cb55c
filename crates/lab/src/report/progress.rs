//! A progress bar for long renders (`raylab render`, `raylab grad`): rows
//! done of rows announced ([`raylab::integrator::progress`]), with the rate
//! and an ETA, on stderr. It appears only when stderr is a terminal and
//! the work has taken more than a second (a short render prints nothing
//! extra), never in pipes, and not with `--quiet`; it is cleared when the
//! work ends.

use indicatif::{ProgressBar, ProgressStyle};
use raylab::integrator::progress::snapshot;
use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering::Relaxed};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// Shows the bar while it lives (see the module docs).
pub struct Watch {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl Watch {
    /// Start watching the units announced from now on (image rows, or a
    /// flood-fill cache's propagation steps), labelled `what` and counted
    /// in `unit`; `enabled = false` (or stderr not a terminal) watches
    /// nothing.
    pub fn start(what: &str, unit: &str, enabled: bool) -> Watch {
        let stop = Arc::new(AtomicBool::new(false));
        if !enabled || !std::io::stderr().is_terminal() {
            return Watch { stop, thread: None };
        }
        let (done0, total0) = snapshot();
        let flag = Arc::clone(&stop);
        let label = what.to_string();
        let unit = unit.to_string();
        let thread = std::thread::spawn(move || {
            let t0 = Instant::now();
            let tick = Duration::from_millis(100);
            while t0.elapsed() < Duration::from_secs(1) {
                if flag.load(Relaxed) {
                    return;
                }
                std::thread::sleep(tick);
            }
            let bar = ProgressBar::new(0);
            if let Ok(style) = ProgressStyle::with_template(&format!(
                "{{msg}} [{{bar:30}}] {{pos}}/{{len}} {unit}, {{per_sec}}, eta {{eta}}"
            )) {
                bar.set_style(style.progress_chars("=> "));
            }
            bar.set_message(label);
            while !flag.load(Relaxed) {
                let (done, total) = snapshot();
                bar.set_length(total - total0);
                bar.set_position(done - done0);
                std::thread::sleep(tick);
            }
            bar.finish_and_clear();
        });
        Watch {
            stop,
            thread: Some(thread),
        }
    }
}

impl Drop for Watch {
    fn drop(&mut self) {
        self.stop.store(true, Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}
