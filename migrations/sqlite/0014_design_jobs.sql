-- Design jobs: a scheme design runs as a job of kind 'design', which
-- belongs to no run (run_id NULL, and only for that kind), and its
-- request, who asked and its answer live in `designs`. SQLite cannot
-- change a column's NOT NULL or a CHECK in place: the table is rebuilt,
-- rows and indexes as they were (no table references jobs, so nothing
-- cascades).

CREATE TABLE jobs_new (
    id               TEXT PRIMARY KEY,
    run_id           TEXT REFERENCES runs(id) ON DELETE CASCADE,
    kind             TEXT NOT NULL DEFAULT 'calibrate' CHECK (kind IN ('calibrate', 'diagnose', 'design')),
    state            TEXT NOT NULL CHECK (state IN ('queued', 'running', 'succeeded', 'failed', 'dead_letter', 'cancelled')),
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
    finished_at      INTEGER,
    CHECK ((kind = 'design') = (run_id IS NULL))
);
INSERT INTO jobs_new (id, run_id, kind, state, attempts, max_attempts, lease_owner, lease_expires_at,
                      heartbeat_at, run_after, progress, stage, cancel_requested, error,
                      created_at, started_at, finished_at)
SELECT id, run_id, kind, state, attempts, max_attempts, lease_owner, lease_expires_at,
       heartbeat_at, run_after, progress, stage, cancel_requested, error,
       created_at, started_at, finished_at
FROM jobs;
DROP TABLE jobs;
ALTER TABLE jobs_new RENAME TO jobs;

CREATE INDEX jobs_claim ON jobs (state, run_after, created_at);
CREATE INDEX jobs_lease ON jobs (state, lease_expires_at);
CREATE UNIQUE INDEX jobs_calibrate_run ON jobs (run_id) WHERE kind = 'calibrate';
CREATE UNIQUE INDEX jobs_diagnose_active ON jobs (run_id)
    WHERE kind = 'diagnose' AND state IN ('queued', 'running');
CREATE INDEX jobs_run_kind ON jobs (run_id, kind, created_at);

-- One row per design job: the request as the client wrote it (JSON, the
-- body of POST /designs), the token that asked, and the design (JSON)
-- once the job succeeded.
CREATE TABLE designs (
    job_id       TEXT PRIMARY KEY REFERENCES jobs(id) ON DELETE CASCADE,
    request      TEXT NOT NULL,
    requested_by TEXT NOT NULL,
    created_at   INTEGER NOT NULL,
    completed_at INTEGER,
    design       TEXT
);
CREATE INDEX designs_created ON designs (created_at);
