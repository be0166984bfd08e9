//! The server loop (issue 12): accepts connections, serves HTTP/1.1 over plain TCP or TLS
//! (rustls), bounds how long a client may take to send its request headers, and shuts
//! down gracefully.
//!
//! Shutdown, on SIGTERM or Ctrl-C: the listener closes at once (new connections are
//! refused), the pages' event streams end, every request in flight is finished (within
//! [`NetOptions::shutdown_grace`]; idle keep-alive connections close), then the store is
//! flushed and closed (SQLite: the group commit's queue is drained, the WAL checkpointed),
//! and the loop returns `Ok`, so `jink serve` exits 0. Every write acknowledged before or
//! during the shutdown was committed before its answer was sent.

use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

use hyper_util::rt::{TokioIo, TokioTimer};
use hyper_util::service::TowerToHyperService;
use tokio::net::TcpListener;
use tokio_rustls::TlsAcceptor;
use tokio_rustls::rustls;

use crate::app::{AppState, router};

/// How the loop serves.
#[derive(Debug, Clone)]
pub struct NetOptions {
    /// TLS (`--tls-cert/--tls-key`); plain HTTP when `None`.
    pub tls: Option<Arc<rustls::ServerConfig>>,
    /// A client must send a request's headers (and finish a TLS handshake) within this.
    pub header_read_timeout: Duration,
    /// Requests in flight at shutdown get this long to finish.
    pub shutdown_grace: Duration,
}

impl Default for NetOptions {
    fn default() -> Self {
        Self {
            tls: None,
            header_read_timeout: Duration::from_secs(10),
            shutdown_grace: Duration::from_secs(10),
        }
    }
}

/// Reads a PEM certificate chain and private key into a rustls server configuration
/// (TLS 1.2 and 1.3, the ring provider, HTTP/1.1 by ALPN).
///
/// # Errors
/// A message naming the file that could not be read or the key that does not fit.
pub fn tls_config(cert: &Path, key: &Path) -> Result<Arc<rustls::ServerConfig>, String> {
    use rustls::pki_types::pem::PemObject;
    use rustls::pki_types::{CertificateDer, PrivateKeyDer};
    let certs: Vec<CertificateDer<'static>> = CertificateDer::pem_file_iter(cert)
        .and_then(|it| it.collect::<Result<_, _>>())
        .map_err(|e| format!("cannot read the certificate chain {}: {e}", cert.display()))?;
    if certs.is_empty() {
        return Err(format!("no certificate in {}", cert.display()));
    }
    let key = PrivateKeyDer::from_pem_file(key)
        .map_err(|e| format!("cannot read the private key {}: {e}", key.display()))?;
    let provider = Arc::new(rustls::crypto::ring::default_provider());
    let mut cfg = rustls::ServerConfig::builder_with_provider(provider)
        .with_safe_default_protocol_versions()
        .map_err(|e| format!("TLS set-up: {e}"))?
        .with_no_client_auth()
        .with_single_cert(certs, key)
        .map_err(|e| format!("the certificate and key do not fit together: {e}"))?;
    cfg.alpn_protocols = vec![b"http/1.1".to_vec()];
    Ok(Arc::new(cfg))
}

/// Serves `state` on `listener` until SIGTERM or Ctrl-C, then shuts down as the module
/// documentation says. Prints `jink listening on http[s]://ADDR` on stdout first.
///
/// # Errors
/// When the listener's address cannot be read.
pub async fn serve_with(
    listener: TcpListener,
    state: AppState,
    opts: NetOptions,
) -> std::io::Result<()> {
    let local = listener.local_addr()?;
    let scheme = if opts.tls.is_some() { "https" } else { "http" };
    println!("jink listening on {scheme}://{local}");
    tracing::info!(%local, backend = ?state.store.backend(), tls = opts.tls.is_some(), "serving");
    let app = router(state.clone());
    let acceptor = opts.tls.clone().map(TlsAcceptor::from);
    let graceful = hyper_util::server::graceful::GracefulShutdown::new();
    let mut signal = std::pin::pin!(crate::app::shutdown_signal());
    loop {
        let (stream, _peer) = tokio::select! {
            r = listener.accept() => match r {
                Ok(c) => c,
                Err(e) => {
                    // Out of file descriptors and the like: pause instead of spinning.
                    tracing::warn!(error = %e, "accept failed");
                    tokio::time::sleep(Duration::from_millis(50)).await;
                    continue;
                }
            },
            () = &mut signal => break,
        };
        let _ = stream.set_nodelay(true);
        let svc = TowerToHyperService::new(app.clone());
        let mut http = hyper::server::conn::http1::Builder::new();
        http.timer(TokioTimer::new())
            .header_read_timeout(opts.header_read_timeout);
        let watcher = graceful.watcher();
        let acceptor = acceptor.clone();
        let handshake_limit = opts.header_read_timeout;
        tokio::spawn(async move {
            let result = match acceptor {
                None => {
                    watcher
                        .watch(http.serve_connection(TokioIo::new(stream), svc))
                        .await
                }
                Some(acceptor) => {
                    let tls = match tokio::time::timeout(handshake_limit, acceptor.accept(stream))
                        .await
                    {
                        Ok(Ok(tls)) => tls,
                        Ok(Err(e)) => {
                            tracing::debug!(error = %e, "TLS handshake failed");
                            return;
                        }
                        Err(_) => return,
                    };
                    watcher
                        .watch(http.serve_connection(TokioIo::new(tls), svc))
                        .await
                }
            };
            if let Err(e) = result {
                tracing::debug!(error = %e, "connection ended with an error");
            }
        });
    }
    drop(listener);
    tracing::info!("shutting down: finishing the requests in flight");
    crate::page::shut_down();
    if tokio::time::timeout(opts.shutdown_grace, graceful.shutdown())
        .await
        .is_err()
    {
        tracing::warn!(
            grace_s = opts.shutdown_grace.as_secs_f64(),
            "requests still in flight after the shutdown grace are abandoned (not acknowledged)"
        );
    }
    state.store.close().await;
    tracing::info!("stopped");
    Ok(())
}
