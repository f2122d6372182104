//! `powertwin` command-line interface: a thin layer over the library.
//!
//! Exit codes (`cli::Exit`): 0 ok, 1 error, 2 usage, 3 results flagged.

mod cli;

use clap::Parser;
use cli::Exit;

fn main() -> std::process::ExitCode {
    let args = match cli::Cli::try_parse() {
        Ok(args) => args,
        Err(e) => {
            // Usage errors go to stderr (exit 2); --help and --version to stdout (exit 0).
            let _ = e.print();
            return if e.use_stderr() {
                Exit::Usage
            } else {
                Exit::Ok
            }
            .into();
        }
    };
    match cli::run(args) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {}", chain_message(&e));
            Exit::Error.into()
        }
    }
}

/// The error and its causes, outermost first, joined by ": ", each cause printed once: a
/// cause whose text the message already ends with (library errors such as
/// `powertwin::Error::Io` print their source in their own message) is skipped.
fn chain_message(e: &anyhow::Error) -> String {
    let mut out = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if out.is_empty() {
            out = text;
        } else if !out.ends_with(&text) {
            out.push_str(": ");
            out.push_str(&text);
        }
    }
    out
}
