-- A result's dwells against the positions of the scheme its run's
-- metadata declares, so that a run stopped short of its scheme is a
-- review reason when verdicts are judged again from the columns. NULL:
-- the run declares no scheme, or its result predates the columns.
ALTER TABLE results ADD COLUMN scheme_dwells_found INTEGER;
ALTER TABLE results ADD COLUMN scheme_positions_declared INTEGER;
