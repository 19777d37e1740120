//! `docs/cli.md` is the command line's reference, generated from clap: every subcommand's long
//! help (`caustics SUBCOMMAND --help`) as markdown. This test fails when the file is stale;
//! `CAUSTICS_ACCEPT_CLI_DOC=1 cargo test -p caustics-cli --test cli_doc` rewrites it.

use std::path::PathBuf;
use std::process::Command;

fn help(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_caustics")).args(args).arg("--help").output().unwrap();
    assert!(out.status.success(), "{args:?} --help: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).unwrap()
}

/// The subcommands `caustics --help` lists, in its order.
fn subcommands(top: &str) -> Vec<String> {
    top.lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|c| *c != "help")
        .map(String::from)
        .collect()
}

fn document() -> String {
    let top = help(&[]);
    let mut md = String::from(
        "# The `caustics` command line\n\n\
         Generated from the program's help by `crates/caustics-cli/tests/cli_doc.rs` (do not edit; \
         `CAUSTICS_ACCEPT_CLI_DOC=1 cargo test -p caustics-cli --test cli_doc` rewrites it).\n\n\
         `render`, `bench` and `view` take the same settings: the common flags below, and every \
         other setting by its path, `--set section.key=value` (repeatable; the value is read as \
         JSON, else as a string), or from a file, `--settings file.json`. `--print-settings` \
         prints the effective settings as JSON (every section and key, a file `--settings` \
         reads back); an EXR's header holds the settings it was rendered with \
         (`caustics_settings`).\n\n",
    );
    md += "## caustics\n\n```text\n";
    md += top.trim_end();
    md += "\n```\n";
    for sub in subcommands(&top) {
        md += &format!("\n## caustics {sub}\n\n```text\n");
        md += help(&[&sub]).trim_end();
        md += "\n```\n";
    }
    // Every key `--set` and `--settings` take, with its default.
    let out = Command::new(env!("CARGO_BIN_EXE_caustics")).args(["render", "--print-settings"]).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    md += "\n## Every setting and its default\n\n";
    md += "`caustics render --print-settings` (the keys are documented on the library's settings \
           sections, `caustics::settings`; `cpu` and `spheres` are the command line's own: the CPU \
           reference backend and the caustic spheres' tables):\n\n```json\n";
    md += String::from_utf8(out.stdout).unwrap().trim_end();
    md += "\n```\n";
    md
}

#[test]
fn docs_cli_md_is_current() {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../docs/cli.md");
    let want = document();
    if std::env::var("CAUSTICS_ACCEPT_CLI_DOC").is_ok_and(|v| v == "1") {
        std::fs::write(&path, &want).unwrap();
        return;
    }
    let have = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        have == want,
        "docs/cli.md is stale: run `CAUSTICS_ACCEPT_CLI_DOC=1 cargo test -p caustics-cli --test cli_doc` and commit it"
    );
}
