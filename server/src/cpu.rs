//! The CPU budget (issue 12): how many CPU jobs (plan computations, risk-map builds,
//! replays, rendering) run at once, and which goes first.
//!
//! Every CPU job takes a slot of one [`CpuGate`] before it runs off the async runtime
//! (`spawn_blocking`), so the number of busy job threads never exceeds the gate's slots,
//! whatever mixes of plans and maps arrive. The default leaves one core to the async
//! runtime and the database thread (cores - 1 slots, at least 1; `--cpu-workers`): on a
//! 2-core machine, ingest then never shares its core with a plan or a map build.
//!
//! Two priorities: [`Priority::Foreground`] (work a request is waiting for: plans, the map
//! a plan or `GET .../risk` needs) and [`Priority::Background`] (rebuilding a map after a
//! batch, ahead of its reader). A freed slot goes to the oldest foreground waiter first;
//! background jobs take only slots no foreground job wants. And a foreground job never
//! waits behind background ones alone: when every slot is held by a background job, one
//! foreground job at a time runs at once on an extra slot (the overdraft), so at most
//! `slots + 1` jobs run, the extra one always a request's. A plan that may use the map
//! already published (`--plan-map-max-age-ms`) then starts while the rebuild of the batch
//! just posted runs beside it, instead of waiting for that build's slot.
//!
//! Waiting is cancel-safe: a waiter dropped before or after its slot was handed to it gives
//! the slot on to the next waiter.

use std::collections::VecDeque;
use std::sync::{Arc, Mutex};

use tokio::sync::oneshot;

/// Which waiters a freed slot goes to first.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Priority {
    /// A request waits for the job (a plan, the map it needs).
    Foreground,
    /// Nobody waits for it yet (a map rebuilt after an observation batch).
    Background,
}

#[derive(Debug)]
struct Waiters {
    free: usize,
    /// Slots held by background jobs.
    background_busy: usize,
    /// Whether the extra slot (the overdraft) is held.
    overdraft: bool,
    foreground: VecDeque<oneshot::Sender<CpuPermit>>,
    background: VecDeque<oneshot::Sender<CpuPermit>>,
}

impl Waiters {
    /// Whether a foreground job may take the overdraft: every one of the `slots` runs a
    /// background job and the overdraft is not held.
    fn overdraft_open(&self, slots: usize) -> bool {
        !self.overdraft && self.free == 0 && self.background_busy == slots
    }
}

/// What a [`CpuPermit`] holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Held {
    /// Nothing (a permit that could not be handed over).
    Nothing,
    /// One of the gate's slots, taken at this priority.
    Slot(Priority),
    /// The extra slot of a foreground job while every slot runs a background one.
    Overdraft,
}

/// At most `slots` CPU jobs at once, foreground ones first (see the module docs).
#[derive(Debug)]
pub struct CpuGate {
    slots: usize,
    waiters: Mutex<Waiters>,
}

/// One slot of a [`CpuGate`], given back when dropped.
#[derive(Debug)]
pub struct CpuPermit {
    gate: Arc<CpuGate>,
    held: Held,
}

impl Drop for CpuPermit {
    fn drop(&mut self) {
        match std::mem::replace(&mut self.held, Held::Nothing) {
            Held::Nothing => {}
            Held::Slot(p) => self.gate.release(p),
            Held::Overdraft => self.gate.release_overdraft(),
        }
    }
}

impl CpuPermit {
    /// Whether this permit holds the overdraft (the extra slot).
    #[cfg(test)]
    fn is_overdraft(&self) -> bool {
        self.held == Held::Overdraft
    }
}

impl CpuGate {
    /// A gate of `slots` (at least 1) concurrent jobs.
    pub fn new(slots: usize) -> Arc<Self> {
        let slots = slots.max(1);
        Arc::new(Self {
            slots,
            waiters: Mutex::new(Waiters {
                free: slots,
                background_busy: 0,
                overdraft: false,
                foreground: VecDeque::new(),
                background: VecDeque::new(),
            }),
        })
    }

    /// The default slot count: one core less than the machine has, at least one.
    pub fn default_slots() -> usize {
        std::thread::available_parallelism()
            .map_or(2, std::num::NonZero::get)
            .saturating_sub(1)
            .max(1)
    }

