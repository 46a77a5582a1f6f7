//! The user guide (`docs/src`, an mdBook), the README, the changelog and the
//! crate READMEs cannot go stale silently:
//! - every page is in `SUMMARY.md` and every relative link and `#anchor`
//!   resolves (anchors as mdBook makes them from the headings);
//! - every `gazecast` command the guide shows in a code block parses with the
//!   binary's own parser, every flag a synopsis or an inline mention names
//!   exists on that subcommand, and every script, bench target and example
//!   it names exists;
//! - the quick commands (the mask, a frame, a plan, a headless thresholds
//!   session and validation, `view --explain`, the headless demo, replays;
//!   not the degradation staircase, which takes minutes) run, page by page in the order shown, in a scratch folder where
//!   `config/` and `tests/` are the repository's (slow tier).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Component, Path, PathBuf};
use std::process::Command;

use clap::{CommandFactory, Parser};
use gazecast_viewer::Cli;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .expect("the repository root")
}

/// Every Markdown file the checks cover: the guide's pages (its benchmark
/// reports included), the README, the changelog and the crate READMEs.
fn markdown_files() -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        let mut entries: Vec<_> = std::fs::read_dir(dir)
            .expect("read a docs folder")
            .map(|e| e.expect("a docs entry").path())
            .collect();
        entries.sort();
        for path in entries {
            if path.is_dir() {
                walk(&path, out);
            } else if path.extension().is_some_and(|e| e == "md") {
                out.push(path);
            }
        }
    }
    let root = repo();
    let mut files = Vec::new();
    walk(&root.join("docs/src"), &mut files);
    files.push(root.join("README.md"));
    files.push(root.join("CHANGELOG.md"));
    for entry in std::fs::read_dir(root.join("crates")).expect("read crates/") {
        let readme = entry.expect("a crate folder").path().join("README.md");
        if readme.is_file() {
            files.push(readme);
        }
    }
    files
}

/// One line of a Markdown file with whether it is inside a fenced block.
struct Line<'a> {
    number: usize,
    text: &'a str,
    fenced: bool,
}

fn lines(text: &str) -> Vec<Line<'_>> {
    let mut fence: Option<&str> = None;
    let mut out = Vec::new();
    for (i, text) in text.lines().enumerate() {
        let trimmed = text.trim_start();
        let marker = ["```", "~~~"].into_iter().find(|m| trimmed.starts_with(m));
        match (fence, marker) {
            (None, Some(m)) => fence = Some(m),
            (Some(open), Some(m)) if open == m && trimmed.trim_end() == m => fence = None,
            _ => out.push(Line {
                number: i + 1,
                text,
                fenced: fence.is_some(),
            }),
        }
    }
    out
}

/// A line with its inline code spans blanked out (links inside code are text).
fn without_code_spans(line: &str) -> String {
    let mut out = String::with_capacity(line.len());
    let mut in_code = false;
    for c in line.chars() {
        if c == '`' {
            in_code = !in_code;
            out.push(' ');
        } else {
            out.push(if in_code { ' ' } else { c });
        }
    }
    out
}

/// mdBook's heading ids: the heading's text (code spans as their text),
/// alphanumerics, `_` and `-` kept and lower-cased, whitespace as `-`, the
/// rest dropped; a repeated id gets `-1`, `-2`, ….
fn anchors(text: &str) -> BTreeSet<String> {
    let mut seen: BTreeMap<String, usize> = BTreeMap::new();
    let mut out = BTreeSet::new();
    for line in lines(text).iter().filter(|l| !l.fenced) {
        let Some(rest) = line.text.strip_prefix('#') else {
            continue;
        };
        let title = rest.trim_start_matches('#');
        if !title.starts_with(' ') {
            continue;
        }
        // Link syntax in a heading keeps only its text.
        let mut plain = String::new();
        let mut chars = title.trim().chars().peekable();
        while let Some(c) = chars.next() {
            if c == ']' && chars.peek() == Some(&'(') {
                for d in chars.by_ref() {
                    if d == ')' {
                        break;
                    }
                }
            } else if c != '[' && c != '`' && c != '*' {
                plain.push(c);
            }
        }
        let id: String = plain
            .chars()
            .filter_map(|c| {
                if c.is_alphanumeric() || c == '_' || c == '-' {
                    Some(c.to_ascii_lowercase())
                } else if c.is_whitespace() {
                    Some('-')
                } else {
                    None
                }
            })
            .collect();
        let n = seen.entry(id.clone()).or_insert(0);
        out.insert(if *n == 0 {
            id.clone()
        } else {
            format!("{id}-{n}")
        });
        *n += 1;
    }
    out
}

