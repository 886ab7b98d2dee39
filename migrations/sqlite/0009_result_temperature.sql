-- The temperature of a result's run (SPEC §3a: metadata temperature_c or
-- the temp_c column), so that a unit's thermal model reads its results'
-- parameters and temperatures without their documents. NULL: the run
-- stated none.
ALTER TABLE results ADD COLUMN temperature_c REAL;
ALTER TABLE results ADD COLUMN temperature_span_c REAL;
