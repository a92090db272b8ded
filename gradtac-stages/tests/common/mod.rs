//! Helpers shared by the tests that read the BioTacSP-DoS recordings from `shared/data` beside the repository.

use std::path::{Path, PathBuf};

/// The numbers of a CSV file with one header line, row by row.
pub fn read(path: &Path) -> Vec<Vec<f64>> {
    let text = std::fs::read_to_string(path).unwrap();
    text.lines()
        .skip(1)
        .filter(|l| !l.trim().is_empty())
        .map(|l| l.split(',').map(|v| v.trim().parse().unwrap()).collect())
        .collect()
}

/// `shared/data/biotacsp-dos` when present; `None` (with a printed note) otherwise, so a
/// test can pass without the data.
pub fn data_dir() -> Option<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/biotacsp-dos");
    if root.is_dir() {
        Some(root)
    } else {
        eprintln!("skipped: {} not present", root.display());
        None
    }
}
