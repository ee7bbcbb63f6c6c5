//! The simulated ship as a Zenoh peer: [`helmwatch_core::drivers::probe::Lockstep`] over a real session.
//!
//! Each tick the ship publishes its samples on the contract's keys in lockstep order
//! (rudder, speed, autopilot state and target when due, heading last) and then:
//!
//! - **lockstep** (`ship-peer.lockstep = true`) while a daemon holds `vessels/<v>/fdi/alive`:
//!   waits for the excitation whose `t` equals the heading's `t`, at most
//!   `ship-peer.excitation-timeout-s` of wall time, then steps. After a timeout the ship steps
//!   on with what its autopilot holds: the last valid excitation until its `t + hold_s`, then
//!   its own command. That is how a daemon killed mid-test is observed: the autopilot reverts
//!   within `hold_s` of ship time. A simulated hour runs in seconds and the result does not
//!   depend on the machine's speed.
//! - **real time** (lockstep off, or no daemon alive): ticks on a timer, `speed-up` ship
//!   seconds per wall second, applying excitations as they arrive.
//!
//! The autopilot side of the contract (validity `t .. t + hold_s`, `add`, `replace`, `none`)
//! is the simulator's own ([`helmwatch_core::sim::Autopilot`]); this module only moves messages.
//! Optionally, every publication is recorded as JSON lines (the `simulate` format), so
//! `helmwatch replay` can run the core over a live session afterwards.
//!
//! **NMEA only** ([`ShipNode::nmea_to`], `helmwatch ship --nmea-udp`): the ship's instruments
//! speak NMEA 0183 instead of Zenoh. Each tick is one IEC 61162-450 datagram to a UDP address
//! (RSA, VHW, HTD when due, HDT last, each behind a tag block `s:SI0001,c:<ms>` carrying the
//! sensors' clock in milliseconds, [`helmwatch_core::nmea::tick_sentences`]); a bridge with
//! `time-source = "tag-block-ms"` turns them into the contract's keys. The ship still hears
//! the daemon's excitation over Zenoh and, in lockstep, waits for the excitation whose `t` is
//! the heading's time as the tag block carries it (rounded to the millisecond).

mod links;

use crate::shells::net::{ZenohConfig, ZenohMode};
use helmwatch_core::config::{check_range_open_low, fail, ConfigError};
use helmwatch_core::sim::config::SimConfig;
use helmwatch_core::sim::{CommandSource, Scenario, Ship, SimError, Truth};
use helmwatch_core::wire::{Excitation, Input, Keys, RecordLine, Stream};
use links::{
    declare_stream_publishers, nmea_socket, send_nmea, subscribe_alive, subscribe_excitations,
    zenoh_error, Links,
};
use serde::{Deserialize, Serialize};
use std::future::Future;
use std::io::Write;
use std::sync::atomic::{AtomicI64, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Duration;
use tokio::sync::mpsc;
use tokio::time::Instant;

/// Why the ship peer stopped with an error.
#[derive(Debug, thiserror::Error)]
pub enum ShipNodeError {
    /// The scenario or configuration is not valid.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// The Zenoh session could not be opened or a declaration failed.
    #[error("Zenoh: {0}")]
    Zenoh(String),
    /// Writing the recording failed.
    #[error("writing the recording: {0}")]
    Record(#[from] std::io::Error),
}

/// How the ship peer runs.
#[derive(Debug, Clone, PartialEq)]
pub struct ShipNodeOptions {
    /// Vessel name in the keys.
    pub vessel: String,
    /// Wait for the excitation of each heading while a daemon is alive.
    pub lockstep: bool,
    /// Ship seconds per wall second when ticking on the timer.
    pub speed_up: f64,
    /// Longest lockstep wait for one excitation (wall time).
    pub excitation_timeout: Duration,
    /// Stop after this much ship time [s]; `None` runs until shutdown.
    pub duration_s: Option<f64>,
}

impl ShipNodeOptions {
    /// Options from `[ship-peer]` and the vessel name (`simulation.vessel`), running until
    /// shutdown.
    pub fn from_config(peer: &ShipPeerConfig, vessel: &str) -> Self {
        Self {
            vessel: vessel.to_string(),
            lockstep: peer.lockstep,
            speed_up: peer.speed_up,
            excitation_timeout: Duration::from_secs_f64(peer.excitation_timeout_s),
            duration_s: None,
        }
    }
}

/// What a ship run did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ShipSummary {
    /// Ticks simulated.
    pub ticks: u64,
    /// Ship time at the end [s].
    pub t_end_s: f64,
    /// Excitation messages received.
    pub excitations: u64,
    /// Lockstep waits that ran out.
    pub excitation_timeouts: u64,
    /// Excitation payloads that did not decode.
    pub malformed_excitations: u64,
}

/// Called after every tick with the heading's `t` and the ship's true state after the step
/// (its `command_source` says what steered during the tick).
pub type TickObserver = Box<dyn FnMut(f64, &Truth) + Send>;

/// The simulated ship peer. Build it, optionally observe or record, then [`ShipNode::run`].
pub struct ShipNode {
    ship: Ship,
    opts: ShipNodeOptions,
    observer: Option<TickObserver>,
    record: Option<Box<dyn Write + Send>>,
    nmea: Option<std::net::SocketAddr>,
    nmea_heading: helmwatch_core::nmea::HeadingSentence,
}

impl std::fmt::Debug for ShipNode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ShipNode")
            .field("opts", &self.opts)
            .finish_non_exhaustive()
    }
}

