-- A noise model held for a unit (its characterisation, e.g. a long static
-- recording): each later calibration job of the unit's runs carries it,
-- as the run's noise model ('given') or as the reference its own fitted
-- model is tested against ('reference'). One per unit; replacing it keeps
-- no history here, since each result states the model it ran under.
CREATE TABLE unit_noise_models (
    unit_serial  TEXT PRIMARY KEY REFERENCES units(serial),
    noise        TEXT NOT NULL,          -- JSON object of the noise terms as checked (calib::held_noise)
    used_as      TEXT NOT NULL CHECK (used_as IN ('given', 'reference')),
    set_by       TEXT NOT NULL,          -- the token's id
    set_at       INTEGER NOT NULL
);
