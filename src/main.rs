//! `powertwin` command-line interface: a thin layer over the library.

mod cli;

use clap::Parser;

fn main() -> std::process::ExitCode {
    let args = cli::Cli::parse();
    match cli::run(args) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {}", chain_message(&e));
            std::process::ExitCode::from(1)
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
