-- Every result says whether the 24-parameter model explains its run (the
-- model check, SPEC §5). A run's review (pending, clear, needs_review) is
-- read from its result's row, not stored twice.
ALTER TABLE results ADD COLUMN model_adequate INTEGER;  -- 1 or 0; NULL for results stored before the check
ALTER TABLE results ADD COLUMN model_summary TEXT;      -- the check's verdict in words
