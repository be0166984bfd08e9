//! The SQLite write connection's own thread and runtime (issue 12).
//!
//! SQLite has one write connection. A write holds it from the moment its task acquires it
//! until the task is polled again after the statement (or the transaction's last one)
//! finished, and every step in between is a wake-up of that task on the runtime it runs
//! on. Under load the server's runtime serves thousands of requests a second, so each of
//! those wake-ups waits its turn there, and the connection sits idle but held for that
//! long: with ~1,800 writes a second (telemetry posts, plan rows, observation batches)
//! the connection was busy most of the time, yet SQLite itself only 14% of a core.
//!
//! The frequent writes therefore run on a one-thread runtime of their own, which does
//! nothing else: the connection is held for the statements' own time plus a wake-up on an
//! idle runtime. The request handler sends its write there and waits once for the answer.
//! Rare writes (missions, tokens, interop links) still run where they are called: they
//! share the connection, not the runtime.

use std::future::Future;
use std::sync::Arc;

use tokio::sync::oneshot;

/// A handle to the writer thread's runtime; clones share it. The thread stops when the
/// last clone is dropped (tasks still running on it are then cancelled).
#[derive(Clone, Debug)]
pub struct WriterThread {
    handle: tokio::runtime::Handle,
    _stop: Arc<oneshot::Sender<()>>,
}

impl WriterThread {
    /// Starts the thread (`jink-db-writer`) and its runtime.
    ///
    /// # Errors
    /// When the runtime or the thread cannot be created.
    pub fn spawn() -> std::io::Result<Self> {
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()?;
        let handle = rt.handle().clone();
        let (stop, stopped) = oneshot::channel::<()>();
        std::thread::Builder::new()
            .name("jink-db-writer".into())
            .spawn(move || {
                rt.block_on(async {
                    // Resolves (with an error) when the last handle is dropped.
                    let _ = stopped.await;
                });
            })?;
        Ok(Self {
            handle,
            _stop: Arc::new(stop),
        })
    }

    /// Runs `fut` on the writer's runtime and waits for its result. A panic in `fut` is
    /// resumed here.
    pub async fn run<T, F>(&self, fut: F) -> T
    where
        T: Send + 'static,
        F: Future<Output = T> + Send + 'static,
    {
        match self.handle.spawn(fut).await {
            Ok(v) => v,
            Err(e) if e.is_panic() => std::panic::resume_unwind(e.into_panic()),
            // Only when the runtime stopped, which needs every handle (ours included)
            // dropped: cannot happen while `self` is alive.
            Err(e) => panic!("the database writer's runtime stopped: {e}"),
        }
    }

    /// Starts `fut` on the writer's runtime without waiting for it.
    pub fn spawn_task<F>(&self, fut: F)
    where
        F: Future<Output = ()> + Send + 'static,
    {
        self.handle.spawn(fut);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test]
    async fn work_runs_on_the_writer_thread_and_its_result_comes_back() {
        let w = WriterThread::spawn().expect("writer");
        let name = w
            .run(async { std::thread::current().name().map(str::to_string) })
            .await;
        assert_eq!(name.as_deref(), Some("jink-db-writer"));
        assert_ne!(
            std::thread::current().name(),
            Some("jink-db-writer"),
            "the caller stays where it was"
        );
    }

    #[tokio::test]
    async fn the_thread_stops_when_the_last_handle_is_dropped() {
        let w = WriterThread::spawn().expect("writer");
        let (tx, rx) = oneshot::channel::<()>();
        // A task that never finishes on its own: dropping the runtime cancels it, which
        // drops `tx` and wakes `rx`.
        w.spawn_task(async move {
            let _tx = tx;
            std::future::pending::<()>().await;
        });
        drop(w);
        tokio::time::timeout(std::time::Duration::from_secs(5), rx)
            .await
            .expect("the writer's runtime stopped and cancelled its task")
            .expect_err("cancelled, not completed");
    }
}
