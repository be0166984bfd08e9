//! Per-token write rates: two token buckets per token, one for ingest (telemetry,
//! obstacles) and one for the other writes (plans, replays, missions), so that a token
//! flooding plans keeps its ingest. A refused request gets 429 with `Retry-After` (whole
//! seconds until the bucket holds a request again).

use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use std::time::Instant;

use super::Access;
use crate::error::ApiError;

/// Most tokens tracked; beyond it the buckets start afresh (full), which only ever lets
/// more through.
const MAX_TRACKED: usize = 10_000;

/// Rates and bursts, requests per second per token.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RateSettings {
    /// Sustained ingest requests per second per token (0: unlimited).
    pub ingest_per_s: f64,
    /// Ingest requests a token may send at once.
    pub ingest_burst: f64,
    /// Sustained other writes per second per token (0: unlimited).
    pub other_per_s: f64,
    /// Other writes a token may send at once.
    pub other_burst: f64,
}

impl Default for RateSettings {
    fn default() -> Self {
        // A ground station sends 5-10 telemetry and obstacle posts per second and a plan
        // every second or so: these leave it a wide margin.
        Self {
            ingest_per_s: 50.0,
            ingest_burst: 100.0,
            other_per_s: 10.0,
            other_burst: 20.0,
        }
    }
}

#[derive(Debug, Clone, Copy)]
struct Bucket {
    tokens: f64,
    at: Instant,
}

/// The buckets of every token seen.
#[derive(Debug)]
pub struct RateLimits {
    cfg: RateSettings,
    buckets: Mutex<HashMap<(Arc<str>, bool), Bucket>>,
}

impl RateLimits {
    /// Buckets with `cfg`'s rates.
    pub fn new(cfg: RateSettings) -> Self {
        Self {
            cfg,
            buckets: Mutex::new(HashMap::new()),
        }
    }

    /// Takes one request of class `access` from `name`'s bucket.
    ///
    /// # Errors
    /// 429 with the seconds until the bucket holds a request again.
    pub fn check(&self, name: &Arc<str>, access: Access) -> Result<(), ApiError> {
        let ingest = match access {
            Access::Ingest => true,
            Access::Write | Access::Admin => false,
            Access::Open | Access::Read => return Ok(()),
        };
        let (rate, burst) = if ingest {
            (self.cfg.ingest_per_s, self.cfg.ingest_burst)
        } else {
            (self.cfg.other_per_s, self.cfg.other_burst)
        };
        if rate <= 0.0 {
            return Ok(());
        }
        let burst = burst.max(1.0);
        let now = Instant::now();
        let mut buckets = self
            .buckets
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        if buckets.len() >= MAX_TRACKED {
            buckets.clear();
        }
        let b = buckets.entry((name.clone(), ingest)).or_insert(Bucket {
            tokens: burst,
            at: now,
        });
        b.tokens = (b.tokens + now.duration_since(b.at).as_secs_f64() * rate).min(burst);
        b.at = now;
        if b.tokens >= 1.0 {
            b.tokens -= 1.0;
            return Ok(());
        }
        let wait_s = ((1.0 - b.tokens) / rate).ceil().max(1.0) as u64;
        let class = if ingest { "ingest" } else { "write" };
        let (flag, per_s) = if ingest {
            ("--rate-ingest-per-s", self.cfg.ingest_per_s)
        } else {
            ("--rate-write-per-s", self.cfg.other_per_s)
        };
        Err(ApiError::TooManyRequests {
            detail: format!(
                "token '{name}' is over its {class} rate ({per_s}/s, {flag}); retry after {wait_s} s"
            ),
            retry_after_s: wait_s,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_burst_passes_then_the_rate_holds_and_ingest_has_its_own_bucket() {
        let r = RateLimits::new(RateSettings {
            ingest_per_s: 1.0,
            ingest_burst: 2.0,
            other_per_s: 1.0,
            other_burst: 3.0,
        });
        let a: Arc<str> = Arc::from("a");
        for _ in 0..3 {
            r.check(&a, Access::Write).unwrap();
        }
        let e = r.check(&a, Access::Write).unwrap_err();
        assert!(
            matches!(
                e,
                ApiError::TooManyRequests {
                    retry_after_s: 1,
                    ..
                }
            ),
            "{e:?}"
        );
        // Ingest is untouched by the write flood, and reads are never limited.
        r.check(&a, Access::Ingest).unwrap();
        r.check(&a, Access::Ingest).unwrap();
        assert!(r.check(&a, Access::Ingest).is_err());
        r.check(&a, Access::Read).unwrap();
        // Another token has its own buckets.
        r.check(&Arc::from("b"), Access::Write).unwrap();
    }
}
