//! Progress bars on standard error, one style for every command: shown only when asked for
//! (no `--quiet`) and standard error is a terminal, so that redirected output and the tests
//! never see them.

use std::io::IsTerminal;

use indicatif::{ProgressBar, ProgressStyle};

/// The bar style of `template` (indicatif's template syntax), `=> ` as bar characters.
pub fn style(template: &str) -> ProgressStyle {
    ProgressStyle::with_template(template)
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("=> ")
}

/// A bar of `len` steps drawn with `template`, or `None` when `show` is false or standard
/// error is not a terminal.
pub fn bar(show: bool, len: u64, template: &str) -> Option<ProgressBar> {
    if !(show && std::io::stderr().is_terminal()) {
        return None;
    }
    let pb = ProgressBar::new(len);
    pb.set_style(style(template));
    Some(pb)
}

/// [`bar`], hidden (every call a no-op) instead of `None`.
pub fn bar_or_hidden(show: bool, len: u64, template: &str) -> ProgressBar {
    bar(show, len, template).unwrap_or_else(ProgressBar::hidden)
}
