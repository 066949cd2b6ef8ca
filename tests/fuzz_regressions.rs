//! Replays the fuzz harnesses (`fuzz/src/lib.rs`) on their seeds and on every input a fuzz
//! run ever found (`fuzz/regressions/TARGET/`), so a finding stays fixed without libFuzzer.

#[path = "../fuzz/src/lib.rs"]
mod harness;

use std::path::Path;

/// Every file in `dir` but the placeholder, sorted so failures are reproducible.
fn inputs(dir: &str) -> Vec<std::path::PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join(dir);
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file() && p.file_name().is_some_and(|n| n != ".keep"))
        .collect();
    files.sort();
    files
}

fn replay(target: &str, run: fn(&[u8]), seeds: &str) -> usize {
    let files: Vec<_> = [inputs(seeds), inputs(&format!("fuzz/regressions/{target}"))].concat();
    for file in &files {
        let bytes = std::fs::read(file).unwrap();
        if std::panic::catch_unwind(|| run(&bytes)).is_err() {
            panic!("fuzz harness {target} fails on {}", file.display());
        }
    }
    files.len()
}

#[test]
fn trace_reader_inputs() {
    assert!(replay("trace_reader", harness::trace_reader, "traces") >= 6);
}

#[test]
fn gltf_import_inputs() {
    assert!(replay("gltf_import", harness::gltf_import, "fuzz/seeds/gltf_import") >= 5);
}

#[test]
fn flythrough_inputs() {
    assert!(replay("flythrough", harness::flythrough, "fuzz/seeds/flythrough") >= 2);
}
