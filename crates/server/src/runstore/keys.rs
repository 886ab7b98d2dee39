//! Where a run's bytes sit in an object store, and which objects the sweep
//! may delete. Pure functions, so the rules are tested without a server.

use std::collections::HashSet;
use std::time::Duration;

use chrono::{DateTime, Utc};

use crate::runfiles::RUNS;

/// The object key of a row's `blob_path` under `prefix` (no leading or
/// trailing `/`; empty for the bucket's root): `<prefix>/<blob_path>`, so a
/// bucket laid out this way mirrors the local `runs/` folder and a store
/// can be moved by copying.
pub fn object_key(prefix: &str, blob_path: &str) -> String {
    if prefix.is_empty() {
        blob_path.to_string()
    } else {
        format!("{prefix}/{blob_path}")
    }
}

/// The blob path an object key under `prefix` stands for; `None` for a key
/// outside it.
pub fn blob_path_of<'k>(prefix: &str, key: &'k str) -> Option<&'k str> {
    if prefix.is_empty() {
        Some(key)
    } else {
        key.strip_prefix(prefix)?.strip_prefix('/')
    }
}

/// The key prefix the sweep lists: only the run area, so nothing else
/// that shares the bucket or prefix is ever a candidate for deletion.
pub fn runs_prefix(prefix: &str) -> String {
    object_key(prefix, RUNS)
}

/// Whether the sweep deletes the object at `blob_path`, last modified at
/// `modified`: it is in the run area, no row names it, and it is older
/// than `grace`. The grace period is what makes the sweep safe to run
/// beside uploads: another server may have put the object and not yet
/// committed its rows (see [`super::ORPHAN_GRACE`]).
pub fn is_orphan(
    blob_path: &str,
    modified: DateTime<Utc>,
    known: &HashSet<String>,
    now: DateTime<Utc>,
    grace: Duration,
) -> bool {
    let in_run_area = blob_path
        .strip_prefix(RUNS)
        .is_some_and(|rest| rest.starts_with('/'));
    // A clock ahead of ours makes the age negative: never old enough.
    let old = (now - modified)
        .to_std()
        .map(|age| age > grace)
        .unwrap_or(false);
    in_run_area && old && !known.contains(blob_path)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::runfiles::RunFiles;

    #[test]
    fn a_key_is_the_prefix_and_the_blob_path_and_maps_back() {
        let blob = RunFiles::blob_path("ab12-run", "csv.gz");
        assert_eq!(
            object_key("fleet/a", &blob),
            "fleet/a/runs/ab/ab12-run.csv.gz"
        );
        assert_eq!(object_key("", &blob), "runs/ab/ab12-run.csv.gz");
        for prefix in ["", "fleet", "fleet/a"] {
            let key = object_key(prefix, &blob);
            assert_eq!(blob_path_of(prefix, &key), Some(blob.as_str()));
            // The key survives the object store's path type unchanged, so
            // a listed key compares equal to the row's blob path.
            let path = object_store::path::Path::parse(&key).unwrap();
            assert_eq!(path.as_ref(), key);
        }
        assert_eq!(blob_path_of("fleet", "fleetx/runs/ab/x.csv"), None);
        assert_eq!(blob_path_of("fleet", "other/runs/ab/x.csv"), None);
        assert_eq!(runs_prefix("fleet/a"), "fleet/a/runs");
        assert_eq!(runs_prefix(""), "runs");
    }

    #[test]
    fn only_an_old_object_no_row_names_in_the_run_area_is_an_orphan() {
        let now = DateTime::parse_from_rfc3339("2026-01-01T12:00:00Z")
            .unwrap()
            .with_timezone(&Utc);
        let grace = Duration::from_secs(3600);
        let old = now - chrono::Duration::seconds(3601);
        let fresh = now - chrono::Duration::seconds(3599);
        let ahead = now + chrono::Duration::seconds(60);
        let known = HashSet::from([String::from("runs/ab/ab12-kept.csv")]);

        assert!(is_orphan(
            "runs/cd/cd34-orphan.bin",
            old,
            &known,
            now,
            grace
        ));
        // Named by a row, however old.
        assert!(!is_orphan("runs/ab/ab12-kept.csv", old, &known, now, grace));
        // Perhaps between another server's put and its commit.
        assert!(!is_orphan(
            "runs/cd/cd34-orphan.bin",
            fresh,
            &known,
            now,
            grace
        ));
        assert!(!is_orphan(
            "runs/cd/cd34-orphan.bin",
            ahead,
            &known,
            now,
            grace
        ));
        // Outside the run area: not ours to delete.
        assert!(!is_orphan("notes/readme.txt", old, &known, now, grace));
        assert!(!is_orphan("runsx/ab/x.csv", old, &known, now, grace));
    }
}
