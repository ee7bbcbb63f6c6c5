//! `helmwatch plot`: what a test measured, drawn as SVG (plotters' SVG backend).
//!
//! | input | picture |
//! |---|---|
//! | a CLFRT report | Bode pair: the measured gain [dB] and phase [deg] at the tones with their 90 % intervals, over the nominal ship's `b / (j w (j w + a))` and the ships at the networks' raw estimate and at the estimate calibrated to the vessel |
//! | an HBT report | Nyquist plane: the loop the relay sees, servo describing function times ship `S(w) G(j w)` (solid), and the ship alone `G(j w)` (dashed), nominal and estimated, the relay's `-1/N(A)` locus, the measured limit cycle on it (a circle), the measured response `G(j w_u)` (a cross), the describing-function predictions (triangles) |
//! | a report history | the residuals against `t_end`: chi2 (circles, one per report) with the sequential test's single-test limit (from `fdi.false-alarms-per-year`), and `z_speed`, `z_disp`, `z_rate` |
//! | a recording | heading, rudder and excitation against time (an HBT limit cycle's time trace) |
//! | a vessel's state file (`<state-dir>/vessels/<v>.json`) | the learned reference over speed: per method, the learned tests' `e_u` and `e_D` (circles), the predicted offset and its two-sigma band ([`reference`]) |
//!
//! The nominal ship is the configuration's `[ship]` at its nominal speed and displacement; the
//! estimated ones are the same model at the report's `estimate` (the networks' raw reading,
//! "networks' estimate (raw)") and at its `calibrated_estimate` ("calibrated to the vessel",
//! once the vessel's reference is in force); `(a, b)` from `(u, D)` through
//! [`helmwatch_core::model::ShipConfig::nomoto`]. The relay's height and hysteresis are the
//! report's, as played (a test sized to the loop or to the sea plays another than `[hbt]`'s;
//! the height clamped to `servo.max-angle-deg`, as the relay is).
//!
//! Markers: only the measured points are circles (one per tone in each panel of a Bode pair,
//! one per HBT report, one per report in a history's chi2 panel), so a reader of the SVG can
//! count them.
//!
//! The kind of input is detected ([`detect`]) unless forced: the whole input as one JSON
//! object with `records` is a history (`helmwatch history --json`), with `key` and `payload`
//! a recording, with `method` and `features` a report (`helmwatch probe --json`), with
//! `vessel` and `fdi` a vessel's state file; otherwise
//! its first non-empty line decides: `key` and `payload` a recording (JSON lines), `records`
//! or `method` and `residuals` a history (one report or one history reply per line).
//! Recordings are read through [`recording::Trace::collect`], which takes any iterator of
//! `RecordLine`s: [`recording::json_lines`] is one source; another format (MCAP) plugs in
//! as another iterator.

mod bode;
mod nyquist;
pub mod recording;
mod reference;
mod style;
mod timelines;

use crate::config::Config;
use helmwatch_core::wire::{Method, Report};
use serde_json::Value;

/// What an input holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InputKind {
    /// One report (`fdi/report` payload).
    Report,
    /// Reports over time: JSON lines of reports, or of history replies.
    History,
    /// A recording: JSON lines `{"key", "payload"}`.
    Recording,
    /// A vessel's state file (`<state-dir>/vessels/<v>.json`): its learned reference.
    Reference,
}

impl InputKind {
    /// The name on the command line (`--kind`).
    pub fn name(self) -> &'static str {
        match self {
            InputKind::Report => "report",
            InputKind::History => "history",
            InputKind::Recording => "recording",
            InputKind::Reference => "reference",
        }
    }
}

impl std::str::FromStr for InputKind {
    type Err = helmwatch_core::config::UnknownName;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "report" => Ok(InputKind::Report),
            "history" => Ok(InputKind::History),
            "recording" => Ok(InputKind::Recording),
            "reference" => Ok(InputKind::Reference),
            other => Err(Self::Err::new(
                "kind",
                other,
                "report, history, recording, reference",
            )),
        }
    }
}

/// Why a plot failed.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The input is not what its kind needs (exit 65).
    #[error("{0}")]
    Data(String),
    /// plotters failed to draw (exit 70).
    #[error("drawing: {0}")]
    Draw(String),
}

/// The picture's size and what to take from a recording.
#[derive(Debug, Clone)]
pub struct PlotOptions {
    /// Width [px].
    pub width_px: u32,
    /// Height [px].
    pub height_px: u32,
    /// A recording's vessel (default: the first one in it).
    pub vessel: Option<String>,
}

impl Default for PlotOptions {
    fn default() -> Self {
        Self {
            width_px: 1000,
            height_px: 760,
            vessel: None,
        }
    }
}

fn data(msg: impl Into<String>) -> PlotError {
    PlotError::Data(msg.into())
}

fn is_obj_with(v: &Value, keys: &[&str]) -> bool {
    v.as_object()
        .is_some_and(|o| keys.iter().all(|k| o.contains_key(*k)))
}

