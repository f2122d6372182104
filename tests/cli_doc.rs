//! docs/guide/cli.md carries each command's `-h` output; this checks it is current.
//!
//! Each block between `<!-- generated: powertwin ARGS -->` and `<!-- end generated -->` must be
//! the output of `powertwin ARGS` in a `text` code block. `POWERTWIN_BLESS=1` rewrites the
//! blocks instead of failing.

use std::path::Path;
use std::process::Command;

const BEGIN: &str = "<!-- generated: powertwin ";
const END: &str = "<!-- end generated -->";

/// The block for `args`: the binary's stdout in a `text` code block.
fn block(args: &str) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_powertwin"))
        .args(args.split_whitespace())
        .output()
        .expect("powertwin runs");
    assert!(out.status.success(), "powertwin {args} failed");
    let text = String::from_utf8(out.stdout).expect("UTF-8 help");
    format!("```text\n{}\n```\n", text.trim_end())
}

/// The document with every generated block rewritten.
fn regenerate(doc: &str) -> String {
    let mut out = String::new();
    let mut rest = doc;
    while let Some(start) = rest.find(BEGIN) {
        let header_end = start + rest[start..].find("-->\n").expect("marker ends") + 4;
        let args = rest[start + BEGIN.len()..header_end - 4].trim().to_string();
        let end = header_end + rest[header_end..].find(END).expect("end marker");
        out.push_str(&rest[..header_end]);
        out.push_str(&block(&args));
        rest = &rest[end..];
    }
    out.push_str(rest);
    out
}

#[test]
fn cli_guide_option_lists_are_current() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/guide/cli.md");
    let doc = std::fs::read_to_string(&path).expect("docs/guide/cli.md");
    assert!(doc.contains(BEGIN), "no generated blocks");
    let fresh = regenerate(&doc);
    if std::env::var_os("POWERTWIN_BLESS").is_some() {
        std::fs::write(&path, &fresh).unwrap();
        return;
    }
    assert!(
        fresh == doc,
        "docs/guide/cli.md is out of date with the binary's -h output; regenerate it with \
         POWERTWIN_BLESS=1 cargo test --release --test integration cli_doc::"
    );
}

#[test]
fn every_command_is_in_the_cli_guide() {
    let doc =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/guide/cli.md"))
            .expect("docs/guide/cli.md");
    let out = Command::new(env!("CARGO_BIN_EXE_powertwin"))
        .arg("--help")
        .output()
        .unwrap();
    let help = String::from_utf8(out.stdout).unwrap();
    let commands: Vec<&str> = help
        .lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|c| *c != "help")
        .collect();
    assert!(commands.len() >= 12, "{commands:?}");
    for c in commands {
        assert!(
            doc.contains(&format!("### `powertwin {c}`"))
                && doc.contains(&format!("{BEGIN}{c} -h -->")),
            "docs/guide/cli.md has no section for `{c}`"
        );
    }
    for code in ["| 0 |", "| 1 |", "| 2 |", "| 3 |"] {
        assert!(doc.contains(code), "exit code {code} undocumented");
    }
}
