//! Sizes a reader can hold: no function longer than [`MAX_FN_LINES`] in either crate's
//! sources, no file longer than [`MAX_FILE_LINES`] outside the test files (`*_tests.rs`,
//! `tests.rs`).
//!
//! A function's length runs from the line of its `fn` to the line of its closing brace.
//! Comments, strings and char literals are blanked first ([`blank`], newlines kept), so a brace in a
//! string or a comment does not count. A long function that is a table (data, not logic)
//! would go in [`TABLES`] with its reason; the list is empty.

use super::source::{blank, rust_files};
use std::path::Path;

/// The longest function allowed, in lines.
const MAX_FN_LINES: usize = 120;
/// The longest source file allowed outside the test files, in lines.
const MAX_FILE_LINES: usize = 600;
/// Functions exempt from [`MAX_FN_LINES`]: `(file below the crate's src, fn, why)`.
const TABLES: &[(&str, &str, &str)] = &[];

/// Every function with a body in `src`: `(name, first line, lines)`.
fn functions(src: &str) -> Vec<(String, usize, usize)> {
    let code: Vec<char> = blank(src).chars().collect();
    let line_at = |k: usize| 1 + code[..k].iter().filter(|&&c| c == '\n').count();
    let mut out = Vec::new();
    let mut i = 0;
    while i + 3 < code.len() {
        let word_start = i == 0 || !(code[i - 1].is_alphanumeric() || code[i - 1] == '_');
        if !(word_start && code[i..i + 3] == ['f', 'n', ' ']) {
            i += 1;
            continue;
        }
        let mut j = i + 3;
        let name_start = j;
        while j < code.len() && (code[j].is_alphanumeric() || code[j] == '_') {
            j += 1;
        }
        let name: String = code[name_start..j].iter().collect();
        // The body opens at the first `{` unless a `;` ends a declaration first.
        let Some(open) = (j..code.len()).find(|&k| code[k] == '{' || code[k] == ';') else {
            break;
        };
        if code[open] == ';' || name.is_empty() {
            i = j;
            continue;
        }
        let mut depth = 0usize;
        let mut close = open;
        for (k, &c) in code.iter().enumerate().skip(open) {
            match c {
                '{' => depth += 1,
                '}' => {
                    depth -= 1;
                    if depth == 0 {
                        close = k;
                        break;
                    }
                }
                _ => {}
            }
        }
        let first = line_at(i);
        out.push((name, first, line_at(close) - first + 1));
        i = j;
    }
    out
}

fn is_test_file(rel: &str) -> bool {
    rel.ends_with("_tests.rs") || rel.ends_with("/tests.rs") || rel == "tests.rs"
}

/// The functions and files over their limits in `files` (`(path, text)`).
fn oversized(src: &str, files: &[(String, String)]) -> Vec<String> {
    let mut over = Vec::new();
    for (rel, text) in files {
        let lines = text.lines().count();
        if lines > MAX_FILE_LINES && !is_test_file(rel) {
            over.push(format!("{src}/{rel}: {lines} lines (> {MAX_FILE_LINES})"));
        }
        for (name, first, n) in functions(text) {
            let table = TABLES.iter().any(|(f, g, _)| *f == rel && *g == name);
            if n > MAX_FN_LINES && !table {
                over.push(format!(
                    "{src}/{rel}:{first}: fn {name} {n} lines (> {MAX_FN_LINES})"
                ));
            }
        }
    }
    over
}

#[test]
fn no_function_or_file_is_longer_than_a_reader_holds() {
    let mut over = Vec::new();
    for src in ["crates/core/src", "src"] {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join(src);
        let mut files = Vec::new();
        rust_files(&root, &root, &mut files);
        assert!(files.len() > 30, "read {} files in {src}", files.len());
        over.extend(oversized(src, &files));
    }
    assert!(over.is_empty(), "too long:\n{}", over.join("\n"));
}

#[test]
fn a_long_function_is_measured_from_fn_to_its_closing_brace() {
    let body: String = (0..130).map(|k| format!("    let x{k} = {k};\n")).collect();
    let src = format!(
        "/// Docs {{ not a brace.\nfn short() {{ let s = \"}}{{\"; let c = '}}'; }}\n\nfn long(a: u8) -> u8 {{\n{body}    a\n}}\n"
    );
    let f = functions(&src);
    assert_eq!(f[0], ("short".to_string(), 2, 1), "{f:?}");
    assert_eq!(f[1], ("long".to_string(), 4, 133), "{f:?}");
    let files = [("x.rs".to_string(), src.clone())];
    assert_eq!(oversized("src", &files).len(), 1);
    // Declarations without a body and test files' length are not counted.
    assert!(functions("trait T { fn f(&self); }\n").is_empty());
    let long_file: String = "// line\n".repeat(700);
    assert!(oversized(
        "src",
        &[("dsp/tones_tests.rs".to_string(), long_file.clone())]
    )
    .is_empty());
    assert_eq!(
        oversized("src", &[("dsp/tones.rs".to_string(), long_file)]).len(),
        1
    );
}
