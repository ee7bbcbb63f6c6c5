//! The metrics endpoint: binds `daemon.metrics-listen` or `bridge.metrics-listen` and serves
//! `GET /metrics` over HTTP/1.

use super::{encode, CONTENT_TYPE};
use http_body_util::Full;
use hyper::body::Bytes;
use prometheus_client::registry::Registry;
use std::net::SocketAddr;
use std::sync::Arc;
use std::time::Duration;

/// Why the metrics endpoint could not start.
#[derive(Debug, thiserror::Error)]
#[error("cannot listen for metrics on {key} = {addr:?}: {reason}")]
pub struct MetricsError {
    /// The key that set the address (`daemon.metrics-listen`, `bridge.metrics-listen`).
    pub key: &'static str,
    /// The configured address.
    pub addr: String,
    /// The operating system's message.
    pub reason: String,
}

/// Binds the metrics listener on `addr` (`IP:PORT`; port 0 picks a free one), the value of
/// `key`.
pub async fn bind(key: &'static str, addr: &str) -> Result<tokio::net::TcpListener, MetricsError> {
    let err = |reason: String| MetricsError {
        key,
        addr: addr.to_string(),
        reason,
    };
    let sa: SocketAddr = addr.parse().map_err(|e| err(format!("{e}")))?;
    tokio::net::TcpListener::bind(sa)
        .await
        .map_err(|e| err(e.to_string()))
}

/// At most this many scrape connections at once; more wait in the listen backlog.
const MAX_CONNECTIONS: usize = 16;

/// Serves `GET /metrics` on `listener` until the task is dropped (which closes every
/// connection). Other paths answer 404, other methods 405. A connection that sends no
/// complete request head within 10 s is closed.
pub async fn serve(listener: tokio::net::TcpListener, registry: Arc<Registry>) {
    use hyper::server::conn::http1;
    use hyper_util::rt::{TokioIo, TokioTimer};
    let mut connections = tokio::task::JoinSet::new();
    loop {
        while connections.try_join_next().is_some() {}
        if connections.len() >= MAX_CONNECTIONS {
            let _ = connections.join_next().await;
            continue;
        }
        let (stream, peer) = match listener.accept().await {
            Ok(s) => s,
            Err(e) => {
                // Out of file descriptors and the like: wait a little rather than spin.
                tracing::warn!("metrics endpoint: accept failed: {e}");
                tokio::time::sleep(Duration::from_millis(100)).await;
                continue;
            }
        };
        let reg = registry.clone();
        connections.spawn(async move {
            let service = hyper::service::service_fn(move |req| {
                let reg = reg.clone();
                async move { Ok::<_, std::convert::Infallible>(respond(&reg, &req)) }
            });
            let conn = http1::Builder::new()
                .timer(TokioTimer::new())
                .header_read_timeout(Duration::from_secs(10))
                .serve_connection(TokioIo::new(stream), service);
            if let Err(e) = conn.await {
                tracing::debug!(%peer, "metrics connection: {e}");
            }
        });
    }
}

fn respond<B>(registry: &Registry, req: &hyper::Request<B>) -> hyper::Response<Full<Bytes>> {
    let (status, ctype, body) = if req.uri().path() != "/metrics" {
        (
            404,
            "text/plain; charset=utf-8",
            "not found: GET /metrics\n".to_string(),
        )
    } else if req.method() != hyper::Method::GET && req.method() != hyper::Method::HEAD {
        (
            405,
            "text/plain; charset=utf-8",
            "method not allowed\n".to_string(),
        )
    } else {
        (200, CONTENT_TYPE, encode(registry))
    };
    let mut resp = hyper::Response::new(Full::new(Bytes::from(body)));
    *resp.status_mut() = hyper::StatusCode::from_u16(status).unwrap_or_default();
    if let Ok(v) = hyper::header::HeaderValue::from_str(ctype) {
        resp.headers_mut().insert(hyper::header::CONTENT_TYPE, v);
    }
    resp
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_error_names_the_key_that_set_the_address() {
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap();
        for key in ["daemon.metrics-listen", "bridge.metrics-listen"] {
            let e = rt.block_on(super::bind(key, "not an address")).unwrap_err();
            assert!(
                e.to_string()
                    .starts_with(&format!("cannot listen for metrics on {key} = ")),
                "{e}"
            );
        }
    }
}
