//! Replicas on one PostgreSQL database: a dedicated connection `LISTEN`s to
//! [`OBSERVATION_CHANNEL`], on which every committed observation batch announces
//! `"<seq> <mission id>"` (sent inside the batch's transaction, so only committed batches
//! are announced). A live mission behind that number catches up with one read of the
//! missing batches. After the connection drops, the listener reconnects (sqlx's
//! `PgListener` does) and catches every live mission up, since notifications sent while
//! it was away are lost. The database is the only coordination between replicas.
//!
//! Delay bound: a notification arrives a few milliseconds after the commit on loopback;
//! independently, every read on PostgreSQL checks the store's batch number first (see
//! [`super::MissionLive::snapshot`]), so a plan never sees less than was committed before
//! it arrived.

use std::time::Duration;

use sqlx::postgres::PgListener;

use crate::app::AppState;
use crate::store::observations::OBSERVATION_CHANNEL;
use wire::ids::MissionId;

/// Parses a notification payload `"<seq> <mission id>"`.
pub fn parse_payload(payload: &str) -> Option<(i64, &str)> {
    let (seq, id) = payload.split_once(' ')?;
    Some((seq.parse().ok()?, id))
}

/// Listens until the process ends (spawn it once per server on PostgreSQL).
pub async fn listen(state: AppState, url: String) {
    loop {
        match PgListener::connect(&url).await {
            Ok(mut listener) => {
                if let Err(e) = listener.listen(OBSERVATION_CHANNEL).await {
                    tracing::warn!(error = %e, "LISTEN failed; retrying");
                } else {
                    tracing::info!(
                        channel = OBSERVATION_CHANNEL,
                        "listening for other replicas' batches"
                    );
                    // Anything committed before the LISTEN took effect.
                    state.live.catch_up_all(&state).await;
                    loop {
                        match listener.try_recv().await {
                            Ok(Some(n)) => {
                                if let Some((seq, id)) = parse_payload(n.payload()) {
                                    state.live.notified(&state, &MissionId::from(id), seq).await;
                                }
                            }
                            // The connection was lost and is re-established by the next
                            // call: notifications in between are lost, so catch up.
                            Ok(None) => state.live.catch_up_all(&state).await,
                            Err(e) => {
                                tracing::warn!(error = %e, "listener failed; reconnecting");
                                break;
                            }
                        }
                    }
                }
            }
            Err(e) => tracing::warn!(error = %e, "cannot connect the listener; retrying"),
        }
        tokio::time::sleep(Duration::from_secs(1)).await;
    }
}

#[cfg(test)]
mod tests {
    use super::parse_payload;

    #[test]
    fn a_payload_names_the_batch_and_the_mission_even_with_spaces_in_the_id() {
        assert_eq!(parse_payload("12 webster"), Some((12, "webster")));
        assert_eq!(parse_payload("3 a b"), Some((3, "a b")));
        assert_eq!(parse_payload("x webster"), None);
        assert_eq!(parse_payload("12"), None);
    }
}
