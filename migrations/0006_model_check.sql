-- Every result says whether the 24-parameter model explains its run (the
-- model check, SPEC §5), and a run whose result it does not is marked for
-- an engineer's review.
ALTER TABLE results ADD COLUMN model_adequate INTEGER;  -- 1 or 0; NULL for results stored before the check
ALTER TABLE results ADD COLUMN model_summary TEXT;      -- the check's verdict in words
ALTER TABLE runs ADD COLUMN review TEXT;                -- NULL until calibrated, then 'clear' or 'needs_review'
