-- History and repeatability read small rows. Two changes:
--
-- 1. The whole result document (its convergence history is ~1 MB of JSON)
--    moves to its own table: left in `results` it filled overflow pages
--    that every read of a later column had to walk, and made the table
--    scanned by history a thousand times larger than what history returns.
-- 2. Each result keeps its 24 values as one blob, 24 little-endian f64 in
--    the canonical order of SPEC §2 (NaN for a parameter the result
--    lacks), so repeatability reads one index entry per run instead of 24
--    rows. Results stored before this migration get their blob from
--    `parameters` (JSON) when the store opens; the per-parameter rows are
--    then redundant.

CREATE TABLE result_documents (
    run_id  TEXT PRIMARY KEY REFERENCES runs(id) ON DELETE CASCADE,
    result  TEXT NOT NULL      -- the whole CalibrationResult JSON
);
INSERT INTO result_documents (run_id, result) SELECT run_id, result FROM results;

-- Rebuilt rather than ALTER TABLE DROP COLUMN, which trips over the
-- comments in the original CREATE TABLE text. Nothing references results.
CREATE TABLE results_new (
    run_id        TEXT PRIMARY KEY REFERENCES runs(id) ON DELETE CASCADE,
    job_id        TEXT NOT NULL,
    unit_serial   TEXT NOT NULL,
    run_time      INTEGER NOT NULL,
    completed_at  INTEGER NOT NULL,
    parameters    TEXT NOT NULL,   -- JSON of the 24 {value, sigma, unit}: what history returns
    param_values  BLOB             -- 24 f64 LE, canonical order; NULL until backfilled
);
INSERT INTO results_new (run_id, job_id, unit_serial, run_time, completed_at, parameters)
SELECT run_id, job_id, unit_serial, run_time, completed_at, parameters FROM results;
DROP TABLE results;
ALTER TABLE results_new RENAME TO results;
DROP TABLE result_params;

-- History pages in (time, run id) order; repeatability reads the blobs
-- from this index alone.
CREATE INDEX results_unit_values ON results (unit_serial, run_time, run_id, param_values);
