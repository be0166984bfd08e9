//! One moving obstacle's track (seed 002, "Heading, speed, turn radius characterizations"):
//! observations kept in timestamp order, duplicates recognised, physically impossible
//! observations flagged rather than trusted, and position interpolation along the track.
//!
//! # Units
//! ENU metres, mission seconds, metres per second.

use geom::dist;

/// One observation of an obstacle.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Observation {
    /// Mission time, seconds.
    pub t_s: f64,
    /// Position, ENU metres `[east, north]`.
    pub p_m: [f64; 2],
    /// Altitude of the sphere's centre, metres (MSL or above home, as the caller uses).
    pub alt_m: f64,
    /// Sphere radius, metres.
    pub radius_m: f64,
}

/// What the track did with an observation.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case", tag = "outcome"))]
pub enum ObserveOutcome {
    /// Stored in its place by timestamp.
    Accepted,
    /// The same observation (same time and position) was already stored; nothing changed.
    Duplicate,
    /// Rejected as contradicting physics: reaching it from a neighbouring observation needs
    /// `implied_speed_mps` (infinite for a different position at the same timestamp).
    Flagged {
        /// Speed implied by the jump, m/s.
        implied_speed_mps: f64,
    },
}

/// Observations of one obstacle, sorted by time.
#[derive(Debug, Default)]
pub struct Track {
    obs: Vec<Observation>,
    flagged: usize,
    duplicates: usize,
}

impl Clone for Track {
    fn clone(&self) -> Self {
        Self {
            obs: clone_with_headroom(&self.obs),
            flagged: self.flagged,
            duplicates: self.duplicates,
        }
    }
}

/// A copy of `v` with room for more elements: a live mission's predictor is cloned when
/// snapshots hold both of the server's copies (its writer's left-right pair), and the
/// clone then grows by one observation per obstacle. With the capacity of a plain clone
/// (its length) that first push reallocated and copied the whole history a second time.
pub(crate) fn clone_with_headroom<T: Clone>(v: &[T]) -> Vec<T> {
    let mut c = Vec::with_capacity(v.len() + v.len() / 8 + 16);
    c.extend_from_slice(v);
    c
}

/// Positions closer than this (metres) at the same timestamp count as the same observation.
const SAME_POSITION_M: f64 = 1e-6;

impl Track {
    /// Inserts `o` in timestamp order. `flag_speed_mps` is the largest believable speed;
    /// `noise_m` is subtracted from jumps before dividing by the time step so that position
    /// noise at 10 Hz does not look like speed. Returns the outcome and, when accepted, the
    /// index the observation took.
    pub fn insert(
        &mut self,
        o: Observation,
        flag_speed_mps: f64,
        noise_m: f64,
    ) -> (ObserveOutcome, Option<usize>) {
        let i = self.obs.partition_point(|x| x.t_s < o.t_s);
        if let Some(same) = self.obs.get(i).filter(|x| x.t_s == o.t_s) {
            if dist(same.p_m, o.p_m) <= SAME_POSITION_M {
                self.duplicates += 1;
                return (ObserveOutcome::Duplicate, None);
            }
            self.flagged += 1;
            return (
                ObserveOutcome::Flagged {
                    implied_speed_mps: f64::INFINITY,
                },
                None,
            );
        }
        let implied = |n: &Observation| {
            let dt = (o.t_s - n.t_s).abs();
            (dist(o.p_m, n.p_m) - noise_m).max(0.0) / dt
        };
        let mut worst: f64 = 0.0;
        if i > 0 {
            worst = worst.max(implied(&self.obs[i - 1]));
        }
        if let Some(next) = self.obs.get(i) {
            worst = worst.max(implied(next));
        }
        if worst > flag_speed_mps {
            self.flagged += 1;
            return (
                ObserveOutcome::Flagged {
                    implied_speed_mps: worst,
                },
                None,
            );
        }
        self.obs.insert(i, o);
        (ObserveOutcome::Accepted, Some(i))
    }

    /// The stored observations, oldest first.
    pub fn observations(&self) -> &[Observation] {
        &self.obs
    }

    /// Number of stored observations.
    pub fn len(&self) -> usize {
        self.obs.len()
    }

