//! Progress bars: drawn on a terminal, hidden otherwise. Updated only when
//! the library reports progress (no ticker thread, no busy-waiting).

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;

struct Bar(ProgressBar);

impl Bar {
    fn new(label: &str) -> Self {
        let target = if std::io::stderr().is_terminal() { ProgressDrawTarget::stderr_with_hz(10) } else { ProgressDrawTarget::hidden() };
        let bar = ProgressBar::with_draw_target(Some(1), target);
        bar.set_style(
            ProgressStyle::with_template("{prefix:>10} [{bar:40}] {percent:>3}% {elapsed_precise}")
                .expect("valid template")
                .progress_chars("=> "),
        );
        bar.set_prefix(label.to_string());
        Bar(bar)
    }

    /// The callback to hand to the library.
    fn update(&self, done: u64, total: u64) {
        self.0.set_length(total.max(1));
        self.0.set_position(done.min(total));
    }

    fn finish(self) {
        self.0.finish_and_clear();
    }
}

/// Run `work` with a bar labelled `label`, handing it the progress callback
/// (which also reports to an embedding, see [`crate::embed`]).
pub fn with_bar<T>(label: &str, work: impl FnOnce(&(dyn Fn(u64, u64) + Sync)) -> T) -> T {
    let bar = Bar::new(label);
    let hook = crate::embed::progress_hook();
    let out = work(&|done, total| {
        bar.update(done, total);
        if let Some(h) = &hook {
            h(label, done, total);
        }
    });
    bar.finish();
    out
}
