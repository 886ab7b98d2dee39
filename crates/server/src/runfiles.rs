//! The run files on disk: where they live under the data folder, how one
//! becomes durable, how one is removed, and the startup sweep of what a
//! crash leaves behind. Upload, deletion, the workers and the server's
//! start all go through here; nothing else spells these paths.
//!
//! Layout, under the data folder:
//! - `runs/tmp/<uuid>.part`: an upload being received (and the readiness
//!   probe's scratch file);
//! - `runs/<ab>/<run id>.<ext>`: a stored run, `<ab>` the first two
//!   characters of the run's UUID, so no directory grows past a few
//!   thousand entries and no path contains user input.
//!
//! The durability rule: a run's bytes go to a temp file, which is fsynced,
//! renamed into its shard, and the shard directory (and `runs/`, which
//! may have gained the shard) fsynced; only then are its database rows
//! written. So a row never names a file that a power loss can take away,
//! and a crash between the steps leaves only a file without a row, which
//! [`RunFiles::sweep`] removes at the next start. Deletion is the reverse:
//! rows first, then the file.
//!
//! A leaf module: it knows nothing of the database or of HTTP.

use std::collections::HashSet;
use std::ffi::CString;
use std::fs::File;
use std::io;
use std::os::unix::ffi::OsStrExt;
use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime};

/// The folder of run files, relative to the data folder, and the first
/// part of every blob path (an object store's keys mirror it).
pub const RUNS: &str = "runs";
/// The folder of partial uploads, inside `runs/`.
const TMP: &str = "tmp";

/// The run-file area of one data folder.
#[derive(Clone, Debug)]
pub struct RunFiles {
    data_dir: PathBuf,
}

/// What [`RunFiles::sweep`] removed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Swept {
    /// Partial uploads in `runs/tmp`.
    pub partial: usize,
    /// Run files whose rows never committed (or whose rows were deleted
    /// before the file was).
    pub orphans: usize,
}

/// A run file no database row refers to yet: removed when dropped, unless
/// [`Pending::keep`] says its rows committed. It starts as a temp file in
/// `runs/tmp` and, after [`Pending::commit`], is the run's stored file.
#[derive(Debug)]
pub struct Pending {
    path: PathBuf,
    keep: bool,
}

impl Pending {
    /// Where the file is now (the temp file, or its place once committed).
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Makes the file durable at `blob_path` (from [`RunFiles::blob_path`]):
    /// fsync its data, rename it into its shard, fsync the shard and
    /// `runs/`. Blocking. Still pending afterwards: its rows come next. On
    /// error the file, wherever it got to, is removed.
    pub fn commit(mut self, files: &RunFiles, blob_path: &str) -> io::Result<Pending> {
        File::open(&self.path)?.sync_all()?;
        let to = files.path(blob_path);
        let shard = to.parent().expect("a blob path has a shard").to_path_buf();
        std::fs::create_dir_all(&shard)?;
        std::fs::rename(&self.path, &to)?;
        self.path = to;
        sync_dir(&shard)?;
        // The shard directory may be new: make its entry durable too.
        sync_dir(shard.parent().expect("a shard is inside runs/"))?;
        Ok(self)
    }

    /// [`Pending::commit`] on a blocking thread, for async callers.
    pub async fn commit_off_runtime(self, files: RunFiles, blob_path: &str) -> io::Result<Pending> {
        let blob_path = blob_path.to_string();
        tokio::task::spawn_blocking(move || self.commit(&files, &blob_path))
            .await
            .map_err(|e| io::Error::other(format!("persist task: {e}")))?
    }

    /// The file's rows committed: the file stays.
    pub fn keep(mut self) {
        self.keep = true;
    }
}

