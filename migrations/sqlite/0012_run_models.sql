-- Which error model each calibration carries, and the results a run had
-- before its model changed.
--
-- A run's calibration model is the one adopted for it from a diagnosis
-- (runs.model), else its product type's (product_types.model), else the
-- server's. Every result states the model it was made with, in a column
-- so that history and repeatability show it without reading documents.
ALTER TABLE runs ADD COLUMN model TEXT;              -- adopted model, e.g. base-24+accel_delay
ALTER TABLE runs ADD COLUMN model_diagnosis TEXT;    -- the diagnose job whose named effects it adopts
ALTER TABLE runs ADD COLUMN model_adopted_by TEXT;   -- the token that adopted it
ALTER TABLE runs ADD COLUMN model_adopted_at INTEGER;

ALTER TABLE product_types ADD COLUMN model TEXT;     -- the line's model; NULL: the server's
ALTER TABLE product_type_revisions ADD COLUMN model TEXT;

ALTER TABLE results ADD COLUMN model TEXT;
UPDATE results SET model = (SELECT json_extract(d.result, '$.model') FROM result_documents d
                            WHERE d.run_id = results.run_id);

-- A run calibrated again (a new model adopted, or the calibration asked
-- for again) keeps the result it replaces here, numbered from 1 in the
-- order they were replaced; the current result is the run's last.
CREATE TABLE superseded_results (
    run_id          TEXT NOT NULL REFERENCES runs(id) ON DELETE CASCADE,
    seq             INTEGER NOT NULL,
    job_id          TEXT NOT NULL,
    model           TEXT,
    completed_at    INTEGER NOT NULL,
    superseded_at   INTEGER NOT NULL,
    verdict         TEXT,
    model_adequate  INTEGER,
    result          TEXT NOT NULL,      -- the whole CalibrationResult JSON
    PRIMARY KEY (run_id, seq)
);
