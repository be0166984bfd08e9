//! When a search must stop, separate from what it searches for (as OMPL's termination
//! conditions): an optional wall-clock deadline and an optional cancel flag another thread
//! may raise. Planning parameters say *what* to plan; a [`Termination`] says *until when*.
//!
//! Checked inside the sampling loops of [`crate::bisection`]; a stopped search keeps what it
//! has decided (anytime) and the plan reports [`crate::PlanOutcome::Timeout`] or
//! [`crate::PlanOutcome::Approximate`]. Without a deadline or a raised flag a plan is a
//! pure function of its inputs and seed.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

/// Deadline and cancel flag of one planning call (default: run to completion).
#[derive(Debug, Clone, Default)]
pub struct Termination {
    /// Stop once this instant has passed.
    pub deadline: Option<Instant>,
    /// Stop once this flag is true (e.g. a newer plan request superseded this one).
    pub cancel: Option<Arc<AtomicBool>>,
}

impl Termination {
    /// Run to completion.
    pub fn none() -> Self {
        Self::default()
    }

    /// Stop at `deadline` (None: never).
    pub fn deadline(deadline: Option<Instant>) -> Self {
        Self {
            deadline,
            cancel: None,
        }
    }

    /// Also stop when `flag` is raised.
    pub fn with_cancel(mut self, flag: Arc<AtomicBool>) -> Self {
        self.cancel = Some(flag);
        self
    }

    /// Whether the search must stop now.
    pub fn should_stop(&self) -> bool {
        self.cancel
            .as_ref()
            .is_some_and(|c| c.load(Ordering::Relaxed))
            || self.deadline.is_some_and(|d| Instant::now() >= d)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stops_on_a_raised_flag_or_a_past_deadline_only() {
        assert!(!Termination::none().should_stop());
        let flag = Arc::new(AtomicBool::new(false));
        let t = Termination::deadline(None).with_cancel(flag.clone());
        assert!(!t.should_stop());
        flag.store(true, Ordering::Relaxed);
        assert!(t.should_stop());
        assert!(Termination::deadline(Some(Instant::now())).should_stop());
        let later = Instant::now() + std::time::Duration::from_secs(3600);
        assert!(!Termination::deadline(Some(later)).should_stop());
    }
}