    /// Concurrent jobs allowed.
    pub fn slots(&self) -> usize {
        self.slots
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Waiters> {
        // The critical sections only move counters and queue entries.
        self.waiters
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Waits for a slot at `priority`.
    pub async fn acquire(self: &Arc<Self>, priority: Priority) -> CpuPermit {
        let rx = {
            let mut w = self.lock();
            // A background job also waits while foreground jobs wait (it would take
            // their slot); a foreground job passes background waiters.
            let ahead = match priority {
                Priority::Foreground => !w.foreground.is_empty(),
                Priority::Background => !w.foreground.is_empty() || !w.background.is_empty(),
            };
            if w.free > 0 && !ahead {
                w.free -= 1;
                if priority == Priority::Background {
                    w.background_busy += 1;
                }
                return CpuPermit {
                    gate: self.clone(),
                    held: Held::Slot(priority),
                };
            }
            if priority == Priority::Foreground && !ahead && w.overdraft_open(self.slots) {
                w.overdraft = true;
                return CpuPermit {
                    gate: self.clone(),
                    held: Held::Overdraft,
                };
            }
            let (tx, rx) = oneshot::channel();
            match priority {
                Priority::Foreground => w.foreground.push_back(tx),
                Priority::Background => w.background.push_back(tx),
            }
            rx
        };
        // The sender lives in the queue until a slot is handed over, and the gate is
        // alive while this future holds `self`: the channel only closes by a hand-over.
        rx.await.unwrap_or_else(|_| CpuPermit {
            gate: self.clone(),
            held: Held::Nothing,
        })
    }

    /// Gives back a slot held at `priority`: hands it to the next waiter (foreground
    /// first), or marks it free.
    fn release(self: &Arc<Self>, priority: Priority) {
        let mut held = Some(priority);
        loop {
            let (next, to) = {
                let mut w = self.lock();
                if held.take() == Some(Priority::Background) {
                    w.background_busy -= 1;
                }
                if let Some(tx) = w.foreground.pop_front() {
                    (tx, Held::Slot(Priority::Foreground))
                } else if let Some(tx) = w.background.pop_front() {
                    w.background_busy += 1;
                    (tx, Held::Slot(Priority::Background))
                } else {
                    w.free += 1;
                    return;
                }
            };
            // Outside the lock: a refused permit is dropped here (as nothing; the slot
            // goes round again), and a permit dropped in an abandoned channel later
            // releases again.
            match next.send(CpuPermit {
                gate: self.clone(),
                held: to,
            }) {
                Ok(()) => return,
                Err(mut refused) => {
                    if to == Held::Slot(Priority::Background) {
                        held = Some(Priority::Background);
                    }
                    refused.held = Held::Nothing;
                }
            }
        }
    }

    /// Gives back the overdraft: to the oldest foreground waiter while every slot still
    /// runs a background job, else it closes.
    fn release_overdraft(self: &Arc<Self>) {
        loop {
            let next = {
                let mut w = self.lock();
                w.overdraft = false;
                if !w.overdraft_open(self.slots) {
                    return;
                }
                let Some(tx) = w.foreground.pop_front() else {
                    return;
                };
                w.overdraft = true;
                tx
            };
            match next.send(CpuPermit {
                gate: self.clone(),
                held: Held::Overdraft,
            }) {
                Ok(()) => return,
                Err(mut refused) => refused.held = Held::Nothing,
            }
        }
    }

    /// Slots free now.
    #[cfg(test)]
    pub fn free(&self) -> usize {
        self.lock().free
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    async fn settle() {
        for _ in 0..10 {
            tokio::task::yield_now().await;
        }
    }

    #[tokio::test]
    async fn a_freed_slot_goes_to_a_foreground_waiter_before_an_older_background_one() {
        let gate = CpuGate::new(1);
        let held = gate.acquire(Priority::Foreground).await;
        let order = Arc::new(Mutex::new(Vec::new()));
        let spawn = |p: Priority, name: &'static str| {
            let (gate, order) = (gate.clone(), order.clone());
            tokio::spawn(async move {
                let _permit = gate.acquire(p).await;
                order.lock().unwrap().push(name);
                tokio::time::sleep(Duration::from_millis(5)).await;
            })
        };
        let bg = spawn(Priority::Background, "background");
        settle().await;
        let fg = spawn(Priority::Foreground, "foreground");
        settle().await;
        drop(held);
        fg.await.unwrap();
        bg.await.unwrap();
        assert_eq!(*order.lock().unwrap(), ["foreground", "background"]);
        assert_eq!(gate.free(), 1);
    }

    #[tokio::test]
    async fn at_most_one_job_more_than_slots_runs_and_it_is_a_requests_beside_background_ones() {
        use std::sync::atomic::{AtomicUsize, Ordering::SeqCst};
        let gate = CpuGate::new(2);
        // Jobs running now (foreground, background), the most at once, times the extra slot
        // was taken and jobs on it now.
        let fg = Arc::new(AtomicUsize::new(0));
        let bg = Arc::new(AtomicUsize::new(0));
        let most = Arc::new(AtomicUsize::new(0));
        let extra = Arc::new(AtomicUsize::new(0));
        let od = Arc::new(AtomicUsize::new(0));
        let mut tasks = Vec::new();
        for i in 0..40 {
            let (gate, fg, bg, most, extra, od) = (
                gate.clone(),
                fg.clone(),
                bg.clone(),
                most.clone(),
                extra.clone(),
                od.clone(),
            );
            // Rounds of two background jobs, then a request once they have started.
            let p = if i % 3 == 2 {
                settle().await;
                Priority::Foreground
            } else {
                Priority::Background
            };
            tasks.push(tokio::spawn(async move {
                let permit = gate.acquire(p).await;
                let mine = if p == Priority::Foreground { &fg } else { &bg };
                mine.fetch_add(1, SeqCst);
                if permit.is_overdraft() {
                    assert_eq!(
                        p,
                        Priority::Foreground,
                        "a background job on the extra slot"
                    );
                    extra.fetch_add(1, SeqCst);
                    od.fetch_add(1, SeqCst);
                }
                let (f, b) = (fg.load(SeqCst), bg.load(SeqCst));
                most.fetch_max(f + b, SeqCst);
                if f + b > 2 {
                    // One job more than slots: the one on the extra slot, a request's.
                    assert_eq!(od.load(SeqCst), 1, "{f} foreground and {b} background jobs");
                }
                tokio::time::sleep(Duration::from_millis(1 + (i % 4) as u64)).await;
                if permit.is_overdraft() {
                    od.fetch_sub(1, SeqCst);
                }
                mine.fetch_sub(1, SeqCst);
                drop(permit);
            }));
        }
        for t in tasks {
            t.await.unwrap();
        }
        assert_eq!(most.load(SeqCst), 3);
        assert!(extra.load(SeqCst) > 0);
        assert_eq!(gate.free(), 2);
        let w = gate.lock();
        assert_eq!((w.background_busy, w.overdraft), (0, false));
    }

    #[tokio::test]
    async fn a_request_starts_beside_a_background_build_and_the_next_waits_its_turn() {
        let gate = CpuGate::new(1);
        let build = gate.acquire(Priority::Background).await;
        // The plan starts at once on the extra slot.
        let plan = tokio::time::timeout(Duration::from_secs(1), gate.acquire(Priority::Foreground))
            .await
            .expect("a request waited behind a background job");
        assert!(plan.is_overdraft());
        // A request that waits; it answers whether it got the extra slot.
        let request = || {
            let gate = gate.clone();
            tokio::spawn(async move { gate.acquire(Priority::Foreground).await.is_overdraft() })
        };
        // A second request waits: the extra slot is taken.
        let second = request();
        settle().await;
        assert!(!second.is_finished());
        // The first gives the extra slot back: the build still runs, so it goes on.
        drop(plan);
        assert!(second.await.unwrap());
        // No background job holds a slot now: a request takes the slot itself.
        drop(build);
        let third = gate.acquire(Priority::Foreground).await;
        assert!(!third.is_overdraft());
        // And with the slot held by a request, another waits (no extra slot then).
        let fourth = request();
        settle().await;
        assert!(!fourth.is_finished());
        drop(third);
        assert!(!fourth.await.unwrap());
        assert_eq!(gate.free(), 1);
    }

    #[tokio::test]
    async fn a_waiter_dropped_while_queued_does_not_lose_the_slot() {
        let gate = CpuGate::new(1);
        let held = gate.acquire(Priority::Foreground).await;
        let abandoned = {
            let gate = gate.clone();
            tokio::spawn(async move {
                let _p = gate.acquire(Priority::Foreground).await;
            })
        };
        settle().await;
        abandoned.abort();
        let _ = abandoned.await;
        drop(held);
        let again =
            tokio::time::timeout(Duration::from_secs(1), gate.acquire(Priority::Background)).await;
        assert!(again.is_ok(), "the slot was lost");
        drop(again);
        assert_eq!(gate.free(), 1);
    }
}
