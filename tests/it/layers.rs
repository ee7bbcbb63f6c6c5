//! The floors of the house: every module imports only from the floors below it.
//!
//! The compiler keeps the core crate (crates/core) below the service crate (src/): the core
//! cannot name the service. Inside each crate the order is this test's to keep:
//! [`CORE_FLOORS`] and [`SERVICE_FLOORS`] list the units from the bottom up; a unit is a module path, and a
//! file belongs to the longest unit that prefixes its module path. A reference to
//! `crate::...` (or `super::...`) that lands in a unit listed *after* the referring file's
//! unit is an upward import. Because the list is a total order, a cycle between folders always
//! contains an upward import, so this also rules out cycles. Comments and string literals are
//! left out ([`blank`]); test modules inside `src/` are held to the same rule.
//!
//! A new folder or top-level file must be placed in the list (an unlisted module fails the
//! test), which is where its floor is decided; docs/architecture.md draws the same order.

use super::source::{blank, rust_files};
use std::collections::BTreeSet;
use std::path::Path;

/// The core crate's units (crates/core/src) from the bottom floor up. See
/// docs/architecture.md.
const CORE_FLOORS: &[&str] = &[
    // The pure core: config data first, then the code that uses it.
    "angle",
    "config",
    "wire",
    "timeline",
    "nmea",
    "model",
    "design",
    "baseline::config",
    "estimator::config",
    "fdi::config",
    "monitor::config",
    "dsp",
    "baseline",
    "passive",
    "estimator",
    // The fault decision, by the flow of a test's evidence: tools, the residual against the
    // design, the vessel's normal, the decision, the report.
    "fdi::ablation",
    "fdi::stats",
    "fdi::sensitivity",
    "fdi::limits",
    "fdi::fit",
    "fdi::shape",
    "fdi::raw",
    "fdi::point",
    "fdi::envelope",
    "fdi::prior",
    "fdi::measured",
    "fdi::noise",
    "fdi::resolve",
    "fdi::summary",
    "fdi::reference",
    "fdi::changepoint",
    "fdi::window",
    "fdi::isolation",
    "fdi::decision",
    "fdi::learning",
    "fdi::budget",
    "fdi::report",
    "fdi",
    "monitor",
    "ownership",
    // The simulated ship.
    "sim::config",
    "sim",
    // Drivers without I/O of their own.
    "drivers::probe",
    "drivers::replay",
    "drivers",
    // Samples for tests (this crate's and, with `test-support`, the service's): compiled for
    // tests only, so any floor's tests may use it (see TEST_ONLY).
    "testing",
];

/// Units compiled for tests only (`#[cfg(any(test, feature = "test-support"))]`): a
/// reference to one is no upward import, since no build of the daemon contains it.
const TEST_ONLY: &[&str] = &["testing"];

/// The service crate's units (src/) from the bottom floor up; the core is below all of them
/// (a dependency the compiler enforces).
const SERVICE_FLOORS: &[&str] = &[
    // Shells: the world.
    "shells::net",
    "shells::systemd",
    "shells::state",
    "shells::history",
    "shells::recording",
    "shells::metrics",
    "shells::bridge",
    "shells::daemon",
    "shells::shipnode",
    "shells",
    // The configuration file as a whole.
    "config",
    // Offline tools.
    "tools::training",
    "tools::eval",
    "tools::loopback",
    "tools::demo",
    "tools::bench",
    "tools::time_to_alarm",
    "tools::plot",
    "tools::fleet",
    "tools",
    // The command line.
    "cli",
];

/// One upward import: `(file, its unit, the path, the unit it reaches)`.
type Violation = (String, String, String, String);

/// Module path of a file below `src/`: `core/monitor/hbt.rs` -> `core::monitor::hbt`,
/// `core/monitor/mod.rs` -> `core::monitor`; `lib.rs` and `main.rs` -> "" (the crate root).
fn module_path(rel: &str) -> String {
    let rel = rel.trim_end_matches(".rs");
    let mut parts: Vec<&str> = rel.split('/').collect();
    if matches!(parts.last(), Some(&"mod")) {
        parts.pop();
    }
    if parts == ["lib"] || parts == ["main"] {
        return String::new();
    }
    parts.join("::")
}

/// Rank of the unit a module path belongs to (the longest listed prefix), or `None`.
fn unit_of(floors: &'static [&'static str], path: &str) -> Option<(usize, &'static str)> {
    floors
        .iter()
        .enumerate()
        .filter(|(_, u)| path == **u || path.starts_with(&format!("{u}::")))
        .max_by_key(|(_, u)| u.len())
        .map(|(i, u)| (i, *u))
}