/// `](target)` link targets outside code, with their line numbers.
fn links(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    for line in lines(text).iter().filter(|l| !l.fenced) {
        let plain = without_code_spans(line.text);
        let mut rest = plain.as_str();
        while let Some(at) = rest.find("](") {
            let after = &rest[at + 2..];
            let Some(end) = after.find(')') else { break };
            let target = after[..end].split_whitespace().next().unwrap_or("");
            out.push((line.number, target.to_string()));
            rest = &after[end..];
        }
        if let Some(include) = plain.trim().strip_prefix("{{#include ") {
            out.push((
                line.number,
                include.trim_end_matches("}}").trim().to_string(),
            ));
        }
    }
    out
}

fn normalise(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for c in path.components() {
        match c {
            Component::ParentDir => {
                out.pop();
            }
            Component::CurDir => {}
            other => out.push(other),
        }
    }
    out
}

#[test]
fn every_page_is_in_the_summary_and_every_link_resolves() {
    let root = repo();
    let src = root.join("docs/src");
    let summary = std::fs::read_to_string(src.join("SUMMARY.md")).expect("read SUMMARY.md");
    let listed: BTreeSet<PathBuf> = links(&summary)
        .into_iter()
        .map(|(_, t)| normalise(&src.join(t)))
        .collect();
    let mut problems = Vec::new();
    for file in markdown_files() {
        let text = std::fs::read_to_string(&file).expect("read a Markdown file");
        let shown = file
            .strip_prefix(&root)
            .unwrap_or(&file)
            .display()
            .to_string();
        if file.starts_with(&src)
            && file.file_name() != Some("SUMMARY.md".as_ref())
            && !listed.contains(&normalise(&file))
        {
            problems.push(format!("{shown}: not listed in docs/src/SUMMARY.md"));
        }
        for (line, target) in links(&text) {
            if target.contains("://") || target.starts_with("mailto:") {
                continue;
            }
            let (path, anchor) = match target.split_once('#') {
                Some((p, a)) => (p, Some(a)),
                None => (target.as_str(), None),
            };
            let resolved = if path.is_empty() {
                file.clone()
            } else {
                normalise(&file.parent().expect("a parent").join(path))
            };
            if !resolved.exists() {
                problems.push(format!("{shown}:{line}: {target}: no such file"));
                continue;
            }
            if let Some(anchor) = anchor {
                let is_md = resolved.extension().is_some_and(|e| e == "md");
                let ok = is_md
                    && anchors(&std::fs::read_to_string(&resolved).expect("read a link target"))
                        .contains(anchor);
                if !ok {
                    problems.push(format!("{shown}:{line}: {target}: no such heading"));
                }
            }
        }
    }
    assert!(
        problems.is_empty(),
        "broken links:\n{}",
        problems.join("\n")
    );
}

/// A command the guide shows: where, its words, and whether it is a whole
/// command in a code block (as opposed to a synopsis or an inline mention).
#[derive(Debug)]
struct Shown {
    at: String,
    words: Vec<String>,
    whole: bool,
}

/// Where a shell line's program starts: leading `VAR=value` assignments
/// are skipped.
fn program_words(line: &str) -> Option<Vec<String>> {
    let words = shlex::split(line)?;
    let start = words
        .iter()
        .position(|w| !w.contains('=') || w.starts_with('-'))?;
    Some(words[start..].to_vec())
}

