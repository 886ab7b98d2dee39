-- sinscal server schema. Times are integer Unix milliseconds (UTC): they
-- sort and compare as numbers and the API renders them as RFC 3339.

CREATE TABLE tokens (
    id          TEXT PRIMARY KEY,            -- uuid, names the token without revealing it
    hash        TEXT NOT NULL UNIQUE,        -- sha256 hex of the bearer token; the token itself is never stored
    role        TEXT NOT NULL CHECK (role IN ('station', 'engineer', 'admin')),
    label       TEXT,
    created_at  INTEGER NOT NULL,
    revoked_at  INTEGER
);

CREATE TABLE units (
    serial      TEXT PRIMARY KEY,
    created_at  INTEGER NOT NULL
);

CREATE TABLE runs (
    id           TEXT PRIMARY KEY,           -- uuid; the blob path derives from it, never from user input
    unit_serial  TEXT NOT NULL REFERENCES units(serial),
    sha256       TEXT NOT NULL,
    size_bytes   INTEGER NOT NULL,
    records      INTEGER NOT NULL,
    format       TEXT NOT NULL,              -- csv | f64le
    gzip         INTEGER NOT NULL,
    blob_path    TEXT NOT NULL,              -- relative to the data directory
    metadata     TEXT NOT NULL,              -- SPEC §5 metadata JSON as validated
    recorded_at  INTEGER,                    -- metadata.recorded_at, when given
    run_time     INTEGER NOT NULL,           -- recorded_at, else uploaded_at: the time history sorts by
    uploaded_at  INTEGER NOT NULL,
    UNIQUE (unit_serial, sha256)             -- the same bytes for the same unit are one run
);
CREATE INDEX runs_unit_time ON runs (unit_serial, run_time);

CREATE TABLE jobs (
    id               TEXT PRIMARY KEY,
    run_id           TEXT NOT NULL UNIQUE REFERENCES runs(id) ON DELETE CASCADE,
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
CREATE INDEX jobs_claim ON jobs (state, run_after, created_at);
CREATE INDEX jobs_lease ON jobs (state, lease_expires_at);

CREATE TABLE results (
    run_id        TEXT PRIMARY KEY REFERENCES runs(id) ON DELETE CASCADE,
    job_id        TEXT NOT NULL,
    unit_serial   TEXT NOT NULL,
    run_time      INTEGER NOT NULL,
    completed_at  INTEGER NOT NULL,
    parameters    TEXT NOT NULL,   -- JSON of the 24 {value, sigma, unit}: what history returns, one row per run
    result        TEXT NOT NULL    -- the whole CalibrationResult JSON
);
CREATE INDEX results_unit_time ON results (unit_serial, run_time);

-- One row per run and parameter, so repeatability is one indexed SQL query.
CREATE TABLE result_params (
    run_id       TEXT NOT NULL REFERENCES runs(id) ON DELETE CASCADE,
    unit_serial  TEXT NOT NULL,
    run_time     INTEGER NOT NULL,
    name         TEXT NOT NULL,
    value        REAL NOT NULL,
    sigma        REAL NOT NULL,
    unit         TEXT NOT NULL,
    PRIMARY KEY (run_id, name)
);
CREATE INDEX result_params_unit ON result_params (unit_serial, name, run_time);