impl Drop for Pending {
    fn drop(&mut self) {
        if !self.keep {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}

impl RunFiles {
    pub fn new(data_dir: impl Into<PathBuf>) -> RunFiles {
        RunFiles {
            data_dir: data_dir.into(),
        }
    }

    /// Creates `runs/` and `runs/tmp` (and the data folder) if missing.
    pub fn create_dirs(&self) -> io::Result<()> {
        std::fs::create_dir_all(self.tmp_dir())
    }

    fn runs_dir(&self) -> PathBuf {
        self.data_dir.join(RUNS)
    }

    fn tmp_dir(&self) -> PathBuf {
        self.runs_dir().join(TMP)
    }

    /// The stored path of a run's file, relative to the data folder: what
    /// its row keeps. `ext` is `csv`, `csv.gz` or `bin`.
    pub fn blob_path(run_id: &str, ext: &str) -> String {
        let shard = run_id.get(..2).unwrap_or(run_id);
        format!("{RUNS}/{shard}/{run_id}.{ext}")
    }

    /// The file a row's `blob_path` names.
    pub fn path(&self, blob_path: &str) -> PathBuf {
        self.data_dir.join(blob_path)
    }

    /// A new, empty temp file for an upload, and its guard.
    pub fn create_temp(&self) -> io::Result<(Pending, File)> {
        let path = self
            .tmp_dir()
            .join(format!("{}.part", uuid::Uuid::new_v4()));
        let file = File::create(&path)?;
        Ok((Pending { path, keep: false }, file))
    }

    /// Removes a run's file once its rows are deleted. A file already gone
    /// is not an error; if the removal fails the sweep retries at the next
    /// start.
    pub fn remove(&self, blob_path: &str) -> io::Result<()> {
        match std::fs::remove_file(self.path(blob_path)) {
            Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(()),
            other => other,
        }
    }

    /// Writes, syncs and removes a small file where uploads are spooled:
    /// fails when the run area cannot take a durable write.
    pub fn probe_write(&self) -> io::Result<()> {
        use std::io::Write;
        let path = self.tmp_dir().join("ready-probe");
        let result = (|| {
            let mut f = File::create(&path)?;
            f.write_all(&[0u8; 4096])?;
            f.sync_all()
        })();
        let _ = std::fs::remove_file(&path);
        result
    }

    /// Removes what a crash can leave behind: every file in `runs/tmp`, and
    /// every run file whose blob path is not in `known` (the paths the
    /// database's rows name), if last written more than `grace` ago.
    ///
    /// A server alone on its data folder runs it before uploads are
    /// accepted, with no grace: nothing is in flight. Where other
    /// processes share the folder and the database, one of them may be
    /// between writing a run's file and committing its row (or still
    /// receiving a body): the grace leaves their files alone.
    pub fn sweep(&self, known: &HashSet<String>, grace: Duration) -> io::Result<Swept> {
        let known: HashSet<PathBuf> = known.iter().map(|p| self.path(p)).collect();
        let runs = self.runs_dir();
        let mut swept = Swept {
            partial: self.sweep_partial(grace)?,
            orphans: 0,
        };
        for shard in std::fs::read_dir(&runs)? {
            let shard = shard?.path();
            if !shard.is_dir() || shard.file_name().is_some_and(|n| n == TMP) {
                continue;
            }
            for file in std::fs::read_dir(&shard)? {
                let file = file?.path();
                if !known.contains(&file)
                    && written_before(&file, grace)
                    && std::fs::remove_file(&file).is_ok()
                {
                    swept.orphans += 1;
                }
            }
        }
        Ok(swept)
    }

    /// Removes the files in `runs/tmp` (uploads a crash interrupted) last
    /// written more than `grace` ago, and only those: what
    /// [`RunFiles::sweep`] does first, and all of it when the runs
    /// themselves are kept elsewhere.
    pub fn sweep_partial(&self, grace: Duration) -> io::Result<usize> {
        let mut partial = 0;
        for entry in std::fs::read_dir(self.tmp_dir())? {
            let path = entry?.path();
            if written_before(&path, grace) && std::fs::remove_file(&path).is_ok() {
                partial += 1;
            }
        }
        Ok(partial)
    }

    /// Bytes an unprivileged process may still write on the filesystem of
    /// the data folder (`statvfs`: available blocks × fragment size).
    pub fn available_bytes(&self) -> io::Result<u64> {
        available_bytes(&self.data_dir)
    }
}

/// Whether `path` was last written more than `grace` ago (any file, when
/// `grace` is zero; none whose time cannot be read, otherwise).
fn written_before(path: &Path, grace: Duration) -> bool {
    grace.is_zero()
        || std::fs::metadata(path)
            .and_then(|m| m.modified())
            .is_ok_and(|t| SystemTime::now().duration_since(t).unwrap_or_default() > grace)
}

/// fsyncs a directory so that a rename into it survives power loss.
fn sync_dir(dir: &Path) -> io::Result<()> {
    File::open(dir)?.sync_all()
}

/// Bytes an unprivileged process may still write on the filesystem that
/// holds `path`.
fn available_bytes(path: &Path) -> io::Result<u64> {
    let c_path = CString::new(path.as_os_str().as_bytes())
        .map_err(|e| io::Error::new(io::ErrorKind::InvalidInput, e))?;
    // SAFETY: `c_path` is a valid NUL-terminated string and `stat` a
    // zeroed plain-data struct that statvfs fills in; nothing is retained.
    let mut stat: libc::statvfs = unsafe { std::mem::zeroed() };
    let rc = unsafe { libc::statvfs(c_path.as_ptr(), &mut stat) };
    if rc != 0 {
        return Err(io::Error::last_os_error());
    }
    Ok((stat.f_bavail as u64).saturating_mul(stat.f_frsize as u64))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    fn files() -> (tempfile::TempDir, RunFiles) {
        let dir = tempfile::tempdir().unwrap();
        let files = RunFiles::new(dir.path().join("data"));
        files.create_dirs().unwrap();
        (dir, files)
    }

    /// A temp file with `bytes`, as an upload leaves it.
    fn written(files: &RunFiles, bytes: &[u8]) -> Pending {
        let (pending, mut file) = files.create_temp().unwrap();
        file.write_all(bytes).unwrap();
        pending
    }

    fn tmp_count(files: &RunFiles) -> usize {
        std::fs::read_dir(files.tmp_dir()).unwrap().count()
    }

    #[test]
    fn a_committed_and_kept_file_is_at_its_blob_path_and_survives_the_sweep() {
        let (_dir, files) = files();
        let pending = written(&files, b"run bytes");
        assert!(pending.path().starts_with(files.tmp_dir()));
        let blob = RunFiles::blob_path("ab12-run", "bin");
        assert_eq!(blob, "runs/ab/ab12-run.bin");
        let pending = pending.commit(&files, &blob).unwrap();
        assert_eq!(pending.path(), files.path(&blob));
        pending.keep();
        assert_eq!(std::fs::read(files.path(&blob)).unwrap(), b"run bytes");
        assert_eq!(tmp_count(&files), 0);

        let known = HashSet::from([blob.clone()]);
        assert_eq!(
            files.sweep(&known, Duration::ZERO).unwrap(),
            Swept::default()
        );
        assert!(files.path(&blob).is_file());

        files.remove(&blob).unwrap();
        assert!(!files.path(&blob).exists());
        // Removing it again (a retried delete) is not an error.
        files.remove(&blob).unwrap();
    }

    #[test]
    fn a_file_whose_rows_never_committed_is_removed_on_drop() {
        let (_dir, files) = files();
        let refused = written(&files, b"refused upload");
        drop(refused);
        assert_eq!(tmp_count(&files), 0);

        let committed = written(&files, b"rows failed");
        let blob = RunFiles::blob_path("cd34-run", "csv");
        let committed = committed.commit(&files, &blob).unwrap();
        drop(committed);
        assert!(!files.path(&blob).exists());
    }

    #[test]
    fn the_sweep_removes_what_a_crash_left_at_each_step() {
        let (_dir, files) = files();
        // Crash while receiving: a temp file, never committed.
        let partial = written(&files, b"half an upload");
        std::mem::forget(partial);
        // Crash after the rename, before the rows: a file no row names.
        let orphan = written(&files, b"no rows");
        let orphan_blob = RunFiles::blob_path("ef56-orphan", "bin");
        let orphan = orphan.commit(&files, &orphan_blob).unwrap();
        std::mem::forget(orphan);
        // A stored run, named by its row.
        let kept = written(&files, b"stored");
        let kept_blob = RunFiles::blob_path("ef78-kept", "csv.gz");
        let kept = kept.commit(&files, &kept_blob).unwrap();
        kept.keep();
        assert_eq!(tmp_count(&files), 1);

        let swept = files
            .sweep(&HashSet::from([kept_blob.clone()]), Duration::ZERO)
            .unwrap();
        assert_eq!(
            swept,
            Swept {
                partial: 1,
                orphans: 1
            }
        );
        assert_eq!(tmp_count(&files), 0);
        assert!(!files.path(&orphan_blob).exists());
        assert!(files.path(&kept_blob).is_file());
        // A second sweep finds nothing.
        let known = HashSet::from([kept_blob]);
        assert_eq!(
            files.sweep(&known, Duration::ZERO).unwrap(),
            Swept::default()
        );
    }

    /// With a grace period (other processes share the folder), what was
    /// written within it stays: it may be an upload still in flight, or a
    /// run whose row is about to commit.
    #[test]
    fn the_sweep_leaves_files_younger_than_its_grace() {
        let (_dir, files) = files();
        let partial = written(&files, b"still arriving");
        let orphan = written(&files, b"row about to commit");
        let blob = RunFiles::blob_path("ab12-fresh", "csv");
        let orphan = orphan.commit(&files, &blob).unwrap();
        let grace = Duration::from_secs(600);
        assert_eq!(
            files.sweep(&HashSet::new(), grace).unwrap(),
            Swept::default()
        );
        assert!(files.path(&blob).is_file());
        assert_eq!(tmp_count(&files), 1);
        drop((partial, orphan));
    }

    #[test]
    fn the_probe_leaves_nothing_and_a_temp_folder_has_some_space() {
        let (dir, files) = files();
        files.probe_write().unwrap();
        assert_eq!(tmp_count(&files), 0);
        assert!(files.available_bytes().unwrap() > 0);
        assert!(available_bytes(&dir.path().join("missing")).is_err());
    }
}
