-- Browser sessions of the pages (the workbench). A session is opened by
-- signing in with a bearer token and acts with that token's role; the
-- cookie carries a random secret of which only the sha256 is stored, as
-- with tokens. Revoking the token ends its sessions (they are read through
-- a join on the live token).
CREATE TABLE sessions (
    hash        TEXT PRIMARY KEY,            -- sha256 hex of the cookie's secret
    token_id    TEXT NOT NULL REFERENCES tokens(id) ON DELETE CASCADE,
    created_at  INTEGER NOT NULL,
    expires_at  INTEGER NOT NULL
);
CREATE INDEX sessions_expiry ON sessions (expires_at);
