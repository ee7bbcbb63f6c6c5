//! `helmwatch plot` on real reports: the SVG parses, and its points read back through the
//! axes (fitted to the tick labels in the SVG itself) are the report's values, within a pixel.
//! The model curves are checked against the analytic Nomoto response computed here from the
//! ship's particulars, not through the crate's model code.

use helmwatch::config::Config;
use helmwatch::tools::plot::{detect, plot, InputKind, PlotOptions};
use helmwatch_core::drivers::probe::{run_probe, ProbeOptions};
use helmwatch_core::estimator::Estimator;
use helmwatch_core::sim::Scenario;
use helmwatch_core::wire::{Method, Report};

fn report(cfg: &Config, method: Method, seed: u64) -> Report {
    let mut opts = ProbeOptions::new(&cfg.core(), method);
    opts.estimator = Estimator::from_config(&cfg.core()).unwrap();
    let r = run_probe(
        &cfg.core(),
        &cfg.sim(),
        &Scenario::nominal(&cfg.sim(), seed),
        &opts,
    )
    .unwrap()
    .report;
    assert!(r.estimate.is_some(), "{r:?}");
    r
}

/// Circles `(cx, cy)` and numeric tick labels `(x, y, value, anchor)` of an SVG.
struct Svg {
    width: f64,
    height: f64,
    circles: Vec<(f64, f64)>,
    labels: Vec<(f64, f64, f64, String)>,
    /// Polylines: (stroke colour, points).
    polylines: Vec<(String, Vec<(f64, f64)>)>,
}

fn parse(svg: &str) -> Svg {
    let doc = roxmltree::Document::parse(svg).expect("valid XML");
    let root = doc.root_element();
    assert_eq!(root.tag_name().name(), "svg");
    assert_eq!(
        root.tag_name().namespace(),
        Some("http://www.w3.org/2000/svg")
    );
    let num = |n: &roxmltree::Node, a: &str| n.attribute(a).unwrap().parse::<f64>().unwrap();
    let mut out = Svg {
        width: num(&root, "width"),
        height: num(&root, "height"),
        circles: Vec::new(),
        labels: Vec::new(),
        polylines: Vec::new(),
    };
    for n in root.descendants().filter(|n| n.is_element()) {
        match n.tag_name().name() {
            "circle" => out.circles.push((num(&n, "cx"), num(&n, "cy"))),
            "text" if n.attribute("transform").is_none() => {
                let text = n.text().unwrap_or("").trim();
                if let Ok(v) = text.parse::<f64>() {
                    out.labels.push((
                        num(&n, "x"),
                        num(&n, "y"),
                        v,
                        n.attribute("text-anchor").unwrap_or("").to_string(),
                    ));
                }
            }
            "polyline" => {
                let pts = n
                    .attribute("points")
                    .unwrap()
                    .split_whitespace()
                    .map(|p| {
                        let (x, y) = p.split_once(',').unwrap();
                        (x.parse().unwrap(), y.parse().unwrap())
                    })
                    .collect();
                out.polylines
                    .push((n.attribute("stroke").unwrap_or("").to_string(), pts));
            }
            _ => {}
        }
    }
    out
}