impl ShipNode {
    /// A ship for `scenario` (checked with the configuration).
    pub fn new(
        cfg: &SimConfig,
        scenario: &Scenario,
        opts: ShipNodeOptions,
    ) -> Result<Self, ShipNodeError> {
        helmwatch_core::config::check_vessel_name("vessel", &opts.vessel)
            .map_err(SimError::from)?;
        Ok(Self {
            ship: Ship::new(cfg, scenario)?,
            opts,
            observer: None,
            record: None,
            nmea: None,
            nmea_heading: helmwatch_core::nmea::HeadingSentence::Hdt,
        })
    }

    /// Calls `f` after every tick (tests, the demo).
    pub fn observe(mut self, f: impl FnMut(f64, &Truth) + Send + 'static) -> Self {
        self.observer = Some(Box::new(f));
        self
    }

    /// Records every publication as JSON lines `{"key", "payload"}` (the `simulate` format).
    pub fn record_to(mut self, w: impl Write + Send + 'static) -> Self {
        self.record = Some(Box::new(std::io::BufWriter::new(w)));
        self
    }

    /// The instruments speak NMEA: each tick is sent as one IEC 61162-450 datagram to `addr`
    /// instead of being published on the contract's keys (see the module doc).
    pub fn nmea_to(mut self, addr: std::net::SocketAddr) -> Self {
        self.nmea = Some(addr);
        self
    }

    /// The heading sentence the NMEA instruments send (HDT unless set: THS as gyros and INS
    /// that do not send HDT, HDG as a magnetic compass without deviation or variation).
    pub fn nmea_heading(mut self, h: helmwatch_core::nmea::HeadingSentence) -> Self {
        self.nmea_heading = h;
        self
    }

    /// Opens a session on `zcfg` and runs until `shutdown` completes or the duration is over.
    pub async fn run(
        mut self,
        zcfg: zenoh::Config,
        shutdown: impl Future<Output = ()>,
    ) -> Result<ShipSummary, ShipNodeError> {
        let session = zenoh::open(zcfg).await.map_err(zenoh_error)?;
        let nmea = match self.nmea {
            Some(addr) => Some((nmea_socket(addr).await?, addr)),
            None => None,
        };
        let keys = Keys::new(&self.opts.vessel);
        let (pubs, stream_keys) =
            declare_stream_publishers(&session, &keys, self.opts.lockstep).await?;
        let malformed = Arc::new(AtomicU64::new(0));
        let (_excitation_sub, erx) =
            subscribe_excitations(&session, &keys, malformed.clone()).await?;
        let alive = Arc::new(AtomicI64::new(0));
        let _alive_sub = subscribe_alive(&session, &keys, alive.clone()).await?;
        tracing::info!(
            vessel = %self.opts.vessel,
            lockstep = self.opts.lockstep,
            speed_up = self.opts.speed_up,
            "ship peer running"
        );
        let mut links = Links {
            pubs,
            stream_keys,
            nmea,
            erx,
            alive,
        };
        let mut summary = ShipSummary::default();
        let result = self.tick_loop(&mut links, &mut summary, shutdown).await;
        if let Some(w) = self.record.as_mut() {
            w.flush()?;
        }
        summary.t_end_s = self.ship.time_s();
        summary.malformed_excitations = malformed.load(Ordering::Relaxed);
        if let Err(e) = session.close().await {
            tracing::warn!("closing the Zenoh session: {e}");
        }
        tracing::info!(
            ticks = summary.ticks,
            t_end_s = summary.t_end_s,
            excitations = summary.excitations,
            timeouts = summary.excitation_timeouts,
            "ship peer stopped"
        );
        result.map(|()| summary)
    }

