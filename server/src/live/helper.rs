//! A second pair of hands for live map builds (issue 9): a plan waits for the map of the
//! batch posted just before it, and on the two cores a field laptop has, one core builds
//! that map (its CPU slot, [`crate::cpu`]) while the other, kept for the async runtime, is
//! mostly idle. The helper is one thread at the lowest priority (SCHED_IDLE) that takes
//! obstacles from the back of a build's list while the build takes them from the front,
//! each on a map of its own; the build then puts the helper's parts into its map
//! ([`predictor::RiskMap::put_layer`]) in the list's order, so the cells are those of a
//! one-thread build, bit for bit (replay rebuilds them without the helper).
//!
//! The build never waits for the helper: an obstacle the helper took but has not finished
//! when the two meet is computed again by the build (the helper's late part is dropped).
//! So a helper starved by a busy runtime costs the build at most the two lock operations
//! per obstacle, and ingest on the runtime keeps its core: under SCHED_IDLE any thread
//! that wakes preempts the helper at once (at nice 19 alone, measured, the client-side
//! ingest p99 rose by 1-4 ms: the helper ran on until the scheduler preempted it).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::sync::{Arc, Mutex};

use predictor::{Layer, Predictor, RiskMap, RiskMapConfig};

/// The obstacles of a build not yet taken: `front..back`.
#[derive(Debug)]
struct Claims {
    front: usize,
    back: usize,
}

/// One map build shared with the helper.
#[derive(Debug)]
struct Job {
    predictor: Arc<Predictor>,
    cfg: RiskMapConfig,
    t0_s: f64,
    ids: Vec<String>,
    claims: Mutex<Claims>,
    /// The helper's finished parts, by index in `ids`.
    slots: Vec<Mutex<Option<Layer>>>,
    /// The build has finished: the helper stops taking obstacles.
    done: AtomicBool,
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

impl Job {
    fn take_front(&self) -> Option<usize> {
        let mut c = lock(&self.claims);
        (c.front < c.back).then(|| {
            c.front += 1;
            c.front - 1
        })
    }

    fn take_back(&self) -> Option<usize> {
        let mut c = lock(&self.claims);
        (c.front < c.back).then(|| {
            c.back -= 1;
            c.back
        })
    }
}

/// The helper thread's queue (cheap to clone).
#[derive(Debug, Clone)]
pub struct MapHelper {
    tx: mpsc::Sender<Arc<Job>>,
}

impl MapHelper {
    /// Starts the helper thread under SCHED_IDLE (nice 19 where that is refused); `None`
    /// when it cannot be started.
    pub fn spawn() -> Option<Self> {
        Self::spawn_at(HelperPriority::Idle)
    }

    /// Starts the helper thread at `priority`.
    pub fn spawn_at(priority: HelperPriority) -> Option<Self> {
        let (tx, rx) = mpsc::channel::<Arc<Job>>();
        std::thread::Builder::new()
            .name("jink-map-helper".into())
            .spawn(move || {
                priority.apply();
                let mut map: Option<RiskMap> = None;
                for job in rx {
                    help(&job, &mut map);
                }
            })
            .ok()?;
        Some(Self { tx })
    }
}

/// How the helper thread is scheduled.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HelperPriority {
    /// Linux's SCHED_IDLE: the thread runs only on a core nothing else wants, and any
    /// other thread that wakes preempts it at once (so ingest on the runtime never waits
    /// for it); nice 19 where the policy is refused.
    Idle,
    /// The process's own priority (tests on a busy machine).
    Normal,
}

impl HelperPriority {
    /// Applies to the calling thread. Failure is harmless: the helper then runs at the
    /// normal priority.
    fn apply(self) {
        #[cfg(target_os = "linux")]
        if self == Self::Idle {
            use thread_priority::unix::{
                NormalThreadSchedulePolicy, ThreadSchedulePolicy, set_thread_priority_and_policy,
                thread_native_id,
            };
            let idle = set_thread_priority_and_policy(
                thread_native_id(),
                thread_priority::ThreadPriority::Min,
                ThreadSchedulePolicy::Normal(NormalThreadSchedulePolicy::Idle),
            );
            if idle.is_err() {
                let tid = Some(rustix::thread::gettid());
                let _ = rustix::process::setpriority_process(tid, 19);
            }
        }
    }
}

/// The helper's part of `job`: obstacles from the back, each computed on `map` (reused
/// across jobs of one configuration) and moved out as a layer.
fn help(job: &Job, map: &mut Option<RiskMap>) {
    if job.done.load(Ordering::Acquire) {
        return;
    }
    let m = match map.take() {
        Some(mut m) if m.config() == &job.cfg => {
            m.reset(&[], job.t0_s);
            m
        }
        _ => match RiskMap::new(job.cfg.clone(), &[], job.t0_s) {
            Ok(m) => m,
            Err(_) => return,
        },
    };
    let m = map.insert(m);
    while !job.done.load(Ordering::Acquire) {
        let Some(i) = job.take_back() else { break };
        job.predictor.update_map_obstacle(m, &job.ids[i]);
        if let Some(layer) = m.take_layer(&job.ids[i]) {
            *lock(&job.slots[i]) = Some(layer);
        }
    }
}