/// Least-squares line `pixel = c0 + c1 value` through `(value, pixel)`; asserts the labels lie
/// on it (a linear axis) within a pixel: each label sits on a whole pixel, within half a pixel
/// of the true line, and the fitted line is within half a pixel of the true one. Returns the
/// inverse map pixel -> value.
fn axis(pairs: &[(f64, f64)]) -> impl Fn(f64) -> f64 {
    assert!(pairs.len() >= 3, "too few tick labels: {pairs:?}");
    let n = pairs.len() as f64;
    let (mv, mp) = (
        pairs.iter().map(|p| p.0).sum::<f64>() / n,
        pairs.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let c1 = pairs.iter().map(|p| (p.0 - mv) * (p.1 - mp)).sum::<f64>()
        / pairs.iter().map(|p| (p.0 - mv).powi(2)).sum::<f64>();
    let c0 = mp - c1 * mv;
    for p in pairs {
        assert!((c0 + c1 * p.0 - p.1).abs() <= 1.0, "{p:?} off the axis");
    }
    move |pixel| (pixel - c0) / c1
}

/// The axes of the panel between `y0` and `y1` pixels: y labels (anchor end) and x labels
/// (anchor middle, just below the panel), x through `fx` (identity or ln).
fn panel_axes(
    s: &Svg,
    y0: f64,
    y1: f64,
    fx: fn(f64) -> f64,
) -> (impl Fn(f64) -> f64, impl Fn(f64) -> f64) {
    let ys: Vec<(f64, f64)> = s
        .labels
        .iter()
        .filter(|l| l.3 == "end" && l.1 >= y0 && l.1 < y1)
        .map(|l| (l.2, l.1))
        .collect();
    let xs: Vec<(f64, f64)> = s
        .labels
        .iter()
        .filter(|l| l.3 == "middle" && l.1 >= y0 && l.1 < y1)
        .map(|l| (fx(l.2), l.0))
        .collect();
    (axis(&xs), axis(&ys))
}

/// Nomoto (a, b) from the default ship's particulars (docs/architecture.md), by hand.
fn nomoto(u: f64, d: f64) -> (f64, f64) {
    let (l, a0, area, rho) = (120.0, 0.25, 20.0, 1.025);
    (a0 * u / l, 0.5 * (u / l).powi(2) * area * l / (d / rho))
}

#[test]
fn clfrt_report_is_a_bode_pair_with_the_tones_where_they_belong() {
    let cfg = Config::default();
    let r = report(&cfg, Method::Clfrt, 1);
    let tones = &r.features.clfrt().unwrap().tones;
    assert_eq!(tones.len(), 3);
    // Through the binary, as a user runs it.
    let dir = std::env::temp_dir().join(format!("helmwatch-plot-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (input, out) = (dir.join("clfrt.json"), dir.join("clfrt.svg"));
    std::fs::write(&input, serde_json::to_string_pretty(&r).unwrap()).unwrap();
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_helmwatch"))
        .args([
            "plot",
            input.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .status()
        .unwrap();
    assert!(status.success());
    let svg = parse(&std::fs::read_to_string(&out).unwrap());
    assert_eq!((svg.width, svg.height), (1000.0, 760.0));
    // One circle per tone in each panel.
    assert_eq!(svg.circles.len(), 2 * tones.len(), "{:?}", svg.circles);
    let mid = svg.height / 2.0;
    for (panel, (y0, y1)) in [(0, (0.0, mid)), (1, (mid, svg.height))] {
        let (x_of, y_of) = panel_axes(&svg, y0, y1, f64::ln);
        let mut pts: Vec<(f64, f64)> = svg
            .circles
            .iter()
            .copied()
            .filter(|c| c.1 >= y0 && c.1 < y1)
            .collect();
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        assert_eq!(pts.len(), tones.len());
        for (t, &(cx, cy)) in tones.iter().zip(&pts) {
            let want = if panel == 0 {
                20.0 * t.gain.log10()
            } else {
                t.phase_rad.to_degrees()
            };
            // Within a pixel: compare in pixels through the axis's scale.
            let px_per_unit = 1.0 / (y_of(cy + 1.0) - y_of(cy)).abs();
            assert!(
                (y_of(cy) - want).abs() * px_per_unit <= 1.0,
                "panel {panel}: {} vs {want}",
                y_of(cy)
            );
            let px_per_ln = 1.0 / (x_of(cx + 1.0) - x_of(cx)).abs();
            assert!(
                (x_of(cx) - t.omega_rad_s.ln()).abs() * px_per_ln <= 1.0,
                "{} vs {}",
                x_of(cx).exp(),
                t.omega_rad_s
            );
        }
        // The nominal curve (blue) is the analytic ship at 7 m/s, 7000 t.
        let (a, b) = nomoto(7.0, 7000.0);
        let blue = svg
            .polylines
            .iter()
            .find(|(c, p)| {
                c == "#0000FF" && p.len() > 50 && p.iter().all(|q| q.1 >= y0 && q.1 < y1)
            })
            .expect("the nominal curve");
        for &(px, py) in &blue.1 {
            let w = x_of(px).exp();
            let want = if panel == 0 {
                20.0 * (b / (w * (w * w + a * a).sqrt())).log10()
            } else {
                -90.0 - (w / a).atan().to_degrees()
            };
            let px_per_unit = 1.0 / (y_of(py + 1.0) - y_of(py)).abs();
            assert!(
                (y_of(py) - want).abs() * px_per_unit <= 1.5,
                "panel {panel}: at w {w}: {} vs {want}",
                y_of(py)
            );
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn hbt_report_puts_the_measured_cycle_on_the_relay_locus() {
    let cfg = Config::default();
    let r = report(&cfg, Method::Hbt, 2);
    let f = r.features.hbt().unwrap().clone();
    let text = serde_json::to_string_pretty(&r).unwrap();
    assert_eq!(detect(&text).unwrap(), InputKind::Report);
    let svg = parse(&plot(&cfg, &text, InputKind::Report, &PlotOptions::default()).unwrap());
    assert_eq!(svg.circles.len(), 1, "{:?}", svg.circles);
    let (x_of, y_of) = panel_axes(&svg, 0.0, svg.height, |x| x);
    // -1/N(A) of the default relay (h = 8 deg, eps = 1 deg), from its definition.
    let (h, eps, a) = (8f64.to_radians(), 1f64.to_radians(), f.amplitude_rad);
    let k = std::f64::consts::PI / (4.0 * h);
    let want = (-k * (a * a - eps * eps).sqrt(), -k * eps);
    let (cx, cy) = svg.circles[0];
    let (sx, sy) = (
        1.0 / (x_of(cx + 1.0) - x_of(cx)).abs(),
        1.0 / (y_of(cy + 1.0) - y_of(cy)).abs(),
    );
    assert!(
        (x_of(cx) - want.0).abs() * sx <= 1.0,
        "{} vs {}",
        x_of(cx),
        want.0
    );
    assert!(
        (y_of(cy) - want.1).abs() * sy <= 1.0,
        "{} vs {}",
        y_of(cy),
        want.1
    );
    // The locus (green) is the horizontal line Im = -pi eps / 4h.
    let green = svg
        .polylines
        .iter()
        .find(|(c, p)| c == "#00FF00" && p.len() > 10)
        .expect("the locus");
    assert!(green.1.iter().all(|p| (p.1 - cy).abs() <= 1.0));
}

#[test]
fn history_has_one_point_per_report() {
    let cfg = Config::default();
    let reports = vec![
        report(&cfg, Method::Clfrt, 3),
        report(&cfg, Method::Hbt, 4),
        report(&cfg, Method::Clfrt, 5),
        report(&cfg, Method::Hbt, 6),
    ];
    // Two reports as lines, two in a history reply (as `helmwatch history --json` prints),
    // with a notification record that is not a point.
    let record = |r: &Report| {
        serde_json::json!({"kind": "report", "t": r.t_end, "written_unix_s": 0.0,
            "payload": serde_json::to_value(r).unwrap()})
    };
    let reply = serde_json::json!({"vessel": "self", "records": [
        record(&reports[2]),
        {"kind": "notification", "t": 1.0, "written_unix_s": 0.0,
         "payload": {"state": "normal", "method": [], "message": "x"}},
        record(&reports[3]),
    ]});
    let text = format!(
        "{}\n{}\n{}\n",
        serde_json::to_string(&reports[0]).unwrap(),
        serde_json::to_string(&reports[1]).unwrap(),
        reply
    );
    assert_eq!(detect(&text).unwrap(), InputKind::History);
    let svg = parse(&plot(&cfg, &text, InputKind::History, &PlotOptions::default()).unwrap());
    assert_eq!(svg.circles.len(), reports.len(), "{:?}", svg.circles);
    let (x_of, y_of) = panel_axes(&svg, 0.0, svg.height / 2.0, |x| x);
    for r in &reports {
        let chi2 = r.residuals.parameters.as_ref().unwrap().chi2;
        let hit = svg.circles.iter().any(|&(cx, cy)| {
            let sx = 1.0 / (x_of(cx + 1.0) - x_of(cx)).abs();
            let sy = 1.0 / (y_of(cy + 1.0) - y_of(cy)).abs();
            (x_of(cx) - r.t_end).abs() * sx <= 1.0 && (y_of(cy) - chi2).abs() * sy <= 1.0
        });
        assert!(hit, "no point at t_end {} chi2 {chi2}", r.t_end);
    }
}

#[test]
fn recording_is_detected_and_bad_input_is_refused() {
    let cfg = Config::default();
    let mut rec = Vec::new();
    helmwatch_core::sim::record(
        &cfg.sim(),
        &Scenario::nominal(&cfg.sim(), 1),
        120.0,
        "self",
        &mut rec,
    )
    .unwrap();
    let text = String::from_utf8(rec).unwrap();
    assert_eq!(detect(&text).unwrap(), InputKind::Recording);
    let svg = parse(&plot(&cfg, &text, InputKind::Recording, &PlotOptions::default()).unwrap());
    // Heading (blue) in the upper half, one vertex per sample (10 Hz, 120 s).
    let heading = svg
        .polylines
        .iter()
        .find(|(c, p)| c == "#0000FF" && p.len() > 100)
        .expect("the heading");
    assert_eq!(heading.1.len(), 1200);
    assert!(heading.1.iter().all(|p| p.1 < svg.height / 2.0));
    assert!(detect("hello").is_err());
    assert!(plot(
        &cfg,
        "{\"a\": 1}",
        InputKind::Report,
        &PlotOptions::default()
    )
    .is_err());
    // The binary: bad data 65, a missing file 74.
    let run = |args: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_helmwatch"))
            .args(args)
            .output()
            .unwrap()
            .status
            .code()
    };
    let dir = std::env::temp_dir().join(format!("helmwatch-plot-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("bad.json");
    std::fs::write(&bad, "not json\n").unwrap();
    let out = dir.join("out.svg");
    assert_eq!(
        run(&[
            "plot",
            bad.to_str().unwrap(),
            "--out",
            out.to_str().unwrap()
        ]),
        Some(65)
    );
    assert_eq!(
        run(&[
            "plot",
            "/nonexistent/x.json",
            "--out",
            out.to_str().unwrap()
        ]),
        Some(74)
    );
    assert!(!out.exists());
    let _ = std::fs::remove_dir_all(&dir);
}

/// The daemon's MCAP recording of a stretch plots exactly as the JSON-lines recording of the
/// same samples: the same SVG, byte for byte (the MCAP reader feeds the same trace).
#[test]
fn an_mcap_recording_plots_as_its_json_lines() {
    use helmwatch::shells::recording::message::Kind;
    use helmwatch::shells::recording::{Limits, Recorder};
    use helmwatch_core::wire::{Keys, RecordLine, Stream};
    let cfg = Config::default();
    let mut rec = Vec::new();
    helmwatch_core::sim::record(
        &cfg.sim(),
        &Scenario::nominal(&cfg.sim(), 2),
        60.0,
        "self",
        &mut rec,
    )
    .unwrap();
    let text = String::from_utf8(rec).unwrap();
    let dir = std::env::temp_dir().join(format!("helmwatch-plot-mcap-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let limits = Limits {
        max_bytes: 1 << 30,
        max_files: 10,
        segment_bytes: 1 << 29,
        segment_s: 3600.0,
    };
    let mut recorder = Recorder::open(&dir, limits).unwrap();
    let keys = Keys::new("self");
    let mut written = 0;
    for line in text.lines() {
        let l: RecordLine = serde_json::from_str(line).unwrap();
        let Some(&s) = Stream::BY_INDEX.iter().find(|&&s| keys.stream(s) == l.key) else {
            continue;
        };
        let t = l.payload["t"].as_f64().unwrap();
        let bytes = serde_json::to_vec(&l.payload).unwrap();
        recorder.write(&l.key, Kind::Input(s), t, &bytes).unwrap();
        written += 1;
    }
    assert!(written > 600, "{written}");
    recorder.finish().unwrap();
    let file = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.extension().is_some_and(|x| x == "mcap"))
        .expect("a finished recording");
    let bytes = std::fs::read(&file).unwrap();
    let opts = PlotOptions::default();
    let from_mcap = helmwatch::tools::plot::plot_mcap(&bytes, &opts).unwrap();
    let from_lines = plot(&cfg, &text, InputKind::Recording, &opts).unwrap();
    assert_eq!(from_mcap, from_lines);
    let svg = parse(&from_mcap);
    assert!(svg
        .polylines
        .iter()
        .any(|(c, p)| c == "#0000FF" && p.len() == 600));
    // The binary takes the file as it is.
    let out = dir.join("trace.svg");
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_helmwatch"))
        .args([
            "plot",
            file.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .status()
        .unwrap();
    assert!(status.success());
    assert_eq!(std::fs::read_to_string(&out).unwrap(), from_lines);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_state_file_plots_the_learned_reference_with_one_point_per_learned_test() {
    use helmwatch_core::fdi::raw::Raw;
    use helmwatch_core::fdi::Fdi;
    use helmwatch_core::monitor::VesselState;
    let cfg = Config::default();
    let fdi = Fdi::new(&cfg.core());
    let s = fdi.settings();
    let mut st = fdi.state();
    // CLFRT commissioned at 7 m/s, then learned at 8.5 m/s; HBT still commissioning.
    let raw = |u: f64, w: f64| Raw {
        speed_mps: 0.5 - 0.4 * (u - 7.0) + w,
        displacement: -0.1 + w / 10.0,
        speed_sigma_mps: 0.05,
        displacement_sigma: 0.002,
        speed_log_mps: u,
        displacement_declared_t: 7000.0,
        excitation_scale: 1.0,
        sea_index: None,
        ln_gain: Some(-5.0 + w / 10.0),
        ln_damping: None,
        speed_slope: [0.0; 3],
        loading_slope: [0.0; 3],
        meas: None,
        log_slope: 0.0,
    };
    let wobble = [0.0, 0.03, -0.03, 0.02, -0.02, 0.01, -0.01, 0.015];
    // The vessel's test numbers order the samples (`MethodReference::add`'s third argument).
    let mut order = 0..;
    for w in wobble {
        st.commissioning[0].add(&s, &raw(7.0, w), order.next().unwrap());
    }
    for w in &wobble[..4] {
        st.commissioning[0].add(&s, &raw(8.5, *w), order.next().unwrap());
    }
    for w in &wobble[..3] {
        st.commissioning[1].add(&s, &raw(7.0, *w), order.next().unwrap());
    }
    let learned = st.commissioning[0].samples.len() + st.commissioning[1].samples.len();
    assert_eq!(learned, 8 + 4 + 3);
    let state = VesselState {
        format: VesselState::FORMAT.into(),
        vessel: "self".into(),
        fdi: st,
        last_test_end: Some(1.0),
        next_method: 0,
        test_seq: 15,
        sea_wave_yaw_rad: None,
        commissioning_gap_s: None,
        clfrt_heading_guard: false,
    };
    let text = serde_json::to_string_pretty(&state).unwrap();
    assert_eq!(detect(&text).unwrap(), InputKind::Reference);
    let svg = parse(&plot(&cfg, &text, InputKind::Reference, &PlotOptions::default()).unwrap());
    // Each learned test in both of its method's panels (e_u and e_D).
    assert_eq!(svg.circles.len(), 2 * learned, "{:?}", svg.circles.len());
    // Nothing learned: a clear refusal.
    let empty = VesselState {
        fdi: fdi.state(),
        ..state
    };
    let e = plot(
        &cfg,
        &serde_json::to_string(&empty).unwrap(),
        InputKind::Reference,
        &PlotOptions::default(),
    )
    .unwrap_err();
    assert!(e.to_string().contains("no learned test"), "{e}");
}
