-- Missions are stored as their native JSON (the validated, unit-converted form).
CREATE TABLE missions (
    id TEXT PRIMARY KEY NOT NULL,
    created_at_us BIGINT NOT NULL,
    source_format TEXT NOT NULL,
    body TEXT NOT NULL
);

-- Telemetry rows reference their mission, so an insert for an unknown (or concurrently
-- deleted) mission fails inside the insert itself.
-- Moving-obstacle observations; (mission, obstacle, time) identifies one, so a resend is
-- a duplicate. Times are Unix microseconds.
CREATE TABLE obstacle_observations (
    mission_id TEXT NOT NULL REFERENCES missions (id),
    obstacle_id TEXT NOT NULL,
    t_us BIGINT NOT NULL,
    lat_deg DOUBLE PRECISION NOT NULL,
    lon_deg DOUBLE PRECISION NOT NULL,
    alt_msl_m DOUBLE PRECISION NOT NULL,
    radius_m DOUBLE PRECISION NOT NULL,
    received_at_us BIGINT NOT NULL,
    PRIMARY KEY (mission_id, obstacle_id, t_us)
) WITHOUT ROWID;

CREATE TABLE aircraft_telemetry (
    mission_id TEXT NOT NULL REFERENCES missions (id),
    t_us BIGINT NOT NULL,
    lat_deg DOUBLE PRECISION NOT NULL,
    lon_deg DOUBLE PRECISION NOT NULL,
    alt_msl_m DOUBLE PRECISION NOT NULL,
    heading_deg DOUBLE PRECISION NOT NULL,
    speed_mps DOUBLE PRECISION,
    received_at_us BIGINT NOT NULL,
    PRIMARY KEY (mission_id, t_us)
) WITHOUT ROWID;
