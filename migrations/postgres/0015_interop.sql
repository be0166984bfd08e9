-- Interop gateway (issue 15).
--
-- Missions the upstream link pulled from the judges' server (or `jink interop pull`):
-- their aircraft telemetry is forwarded upstream. A changed upstream mission is stored as
-- a new jink mission with a new row here; the newest row of an upstream mission is the
-- one in use.
CREATE TABLE interop_links (
    mission_id TEXT PRIMARY KEY NOT NULL,
    upstream_url TEXT NOT NULL,
    upstream_mission BIGINT NOT NULL,
    linked_at_us BIGINT NOT NULL
);

-- The forwarding queue's other half: the telemetry of linked missions not listed here is
-- still to be sent upstream, in the order it was accepted (received_at_us, t_us). A row is
-- written only after the upstream server acknowledged the sample ('sent') or refused it
-- for good with a 400/422 ('rejected'), so an outage or a restart loses nothing.
CREATE TABLE interop_forwarded (
    mission_id TEXT NOT NULL,
    t_us BIGINT NOT NULL,
    outcome TEXT NOT NULL,
    at_us BIGINT NOT NULL,
    PRIMARY KEY (mission_id, t_us)
);

-- Interop mission ids are integers; a mission with no interop id of its own gets
-- 1000000 + seq here the first time the interop surface shows it.
CREATE TABLE interop_numbers (
    seq BIGSERIAL PRIMARY KEY,
    mission_id TEXT NOT NULL UNIQUE
);
