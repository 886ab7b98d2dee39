//! The local run store: today's `runs/` folder of [`RunFiles`], on
//! blocking threads.

use std::collections::HashSet;

use super::{RunStoreError, Stored, StoredInner};
use crate::runfiles::{Pending, RunFiles};

/// fsync, rename into the shard, fsync the directories (see
/// [`Pending::commit`]).
pub(super) async fn commit(
    files: &RunFiles,
    pending: Pending,
    blob_path: &str,
) -> Result<Stored, RunStoreError> {
    let committed = pending
        .commit_off_runtime(files.clone(), blob_path)
        .await
        .map_err(RunStoreError::io(format!("storing {blob_path}")))?;
    Ok(Stored {
        inner: StoredInner::Local(committed),
    })
}

pub(super) async fn remove(files: &RunFiles, blob_path: &str) -> Result<(), RunStoreError> {
    let (files, blob) = (files.clone(), blob_path.to_string());
    tokio::task::spawn_blocking(move || files.remove(&blob))
        .await
        .map_err(|e| RunStoreError::io("removing a run file")(std::io::Error::other(e)))?
        .map_err(RunStoreError::io(format!("removing {blob_path}")))
}

/// (partial uploads, orphan files) removed.
pub(super) async fn sweep(
    files: &RunFiles,
    known: &HashSet<String>,
    grace: std::time::Duration,
) -> Result<(usize, usize), RunStoreError> {
    let (files, known) = (files.clone(), known.clone());
    let swept = tokio::task::spawn_blocking(move || files.sweep(&known, grace))
        .await
        .map_err(|e| RunStoreError::io("sweeping the run files")(std::io::Error::other(e)))?
        .map_err(RunStoreError::io("sweeping the run files"))?;
    Ok((swept.partial, swept.orphans))
}
