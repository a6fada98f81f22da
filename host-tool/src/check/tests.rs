//! The check against the simulated board: healthy, and with each fault a first board shows.

use super::sim::{SimFault, SimulatedBoard};
use super::{session, CheckReport, Hint, Limits, Outcome, Side, StepId};
use crate::sim::board::Pacing;
use std::time::Duration;

/// Runs the check on a simulated board with `fault`, at 4× real time (the rate is measured on
/// the board's clock, so the pace does not change it).
fn check_simulated(fault: Option<SimFault>) -> CheckReport {
    let board = SimulatedBoard::spawn(fault, Pacing::Scaled(4.0)).expect("pty");
    let limits = Limits {
        hello_timeout: Duration::from_secs(2),
        window: Duration::from_millis(1_500),
        ..Limits::default()
    };
    let mut open = board.opener();
    let path = board.path().to_owned();
    let report = session::run(Some(&path), &[], &mut open, &limits);
    board.finish().expect("the simulated board ran");
    report
}

/// The first failed step and its hint.
fn first_failure(report: &CheckReport) -> (StepId, Hint) {
    let step = report
        .first_failure()
        .unwrap_or_else(|| panic!("no failure:\n{report}"));
    (step.id, step.hint.clone().expect("a failure has a hint"))
}

#[test]
fn a_healthy_simulated_board_passes_every_step() {
    let report = check_simulated(None);
    assert!(report.passed, "{report}");
    assert_eq!(report.steps.len(), StepId::ALL.len());
    assert!(report.steps.iter().all(|s| s.outcome == Outcome::Pass));
    let chips = report.step(StepId::Chips).expect("step");
    assert!(
        chips.detail.contains("0x5449/0x2260 CAL 2048"),
        "{}",
        chips.detail
    );
}

#[test]
fn a_missing_chip_fails_the_chips_step_with_its_straps() {
    let report = check_simulated(Some(SimFault::MissingChip));
    assert_eq!(
        first_failure(&report),
        (
            StepId::Chips,
            Hint::ChipMissing {
                side: Side::Right,
                address: 0x45
            }
        )
    );
    let text = report.to_string();
    assert!(text.contains("A0 and A1 to VS"), "{text}");
}

#[test]
fn a_wrong_id_names_what_answered() {
    let report = check_simulated(Some(SimFault::WrongId));
    assert_eq!(
        first_failure(&report),
        (
            StepId::Chips,
            Hint::WrongId {
                side: Side::Right,
                manufacturer: 0x5449,
                die: 0x2270
            }
        )
    );
    assert!(report.to_string().contains("INA260"));
}

#[test]
fn a_chip_that_resets_fails_stability_with_the_supply_hint() {
    let report = check_simulated(Some(SimFault::ResetChip));
    let (step, hint) = first_failure(&report);
    assert_eq!(step, StepId::ChipStability, "{report}");
    assert!(
        matches!(hint, Hint::ChipResets { side: Side::Right, resets } if resets >= 2),
        "{hint:?}"
    );
}

#[test]
fn a_port_without_dtr_fails_at_dtr() {
    let report = check_simulated(Some(SimFault::NoDtr));
    assert_eq!(first_failure(&report), (StepId::Dtr, Hint::NoDtr));
    assert_eq!(
        report.step(StepId::Hello).map(|s| s.outcome),
        Some(Outcome::NotRun)
    );
}

#[test]
fn another_protocol_version_is_named() {
    let report = check_simulated(Some(SimFault::WrongProtocol));
    assert_eq!(
        first_failure(&report),
        (
            StepId::Hello,
            Hint::ProtocolMismatch {
                board: model_core::wire::PROTOCOL_VERSION - 1
            }
        )
    );
}

#[test]
fn a_silent_port_points_at_the_led() {
    let report = check_simulated(Some(SimFault::SilentPort));
    assert_eq!(first_failure(&report), (StepId::Hello, Hint::SilentPort));
    assert!(report.to_string().contains("PC13"));
}

#[test]
fn the_seeds_standstill_offset_fails_the_standstill_step() {
    let report = check_simulated(Some(SimFault::StandstillOffset));
    assert_eq!(
        first_failure(&report),
        (
            StepId::Standstill,
            Hint::StandstillCurrent { side: Side::Right }
        )
    );
}

#[test]
fn the_json_report_names_steps_outcomes_and_hint_kinds() {
    let report = CheckReport::new(
        Some("/dev/ttyACM0".into()),
        vec![super::Step::fail(StepId::Port, "x", Hint::NoBoardFound)],
    );
    let json = serde_json::to_value(&report).expect("json");
    assert_eq!(json["passed"], false);
    assert_eq!(json["steps"][0]["step"], "port");
    assert_eq!(json["steps"][0]["hint_kind"], "no-board-found");
    assert_eq!(json["steps"][1]["outcome"], "not-run");
    assert_eq!(
        json["steps"].as_array().map(Vec::len),
        Some(StepId::ALL.len())
    );
}

#[test]
fn the_real_port_code_checks_a_board_behind_a_pty() {
    use crate::sim::board::{PtyBoard, SimBoard};
    use firmware::sampler::SamplerConfig;
    // A plain simulated board (connected from the start: a pty has no DTR) read through the
    // opener `check --port` uses.
    let board = PtyBoard::spawn(
        SimBoard::new(SamplerConfig::BOARD),
        u64::MAX,
        Pacing::Scaled(4.0),
    )
    .expect("pty");
    let limits = Limits {
        window: Duration::from_millis(1_000),
        ..Limits::default()
    };
    let path = board.path().to_owned();
    let report = session::run(Some(&path), &[], &mut session::serial_opener(), &limits);
    // Read what is left so the pty hangs up at once.
    board.stop();
    let port = crate::serial::open(&path, Duration::from_millis(20)).expect("reopen");
    let mut reader = crate::serial::PortReader::new(port);
    let mut decoder = crate::decode::StreamDecoder::new();
    let start = std::time::Instant::now();
    while !reader.vanished() && start.elapsed() < Duration::from_secs(10) {
        reader.poll(&mut decoder, |_| {});
    }
    board.join().expect("the board ran");
    // The ideal chips of SimBoard::new read 0 A at 24 V on both sides.
    assert!(report.passed, "{report}");
}