    /// Ticks until `shutdown` completes or the duration is over: each tick publishes the
    /// samples, waits for the daemon's excitation (lockstep) or for the timer, then steps.
    async fn tick_loop(
        &mut self,
        links: &mut Links,
        summary: &mut ShipSummary,
        shutdown: impl Future<Output = ()>,
    ) -> Result<(), ShipNodeError> {
        let dt = self.ship.dt_s();
        let pace = Duration::from_secs_f64(dt / self.opts.speed_up);
        let t0 = self.ship.time_s();
        let mut inputs: Vec<Input> = Vec::with_capacity(8);
        let mut last_exc_t: f64;
        let mut next = Instant::now();
        let mut source = CommandSource::Own;
        let mut daemon_seen = false;
        tokio::pin!(shutdown);
        loop {
            if let Some(d) = self.opts.duration_s {
                if self.ship.time_s() - t0 >= d - 1e-9 {
                    return Ok(());
                }
            }
            tokio::select! {
                biased;
                _ = &mut shutdown => return Ok(()),
                _ = std::future::ready(()) => {}
            }
            inputs.clear();
            self.ship.publish(&mut inputs);
            // The excitation to wait for carries the heading's `t` as published: the sensors'
            // clock, which may have stepped (a clock fault) or be wild for one tick.
            let t = inputs
                .iter()
                .rev()
                .find(|i| i.stream() == Stream::Heading)
                .map_or_else(|| self.ship.clock_s(), |i| i.t());
            // Excitations of earlier ticks do not answer this one (a clock stepped back
            // would otherwise leave an old, later `t` standing in for it).
            last_exc_t = f64::NEG_INFINITY;
            self.publish_inputs(&inputs, links).await?;
            let t = send_nmea(links.nmea.as_ref(), self.nmea_heading, t, &inputs).await;
            let daemon_alive = links.alive.load(Ordering::Relaxed) > 0;
            if daemon_alive != daemon_seen {
                daemon_seen = daemon_alive;
                tracing::info!(
                    t,
                    "daemon {}",
                    if daemon_alive {
                        "alive: lockstep"
                    } else {
                        "gone: ticking on the timer"
                    }
                );
            }
            self.take_excitations(&mut links.erx, &mut last_exc_t, summary);
            if self.opts.lockstep && daemon_alive && last_exc_t < t {
                let waited = self
                    .await_excitation(&mut links.erx, t, &mut last_exc_t, summary, &mut shutdown)
                    .await;
                if !waited {
                    return Ok(());
                }
                next = Instant::now();
            } else if !(self.opts.lockstep && daemon_alive) {
                next += pace;
                let now = Instant::now();
                if next + Duration::from_secs(1) < now {
                    next = now; // after a stall, do not burst to catch up
                }
                tokio::select! {
                    biased;
                    _ = &mut shutdown => return Ok(()),
                    _ = tokio::time::sleep_until(next) => {}
                }
                self.take_excitations(&mut links.erx, &mut last_exc_t, summary);
            }
            self.step(t, &mut source, summary);
        }
    }

    /// Records the tick's samples (when recording) and publishes them on their keys (unless
    /// the instruments speak NMEA).
    async fn publish_inputs(
        &mut self,
        inputs: &[Input],
        links: &Links,
    ) -> Result<(), ShipNodeError> {
        for input in inputs {
            let payload = input.payload();
            let i = input.stream().index();
            if let Some(w) = self.record.as_mut() {
                let line = RecordLine {
                    key: links.stream_keys[i].clone(),
                    payload: payload.clone(),
                };
                serde_json::to_writer(&mut *w, &line)
                    .map_err(std::io::Error::from)
                    .and_then(|()| w.write_all(b"\n"))?;
            }
            if links.nmea.is_some() {
                continue;
            }
            let bytes = serde_json::to_vec(&payload).unwrap_or_default();
            if let Err(e) = links.pubs[i].put(bytes).await {
                tracing::warn!("publishing {}: {e}", links.stream_keys[i]);
            }
        }
        Ok(())
    }

    /// Applies the excitations already received.
    fn take_excitations(
        &mut self,
        erx: &mut mpsc::Receiver<Excitation>,
        last_exc_t: &mut f64,
        summary: &mut ShipSummary,
    ) {
        while let Ok(e) = erx.try_recv() {
            *last_exc_t = last_exc_t.max(e.t);
            self.ship.receive_excitation(&e);
            summary.excitations += 1;
        }
    }