/// A trailing ` # comment` outside quotes removed.
fn strip_comment(line: &str) -> &str {
    let mut quote: Option<char> = None;
    let bytes: Vec<char> = line.chars().collect();
    let mut byte_at = 0;
    for (i, &c) in bytes.iter().enumerate() {
        match (quote, c) {
            (None, '\'' | '"') => quote = Some(c),
            (Some(q), c) if c == q => quote = None,
            (None, '#') if i == 0 || bytes[i - 1].is_whitespace() => {
                return line[..byte_at].trim_end()
            }
            _ => {}
        }
        byte_at += c.len_utf8();
    }
    line
}

fn is_gazecast(word: &str) -> bool {
    word == "gazecast" || word == "./gazecast.sh" || word.ends_with("/gazecast")
}

/// Every command line shown in the Markdown files: code-block lines (with
/// `\` continuations joined) and inline code spans.
fn shown_commands() -> Vec<Shown> {
    let root = repo();
    let mut out = Vec::new();
    for file in markdown_files() {
        let text = std::fs::read_to_string(&file).expect("read a Markdown file");
        let shown = file
            .strip_prefix(&root)
            .unwrap_or(&file)
            .display()
            .to_string();
        let mut pending = String::new();
        let mut pending_line = 0;
        for line in lines(&text) {
            if line.fenced {
                let part = strip_comment(line.text.trim());
                if pending.is_empty() {
                    pending_line = line.number;
                }
                if let Some(head) = part.strip_suffix('\\') {
                    pending.push_str(head);
                    pending.push(' ');
                    continue;
                }
                pending.push_str(part);
                let command = std::mem::take(&mut pending);
                if let Some(words) = program_words(&command) {
                    out.push(Shown {
                        at: format!("{shown}:{pending_line}"),
                        words,
                        whole: true,
                    });
                }
            } else {
                let mut rest = line.text;
                while let Some(open) = rest.find('`') {
                    let after = &rest[open + 1..];
                    let Some(close) = after.find('`') else { break };
                    if let Some(words) = program_words(&after[..close]) {
                        out.push(Shown {
                            at: format!("{shown}:{}", line.number),
                            words,
                            whole: false,
                        });
                    }
                    rest = &after[close + 1..];
                }
            }
        }
    }
    out
}

/// A synopsis rather than a command: optional parts, alternatives, or a
/// placeholder in capitals (`FILE`, `DIR`, `N`, `SCENE.ron`, `X,Y`).
fn is_synopsis(words: &[String]) -> bool {
    words.iter().any(|w| {
        w.contains(['[', ']', '|', '…', '(', ')'])
            || w.contains("...")
            || w.split([',', '=']).any(|part| {
                let stem = part.split('.').next().unwrap_or("");
                !stem.is_empty() && stem.chars().all(|c| c.is_ascii_uppercase() || c == '_')
            })
    })
}

/// The subcommand the words name, and how many words name it.
fn subcommand<'a>(cli: &'a clap::Command, words: &[String]) -> (&'a clap::Command, usize) {
    let mut at = cli;
    let mut used = 0;
    for w in words {
        match at
            .get_subcommands()
            .find(|s| s.get_name() == w || s.get_all_aliases().any(|a| a == w))
        {
            Some(sub) => {
                at = sub;
                used += 1;
            }
            None => break,
        }
    }
    (at, used)
}

fn long_flags(cmd: &clap::Command) -> BTreeSet<String> {
    let mut flags: BTreeSet<String> = ["help", "version"].map(String::from).into();
    for arg in cmd.get_arguments() {
        flags.extend(arg.get_long().map(String::from));
        flags.extend(
            arg.get_all_aliases()
                .into_iter()
                .flatten()
                .map(String::from),
        );
    }
    flags
}

