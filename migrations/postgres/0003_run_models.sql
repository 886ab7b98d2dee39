-- Which error model each calibration carries, and the results a run had
-- before its model changed (as sqlite 0012).
ALTER TABLE runs ADD COLUMN model TEXT;
ALTER TABLE runs ADD COLUMN model_diagnosis TEXT;
ALTER TABLE runs ADD COLUMN model_adopted_by TEXT;
ALTER TABLE runs ADD COLUMN model_adopted_at BIGINT;

ALTER TABLE product_types ADD COLUMN model TEXT;
ALTER TABLE product_type_revisions ADD COLUMN model TEXT;

ALTER TABLE results ADD COLUMN model TEXT;
UPDATE results SET model = (SELECT d.result::jsonb ->> 'model' FROM result_documents d
                            WHERE d.run_id = results.run_id);

CREATE TABLE superseded_results (
    run_id          TEXT NOT NULL REFERENCES runs(id) ON DELETE CASCADE,
    seq             BIGINT NOT NULL,
    job_id          TEXT NOT NULL,
    model           TEXT,
    completed_at    BIGINT NOT NULL,
    superseded_at   BIGINT NOT NULL,
    verdict         TEXT,
    model_adequate  BOOLEAN,
    result          TEXT NOT NULL,
    PRIMARY KEY (run_id, seq)
);
