-- Whether a run's calibration fits a bias wander its dwells do not show
-- (EstimateOptions::fit_unseen_wander): set by an engineer who asks for
-- the calibration again after the discrepancy workflow named no effect
-- for a failed check whose result proposed it; kept for later
-- calibrations of the run until asked otherwise.
ALTER TABLE runs ADD COLUMN fit_unseen_wander INTEGER NOT NULL DEFAULT 0;
