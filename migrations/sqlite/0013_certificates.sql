-- Calibration certificates: one per approved result. A certificate is
-- issued when an engineer or admin approves a run's current result (its
-- calibration job), so a draft has no row and takes no number; the issue
-- date is the approval's. A run calibrated again has a new current result
-- that needs its own approval: the old certificate stays, naming the
-- result (now in superseded_results) it certified.
--
-- No foreign key to runs: a certificate is a record filed elsewhere, and
-- outlives its run (deleting a run keeps its certificates, so a number is
-- never issued twice).
CREATE TABLE certificates (
    seq            INTEGER PRIMARY KEY,      -- 1, 2, …: the number's digits
    number         TEXT NOT NULL UNIQUE,     -- e.g. SC-000042
    run_id         TEXT NOT NULL,
    result_seq     INTEGER NOT NULL,         -- the result it certifies: its number among the run's results
    job_id         TEXT NOT NULL,            -- and its calibration job (a run calibrated again keeps its job)
    unit_serial    TEXT NOT NULL,
    issued_at      INTEGER NOT NULL,
    approved_by    TEXT NOT NULL,            -- the approving token's label, else its id
    approver_token TEXT NOT NULL,            -- the approving token's id
    approver_role  TEXT NOT NULL CHECK (approver_role IN ('engineer', 'admin')),
    approved_at    INTEGER NOT NULL
);
CREATE UNIQUE INDEX certificates_result ON certificates (run_id, result_seq);
