-- Calibration certificates: one per approved result (as sqlite 0013).
CREATE TABLE certificates (
    seq            BIGINT PRIMARY KEY,
    number         TEXT NOT NULL UNIQUE,
    run_id         TEXT NOT NULL,
    result_seq     BIGINT NOT NULL,
    job_id         TEXT NOT NULL,
    unit_serial    TEXT NOT NULL,
    issued_at      BIGINT NOT NULL,
    approved_by    TEXT NOT NULL,
    approver_token TEXT NOT NULL,
    approver_role  TEXT NOT NULL CHECK (approver_role IN ('engineer', 'admin')),
    approved_at    BIGINT NOT NULL
);
CREATE UNIQUE INDEX certificates_result ON certificates (run_id, result_seq);
