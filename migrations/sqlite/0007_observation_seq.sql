-- Live mission state: every accepted observation batch takes its mission's next sequence
-- number (missions.obs_seq, bumped inside the batch's transaction, so on PostgreSQL the
-- mission row's lock makes sequence order commit order). A replica catches up with
-- "seq > the last one applied"; a plan records the sequence number its inputs were cut at.
-- Rows stored before this migration keep seq 0 (replayed first, in time order).
ALTER TABLE missions ADD COLUMN obs_seq BIGINT NOT NULL DEFAULT 0;
ALTER TABLE obstacle_observations ADD COLUMN seq BIGINT NOT NULL DEFAULT 0;
CREATE INDEX obstacle_observations_by_seq ON obstacle_observations (mission_id, seq);