/// Adds obstacles `ids` (ascending) of `predictor` to `map` (empty, anchored at `t0_s`),
/// sharing the work with `helper` when given: the same cells, bit for bit, as adding them
/// one by one in that order ([`planner::replan::build_map`]).
/// Returns how many obstacles the helper computed.
pub fn add_obstacles(
    map: &mut RiskMap,
    predictor: &Arc<Predictor>,
    ids: &[String],
    t0_s: f64,
    helper: Option<&MapHelper>,
) -> usize {
    let sequential = |map: &mut RiskMap| {
        for id in ids {
            predictor.update_map_obstacle(map, id);
        }
    };
    // With fewer than two obstacles there is nothing to share.
    let Some(helper) = helper.filter(|_| ids.len() >= 2) else {
        sequential(map);
        return 0;
    };
    let job = Arc::new(Job {
        predictor: predictor.clone(),
        cfg: map.config().clone(),
        t0_s,
        ids: ids.to_vec(),
        claims: Mutex::new(Claims {
            front: 0,
            back: ids.len(),
        }),
        slots: ids.iter().map(|_| Mutex::new(None)).collect(),
        done: AtomicBool::new(false),
    });
    if helper.tx.send(job.clone()).is_err() {
        // The helper is gone: the build takes every obstacle itself.
        sequential(map);
        return 0;
    }
    while let Some(i) = job.take_front() {
        predictor.update_map_obstacle(map, &ids[i]);
    }
    job.done.store(true, Ordering::Release);
    let split = lock(&job.claims).front;
    let mut helped = 0;
    for (i, id) in ids.iter().enumerate().skip(split) {
        let layer = lock(&job.slots[i]).take();
        match layer.map(|l| map.put_layer(l)) {
            Some(Ok(())) => helped += 1,
            // Not finished by the helper (or of another frame): computed here.
            _ => predictor.update_map_obstacle(map, id),
        }
    }
    helped
}

/// Asserts that two maps hold the same cells, bit for bit, in every slice (`what` names
/// the case in the failure).
#[cfg(test)]
pub(crate) fn assert_same_cells(a: &RiskMap, b: &RiskMap, what: &str) {
    assert_eq!(a.slices(), b.slices(), "{what}: slices");
    for k in 0..a.slices() {
        let t = a.t0_s() + k as f64;
        let (sa, sb) = (a.slice(t), b.slice(t));
        assert!(
            sa.data.len() == sb.data.len()
                && sa
                    .data
                    .iter()
                    .zip(&sb.data)
                    .all(|(x, y)| x.to_bits() == y.to_bits()),
            "{what}, slice {k}"
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use predictor::{Observation, PredictorConfig};

    /// Ten obstacles on circles, 20 s at 5 Hz.
    fn predictor() -> Arc<Predictor> {
        let mut p = Predictor::new(PredictorConfig::default());
        for i in 0..100 {
            let t = 0.2 * f64::from(i);
            for k in 0..10 {
                let a = 0.005 * f64::from(k + 1) * t + f64::from(k);
                p.observe(
                    &k.to_string(),
                    Observation {
                        t_s: t,
                        p_m: [300.0 * a.cos() + 20.0 * f64::from(k), 300.0 * a.sin()],
                        alt_m: 60.0,
                        radius_m: 20.0 + 5.0 * f64::from(k),
                    },
                );
            }
        }
        Arc::new(p)
    }

    #[test]
    fn obstacles_the_helper_computed_give_the_cells_of_a_one_thread_build() {
        let p = predictor();
        let ids: Vec<String> = (0..10).map(|k| k.to_string()).collect();
        let cfg = RiskMapConfig::default()
            .bounds([-600.0, -600.0], [600.0, 600.0])
            .time(1.0, 60.0);
        let t0 = 19.8;
        let mut one = RiskMap::new(cfg.clone(), &[], t0).unwrap();
        assert_eq!(add_obstacles(&mut one, &p, &ids, t0, None), 0);
        for id in &ids {
            // Particles, not an analytic disc: their cells are what the helper moves.
            assert!(
                one.obstacle_mass_m2(id, 30).is_some_and(|m| m > 0.0),
                "{id}"
            );
        }
        // At the normal priority, so that a busy test machine still lets it help.
        let helper = MapHelper::spawn_at(HelperPriority::Normal).expect("a thread");
        let mut helped = 0;
        for run in 0..200 {
            let mut map = RiskMap::new(cfg.clone(), &[], t0).unwrap();
            helped += add_obstacles(&mut map, &p, &ids, t0, Some(&helper));
            assert_same_cells(&one, &map, &format!("run {run}"));
            if helped >= 5 {
                break;
            }
        }
        assert!(
            helped >= 5,
            "the helper computed {helped} obstacles in 200 builds"
        );
    }
}
