//! Bad input through the built binary: `prism render <scene> -o <out>.exr` must exit with code 2
//! and print exactly one line `prism: error: <message>` on stderr, never a panic.
//!
//! The corpus lives in tests/data/malformed/ (regenerate with `python3 make_corpus.py` there);
//! the expected message fragments are in tests/common/malformed_cases.rs, which
//! tests/scene_load.rs also checks through the library API.

#[path = "common/malformed_cases.rs"]
mod malformed_cases;

use std::path::Path;
use std::process::Command;

use malformed_cases::{corpus_dir, CASES, NONEXISTENT};

fn run_render(scene: &Path, tag: &str) -> (Option<i32>, String) {
    let out_dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("malformed_input");
    std::fs::create_dir_all(&out_dir).unwrap();
    let out = out_dir.join(format!("{tag}.exr"));
    let o = Command::new(env!("CARGO_BIN_EXE_prism"))
        .arg("render")
        .arg(scene)
        .arg("-o")
        .arg(&out)
        .output()
        .expect("cannot run the prism binary");
    (
        o.status.code(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

fn check(scene: &Path, tag: &str, fragment: &str) -> Result<(), String> {
    let (code, stderr) = run_render(scene, tag);
    let mut problems = Vec::new();
    if code != Some(2) {
        problems.push(format!("exit code {code:?}, expected 2"));
    }
    if stderr.contains("panicked") {
        problems.push("stderr mentions a panic".to_string());
    }
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    if lines.len() != 1 {
        problems.push(format!("expected one stderr line, got {}", lines.len()));
    }
    if !lines.iter().any(|l| l.starts_with("prism: error: ")) {
        problems.push("no 'prism: error: ' line".to_string());
    }
    if !stderr.contains(fragment) {
        problems.push(format!("stderr lacks '{fragment}'"));
    }
    if problems.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "{tag}: {}\n--- stderr:\n{stderr}---",
            problems.join("; ")
        ))
    }
}

#[test]
fn malformed_corpus_exits_with_code_2_and_one_line() {
    let dir = corpus_dir();
    let failures: Vec<String> = CASES
        .iter()
        .filter_map(|(file, fragment)| check(&dir.join(file), file, fragment).err())
        .collect();
    assert!(
        failures.is_empty(),
        "{} of {} cases failed:\n{}",
        failures.len(),
        CASES.len(),
        failures.join("\n")
    );
}

#[test]
fn nonexistent_scene_exits_with_code_2() {
    let (file, fragment) = NONEXISTENT;
    let scene = corpus_dir().join(file);
    assert!(!scene.exists());
    check(&scene, "nonexistent", fragment).unwrap();
}
