-- Access tokens (issue 12): a token is stored only as the SHA-256 digest of its text (hex);
-- its name identifies the writer of everything it stores. A revoked token keeps its row
-- (revoked_at_us set) so that its name is never given to another token.
CREATE TABLE tokens (
    name TEXT PRIMARY KEY NOT NULL,
    role TEXT NOT NULL,
    digest TEXT NOT NULL UNIQUE,
    created_at_us BIGINT NOT NULL,
    revoked_at_us BIGINT
);

-- Who wrote what: the name of the token that stored each row, or 'local' (no token, on a
-- loopback bind or with --auth off). Rows stored before this migration are 'local'.
ALTER TABLE missions ADD COLUMN written_by TEXT NOT NULL DEFAULT 'local';
ALTER TABLE obstacle_observations ADD COLUMN written_by TEXT NOT NULL DEFAULT 'local';
ALTER TABLE aircraft_telemetry ADD COLUMN written_by TEXT NOT NULL DEFAULT 'local';
ALTER TABLE plans ADD COLUMN written_by TEXT NOT NULL DEFAULT 'local';