fn prev_ident(b: &[char], i: usize) -> bool {
    i > 0 && (b[i - 1].is_alphanumeric() || b[i - 1] == '_')
}

/// Every module path a `crate::` / `super::` reference in `code` names, expanded through
/// `{...}` groups: `crate::{a::b, c::{d, e}}` -> `a::b`, `c::d`, `c::e`. `module` is the
/// referring file's module path (for `super::`).
fn references(code: &str, module: &str) -> BTreeSet<String> {
    let chars: Vec<char> = code.chars().collect();
    let mut found = BTreeSet::new();
    // Inline modules (`mod tests { .. }`) open at a brace depth: `super::` inside one
    // starts from it, not from the file's module.
    let mut depth = 0usize;
    let mut inline: Vec<(String, usize)> = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let rest: String = chars[i..chars.len().min(i + 7)].iter().collect();
        let starts_word = i == 0 || !prev_ident(&chars, i);
        match chars[i] {
            '{' => {
                depth += 1;
                i += 1;
                continue;
            }
            '}' => {
                depth = depth.saturating_sub(1);
                while inline.last().is_some_and(|(_, d)| *d > depth) {
                    inline.pop();
                }
                i += 1;
                continue;
            }
            _ => {}
        }
        if starts_word && rest.starts_with("mod ") {
            let mut j = i + 4;
            let start = j;
            while j < chars.len() && (chars[j].is_alphanumeric() || chars[j] == '_') {
                j += 1;
            }
            let name: String = chars[start..j].iter().collect();
            while j < chars.len() && chars[j].is_whitespace() {
                j += 1;
            }
            if chars.get(j) == Some(&'{') {
                depth += 1;
                inline.push((name, depth));
                i = j + 1;
                continue;
            }
            i = j.max(i + 1);
        } else if starts_word && (rest.starts_with("crate::") || rest.starts_with("super::")) {
            let (base, mut j) = if rest.starts_with("crate::") {
                (Vec::new(), i + 7)
            } else {
                let mut base: Vec<String> = module.split("::").map(str::to_string).collect();
                base.extend(inline.iter().map(|(n, _)| n.clone()));
                let mut j = i;
                while chars[j..].iter().take(7).collect::<String>() == "super::" {
                    base.pop();
                    j += 7;
                }
                (base, j)
            };
            parse_tree(&chars, &mut j, base, &mut found);
            i = j.max(i + 1);
        } else {
            i += 1;
        }
    }
    found
}

/// Parses `seg::seg::{tree, tree}` at `chars[*j..]`, pushing each full path onto `found`.
fn parse_tree(chars: &[char], j: &mut usize, mut path: Vec<String>, found: &mut BTreeSet<String>) {
    loop {
        while *j < chars.len() && chars[*j].is_whitespace() {
            *j += 1;
        }
        if chars.get(*j) == Some(&'{') {
            *j += 1;
            loop {
                parse_tree(chars, j, path.clone(), found);
                while *j < chars.len() && chars[*j].is_whitespace() {
                    *j += 1;
                }
                match chars.get(*j) {
                    Some(',') => *j += 1,
                    Some('}') => {
                        *j += 1;
                        return;
                    }
                    _ => return,
                }
                while *j < chars.len() && chars[*j].is_whitespace() {
                    *j += 1;
                }
                if chars.get(*j) == Some(&'}') {
                    *j += 1;
                    return;
                }
            }
        }
        let start = *j;
        while *j < chars.len() && (chars[*j].is_alphanumeric() || chars[*j] == '_') {
            *j += 1;
        }
        let seg: String = chars[start..*j].iter().collect();
        if seg.is_empty() || seg == "self" {
            found.insert(path.join("::"));
            return;
        }
        path.push(seg);
        if chars[*j..].iter().take(2).collect::<String>() == "::" {
            *j += 2;
        } else {
            found.insert(path.join("::"));
            return;
        }
    }
}

