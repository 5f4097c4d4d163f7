//! Every `ins-gnss` command of the README's and the guide's shell blocks, run as written
//! (the test's build of the program, from a folder that sees the repository's `data/` and
//! `ins-gnss/scenarios/`), must succeed; so must the demo (`cargo run --release -p
//! ins-gnss`, the program without arguments). The blocks' other lines are the commands
//! CI itself runs (`cargo test --workspace`, `python/run-tests`, `firmware/check`, the
//! no_std build) or examples with their own tests (`cargo run --example …`); synopses (a
//! line with `[`, `|` or a placeholder in capitals) are not commands.

use std::path::{Path, PathBuf};
use std::process::Command;

/// The `ins-gnss` command lines of the shell blocks: (where, the arguments, the file
/// a `>` sends the output to).
fn commands(root: &Path) -> Vec<(String, Vec<String>, Option<String>)> {
    let mut files = vec![root.join("README.md")];
    let mut guide: Vec<PathBuf> = std::fs::read_dir(root.join("docs/guide"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .collect();
    guide.sort();
    files.extend(guide);
    let mut out = Vec::new();
    for file in &files {
        let text = std::fs::read_to_string(file).unwrap();
        let mut in_sh = false;
        let mut pending = String::new();
        for (k, line) in text.lines().enumerate() {
            if line.starts_with("```") {
                in_sh = line.trim_end() == "```sh";
                continue;
            }
            if !in_sh {
                continue;
            }
            let code = line.split(" #").next().unwrap_or("").trim_end();
            let code = if code.trim_start().starts_with('#') { "" } else { code };
            if let Some(head) = code.strip_suffix('\\') {
                pending.push_str(head);
                continue;
            }
            let full = std::mem::take(&mut pending) + code;
            let full = full.trim();
            let args = if let Some(rest) = full.strip_prefix("cargo run --release -p ins-gnss") {
                rest.trim().strip_prefix("--").unwrap_or(rest).trim().to_string()
            } else if let Some(rest) = full.strip_prefix("ins-gnss ") {
                rest.to_string()
            } else {
                continue;
            };
            let synopsis = args.contains('[')
                || args.contains('|')
                || args
                    .split_whitespace()
                    .any(|w| w.len() > 2 && w.chars().all(|c| c.is_ascii_uppercase()));
            if synopsis {
                continue;
            }
            let (args, to) = match args.split_once('>') {
                Some((a, f)) => (a.trim().to_string(), Some(f.trim().to_string())),
                None => (args, None),
            };
            let at = format!("{}:{}", file.file_name().unwrap().to_string_lossy(), k + 1);
            out.push((at, args.split_whitespace().map(str::to_string).collect(), to));
        }
    }
    out
}

/// `from`'s folders made again under `to`, its files linked; earlier runs' output folders
/// (`out*`) left out.
fn mirror(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap();
        if path.is_dir() {
            if !name.to_string_lossy().starts_with("out") {
                mirror(&path, &to.join(name));
            }
        } else {
            std::os::unix::fs::symlink(&path, to.join(name)).unwrap();
        }
    }
}

#[test]
fn every_ins_gnss_command_of_the_docs_runs() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..").canonicalize().unwrap();
    let work = std::env::temp_dir().join(format!("estimator-doc-commands-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&work);
    std::fs::create_dir_all(work.join("ins-gnss")).unwrap();
    // the data's folders are made here and their files linked, so that what a command
    // writes beside its configuration (an `outputpath`) lands here, not in the repository
    mirror(&root.join("data"), &work.join("data"));
    std::os::unix::fs::symlink(root.join("ins-gnss/scenarios"), work.join("ins-gnss/scenarios"))
        .unwrap();
    let list = commands(&root);
    assert!(list.len() >= 8, "{list:?}");
    assert!(list.iter().any(|(_, a, _)| a.is_empty()), "the demo");
    for (at, args, to) in &list {
        let out = Command::new(env!("CARGO_BIN_EXE_ins-gnss"))
            .args(args)
            .current_dir(&work)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{at}: `ins-gnss {}` exited {:?}:\n{}",
            args.join(" "),
            out.status.code(),
            String::from_utf8_lossy(&out.stderr)
        );
        if let Some(file) = to {
            std::fs::write(work.join(file), &out.stdout).unwrap();
        }
    }
    std::fs::remove_dir_all(&work).unwrap();
}
