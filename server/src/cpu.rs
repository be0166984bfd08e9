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
//! background jobs take only slots no foreground job wants. A background rebuild therefore
//! never delays a plan by more than the one build already running.
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
    foreground: VecDeque<oneshot::Sender<CpuPermit>>,
    background: VecDeque<oneshot::Sender<CpuPermit>>,
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
    /// False for a permit that never held a slot (one that could not be handed over).
    armed: bool,
}

impl Drop for CpuPermit {
    fn drop(&mut self) {
        if self.armed {
            self.gate.release();
        }
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
                return CpuPermit {
                    gate: self.clone(),
                    armed: true,
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
            armed: false,
        })
    }

    /// Hands a freed slot to the next waiter (foreground first), or marks it free.
    fn release(self: &Arc<Self>) {
        loop {
            let next = {
                let mut w = self.lock();
                match w
                    .foreground
                    .pop_front()
                    .or_else(|| w.background.pop_front())
                {
                    Some(tx) => tx,
                    None => {
                        w.free += 1;
                        return;
                    }
                }
            };
            // Outside the lock: a refused permit is dropped here, and a permit dropped in
            // an abandoned channel later releases again.
            match next.send(CpuPermit {
                gate: self.clone(),
                armed: true,
            }) {
                Ok(()) => return,
                Err(mut refused) => refused.armed = false,
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
    async fn no_more_jobs_than_slots_run_at_once() {
        let gate = CpuGate::new(2);
        let running = Arc::new(std::sync::atomic::AtomicUsize::new(0));
        let most = Arc::new(std::sync::atomic::AtomicUsize::new(0));
        let mut tasks = Vec::new();
        for i in 0..20 {
            let (gate, running, most) = (gate.clone(), running.clone(), most.clone());
            let p = if i % 3 == 0 {
                Priority::Background
            } else {
                Priority::Foreground
            };
            tasks.push(tokio::spawn(async move {
                let _permit = gate.acquire(p).await;
                let now = running.fetch_add(1, std::sync::atomic::Ordering::SeqCst) + 1;
                most.fetch_max(now, std::sync::atomic::Ordering::SeqCst);
                tokio::time::sleep(Duration::from_millis(2)).await;
                running.fetch_sub(1, std::sync::atomic::Ordering::SeqCst);
            }));
        }
        for t in tasks {
            t.await.unwrap();
        }
        assert_eq!(most.load(std::sync::atomic::Ordering::SeqCst), 2);
        assert_eq!(gate.free(), 2);
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
