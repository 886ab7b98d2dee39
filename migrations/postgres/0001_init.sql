-- The schema on PostgreSQL: the state the SQLite migrations 0001–0009 reach,
-- in one step (a PostgreSQL database starts at this schema; it never held
-- the earlier ones). Types are chosen so that the SQL text the store shares
-- between the two engines means the same on both:
-- - times are BIGINT milliseconds, counts BIGINT (SQLite's INTEGER is 64-bit);
-- - flags are BOOLEAN, written TRUE/FALSE in SQL (SQLite reads them as 1/0);
-- - REAL is DOUBLE PRECISION, BLOB is BYTEA;
-- - the closed vocabularies are TEXT with the same CHECK lists.

CREATE TABLE tokens (
    id          TEXT PRIMARY KEY,
    hash        TEXT NOT NULL UNIQUE,        -- sha256 hex of the bearer token; the token itself is never stored
    role        TEXT NOT NULL CHECK (role IN ('station', 'engineer', 'admin')),
    label       TEXT,
    created_at  BIGINT NOT NULL,
    revoked_at  BIGINT
);

CREATE TABLE units (
    serial      TEXT PRIMARY KEY,
    created_at  BIGINT NOT NULL,
    product     TEXT,
    verdict     TEXT CHECK (verdict IN ('accepted', 'rejected', 'needs_review'))
);
CREATE INDEX units_product ON units (product, serial);
CREATE INDEX units_verdict ON units (verdict, serial);

CREATE TABLE runs (
    id           TEXT PRIMARY KEY,           -- uuid; the blob path derives from it, never from user input
    unit_serial  TEXT NOT NULL REFERENCES units(serial),
    sha256       TEXT NOT NULL,
    size_bytes   BIGINT NOT NULL,
    records      BIGINT NOT NULL,
    format       TEXT NOT NULL,              -- csv | f64le
    gzip         BOOLEAN NOT NULL,
    blob_path    TEXT NOT NULL,              -- relative to the run store's root
    metadata     TEXT NOT NULL,              -- SPEC §5 metadata JSON as validated
    recorded_at  BIGINT,
    run_time     BIGINT NOT NULL,            -- recorded_at, else uploaded_at: the time history sorts by
    uploaded_at  BIGINT NOT NULL,
    uploaded_by  TEXT,
    product      TEXT,
    UNIQUE (unit_serial, sha256)             -- the same bytes for the same unit are one run
);
CREATE INDEX runs_unit_time ON runs (unit_serial, run_time);
CREATE INDEX runs_uploaded_by ON runs (uploaded_by);
CREATE INDEX runs_product ON runs (product, unit_serial);

CREATE TABLE jobs (
    id               TEXT PRIMARY KEY,
    run_id           TEXT NOT NULL REFERENCES runs(id) ON DELETE CASCADE,
    kind             TEXT NOT NULL DEFAULT 'calibrate' CHECK (kind IN ('calibrate', 'diagnose')),
    state            TEXT NOT NULL CHECK (state IN ('queued', 'running', 'succeeded', 'failed', 'dead_letter', 'cancelled')),
    attempts         BIGINT NOT NULL DEFAULT 0,   -- also the fencing token of the current lease
    max_attempts     BIGINT NOT NULL,
    lease_owner      TEXT,
    lease_expires_at BIGINT,
    heartbeat_at     BIGINT,
    run_after        BIGINT NOT NULL,             -- retry backoff: not claimable before this
    progress         DOUBLE PRECISION NOT NULL DEFAULT 0,
    stage            TEXT,
    cancel_requested BOOLEAN NOT NULL DEFAULT FALSE,
    error            TEXT,
    created_at       BIGINT NOT NULL,
    started_at       BIGINT,
    finished_at      BIGINT
);
CREATE INDEX jobs_claim ON jobs (state, run_after, created_at);
CREATE INDEX jobs_lease ON jobs (state, lease_expires_at);
CREATE UNIQUE INDEX jobs_calibrate_run ON jobs (run_id) WHERE kind = 'calibrate';
CREATE UNIQUE INDEX jobs_diagnose_active ON jobs (run_id)
    WHERE kind = 'diagnose' AND state IN ('queued', 'running');
CREATE INDEX jobs_run_kind ON jobs (run_id, kind, created_at);

CREATE TABLE diagnoses (
    job_id        TEXT PRIMARY KEY,
    run_id        TEXT NOT NULL REFERENCES runs(id) ON DELETE CASCADE,
    completed_at  BIGINT NOT NULL,
    report        TEXT NOT NULL
);
CREATE INDEX diagnoses_run_time ON diagnoses (run_id, completed_at);

CREATE TABLE result_documents (
    run_id  TEXT PRIMARY KEY REFERENCES runs(id) ON DELETE CASCADE,
    result  TEXT NOT NULL      -- the whole CalibrationResult JSON
);

CREATE TABLE results (
    run_id              TEXT PRIMARY KEY REFERENCES runs(id) ON DELETE CASCADE,
    job_id              TEXT NOT NULL,
    unit_serial         TEXT NOT NULL,
    run_time            BIGINT NOT NULL,
    completed_at        BIGINT NOT NULL,
    parameters          TEXT NOT NULL,   -- JSON of the 24 {value, sigma, unit}: what history returns
    param_values        BYTEA,           -- 24 f64 LE, canonical order
    model_adequate      BOOLEAN,
    model_summary       TEXT,
    poorly_observable   TEXT,
    cross_check_flagged TEXT,
    verdict             TEXT CHECK (verdict IN ('accepted', 'rejected', 'needs_review')),
    verdict_detail      TEXT,
    verdict_product     TEXT,
    verdict_revision    BIGINT,
    verdict_at          BIGINT,
    temperature_c       DOUBLE PRECISION,
    temperature_span_c  DOUBLE PRECISION
);
-- PostgreSQL cannot carry a BYTEA in a btree key past ~2.7 kB, and the blob
-- is 192 bytes: INCLUDE keeps the index-only scan of repeatability.
CREATE INDEX results_unit_values ON results (unit_serial, run_time, run_id) INCLUDE (param_values);
CREATE INDEX results_unit_verdict ON results (unit_serial, verdict, run_time, run_id);

CREATE TABLE write_probe (
    id         BIGINT PRIMARY KEY CHECK (id = 1),
    checked_at BIGINT NOT NULL
);

CREATE TABLE product_types (
    name         TEXT PRIMARY KEY,
    description  TEXT,
    limits       TEXT NOT NULL,
    revision     BIGINT NOT NULL,
    created_at   BIGINT NOT NULL,
    updated_at   BIGINT NOT NULL
);

CREATE TABLE product_type_revisions (
    name         TEXT NOT NULL,
    revision     BIGINT NOT NULL,
    description  TEXT,
    limits       TEXT,
    changed_at   BIGINT NOT NULL,
    changed_by   TEXT,                      -- the admin token's id
    PRIMARY KEY (name, revision)
);

CREATE TABLE sessions (
    hash        TEXT PRIMARY KEY,            -- sha256 hex of the cookie's secret
    token_id    TEXT NOT NULL REFERENCES tokens(id) ON DELETE CASCADE,
    created_at  BIGINT NOT NULL,
    expires_at  BIGINT NOT NULL
);
CREATE INDEX sessions_expiry ON sessions (expires_at);
