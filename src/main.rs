//! `rtsim`: the command-line front end.
//!
//! Each subcommand lives in [`commands`]; [`run_config`] assembles the layered configuration
//! (defaults → scene descriptor → `--config FILE` → flags → `--set k=v`), and
//! [`progress`] draws progress bars on terminals. Errors print one line and exit with code 2.

mod cli;
mod commands;
mod cputime;
mod progress;
mod run_config;
mod session;

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    install_panic_hook();
    // Ctrl-C, SIGTERM and SIGHUP remove staged outputs before the process ends.
    if let Err(e) = rtsim_core::output::install_interrupt_cleanup() {
        eprintln!("warning: cannot install the interrupt handler: {e}");
    }
    let cli = match cli::Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            // --help and --version are not errors.
            if !e.use_stderr() {
                let _ = e.print();
                return ExitCode::SUCCESS;
            }
            match clap_error_quoting_input(&e) {
                Some(text) => eprint!("{text}"),
                None => {
                    let _ = e.print();
                }
            }
            return ExitCode::from(2);
        }
    };
    match commands::run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", one_line(&e));
            ExitCode::from(2)
        }
    }
}

/// The error and its causes on one line, outermost first, without repeating a cause that the
/// outer message already contains.
fn one_line(e: &anyhow::Error) -> String {
    let mut out = String::new();
    for cause in e.chain() {
        let s = cause.to_string();
        if !out.contains(&s) {
            if !out.is_empty() {
                out.push_str(": ");
            }
            out.push_str(&s);
        }
    }
    // Whatever input a message quotes, the terminal gets one line and no control characters.
    cut(rtsim_core::text::escape_controls(&out.replace('\n', " ")))
}

/// A command-line error that quotes an argument too long or with control characters, as
/// clap would print it but with each quoted argument echoed (escaped and cut); `None` when clap's own text is fine to print as it is (with colour).
fn clap_error_quoting_input(e: &clap::Error) -> Option<String> {
    use clap::error::ContextValue;
    use rtsim_core::text::ECHO_CHARS;
    let bad = |s: &String| s.chars().count() > ECHO_CHARS || s.chars().any(char::is_control);
    let quoted: Vec<&String> = e
        .context()
        .flat_map(|(_, v)| match v {
            ContextValue::String(s) => vec![s],
            ContextValue::Strings(v) => v.iter().collect(),
            _ => Vec::new(),
        })
        .filter(|s| bad(s))
        .collect();
    if quoted.is_empty() {
        return None;
    }
    // clap quotes arguments in single quotes (and has already dropped escape sequences it
    // took for styling); echo each quoted span, then escape what is left, line by line.
    let text = rtsim_core::text::echo_quoted(&e.render().to_string(), '\'');
    let lines: Vec<String> = text
        .split('\n')
        .map(rtsim_core::text::escape_controls)
        .collect();
    Some(cut(lines.join("\n")))
}

/// `line` cut to [`MAX_ERROR_BYTES`] (at a character boundary), saying so.
fn cut(mut line: String) -> String {
    if line.len() > MAX_ERROR_BYTES {
        let mut cut = MAX_ERROR_BYTES;
        while !line.is_char_boundary(cut) {
            cut -= 1;
        }
        line.truncate(cut);
        line.push_str("… (message cut)");
    }
    line
}

/// Longest error line printed (assumed: 4 KiB; messages quote input through
/// `rtsim_core::text::echo`, so only a bug could produce more).
const MAX_ERROR_BYTES: usize = 4096;

/// A panic is a bug in rtsim, never the user's fault: say so on one line.
fn install_panic_hook() {
    std::panic::set_hook(Box::new(|info| {
        let msg = info
            .payload()
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| info.payload().downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown panic".into());
        let at = info
            .location()
            .map(|l| format!(" at {}:{}", l.file(), l.line()))
            .unwrap_or_default();
        eprintln!("internal error (a bug in rtsim, please report it): {msg}{at}");
    }));
}
