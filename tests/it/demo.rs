//! README's first command: `helmwatch demo` commissions the vessel, then the displacement
//! steps up and the demo runs until the alarm, printing it.

#[test]
fn the_demo_commissions_then_runs_until_the_alarm() {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_helmwatch"))
        .arg("demo")
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // Commissioning first (five tests per method in the demo), all nominal.
    let complete = text.matches("commissioning complete").count();
    assert_eq!(complete, 2, "{text}");
    let before: Vec<&str> = text
        .lines()
        .filter(|l| l.contains("REPORT") && l.contains("(nominal ship)"))
        .collect();
    assert_eq!(before.len(), 10, "{text}");
    assert!(
        before.iter().all(|l| l.ends_with("decision Nominal")),
        "{text}"
    );
    // Then the faulty ship, and the demo ends at the alarm naming the displacement.
    let alarm = text
        .lines()
        .find(|l| l.starts_with("NOTIFICATION Alarm"))
        .unwrap_or_else(|| panic!("no alarm: {text}"));
    assert!(
        alarm.contains("displacement_or_rudder_effectiveness"),
        "{alarm}"
    );
    assert!(
        text.contains("(faulty ship): Completed, decision Fault"),
        "{text}"
    );
}
