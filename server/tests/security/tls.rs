//! TLS: `--tls-cert/--tls-key` with a self-signed certificate made here; a client that
//! trusts it gets answers, a plain-HTTP client gets none.

use std::sync::Arc;

use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio_rustls::rustls;

use crate::server::{Db, Server};

#[tokio::test]
async fn a_tls_round_trip_with_a_self_signed_certificate() {
    let db = Db::sqlite();
    let ck = rcgen::generate_simple_self_signed(vec!["localhost".to_string()]).unwrap();
    let cert_path = db.dir.path().join("cert.pem");
    let key_path = db.dir.path().join("key.pem");
    std::fs::write(&cert_path, ck.cert.pem()).unwrap();
    std::fs::write(&key_path, ck.signing_key.serialize_pem()).unwrap();
    let token = db.create_token("ops", "admin");
    let s = Server::start(
        &db,
        &[
            "--bind",
            "127.0.0.1:0",
            "--auth",
            "on",
            "--tls-cert",
            cert_path.to_str().unwrap(),
            "--tls-key",
            key_path.to_str().unwrap(),
        ],
    );
    assert!(s.base.starts_with("https://"), "{}", s.base);
    let addr = s.base.trim_start_matches("https://").to_string();

    let mut roots = rustls::RootCertStore::empty();
    roots.add(ck.cert.der().clone()).unwrap();
    let provider = Arc::new(rustls::crypto::ring::default_provider());
    let cfg = rustls::ClientConfig::builder_with_provider(provider)
        .with_safe_default_protocol_versions()
        .unwrap()
        .with_root_certificates(roots)
        .with_no_client_auth();
    let connector = tokio_rustls::TlsConnector::from(Arc::new(cfg));
    let request = |path: &str, token: Option<&str>| {
        let auth = token.map_or(String::new(), |t| format!("Authorization: Bearer {t}\r\n"));
        format!("GET {path} HTTP/1.1\r\nHost: localhost\r\n{auth}Connection: close\r\n\r\n")
    };
    let fetch = |req: String| {
        let (connector, addr) = (connector.clone(), addr.clone());
        async move {
            let tcp = tokio::net::TcpStream::connect(&addr).await.unwrap();
            let name = rustls::pki_types::ServerName::try_from("localhost").unwrap();
            let mut tls = connector.connect(name, tcp).await.unwrap();
            tls.write_all(req.as_bytes()).await.unwrap();
            let mut out = Vec::new();
            // A peer closing without close_notify is fine here: the answer is complete.
            let _ = tls.read_to_end(&mut out).await;
            String::from_utf8_lossy(&out).to_string()
        }
    };
    let health = fetch(request("/healthz", None)).await;
    assert!(health.starts_with("HTTP/1.1 200"), "{health}");
    // The token travels inside TLS and works; without it, 401.
    let listed = fetch(request("/api/v1/missions", Some(&token))).await;
    assert!(listed.starts_with("HTTP/1.1 200"), "{listed}");
    assert!(listed.ends_with("[]"), "{listed}");
    let refused = fetch(request("/api/v1/missions", None)).await;
    assert!(refused.starts_with("HTTP/1.1 401"), "{refused}");

    // Plain HTTP on the TLS port gets no HTTP answer.
    let mut tcp = tokio::net::TcpStream::connect(&addr).await.unwrap();
    tcp.write_all(request("/healthz", None).as_bytes())
        .await
        .unwrap();
    let mut out = Vec::new();
    let _ =
        tokio::time::timeout(std::time::Duration::from_secs(5), tcp.read_to_end(&mut out)).await;
    assert!(!String::from_utf8_lossy(&out).contains("200 OK"));
}
