//! The calling thread's CPU time, for replan latencies that a loaded machine does not
//! inflate: the wall clock counts the time the thread waits for a core (two simulations
//! on two cores, a build beside them), its CPU time only the work done. Linux only
//! (`CLOCK_THREAD_CPUTIME_ID`, through rustix since the workspace forbids `unsafe`);
//! elsewhere `None`, and the reports say 0.

/// CPU time the calling thread has used so far, milliseconds; `None` where it cannot be
/// read.
pub fn thread_cpu_ms() -> Option<f64> {
    #[cfg(target_os = "linux")]
    {
        let t = rustix::time::clock_gettime(rustix::time::ClockId::ThreadCPUTime);
        Some(t.tv_sec as f64 * 1e3 + t.tv_nsec as f64 / 1e6)
    }
    #[cfg(not(target_os = "linux"))]
    {
        None
    }
}

/// CPU time the calling thread has used since `start` (a reading of [`thread_cpu_ms`]),
/// milliseconds; `None` where the clock cannot be read.
pub fn since(start: Option<f64>) -> Option<f64> {
    start.zip(thread_cpu_ms()).map(|(a, b)| b - a)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    #[cfg_attr(
        not(target_os = "linux"),
        ignore = "thread CPU time is read on Linux only"
    )]
    fn work_is_counted_and_sleep_is_not() {
        let t0 = thread_cpu_ms().unwrap();
        std::thread::sleep(std::time::Duration::from_millis(50));
        let slept = thread_cpu_ms().unwrap() - t0;
        // Spin until 30 ms of wall time have passed: at least some of that is CPU.
        let t1 = thread_cpu_ms().unwrap();
        let w = std::time::Instant::now();
        let mut x = 0u64;
        while w.elapsed().as_millis() < 30 {
            x = std::hint::black_box(x.wrapping_mul(31).wrapping_add(7));
        }
        let spun = since(Some(t1)).unwrap();
        assert!(slept < 20.0, "a 50 ms sleep counted {slept:.1} ms of CPU");
        assert!(spun > 1.0, "30 ms of spinning counted {spun:.2} ms of CPU");
        assert!(spun <= 30.0 + 5.0, "more CPU ({spun:.1} ms) than wall time");
        assert_eq!(since(None), None, "no start reading, no interval");
    }
}