/// The kind of `text` (module documentation), or why it has none.
pub fn detect(text: &str) -> Result<InputKind, PlotError> {
    if let Ok(v) = serde_json::from_str::<Value>(text) {
        if is_obj_with(&v, &["records"]) {
            return Ok(InputKind::History);
        }
        if is_obj_with(&v, &["key", "payload"]) {
            return Ok(InputKind::Recording);
        }
        if is_obj_with(&v, &["method", "features"]) {
            return Ok(InputKind::Report);
        }
        if is_obj_with(&v, &["vessel", "fdi"]) {
            return Ok(InputKind::Reference);
        }
    }
    let first = text
        .lines()
        .find(|l| !l.trim().is_empty())
        .ok_or_else(|| data("the input is empty"))?;
    let v: Value = serde_json::from_str(first)
        .map_err(|e| data(format!("the first line is not JSON: {e}")))?;
    if is_obj_with(&v, &["key", "payload"]) {
        Ok(InputKind::Recording)
    } else if is_obj_with(&v, &["records"]) || is_obj_with(&v, &["method", "residuals"]) {
        Ok(InputKind::History)
    } else {
        Err(data(
            "neither a report, a report history nor a recording (use --kind to say which)",
        ))
    }
}

/// One report from `text` (a JSON object, pretty-printed or not).
pub fn parse_report(text: &str) -> Result<Report, PlotError> {
    serde_json::from_str(text).map_err(|e| data(format!("not a report: {e}")))
}

/// The reports of a history: JSON lines, each a report or a history reply (`{"vessel",
/// "records"}`, whose `report` records are taken), or the whole text one of those. Returns
/// the vessel when a reply names it.
pub fn parse_history(text: &str) -> Result<(Option<String>, Vec<Report>), PlotError> {
    let mut vessel = None;
    let mut reports = Vec::new();
    let mut take = |v: Value, line: usize| -> Result<(), PlotError> {
        if let Some(records) = v.get("records").and_then(Value::as_array) {
            if let Some(name) = v.get("vessel").and_then(Value::as_str) {
                vessel.get_or_insert_with(|| name.to_string());
            }
            for r in records {
                if r.get("kind").and_then(Value::as_str) == Some("report") {
                    let p = r.get("payload").cloned().unwrap_or(Value::Null);
                    reports.push(
                        serde_json::from_value(p)
                            .map_err(|e| data(format!("line {line}: a record: {e}")))?,
                    );
                }
            }
        } else {
            reports.push(
                serde_json::from_value(v)
                    .map_err(|e| data(format!("line {line}: not a report: {e}")))?,
            );
        }
        Ok(())
    };
    if let Ok(v) = serde_json::from_str::<Value>(text) {
        take(v, 1)?;
    } else {
        for (i, line) in text.lines().enumerate() {
            if line.trim().is_empty() {
                continue;
            }
            let v: Value = serde_json::from_str(line)
                .map_err(|e| data(format!("line {}: not JSON: {e}", i + 1)))?;
            take(v, i + 1)?;
        }
    }
    Ok((vessel, reports))
}

/// The SVG of `text` read as `kind`, with the nominal ship of `cfg`.
pub fn plot(
    cfg: &Config,
    text: &str,
    kind: InputKind,
    opts: &PlotOptions,
) -> Result<String, PlotError> {
    let size = (opts.width_px, opts.height_px);
    let mut svg = String::new();
    match kind {
        InputKind::Report => {
            let r = parse_report(text)?;
            plot_report(cfg, &r, size, &mut svg)?;
        }
        InputKind::History => {
            let (vessel, reports) = parse_history(text)?;
            if reports.is_empty() {
                return Err(data("no report in the history"));
            }
            let points = history_points(&reports);
            let title = match vessel {
                Some(v) => format!("{v}: residuals of {} reports", reports.len()),
                None => format!("residuals of {} reports", reports.len()),
            };
            // The single-test limit of the sequential test (one method, a window of one).
            let limit = helmwatch_core::fdi::limits::DecisionLimits::new(
                cfg.fdi.false_alarms_per_year,
                cfg.scheduler.interval_s + cfg.scheduler.steady_time_s,
                cfg.fdi.window_tests,
            )
            .param[helmwatch_core::fdi::stats::P];
            timelines::history(&mut svg, size, &title, &points, limit)?;
        }
        InputKind::Recording => {
            let trace =
                recording::Trace::collect(recording::json_lines(text), opts.vessel.as_deref())?;
            timelines::trace(&mut svg, size, &trace)?;
        }
        InputKind::Reference => {
            let state: helmwatch_core::monitor::VesselState = serde_json::from_str(text)
                .map_err(|e| data(format!("not a vessel state file: {e}")))?;
            // The vessel's own configuration, when the file has a table for it.
            let core = cfg
                .fleet()
                .ok()
                .and_then(|v| v.into_iter().find(|(name, _)| *name == state.vessel))
                .map_or_else(|| cfg.core(), |(_, c)| c);
            let settings = helmwatch_core::fdi::Fdi::new(&core).settings();
            let title = format!("{}: the learned reference over speed", state.vessel);
            reference::reference(&mut svg, size, &title, &state.fdi.commissioning, &settings)?;
        }
    }
    Ok(svg)
}

