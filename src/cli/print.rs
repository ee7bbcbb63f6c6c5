//! How a report reads on a terminal: features, the estimate, the baseline.

use helmwatch_core::wire::{Features, Report};

/// The tones (CLFRT) or the limit cycle (HBT).
pub(crate) fn print_features(f: &Features) {
    match f {
        Features::Clfrt(c) => {
            println!("  tone  omega rad/s      gain   phase deg  +-gain %  +-phase deg  coherence");
            for (i, t) in c.tones.iter().enumerate() {
                println!(
                    "  {:>4}  {:>11.4}  {:>8.4}  {:>10.2}  {:>8.2}  {:>11.2}  {:>9.3}",
                    i + 1,
                    t.omega_rad_s,
                    t.gain,
                    t.phase_rad.to_degrees(),
                    100.0 * t.gain_ci90_rel,
                    t.phase_ci90_rad.to_degrees(),
                    t.coherence,
                );
            }
        }
        Features::Hbt(h) => {
            println!(
                "  limit cycle: period {:.1} s (omega_u {:.4} rad/s), amplitude {:.3} deg, trim {:.2} deg, shortest switch interval {:.1} s",
                h.period_s,
                h.omega_u_rad_s,
                h.amplitude_rad.to_degrees(),
                h.trim_rad.to_degrees(),
                h.min_switch_interval_s,
            );
            if let Some(scale) = h.relay_scale {
                println!(
                    "  relay sized to the loop: {:.0} % of the design (h {:.2} deg, eps {:.2} deg)",
                    100.0 * scale,
                    h.relay_height_rad.to_degrees(),
                    h.hysteresis_rad.to_degrees(),
                );
            }
        }
        Features::None => {}
    }
}

/// The networks' estimate (raw) beside the speed log, and the estimate calibrated to the
/// vessel when its reference is in force.
pub(crate) fn print_estimate(r: &Report) {
    if let Some(e) = &r.estimate {
        println!(
            "  networks' estimate (raw): speed {:.2} m/s, displacement {:.0} t (speed log {:.2} m/s)",
            e.speed_mps,
            e.displacement_t,
            r.features.speed_log_mps().unwrap_or(f64::NAN)
        );
    }
    if let Some(c) = &r.calibrated_estimate {
        println!("  {}", c.sentence());
    }
}

/// The time-domain baseline, or why there is none.
pub(crate) fn print_baseline(f: &Features) {
    let error = match f {
        Features::Clfrt(c) => c.baseline_error.as_deref(),
        Features::Hbt(h) => h.baseline_error.as_deref(),
        Features::None => None,
    };
    if let Some(b) = f.baseline() {
        println!(
            "  baseline (time domain): a {:.5} 1/s, b {:.3e} 1/s^2, speed {:.2} m/s, displacement {:.0} t",
            b.a_per_s, b.b_per_s2, b.speed_mps, b.displacement_t,
        );
    } else if let Some(e) = error {
        println!("  baseline (time domain): none: {e}");
    }
}
