//! Progress bars with ETA, drawn only on a terminal (hidden when stderr is not a TTY) and only
//! for work expected to take more than a few seconds.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::time::Duration;

/// A progress bar over `total` units of work. It stays invisible for the first two seconds,
/// so quick runs print nothing.
pub fn bar(total: u64, what: &str) -> ProgressBar {
    let pb = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::hidden());
    if std::io::stderr().is_terminal() {
        pb.set_style(
            ProgressStyle::with_template(
                "{msg:>10} [{bar:40}] {percent:>3}% {elapsed_precise} ETA {eta}",
            )
            .expect("static template is valid")
            .progress_chars("=> "),
        );
        pb.set_message(what.to_string());
        let delayed = pb.clone();
        // Reveal the bar only if the work is still running after two seconds.
        std::thread::spawn(move || {
            std::thread::sleep(Duration::from_secs(2));
            if !delayed.is_finished() {
                delayed.set_draw_target(ProgressDrawTarget::stderr());
            }
        });
    }
    pb
}
