//! The library's [`Progress`] drawn as an indicatif bar with an ETA on standard error — only
//! when standard error is a terminal and `--quiet` was not given. Drawing changes no output.

use common::progress::Progress;
use std::io::IsTerminal;
use std::sync::Mutex;

/// A progress bar per stage (a new one for every [`Progress::set_len`]), or nothing at all.
pub struct Bar {
    shown: bool,
    bar: Mutex<Option<indicatif::ProgressBar>>,
}

impl Bar {
    /// A bar that draws when standard error is a terminal and `--quiet` was not given.
    pub fn new() -> Bar {
        Bar {
            shown: !super::quiet() && std::io::stderr().is_terminal(),
            bar: Mutex::new(None),
        }
    }

    fn with(&self, f: impl FnOnce(&mut Option<indicatif::ProgressBar>)) {
        if self.shown {
            // A poisoned lock only means another thread panicked while drawing: go on.
            let mut g = self.bar.lock().unwrap_or_else(|e| e.into_inner());
            f(&mut g);
        }
    }
}

impl Progress for Bar {
    fn set_len(&self, stage: &str, len: u64) {
        self.with(|b| {
            if let Some(old) = b.take() {
                old.finish_and_clear();
            }
            let (bar, template) = if len == 0 {
                (
                    indicatif::ProgressBar::new_spinner(),
                    "{spinner} {msg} {pos} ({elapsed})",
                )
            } else {
                (
                    indicatif::ProgressBar::new(len),
                    "{msg} [{bar:30}] {pos}/{len} ({percent} %, ETA {eta})",
                )
            };
            bar.set_draw_target(indicatif::ProgressDrawTarget::stderr());
            if let Ok(style) = indicatif::ProgressStyle::with_template(template) {
                bar.set_style(style.progress_chars("=> "));
            }
            bar.set_message(stage.to_string());
            if len == 0 {
                // A stage of unknown length (reading a file) spins on its own.
                bar.enable_steady_tick(std::time::Duration::from_millis(120));
            }
            *b = Some(bar);
        });
    }

    fn inc(&self, n: u64) {
        self.with(|b| {
            if let Some(b) = b {
                b.inc(n);
            }
        });
    }

    fn finish(&self) {
        self.with(|b| {
            if let Some(old) = b.take() {
                old.finish_and_clear();
            }
        });
    }
}

impl Drop for Bar {
    fn drop(&mut self) {
        self.finish();
    }
}
