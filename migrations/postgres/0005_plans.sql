-- Plans: each revision of a mission's waypoint stack, with everything needed to replay it
-- (inputs: telemetry start, stack, observations, parameters; the seed) and the answer.
CREATE TABLE plans (
    id TEXT PRIMARY KEY NOT NULL,
    mission_id TEXT NOT NULL REFERENCES missions (id),
    revision BIGINT NOT NULL,
    created_at_us BIGINT NOT NULL,
    seed TEXT NOT NULL,
    inputs TEXT NOT NULL,
    body TEXT NOT NULL,
    UNIQUE (mission_id, revision)
);