#[test]
fn every_command_in_the_guide_parses_and_every_flag_exists() {
    let root = repo();
    let cli = Cli::command();
    let mut problems = Vec::new();
    let mut checked = (0, 0, 0);
    for shown in shown_commands() {
        let Some(program) = shown.words.first() else {
            continue;
        };
        if is_gazecast(program) {
            let args = &shown.words[1..];
            let (sub, used) = subcommand(&cli, args);
            let flags = long_flags(sub);
            for word in &args[used..] {
                let word = word.trim_start_matches(['[', '(']);
                if let Some(flag) = word.strip_prefix("--") {
                    let name = flag.split(['=', ']', ')', ',']).next().unwrap_or("");
                    if !name.is_empty() && !flags.contains(name) {
                        problems.push(format!(
                            "{}: `gazecast {}` has no flag --{name}",
                            shown.at,
                            sub.get_name()
                        ));
                    }
                }
            }
            if shown.whole && !is_synopsis(&shown.words) {
                let mut argv = vec!["gazecast".to_string()];
                argv.extend(args.iter().cloned());
                if let Err(e) = Cli::try_parse_from(&argv) {
                    problems.push(format!("{}: {}\n{e}", shown.at, argv.join(" ")));
                }
                checked.0 += 1;
            } else {
                checked.1 += 1;
            }
        } else if ["bench/", "scripts/"]
            .iter()
            .any(|dir| program.trim_start_matches("./").starts_with(dir))
        {
            // A script (or folder) of the repository.
            let path = root.join(program.trim_start_matches("./"));
            if !program.contains('*') && !path.exists() {
                problems.push(format!("{}: {program}: no such script", shown.at));
            }
            checked.2 += 1;
        } else if program == "cargo" {
            checked.2 += usize::from(check_cargo(&root, &shown, &mut problems));
        }
    }
    assert!(
        problems.is_empty(),
        "the guide's commands are out of date:\n{}",
        problems.join("\n")
    );
    // The extraction found the guide's commands (not nothing).
    assert!(checked.0 >= 20 && checked.1 >= 20, "{checked:?}");
}

/// `cargo bench -p CRATE --bench NAME` and `cargo run -p CRATE --example
/// NAME` name a bench or example that exists. Returns whether it checked.
fn check_cargo(root: &Path, shown: &Shown, problems: &mut Vec<String>) -> bool {
    let w = &shown.words;
    let value = |flag: &str| {
        w.iter()
            .position(|x| x == flag)
            .and_then(|i| w.get(i + 1))
            .cloned()
    };
    let Some(package) = value("-p") else {
        return false;
    };
    let Some((kind, folder)) = [("--bench", "benches"), ("--example", "examples")]
        .into_iter()
        .find(|(k, _)| w.iter().any(|x| x == k))
    else {
        return false;
    };
    let Some(name) = value(kind) else {
        return false;
    };
    let crate_dir = root.join("crates").join(&package);
    let found = crate_dir.join(folder).join(format!("{name}.rs")).is_file()
        || crate_dir.join(folder).join(&name).join("main.rs").is_file();
    if !found {
        problems.push(format!(
            "{}: crates/{package} has no {folder}/{name}.rs",
            shown.at
        ));
    }
    true
}

/// Whether the slow-tier test runs this command: quick, and writing only
/// into the scratch folder.
fn runnable(args: &[String]) -> bool {
    let has = |flag: &str| args.iter().any(|a| a == flag);
    let quick = match args.first().map(String::as_str) {
        Some("mask" | "render" | "replay" | "simulate") => true,
        Some("demo") => !has("--tracker"),
        Some("view") => has("--explain"),
        Some("experiment") => args.get(1).is_some_and(|s| s == "plan"),
        // The degradation staircase renders ~1000 frame pairs (minutes);
        // its CLI test runs a small one, and the parse test checks its flags.
        Some("thresholds") => has("--headless") && args.get(1).is_none_or(|s| s != "degradation"),
        _ => false,
    };
    quick
        && !args.iter().any(|a| {
            a.contains('*') || a.starts_with('/') || a.contains("docs/") || a.contains("..")
        })
}

/// Flags whose value gazecast writes.
const OUTPUT_FLAGS: [&str; 9] = [
    "--out",
    "--csv",
    "--png",
    "--points",
    "--stats",
    "--layers",
    "--record",
    "--screenshot",
    "--json",
];