    /// Lockstep: applies excitations as they come until the one for the heading at `t`, at
    /// most `excitation-timeout-s`; `false` when `shutdown` completed first.
    async fn await_excitation<S: Future<Output = ()>>(
        &mut self,
        erx: &mut mpsc::Receiver<Excitation>,
        t: f64,
        last_exc_t: &mut f64,
        summary: &mut ShipSummary,
        shutdown: &mut std::pin::Pin<&mut S>,
    ) -> bool {
        let deadline = Instant::now() + self.opts.excitation_timeout;
        loop {
            tokio::select! {
                biased;
                _ = &mut *shutdown => return false,
                e = erx.recv() => match e {
                    Some(e) => {
                        *last_exc_t = last_exc_t.max(e.t);
                        self.ship.receive_excitation(&e);
                        summary.excitations += 1;
                        if e.t >= t {
                            return true;
                        }
                    }
                    None => return true,
                },
                _ = tokio::time::sleep_until(deadline) => {
                    summary.excitation_timeouts += 1;
                    if summary.excitation_timeouts.is_power_of_two() {
                        tracing::warn!(
                            t,
                            count = summary.excitation_timeouts,
                            "no excitation for this heading in time: stepping on (a daemon that saw a later t, \
                             e.g. from an earlier simulated ship, rejects these samples as out of order: \
                             restart it, or set simulation.start-time-s past that t)"
                        );
                    }
                    return true;
                }
            }
        }
    }

    /// Steps the ship, logs a change of what steers, tells the observer.
    fn step(&mut self, t: f64, source: &mut CommandSource, summary: &mut ShipSummary) {
        self.ship.step();
        summary.ticks += 1;
        let truth = self.ship.truth();
        if truth.command_source != *source {
            tracing::info!(
                t,
                "autopilot command: {:?} -> {:?}",
                source,
                truth.command_source
            );
            *source = truth.command_source;
        }
        if let Some(obs) = self.observer.as_mut() {
            obs(t, &truth);
        }
    }
}

// ---------------------------------------------------------------------------------------------
// The [ship-peer] section

/// The simulated ship as a Zenoh peer (`helmwatch ship`): its pace, its faults, its session.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields, rename_all = "kebab-case")]
pub struct ShipPeerConfig {
    /// Lockstep: after each heading, wait for the daemon's excitation with that `t` (while a
    /// daemon holds `fdi/alive`); otherwise tick on a timer.
    pub lockstep: bool,
    /// Ship seconds per wall second when ticking on the timer (real time = 1), (0, 10000].
    pub speed_up: f64,
    /// Longest wait for the excitation of one heading in lockstep [s, wall]; then the ship
    /// steps on with what its autopilot holds (its own command once `hold_s` has run out).
    pub excitation_timeout_s: f64,
    /// Faults `KIND:VALUE@ONSET_S` (e.g. `displacement_pct:+10@300`); `--fault` adds more.
    pub faults: Vec<String>,
    /// Zenoh node mode of the ship.
    pub mode: ZenohMode,
    /// Endpoints the ship listens on (none by default).
    pub listen: Vec<String>,
    /// Endpoints the ship connects to (the daemon's by default).
    pub connect: Vec<String>,
    /// UDP multicast scouting.
    pub multicast_scouting: bool,
}

impl Default for ShipPeerConfig {
    fn default() -> Self {
        Self {
            lockstep: true,
            speed_up: 1.0,
            excitation_timeout_s: 1.0,
            faults: Vec::new(),
            mode: ZenohMode::Peer,
            listen: Vec::new(),
            connect: vec!["tcp/127.0.0.1:7447".to_string()],
            multicast_scouting: false,
        }
    }
}

impl ShipPeerConfig {
    /// Checks the section's limits; the error names the key and its allowed range.
    pub fn check(&self) -> Result<(), ConfigError> {
        check_range_open_low("ship-peer.speed-up", self.speed_up, 0.0, 10000.0)?;
        check_range_open_low(
            "ship-peer.excitation-timeout-s",
            self.excitation_timeout_s,
            0.0,
            60.0,
        )?;
        for (i, f) in self.faults.iter().enumerate() {
            if let Err(e) = f.parse::<helmwatch_core::sim::Fault>() {
                return Err(fail(
                    &format!("ship-peer.faults[{i}]"),
                    format!("{f:?}"),
                    &format!("KIND:VALUE@ONSET_S ({e})"),
                ));
            }
        }
        self.zenoh().check("ship-peer")
    }

    /// The ship's Zenoh session settings.
    pub fn zenoh(&self) -> ZenohConfig {
        ZenohConfig {
            mode: self.mode,
            listen: self.listen.clone(),
            connect: self.connect.clone(),
            multicast_scouting: self.multicast_scouting,
            config_file: None,
        }
    }
}