/// The SVG of an MCAP recording (`daemon.record`): the same trace as a JSON-lines one.
pub fn plot_mcap(bytes: &[u8], opts: &PlotOptions) -> Result<String, PlotError> {
    let mut svg = String::new();
    let trace = recording::Trace::collect(recording::mcap_lines(bytes), opts.vessel.as_deref())?;
    timelines::trace(&mut svg, (opts.width_px, opts.height_px), &trace)?;
    Ok(svg)
}

/// A report's picture: Bode pair (CLFRT) or Nyquist plane (HBT).
pub fn plot_report(
    cfg: &Config,
    r: &Report,
    size: (u32, u32),
    svg: &mut String,
) -> Result<(), PlotError> {
    let ship = &cfg.ship;
    let nominal = ship.nomoto(ship.nominal_speed_mps, ship.nominal_displacement_t);
    let estimated = style::Estimated {
        raw: (r.estimate).map(|e| ship.nomoto(e.speed_mps, e.displacement_t)),
        calibrated: (r.calibrated_estimate).map(|e| ship.nomoto(e.speed_mps, e.displacement_t)),
    };
    match r.method {
        Method::Clfrt => {
            let f = r.features.clfrt().ok_or_else(|| {
                data(format!(
                    "report {}: no CLFRT features (outcome {:?}{})",
                    r.test,
                    r.outcome,
                    r.reason
                        .as_ref()
                        .map(|x| format!(": {x}"))
                        .unwrap_or_default()
                ))
            })?;
            if f.tones.is_empty() {
                return Err(data(format!("report {}: no tones", r.test)));
            }
            let title = format!("CLFRT {}: heading / rudder", r.test);
            bode::bode(svg, size, &title, &f.tones, nominal, &estimated)
        }
        Method::Hbt => {
            let f = r.features.hbt().ok_or_else(|| {
                data(format!(
                    "report {}: no HBT features (outcome {:?})",
                    r.test, r.outcome
                ))
            })?;
            // The relay as played (the report's: a sized test played another).
            let relay = nyquist::Relay {
                height_rad: f.relay_height_rad.min(cfg.servo.max_angle_rad()),
                hysteresis_rad: f.hysteresis_rad,
            };
            let title = format!("HBT {}: limit cycle (describing function)", r.test);
            nyquist::nyquist(
                svg,
                size,
                &title,
                &nyquist::NyquistInput {
                    relay,
                    servo: cfg.servo.clone(),
                    omega_u_rad_s: f.omega_u_rad_s,
                    amplitude_rad: f.amplitude_rad,
                    response: f.response_gain.zip(f.response_phase_rad),
                    nominal,
                    estimated,
                },
            )
        }
    }
}

/// One report's residuals for the history chart (`None` where the report has none).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HistoryPoint {
    /// The report's `t_end` [s].
    pub t_end: f64,
    /// Its method.
    pub method: Method,
    /// `residuals.parameters.chi2`: the test's own Mahalanobis chi-square.
    pub chi2: Option<f64>,
    /// `residuals.parameters.z_speed`.
    pub z_speed: Option<f64>,
    /// `residuals.parameters.z_displacement`.
    pub z_disp: Option<f64>,
    /// `residuals.servo_check.z_rate`: the servo's rate shortfall (docs/fdi.md).
    pub z_rate: Option<f64>,
}

/// The residuals of `reports`, in their order.
pub fn history_points(reports: &[Report]) -> Vec<HistoryPoint> {
    let finite = |x: f64| x.is_finite().then_some(x);
    reports
        .iter()
        .map(|r| {
            let p = r.residuals.parameters.as_ref();
            HistoryPoint {
                t_end: r.t_end,
                method: r.method,
                chi2: p.and_then(|p| finite(p.chi2)),
                z_speed: p.and_then(|p| finite(p.z_speed)),
                z_disp: p.and_then(|p| finite(p.z_displacement)),
                z_rate: r.residuals.servo_check.and_then(|s| finite(s.z_rate)),
            }
        })
        .collect()
}

/// Reads `path` (`-`: standard input) as text.
pub fn read_input(path: &std::path::Path) -> std::io::Result<Vec<u8>> {
    use std::io::Read;
    let mut bytes = Vec::new();
    if path.as_os_str() == "-" {
        std::io::stdin().read_to_end(&mut bytes)?;
    } else {
        bytes = std::fs::read(path)?;
    }
    Ok(bytes)
}

/// `bytes` as text, or why they are not (a binary recording format is not read yet).
pub fn as_text(bytes: &[u8]) -> Result<&str, PlotError> {
    std::str::from_utf8(bytes).map_err(|_| {
        data("the input is not UTF-8 text (binary recordings are not read by plot yet)")
    })
}