/// The first input file a command names that is not in `dir` (inputs are
/// positional paths and the values of flags other than the outputs).
fn missing_input(dir: &Path, args: &[String]) -> Option<String> {
    let mut previous: Option<&str> = None;
    for arg in args {
        let is_output = previous.is_some_and(|p| OUTPUT_FLAGS.contains(&p));
        let looks_like_file = !arg.starts_with('-')
            && Path::new(arg).extension().is_some_and(|e| {
                ["ron", "gzrec", "csv", "obj", "tsv", "bin", "log"]
                    .iter()
                    .any(|k| e == *k)
            });
        if !is_output && looks_like_file && !dir.join(arg).exists() {
            return Some(arg.clone());
        }
        previous = Some(arg);
    }
    None
}

#[test]
#[ignore = "slow tier: runs the guide's quick commands (a headless demo, a thresholds session) on the debug binary"]
fn the_guides_quick_commands_run() {
    let root = repo();
    let mut by_page: BTreeMap<String, Vec<Shown>> = BTreeMap::new();
    for shown in shown_commands() {
        let page = shown.at.split(':').next().unwrap_or("").to_string();
        if shown.whole
            && shown.words.first().is_some_and(|p| is_gazecast(p))
            && !is_synopsis(&shown.words)
            && runnable(&shown.words[1..])
        {
            by_page.entry(page).or_default().push(shown);
        }
    }
    let mut ran = 0;
    for (page, commands) in by_page {
        let scratch = tempfile::tempdir().expect("a scratch folder");
        for linked in ["config", "tests"] {
            std::os::unix::fs::symlink(root.join(linked), scratch.path().join(linked))
                .expect("link config/ and tests/ into the scratch folder");
        }
        for shown in commands {
            if let Some(missing) = missing_input(scratch.path(), &shown.words[1..]) {
                // The reader's own file (a recording of theirs, say), or
                // one a command that is not quick would have made.
                eprintln!("{}: not run: its input {missing} is not there", shown.at);
                continue;
            }
            // Folders the command writes into, as gazecast.sh makes them.
            for arg in &shown.words[1..] {
                if let Some(parent) = Path::new(arg)
                    .parent()
                    .filter(|p| !p.as_os_str().is_empty())
                {
                    if arg.contains('/')
                        && !arg.starts_with("config/")
                        && !arg.starts_with("tests/")
                    {
                        std::fs::create_dir_all(scratch.path().join(parent)).ok();
                    }
                }
            }
            let out = Command::new(env!("CARGO_BIN_EXE_gazecast"))
                .args(&shown.words[1..])
                .current_dir(scratch.path())
                .env_remove("DISPLAY")
                .env_remove("WAYLAND_DISPLAY")
                .env("XDG_RUNTIME_DIR", std::env::temp_dir())
                .output()
                .expect("run gazecast");
            assert!(
                out.status.success(),
                "{} ({page}): gazecast {} failed:\n{}",
                shown.at,
                shown.words[1..].join(" "),
                String::from_utf8_lossy(&out.stderr)
            );
            eprintln!("{}: ran gazecast {}", shown.at, shown.words[1..].join(" "));
            ran += 1;
        }
    }
    assert!(ran >= 5, "only {ran} of the guide's commands ran");
}

/// Every subcommand of the binary has a row in the guide's command-line
/// reference, and the reference names no command the binary lacks.
#[test]
fn the_command_line_reference_lists_every_command() {
    fn paths(cmd: &clap::Command, prefix: &str, out: &mut BTreeSet<String>) {
        for sub in cmd.get_subcommands().filter(|s| s.get_name() != "help") {
            let path = format!("{prefix} {}", sub.get_name());
            if sub.has_subcommands() {
                paths(sub, &path, out);
            } else {
                out.insert(path);
            }
        }
    }
    let mut code = BTreeSet::new();
    paths(&Cli::command(), "gazecast", &mut code);
    let page = std::fs::read_to_string(repo().join("docs/src/reference/command-line.md"))
        .expect("read the command-line reference");
    let rows: BTreeSet<String> = page
        .lines()
        .filter_map(|l| l.strip_prefix("| `"))
        .filter_map(|l| l.split('`').next())
        .map(String::from)
        .collect();
    assert_eq!(rows, code, "docs/src/reference/command-line.md's table");
}
