//! `docs/results/`: every figure the docs quote is written by a command. A results file is
//! the command's markdown output under a header that says how to make it again: the command
//! line, the commit it ran at and the seed. Nothing in it is written by hand; re-running the
//! command overwrites it. A suite also writes its rows' figures beside it as JSON
//! (`<name>.json`) for `eval --compare` and `eval --fdi --ablate`.

use std::path::{Path, PathBuf};

/// The commit the binary runs at: `git rev-parse --short=12 HEAD` in the working directory,
/// `-dirty` when a tracked file outside `docs/results/` differs from it (the results a run
/// writes before its later suites do not make them dirty), or `unknown` outside a checkout.
pub fn commit() -> String {
    let git = |args: &[&str]| {
        std::process::Command::new("git")
            .args(args)
            .output()
            .ok()
            .filter(|o| o.status.success())
            .and_then(|o| String::from_utf8(o.stdout).ok())
            .map(|s| s.trim().to_string())
    };
    let Some(head) = git(&["rev-parse", "--short=12", "HEAD"]).filter(|s| !s.is_empty()) else {
        return "unknown".into();
    };
    let dirty = git(&[
        "status",
        "--porcelain",
        "--untracked-files=no",
        "--",
        ".",
        ":(exclude)docs/results",
    ])
    .is_some_and(|s| !s.is_empty());
    if dirty {
        format!("{head}-dirty")
    } else {
        head
    }
}

/// The command line as a user types it: `helmwatch` and the arguments.
pub fn command_line() -> String {
    let mut words = vec!["helmwatch".to_string()];
    words.extend(std::env::args().skip(1).map(|a| {
        if a.is_empty() || a.contains(|c: char| c.is_whitespace() || c == '\'') {
            format!("'{}'", a.replace('\'', "'\\''"))
        } else {
            a
        }
    }));
    words.join(" ")
}

/// The header of a results file.
pub fn header(seed: u64) -> String {
    format!(
        "<!-- Written by a command, not by hand: run it again to regenerate this file. -->\n\n\
         Command: `{}`  \nCommit: `{}`  \nSeed: {seed}\n\n",
        command_line(),
        commit()
    )
}

/// Writes `dir/<name>.md` (the header, then `body`) atomically and returns its path.
pub fn write(dir: &Path, name: &str, seed: u64, body: &str) -> std::io::Result<PathBuf> {
    let path = dir.join(format!("{name}.md"));
    write_atomic(&path, format!("{}{body}", header(seed)).as_bytes())?;
    Ok(path)
}

/// Writes a file through a temporary beside it and a rename.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    if let Some(d) = path.parent() {
        std::fs::create_dir_all(d)?;
    }
    let tmp = path.with_extension("tmp");
    std::fs::write(&tmp, bytes)?;
    std::fs::rename(&tmp, path)
}

/// `name` in a file name: lower case, each run of other characters than letters and digits
/// one `-` ("KVLCC2 MMG 120 m": "kvlcc2-mmg-120-m").
pub fn slug(name: &str) -> String {
    let s: String = name
        .chars()
        .map(|c| match c.is_ascii_alphanumeric() {
            true => c.to_ascii_lowercase(),
            false => '-',
        })
        .collect();
    s.split('-')
        .filter(|w| !w.is_empty())
        .collect::<Vec<_>>()
        .join("-")
}

/// A results page's name's part for a models directory that is set (a class's):
/// `-models-<its name>`; empty for none (the design's models).
pub fn models_suffix(dir: Option<&std::path::Path>) -> String {
    dir.and_then(|d| d.file_name()).map_or(String::new(), |n| {
        format!("-models-{}", slug(&n.to_string_lossy()))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_results_file_says_how_it_was_made() {
        let dir = std::env::temp_dir().join(format!("hw-results-{}", std::process::id()));
        let p = write(&dir, "suite", 7, "| a |\n").unwrap();
        let text = std::fs::read_to_string(&p).unwrap();
        assert!(text.starts_with("<!-- Written by a command"), "{text}");
        assert!(text.contains("Command: `helmwatch"), "{text}");
        assert!(text.contains("Seed: 7\n"), "{text}");
        assert!(text.ends_with("| a |\n"), "{text}");
        assert!(!dir.join("suite.tmp").exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
