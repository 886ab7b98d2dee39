-- Acceptance (CONTRACT §6a): product types with per-parameter limits, the
-- product each run names, and the verdict on each result.

-- A product type: its limits are a JSON object by canonical parameter
-- name, as validated by the library (`accept::ProductLimits`). `revision`
-- counts its versions; every version is kept in product_type_revisions.
CREATE TABLE product_types (
    name         TEXT PRIMARY KEY,
    description  TEXT,
    limits       TEXT NOT NULL,
    revision     INTEGER NOT NULL,
    created_at   INTEGER NOT NULL,
    updated_at   INTEGER NOT NULL
);

-- Every version of every product type, deletions included (limits NULL),
-- so that a stored verdict's (product, revision) names the limits it was
-- judged against. Revisions of a name keep counting across a delete and
-- a re-create.
CREATE TABLE product_type_revisions (
    name         TEXT NOT NULL,
    revision     INTEGER NOT NULL,
    description  TEXT,
    limits       TEXT,
    changed_at   INTEGER NOT NULL,
    changed_by   TEXT,                      -- the admin token's id
    PRIMARY KEY (name, revision)
);

-- The product a run's metadata names (SPEC §5 `product`), kept in a
-- column so that the runs of a product are found by index.
ALTER TABLE runs ADD COLUMN product TEXT;
UPDATE runs SET product = json_extract(metadata, '$.product')
    WHERE json_type(metadata, '$.product') = 'text';
CREATE INDEX runs_product ON runs (product, unit_serial);

-- A unit's product is its latest run's; its verdict is its latest
-- calibrated run's. Both are kept up to date by the store with the rows
-- they derive from, so that the units list filters by index.
ALTER TABLE units ADD COLUMN product TEXT;
ALTER TABLE units ADD COLUMN verdict TEXT
    CHECK (verdict IN ('accepted', 'rejected', 'needs_review'));
UPDATE units SET product = (SELECT r.product FROM runs r WHERE r.unit_serial = units.serial
                            ORDER BY r.run_time DESC, r.id DESC LIMIT 1);
CREATE INDEX units_product ON units (product, serial);
CREATE INDEX units_verdict ON units (verdict, serial);

-- What a verdict is judged on besides the values and σ: the result's
-- poorly observable parameters and the cross-check's flags (JSON arrays
-- of names; NULL for none known).
ALTER TABLE results ADD COLUMN poorly_observable TEXT;
ALTER TABLE results ADD COLUMN cross_check_flagged TEXT;
UPDATE results SET
    poorly_observable = (SELECT json_extract(d.result, '$.poorly_observable')
                         FROM result_documents d WHERE d.run_id = results.run_id),
    cross_check_flagged = (SELECT json_extract(d.result, '$.cross_check.flagged')
                           FROM result_documents d WHERE d.run_id = results.run_id);

-- The verdict: its status (filtered on), the whole verdict as JSON, the
-- product and product-type revision it was judged against (NULL revision:
-- no product type applied), and when it last changed. Results stored
-- before this migration are judged when the store opens.
ALTER TABLE results ADD COLUMN verdict TEXT
    CHECK (verdict IN ('accepted', 'rejected', 'needs_review'));
ALTER TABLE results ADD COLUMN verdict_detail TEXT;
ALTER TABLE results ADD COLUMN verdict_product TEXT;
ALTER TABLE results ADD COLUMN verdict_revision INTEGER;
ALTER TABLE results ADD COLUMN verdict_at INTEGER;
CREATE INDEX results_unit_verdict ON results (unit_serial, verdict, run_time, run_id);
