//! The ship peer's ends of the session: the input streams' publishers, the excitations and
//! `fdi/alive` subscribers, and the NMEA socket (instead of the publishers).

use super::ShipNodeError;
use helmwatch_core::wire::{Excitation, Input, Keys, Stream};
use std::sync::atomic::{AtomicI64, AtomicU64, Ordering};
use std::sync::Arc;
use tokio::sync::mpsc;
use zenoh::bytes::Encoding;
use zenoh::qos::{CongestionControl, Priority};
use zenoh::sample::SampleKind;

/// The ship peer's ends of the session: its publishers and their keys (by stream index), the
/// NMEA socket, the excitations received, the count of `fdi/alive` tokens.
pub(super) struct Links {
    pub(super) pubs: Vec<zenoh::pubsub::Publisher<'static>>,
    pub(super) stream_keys: Vec<String>,
    pub(super) nmea: Option<(tokio::net::UdpSocket, std::net::SocketAddr)>,
    pub(super) erx: mpsc::Receiver<Excitation>,
    pub(super) alive: Arc<AtomicI64>,
}

pub(super) fn zenoh_error(e: zenoh::Error) -> ShipNodeError {
    ShipNodeError::Zenoh(e.to_string())
}

/// A UDP socket to send NMEA datagrams to `addr` from (any local address of its family).
pub(super) async fn nmea_socket(
    addr: std::net::SocketAddr,
) -> Result<tokio::net::UdpSocket, ShipNodeError> {
    let local: std::net::SocketAddr = if addr.is_ipv4() {
        ([0, 0, 0, 0], 0).into()
    } else {
        (std::net::Ipv6Addr::UNSPECIFIED, 0).into()
    };
    Ok(tokio::net::UdpSocket::bind(local).await?)
}

/// One publisher per input stream, in [`Stream::index`] order, with their keys.
pub(super) async fn declare_stream_publishers(
    session: &zenoh::Session,
    keys: &Keys,
    lockstep: bool,
) -> Result<(Vec<zenoh::pubsub::Publisher<'static>>, Vec<String>), ShipNodeError> {
    let cc = if lockstep {
        CongestionControl::Block
    } else {
        CongestionControl::Drop
    };
    let mut pubs = Vec::with_capacity(5);
    let mut stream_keys = Vec::with_capacity(5);
    for s in Stream::BY_INDEX {
        // Index order = Stream::index().
        let key = keys.stream(s);
        // A declared key expression travels as a numeric id: the daemon caches its route.
        let ke = session
            .declare_keyexpr(key.clone())
            .await
            .map_err(zenoh_error)?;
        let p = session
            .declare_publisher(ke)
            .encoding(Encoding::APPLICATION_JSON)
            .congestion_control(cc)
            .priority(Priority::Data)
            // Heading last and express: it flushes the tick's batch in one write.
            .express(s == Stream::Heading)
            .await
            .map_err(zenoh_error)?;
        pubs.push(p);
        stream_keys.push(key);
    }
    Ok((pubs, stream_keys))
}

/// The daemon's excitations, queued for the tick loop; `malformed` counts those that do not
/// decode.
pub(super) async fn subscribe_excitations(
    session: &zenoh::Session,
    keys: &Keys,
    malformed: Arc<AtomicU64>,
) -> Result<(zenoh::pubsub::Subscriber<()>, mpsc::Receiver<Excitation>), ShipNodeError> {
    let (etx, erx) = mpsc::channel::<Excitation>(1024);
    let sub = session
        .declare_subscriber(keys.excitation())
        .callback(move |sample| {
            let bytes = sample.payload().to_bytes();
            match serde_json::from_slice::<Excitation>(&bytes) {
                Ok(e) => {
                    let _ = etx.try_send(e);
                }
                Err(_) => {
                    malformed.fetch_add(1, Ordering::Relaxed);
                }
            }
        })
        .await
        .map_err(zenoh_error)?;
    Ok((sub, erx))
}

/// Counts the `fdi/alive` tokens in `alive` (a daemon monitors the vessel while it is > 0).
pub(super) async fn subscribe_alive(
    session: &zenoh::Session,
    keys: &Keys,
    alive: Arc<AtomicI64>,
) -> Result<zenoh::pubsub::Subscriber<()>, ShipNodeError> {
    session
        .liveliness()
        .declare_subscriber(keys.alive())
        .history(true)
        .callback(move |sample| match sample.kind() {
            SampleKind::Put => {
                alive.fetch_add(1, Ordering::Relaxed);
            }
            SampleKind::Delete => {
                alive.fetch_sub(1, Ordering::Relaxed);
            }
        })
        .await
        .map_err(zenoh_error)
}

/// NMEA only: sends the tick as one datagram; returns the heading's time as the tag block
/// carries it (the excitation to wait for has it). Otherwise returns `t`.
pub(super) async fn send_nmea(
    nmea: Option<&(tokio::net::UdpSocket, std::net::SocketAddr)>,
    heading: helmwatch_core::nmea::HeadingSentence,
    t: f64,
    inputs: &[Input],
) -> f64 {
    match nmea {
        Some((sock, addr)) => {
            let (ms, t_wire) = helmwatch_core::nmea::tag_time_ms(t);
            let sentences = helmwatch_core::nmea::tick_sentences(inputs, heading);
            let d = helmwatch_core::nmea::datagram("SI0001", ms, &sentences);
            if let Err(e) = sock.send_to(&d, addr).await {
                tracing::warn!("sending NMEA to {addr}: {e}");
            }
            t_wire
        }
        None => t,
    }
}
