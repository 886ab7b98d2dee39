-- Design jobs (SQLite's 0014): a job of kind 'design' belongs to no run
-- (run_id NULL, and only for that kind); its request, who asked and its
-- answer live in `designs`.

ALTER TABLE jobs ALTER COLUMN run_id DROP NOT NULL;
ALTER TABLE jobs DROP CONSTRAINT jobs_kind_check;
ALTER TABLE jobs ADD CONSTRAINT jobs_kind_check CHECK (kind IN ('calibrate', 'diagnose', 'design'));
ALTER TABLE jobs ADD CONSTRAINT jobs_run_unless_design CHECK ((kind = 'design') = (run_id IS NULL));

CREATE TABLE designs (
    job_id       TEXT PRIMARY KEY REFERENCES jobs(id) ON DELETE CASCADE,
    request      TEXT NOT NULL,
    requested_by TEXT NOT NULL,
    created_at   BIGINT NOT NULL,
    completed_at BIGINT,
    design       TEXT
);
CREATE INDEX designs_created ON designs (created_at);
