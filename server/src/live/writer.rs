//! A mission's writer side of the predictor, kept as two copies (the "left-right" pattern).
//!
//! Snapshots share the predictor (`Arc`), so the writer may not change a copy a snapshot
//! holds. Copying it for every batch (`Arc::make_mut`) cost time linear in the flight's
//! length: a track keeps every observation, and at 5 Hz with a map in use nearly every batch
//! found the predictor shared (issue 9's `plan_load`: ingest's `live` phase 0.15 ms in the
//! first 20 s of flight, 0.75 ms after 150 s, growing).
//!
//! Instead the writer keeps the copy it last had to leave to readers (the *spare*) and the
//! batches fed since. When the current copy is shared and the spare no longer is (the
//! snapshot that held it was replaced), the spare is brought up to date by feeding it
//! those batches, takes the new batch and becomes current; the shared copy becomes the
//! spare. A batch then costs feeding it twice, whatever the flight's length. Feeding is
//! deterministic and row by row, so both copies are the same predictor after the same
//! rows ([`super::snapshot`]'s test of batch-by-batch feeding). A copy is made only when
//! both are held by readers, or there is no spare yet.

use std::sync::Arc;

use predictor::Predictor;

use super::snapshot;
use crate::geodesy::LocalFrame;
use crate::store::ObservationRow;

/// The most batches kept for the spare; beyond, the spare is dropped (its memory freed):
/// a mission whose snapshots stopped sharing the predictor needs no spare.
const SPARE_MAX_BATCHES: usize = 64;

/// How a batch reached the current predictor (what the tests check).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Fed {
    /// The current copy was not shared: fed in place.
    InPlace,
    /// The spare was brought up to date and took the batch.
    Swapped,
    /// Both copies were held by readers (or there was no spare): the current one was copied.
    Copied,
}

#[derive(Debug)]
struct Spare {
    predictor: Arc<Predictor>,
    /// Batches fed to the current copy since the spare's state, oldest first.
    behind: Vec<Arc<[ObservationRow]>>,
}

/// The predictor a mission's writer feeds, and the batches applied.
#[derive(Debug)]
pub(super) struct Writer {
    predictor: Arc<Predictor>,
    /// Newest batch applied.
    pub(super) applied: i64,
    spare: Option<Spare>,
}

impl Writer {
    pub(super) fn new(predictor: Predictor) -> Self {
        Self {
            predictor: Arc::new(predictor),
            applied: 0,
            spare: None,
        }
    }

    /// The current predictor (every batch through [`Self::applied`]), shared.
    pub(super) fn predictor(&self) -> Arc<Predictor> {
        self.predictor.clone()
    }

    /// Feeds `rows` (one batch or more, in feeding order) to the current predictor.
    pub(super) fn feed(&mut self, frame: &LocalFrame, rows: &[ObservationRow]) -> Fed {
        if let Some(p) = Arc::get_mut(&mut self.predictor) {
            snapshot::feed(p, frame, rows);
            // The rows are kept only while a spare needs them.
            if let Some(s) = &mut self.spare {
                if s.behind.len() >= SPARE_MAX_BATCHES {
                    self.spare = None;
                } else {
                    s.behind.push(rows.into());
                }
            }
            return Fed::InPlace;
        }
        let rows: Arc<[ObservationRow]> = rows.into();
        let swapped = self.spare.take().and_then(|mut s| {
            let p = Arc::get_mut(&mut s.predictor)?;
            for b in &s.behind {
                snapshot::feed(p, frame, b);
            }
            snapshot::feed(p, frame, &rows);
            Some(s.predictor)
        });
        let (next, fed) = match swapped {
            Some(p) => (p, Fed::Swapped),
            None => {
                let mut p = Predictor::clone(&self.predictor);
                snapshot::feed(&mut p, frame, &rows);
                (Arc::new(p), Fed::Copied)
            }
        };
        let held = std::mem::replace(&mut self.predictor, next);
        self.spare = Some(Spare {
            predictor: held,
            behind: vec![rows],
        });
        fed
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::live::snapshot::predictor_config;

    fn frame() -> LocalFrame {
        LocalFrame::new(38.145, -76.428)
    }

    /// Batch `k`: three obstacles, one row each, 0.2 s apart.
    fn batch(k: usize) -> Vec<ObservationRow> {
        (0..3)
            .map(|i| {
                let t = k as f64 * 0.2;
                ObservationRow {
                    obstacle_id: i.to_string(),
                    t_s: t,
                    lat_deg: 38.145 + 1e-5 * t * (i + 1) as f64,
                    lon_deg: -76.428 + 1e-4 * (t * 0.3 + i as f64).sin(),
                    alt_msl_m: 80.0,
                    radius_m: 20.0,
                }
            })
            .collect()
    }

    fn state(p: &Predictor) -> String {
        format!("{p:?}")
    }

    #[test]
    fn the_two_copies_take_turns_and_end_equal_to_one_fed_every_row() {
        let f = frame();
        let mut w = Writer::new(Predictor::new(predictor_config()));
        let mut reference = Predictor::new(predictor_config());
        let mut held = Vec::new();
        let mut seen = Vec::new();
        for k in 0..40 {
            // A snapshot holds the current copy while the next batch comes, as with a map
            // in use; every fifth batch a second reader still holds the older copy too.
            let snap = w.predictor();
            if k % 5 != 0 {
                held.clear();
            }
            seen.push(w.feed(&f, &batch(k)));
            held.push(snap);
            snapshot::feed(&mut reference, &f, &batch(k));
            assert_eq!(state(&w.predictor()), state(&reference), "after batch {k}");
        }
        // Copies only at the start and when both copies were held; swaps otherwise.
        assert_eq!(seen[0], Fed::Copied);
        assert!(
            seen.iter().filter(|f| **f == Fed::Swapped).count() >= 28,
            "{seen:?}"
        );
        assert!(seen.contains(&Fed::Copied));
        // Nobody holds a copy: in place.
        held.clear();
        assert_eq!(w.feed(&f, &batch(40)), Fed::InPlace);
        snapshot::feed(&mut reference, &f, &batch(40));
        assert_eq!(state(&w.predictor()), state(&reference));
    }

    #[test]
    fn a_snapshot_keeps_the_state_it_was_taken_at() {
        let f = frame();
        let mut w = Writer::new(Predictor::new(predictor_config()));
        w.feed(&f, &batch(0));
        let before = w.predictor();
        let text = state(&before);
        for k in 1..5 {
            let _snap = w.predictor();
            w.feed(&f, &batch(k));
        }
        assert_eq!(state(&before), text);
        assert_ne!(state(&w.predictor()), text);
    }

    #[test]
    fn an_unshared_writer_drops_its_spare_after_a_bounded_number_of_batches() {
        let f = frame();
        let mut w = Writer::new(Predictor::new(predictor_config()));
        let snap = w.predictor();
        assert_eq!(w.feed(&f, &batch(0)), Fed::Copied);
        drop(snap);
        for k in 1..=SPARE_MAX_BATCHES {
            assert_eq!(w.feed(&f, &batch(k)), Fed::InPlace);
        }
        assert!(w.spare.is_none());
    }
}
