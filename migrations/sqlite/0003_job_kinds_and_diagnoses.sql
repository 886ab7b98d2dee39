-- Jobs get a kind: 'calibrate' (one per run, made by the upload) or
-- 'diagnose' (the discrepancy workflow, queued on request, any number per
-- run over time). jobs.run_id was UNIQUE, which SQLite cannot drop in
-- place, so the table is rebuilt; nothing references jobs, so dropping the
-- old table is safe with foreign keys on.

CREATE TABLE jobs_new (
    id               TEXT PRIMARY KEY,
    run_id           TEXT NOT NULL REFERENCES runs(id) ON DELETE CASCADE,
    kind             TEXT NOT NULL DEFAULT 'calibrate' CHECK (kind IN ('calibrate', 'diagnose')),
    state            TEXT NOT NULL CHECK (state IN ('queued', 'running', 'succeeded', 'failed', 'cancelled')),
    attempts         INTEGER NOT NULL DEFAULT 0,   -- also the fencing token of the current lease
    max_attempts     INTEGER NOT NULL,
    lease_owner      TEXT,
    lease_expires_at INTEGER,
    heartbeat_at     INTEGER,
    run_after        INTEGER NOT NULL,              -- retry backoff: not claimable before this
    progress         REAL NOT NULL DEFAULT 0,
    stage            TEXT,
    cancel_requested INTEGER NOT NULL DEFAULT 0,
    error            TEXT,
    created_at       INTEGER NOT NULL,
    started_at       INTEGER,
    finished_at      INTEGER
);
INSERT INTO jobs_new (id, run_id, kind, state, attempts, max_attempts, lease_owner, lease_expires_at,
                      heartbeat_at, run_after, progress, stage, cancel_requested, error,
                      created_at, started_at, finished_at)
SELECT id, run_id, 'calibrate', state, attempts, max_attempts, lease_owner, lease_expires_at,
       heartbeat_at, run_after, progress, stage, cancel_requested, error,
       created_at, started_at, finished_at
FROM jobs;
DROP TABLE jobs;
ALTER TABLE jobs_new RENAME TO jobs;

CREATE INDEX jobs_claim ON jobs (state, run_after, created_at);
CREATE INDEX jobs_lease ON jobs (state, lease_expires_at);
-- The old UNIQUE (run_id), kept for calibration jobs: a run's job is its
-- one calibration job.
CREATE UNIQUE INDEX jobs_calibrate_run ON jobs (run_id) WHERE kind = 'calibrate';
-- At most one diagnose job per run waiting or working: a second request
-- returns it instead of queueing a duplicate.
CREATE UNIQUE INDEX jobs_diagnose_active ON jobs (run_id)
    WHERE kind = 'diagnose' AND state IN ('queued', 'running');
CREATE INDEX jobs_run_kind ON jobs (run_id, kind, created_at);

-- One report per succeeded diagnose job (the whole DiagnoseReport JSON).
CREATE TABLE diagnoses (
    job_id        TEXT PRIMARY KEY,
    run_id        TEXT NOT NULL REFERENCES runs(id) ON DELETE CASCADE,
    completed_at  INTEGER NOT NULL,
    report        TEXT NOT NULL
);
CREATE INDEX diagnoses_run_time ON diagnoses (run_id, completed_at);
