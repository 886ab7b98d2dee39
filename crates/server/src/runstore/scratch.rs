//! `scratch/` under the data folder: local copies of runs kept in an
//! object store, made for a reader and removed after it (or, after a
//! crash, at the next start).

use std::path::{Path, PathBuf};

use super::RunStoreError;

/// The scratch folder, relative to the data folder.
const SCRATCH: &str = "scratch";

pub(super) fn create_dir(data_dir: &Path) -> Result<(), RunStoreError> {
    let dir = data_dir.join(SCRATCH);
    std::fs::create_dir_all(&dir).map_err(RunStoreError::io(format!("creating {}", dir.display())))
}

/// A fresh `scratch/<uuid>.<ext>` for the run at `blob_path`, with the
/// blob's extension (`csv`, `csv.gz`, `bin`) so the copy reads as the run.
pub(super) fn new_path(data_dir: &Path, blob_path: &str) -> PathBuf {
    let name = blob_path.rsplit('/').next().unwrap_or(blob_path);
    let id = uuid::Uuid::new_v4();
    let file = match name.split_once('.') {
        Some((_, ext)) => format!("{id}.{ext}"),
        None => id.to_string(),
    };
    data_dir.join(SCRATCH).join(file)
}

/// Removes every scratch file: run at start, when no reader is running.
pub(super) fn sweep(data_dir: &Path) -> Result<usize, RunStoreError> {
    let dir = data_dir.join(SCRATCH);
    let what = || format!("sweeping {}", dir.display());
    let mut removed = 0;
    for entry in std::fs::read_dir(&dir).map_err(RunStoreError::io(what()))? {
        let entry = entry.map_err(RunStoreError::io(what()))?;
        if std::fs::remove_file(entry.path()).is_ok() {
            removed += 1;
        }
    }
    Ok(removed)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_scratch_copy_keeps_the_extension_and_the_sweep_empties_the_folder() {
        let dir = tempfile::tempdir().unwrap();
        create_dir(dir.path()).unwrap();
        let gz = new_path(dir.path(), "runs/ab/ab12-run.csv.gz");
        assert!(gz.starts_with(dir.path().join(SCRATCH)));
        assert!(gz.to_str().unwrap().ends_with(".csv.gz"));
        let bin = new_path(dir.path(), "runs/ab/ab12-run.bin");
        assert!(bin.to_str().unwrap().ends_with(".bin"));
        assert_ne!(new_path(dir.path(), "runs/ab/ab12-run.bin"), bin);
        std::fs::write(&gz, b"left by a crash").unwrap();
        std::fs::write(&bin, b"left by a crash").unwrap();
        assert_eq!(sweep(dir.path()).unwrap(), 2);
        assert_eq!(sweep(dir.path()).unwrap(), 0);
    }
}
