-- Repeatability reads (unit, name, time, value) only: a covering index in
-- (name, time) order lets SQLite aggregate and run LAG() without touching
-- the table or sorting.
DROP INDEX result_params_unit;
CREATE INDEX result_params_cover ON result_params (unit_serial, name, run_time, value);
