//! Progress bars on standard error: drawn only when it is a terminal (a pipe or a log
//! file gets none), in one style per command's template.

use std::io::IsTerminal;

use indicatif::{ProgressBar, ProgressStyle};

/// A bar with `template` (indicatif's syntax) when standard error is a terminal and
/// `wanted` (e.g. the run is long enough to need one); its length is set as work is
/// known ([`show`]).
pub fn bar(template: &str, wanted: bool) -> Option<ProgressBar> {
    (wanted && std::io::stderr().is_terminal()).then(|| {
        let b = ProgressBar::new(0);
        b.set_style(
            ProgressStyle::with_template(template).unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        b
    })
}

/// Shows `done` of `total` on `bar`, if there is one.
pub fn show(bar: Option<&ProgressBar>, done: u64, total: u64) {
    if let Some(b) = bar {
        b.set_length(total);
        b.set_position(done);
    }
}
