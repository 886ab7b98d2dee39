-- Which token uploaded a run: a station token reads only the runs (and
-- their jobs) it uploaded. Runs stored before this column have no
-- uploader and are read by engineers and admins only.
ALTER TABLE runs ADD COLUMN uploaded_by TEXT;
CREATE INDEX runs_uploaded_by ON runs (uploaded_by);

-- One row the readiness probe rewrites: a write that must reach the
-- database file, so that a full disk or a wedged writer shows as not ready.
CREATE TABLE write_probe (
    id         INTEGER PRIMARY KEY CHECK (id = 1),
    checked_at INTEGER NOT NULL
);
