//! How a report reads on a terminal: features, the estimate, the baseline.

pub(crate) fn print_features(f: &serde_json::Value) {
    if let Some(tones) = f.get("tones").and_then(|t| t.as_array()) {
        println!("  tone  omega rad/s      gain   phase deg  +-gain %  +-phase deg  coherence");
        for (i, t) in tones.iter().enumerate() {
            let g = |k: &str| t.get(k).and_then(|v| v.as_f64()).unwrap_or(f64::NAN);
            println!(
                "  {:>4}  {:>11.4}  {:>8.4}  {:>10.2}  {:>8.2}  {:>11.2}  {:>9.3}",
                i + 1,
                g("omega_rad_s"),
                g("gain"),
                g("phase_rad").to_degrees(),
                100.0 * g("gain_ci90_rel"),
                g("phase_ci90_rad").to_degrees(),
                g("coherence"),
            );
        }
    } else if let Some(p) = f.get("period_s").and_then(|v| v.as_f64()) {
        let g = |k: &str| f.get(k).and_then(|v| v.as_f64()).unwrap_or(f64::NAN);
        println!(
            "  limit cycle: period {:.1} s (omega_u {:.4} rad/s), amplitude {:.3} deg, trim {:.2} deg, shortest switch interval {:.1} s",
            p,
            g("omega_u_rad_s"),
            g("amplitude_rad").to_degrees(),
            g("trim_rad").to_degrees(),
            g("min_switch_interval_s"),
        );
    }
}

pub(crate) fn print_estimate(r: &crate::core::wire::Report) {
    if let Some(e) = &r.estimate {
        println!(
            "  estimate: speed {:.2} m/s, displacement {:.0} t (speed log {:.2} m/s)",
            e.speed_mps,
            e.displacement_t,
            r.features
                .get(crate::core::estimator::features::SPEED_LOG_FIELD)
                .and_then(|v| v.as_f64())
                .unwrap_or(f64::NAN)
        );
    }
}

pub(crate) fn print_baseline(f: &serde_json::Value) {
    let g = |k: &str| f["baseline"].get(k).and_then(|v| v.as_f64());
    if let (Some(a), Some(b)) = (g("a_per_s"), g("b_per_s2")) {
        println!(
            "  baseline (time domain): a {a:.5} 1/s, b {b:.3e} 1/s^2, speed {:.2} m/s, displacement {:.0} t",
            g("speed_mps").unwrap_or(f64::NAN),
            g("displacement_t").unwrap_or(f64::NAN),
        );
    } else if let Some(e) = f.get("baseline_error").and_then(|v| v.as_str()) {
        println!("  baseline (time domain): none: {e}");
    }
}