/// Checks `files` (`(path below src/, text)`): the upward imports, and the files that belong
/// to no listed unit.
fn check(
    floors: &'static [&'static str],
    files: &[(String, String)],
) -> (Vec<Violation>, Vec<String>) {
    let mut violations = Vec::new();
    let mut unlisted = Vec::new();
    for (rel, text) in files {
        let module = module_path(rel);
        if module.is_empty() {
            continue; // lib.rs and main.rs declare the floors, they are not one.
        }
        let Some((rank, unit)) = unit_of(floors, &module) else {
            unlisted.push(rel.clone());
            continue;
        };
        for target in references(&blank(text), &module) {
            if let Some((t_rank, t_unit)) = unit_of(floors, &target) {
                if t_rank > rank && !TEST_ONLY.contains(&t_unit) {
                    violations.push((
                        rel.clone(),
                        unit.to_string(),
                        target.clone(),
                        t_unit.to_string(),
                    ));
                }
            }
        }
    }
    (violations, unlisted)
}

#[test]
fn no_module_imports_from_a_floor_above_it() {
    for (src, floors, least) in [
        ("crates/core/src", CORE_FLOORS, 60),
        ("src", SERVICE_FLOORS, 40),
    ] {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join(src);
        let mut files = Vec::new();
        rust_files(&root, &root, &mut files);
        assert!(files.len() > least, "read {} files in {src}", files.len());
        floors_hold(floors, &files);
    }
}

fn floors_hold(floors: &'static [&'static str], files: &[(String, String)]) {
    let (violations, unlisted) = check(floors, files);
    assert!(
        unlisted.is_empty(),
        "modules on no floor (place them in CORE_FLOORS or SERVICE_FLOORS, tests/it/layers.rs, and docs/architecture.md): {unlisted:?}"
    );
    let lines: Vec<String> = violations
        .iter()
        .map(|(f, u, p, t)| format!("{f} ({u}) imports {p} ({t}, a floor above)"))
        .collect();
    assert!(lines.is_empty(), "upward imports:\n{}", lines.join("\n"));
}

fn file(rel: &str, text: &str) -> (String, String) {
    (rel.to_string(), text.to_string())
}

#[test]
fn a_planted_upward_import_is_caught() {
    let (v, _) = check(
        CORE_FLOORS,
        &[file(
            "dsp/spectrum.rs",
            "use crate::angle::wrap_pi;\nuse crate::sim::Ship;\n",
        )],
    );
    assert_eq!(v.len(), 1, "{v:?}");
    assert_eq!(v[0].2, "sim::Ship");
    assert_eq!(v[0].3, "sim");
    // Inside a group, in an expression, and through super::.
    let (v, _) = check(
        CORE_FLOORS,
        &[
            file(
                "monitor/hbt.rs",
                "use crate::{dsp, drivers::probe::Lockstep};",
            ),
            file(
                "sim/ship.rs",
                "fn f() { let x = crate::drivers::replay::replay_lines(); }",
            ),
            file("estimator/nn.rs", "use super::super::fdi::Fdi;"),
            file(
                "angle.rs",
                "mod tests { use super::*; use super::super::monitor::Monitor; }",
            ),
        ],
    );
    let targets: Vec<&str> = v.iter().map(|x| x.2.as_str()).collect();
    assert_eq!(
        targets,
        vec![
            "drivers::probe::Lockstep",
            "drivers::replay::replay_lines",
            "fdi::Fdi",
            "monitor::Monitor"
        ],
        "{v:?}"
    );
}

#[test]
fn a_cycle_between_two_folders_is_caught() {
    // dsp -> fdi and fdi -> dsp: whichever is higher, one edge points up.
    let (v, _) = check(
        CORE_FLOORS,
        &[
            file("dsp/mod.rs", "use crate::fdi::Fdi;"),
            file("fdi/mod.rs", "use crate::dsp::spectrum;"),
        ],
    );
    assert_eq!(v.len(), 1, "{v:?}");
    assert_eq!(v[0].0, "dsp/mod.rs");
}

#[test]
fn comments_strings_and_downward_imports_are_not_violations() {
    let (v, unlisted) = check(CORE_FLOORS, &[
        file(
            "model.rs",
            "//! See [`crate::sim::Ship`].\n/* crate::drivers */ const S: &str = \"crate::sim::x\";\nconst R: &str = r#\"crate::monitor\"#;\nuse crate::config::ConfigError;\nfn f<'a>(x: &'a str) -> char { '\"' }\n",
        ),
        file("drivers/mod.rs", "use crate::{monitor::Monitor, sim::Ship};"),
    ]);
    assert!(v.is_empty(), "{v:?}");
    assert!(unlisted.is_empty());
    let (_, unlisted) = check(CORE_FLOORS, &[file("gadgets/mod.rs", "")]);
    assert_eq!(unlisted, vec!["gadgets/mod.rs".to_string()]);
}
