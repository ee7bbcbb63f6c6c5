//! docs/fdi.md "Report fields" names every field of the typed `residuals`
//! (`core::wire::residuals`), and names no field the type does not have.

use helmwatch_core::wire::residuals::{
    BaselineReport, CauseCosts, DecisionReport, Look, ModelFitReport, ModelMismatch,
    ParameterResiduals, RawResiduals, ReferenceKind, ReferenceReport, Residuals, ServoCheck,
    TrackState,
};
use helmwatch_core::wire::{Cause, Decision};
use serde_json::Value;
use std::collections::BTreeSet;

fn full() -> Residuals {
    let p = ParameterResiduals {
        speed_mps: 0.1,
        speed_sigma_mps: 0.1,
        z_speed: 1.0,
        displacement_t: 10.0,
        displacement_sigma_t: 10.0,
        z_displacement: 1.0,
        ln_gain: Some(-0.02),
        ln_gain_sigma: Some(0.01),
        z_ln_gain: Some(-2.0),
        correlation: -0.5,
        chi2: 2.0,
        dof: 3,
        noise_ratio: Some(1.5),
    };
    let look = Look {
        statistic: 1.0,
        window: 2,
        dof: 4,
        threshold: 34.0,
        alert_threshold: 19.1,
        cause: Some(Cause::SpeedLog),
    };
    Residuals {
        sea_index: Some(0.1),
        sea_fraction: Some(0.4),
        displacement_nominal_t: Some(7000.0),
        raw: Some(RawResiduals {
            speed_mps: 0.1,
            displacement: 0.01,
            speed_sigma_mps: 0.05,
            displacement_sigma: 0.002,
            speed_log_mps: 7.0,
            dd_du_t_per_mps: 900.0,
            ln_gain: Some(-6.2),
            ln_damping: Some(-6.3),
            speed_slope: [-0.2, 0.01, 0.3],
            loading_slope: [0.3, -0.05, -1.0],
        }),
        parameters: Some(p),
        servo_check: Some(ServoCheck {
            rate_ratio: 1.0,
            z_rate: 0.0,
        }),
        model_fit: Some(ModelFitReport {
            chi2: 3.0,
            dof: 4,
            a_per_s: 0.0146,
            b_per_s2: 5.98e-4,
            speed_mps: 7.0,
            displacement_t: 7000.0,
        }),
        model_mismatch: Some(ModelMismatch {
            chi2: 200.0,
            threshold: 100.0,
            advice: "x".into(),
        }),
        reference: Some(ReferenceReport {
            kind: ReferenceKind::Commissioned,
            text: "commissioned".into(),
            tests: 8,
            of: 8,
            learned: Some(20),
            speed_offset_mps: Some(0.1),
            displacement_offset_t: Some(10.0),
            offset_speed_sigma_mps: Some(0.02),
            offset_displacement_sigma_t: Some(5.0),
            ln_gain_offset: Some(-6.2),
            offset_ln_gain_sigma: Some(0.01),
            support: Some(12.0),
            correlation: Some(-0.5),
            speed_log_mps: Some(7.0),
        }),
        decision: Some(DecisionReport {
            state: TrackState::Normal,
            parameters: Some(look),
            servo: Some(look),
            false_alarm_per_test: 1e-5,
            cause_costs: Some(CauseCosts {
                speed_log: 0.4,
                displacement_or_rudder_effectiveness: 1.2,
            }),
            log_step_mps: Some(0.5),
            not_ruled_out: vec![Cause::SpeedLog],
        }),
        baseline: Some(BaselineReport {
            parameters: Some(p),
            outcome: Decision::Nominal,
            isolation: vec![],
        }),
        servo_time_constant_s: Some(1.0),
    }
}

fn keys(v: &Value, out: &mut BTreeSet<String>) {
    if let Value::Object(m) = v {
        for (k, x) in m {
            out.insert(k.clone());
            keys(x, out);
        }
    }
}

#[test]
fn the_report_fields_section_names_every_field_of_the_typed_residuals() {
    let doc = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/fdi.md")).unwrap();
    let start = doc
        .find("## Report fields")
        .expect("a Report fields section");
    let rest = &doc[start..];
    // The field list is the section's first paragraph set, up to its "Changed from" note.
    let end = rest
        .find("Changed from the previous release")
        .unwrap_or(rest.len());
    let section = &rest[..end];
    let mut want = BTreeSet::new();
    keys(&serde_json::to_value(full()).unwrap(), &mut want);
    for k in &want {
        assert!(
            section.contains(&format!("`{k}`")),
            "docs/fdi.md Report fields lacks `{k}`"
        );
    }
    // And every backticked snake_case name in the list is a field (or a value of `kind` or
    // `state`, or a type name).
    let values = [
        "design",
        "commissioning",
        "commissioned",
        "commissioning_inconsistent",
        "predicted",
        "residuals",
        "core::wire::residuals::Residuals",
        "{}",
    ];
    for name in section.split('`').skip(1).step_by(2) {
        if values.contains(&name) {
            continue;
        }
        assert!(
            want.contains(name),
            "docs/fdi.md names `{name}`, no field of residuals"
        );
    }
}