    /// True when nothing is stored.
    pub fn is_empty(&self) -> bool {
        self.obs.is_empty()
    }

    /// The newest observation.
    pub fn last(&self) -> Option<&Observation> {
        self.obs.last()
    }

    /// Observations refused as physically impossible.
    pub fn flagged(&self) -> usize {
        self.flagged
    }

    /// Observations recognised as duplicates.
    pub fn duplicates(&self) -> usize {
        self.duplicates
    }

    /// Position at `t_s` by linear interpolation between the bracketing observations;
    /// `None` outside the track or across a gap longer than `max_gap_s`.
    pub fn position_at(&self, t_s: f64, max_gap_s: f64) -> Option<[f64; 2]> {
        let first = self.obs.first()?;
        let last = self.obs.last()?;
        if t_s < first.t_s || t_s > last.t_s {
            return None;
        }
        let i = self.obs.partition_point(|x| x.t_s < t_s);
        let b = &self.obs[i];
        if b.t_s == t_s {
            return Some(b.p_m);
        }
        let a = &self.obs[i - 1];
        let span = b.t_s - a.t_s;
        if span > max_gap_s {
            return None;
        }
        let f = (t_s - a.t_s) / span;
        Some([
            a.p_m[0] + (b.p_m[0] - a.p_m[0]) * f,
            a.p_m[1] + (b.p_m[1] - a.p_m[1]) * f,
        ])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn o(t_s: f64, x: f64) -> Observation {
        Observation {
            t_s,
            p_m: [x, 0.0],
            alt_m: 50.0,
            radius_m: 10.0,
        }
    }

    #[test]
    fn a_cloned_track_takes_its_next_observations_without_copying_its_history_again() {
        let mut tr = Track::default();
        for k in 0..1000 {
            tr.insert(o(f64::from(k) * 0.2, f64::from(k)), 41.0, 2.0);
        }
        let mut c = tr.clone();
        assert_eq!(c.observations(), tr.observations());
        // Room for 100 more observations in the buffer the clone allocated (a derived
        // clone has none: its capacity is its length).
        assert!(c.obs.capacity() >= 1100, "capacity {}", c.obs.capacity());
        for k in 1000..1100 {
            c.insert(o(f64::from(k) * 0.2, f64::from(k)), 41.0, 2.0);
        }
        assert_eq!(c.len(), 1100);
        assert_eq!(tr.len(), 1000);
    }

    #[test]
    fn out_of_order_observations_take_their_place_and_duplicates_are_idempotent() {
        let mut tr = Track::default();
        assert_eq!(
            tr.insert(o(0.0, 0.0), 41.0, 2.0).0,
            ObserveOutcome::Accepted
        );
        assert_eq!(
            tr.insert(o(2.0, 20.0), 41.0, 2.0).0,
            ObserveOutcome::Accepted
        );
        assert_eq!(
            tr.insert(o(1.0, 10.0), 41.0, 2.0),
            (ObserveOutcome::Accepted, Some(1))
        );
        assert_eq!(
            tr.insert(o(1.0, 10.0), 41.0, 2.0).0,
            ObserveOutcome::Duplicate
        );
        let ts: Vec<f64> = tr.observations().iter().map(|x| x.t_s).collect();
        assert_eq!(ts, vec![0.0, 1.0, 2.0]);
        assert_eq!(tr.duplicates(), 1);
        // Halfway between t=1 (x=10) and t=2 (x=20).
        assert_eq!(tr.position_at(1.5, 5.0), Some([15.0, 0.0]));
    }

    #[test]
    fn an_impossible_jump_is_flagged_with_its_implied_speed() {
        let mut tr = Track::default();
        tr.insert(o(0.0, 0.0), 41.0, 2.0);
        // 102 m in 1 s, minus 2 m of allowed noise: 100 m/s.
        let (out, _) = tr.insert(o(1.0, 102.0), 41.0, 2.0);
        assert_eq!(
            out,
            ObserveOutcome::Flagged {
                implied_speed_mps: 100.0
            }
        );
        assert_eq!(tr.len(), 1);
        assert_eq!(tr.flagged(), 1);
    }
}
