use super::*;
use crate::plan::sweep::TABLE_6_1;
use std::path::Path;
use std::path::PathBuf;

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(path)
}

fn husky() -> Rover {
    crate::rover::load_rover(&repo("rovers/husky-a200.toml")).expect("rover")
}

#[test]
fn the_example_is_thesis_table_6_1() {
    let path = repo("examples/husky-sand-table-6.1.csv");
    assert!(is_path_table_file(&path));
    assert!(!is_path_table_file(&repo("examples/argo-j5-table-4.1.csv")));
    let rows = load_path_table(&path).expect("parses");
    assert_eq!(rows.len(), TABLE_6_1.len());
    for (r, s) in rows.iter().zip(TABLE_6_1) {
        assert_eq!((r.start_deg, r.end_deg, r.distance_m), (45.0, 45.0, 10.0));
        assert_eq!((r.r_lo_over_r_prime, r.r_hi_over_r_prime), (s.lo, s.hi));
        assert_eq!((r.delta_e_pct, r.p_value), (s.delta_e_pct, Some(s.p_value)));
    }
}

#[test]
fn malformed_tables_are_clear_errors() {
    let head = "start_deg,end_deg,distance_m,r_lo_over_r_prime,r_hi_over_r_prime,delta_e_pct";
    let err = |text: &str| parse_path_table(text).expect_err(text).to_string();
    // Bad headers: a typo, a missing column, another order, no header at all.
    assert!(
        err("start_deg,end_deg,distance_m,r_lo,r_hi,delta_e_pct\n").contains("is not `start_deg")
    );
    assert!(
        err("start_deg,end_deg,distance_m,r_lo_over_r_prime,delta_e_pct\n")
            .starts_with("line 1: header")
    );
    assert!(err(&format!("{head},p_value,extra\n")).contains("header"));
    assert!(err("# only a comment\n").contains("header"));
    assert_eq!(err(&format!("{head}\n")), "no rows after the header");
    // A slice with lo ≥ hi.
    assert_eq!(
        err(&format!("{head}\n45,45,10,1.5,0.5,3\n")),
        "line 2: slice 1.5 – 0.5 of R/R' is empty (r_lo_over_r_prime must be < r_hi_over_r_prime)"
    );
    assert!(err(&format!("{head}\n45,45,10,1,1,3\n")).contains("is empty"));
    // p outside (0, 1].
    for p in ["0", "-0.1", "1.5", "nan"] {
        let e = err(&format!("{head},p_value\n45,45,10,0,0.5,3,{p}\n"));
        assert!(e.starts_with("line 2, column 7 (p_value)"), "{e}");
    }
    assert!(parse_path_table(&format!(
        "{head},p_value\n45,45,10,0,0.5,3,1\n45,45,10,0.5,1,3,\n"
    ))
    .is_ok());
    // Other cells.
    assert!(err(&format!("{head}\n45,45,10,0,0.5\n")).contains("row has 5 cells"));
    assert!(err(&format!("{head}\n45,45,0,0,0.5,3\n")).contains("distance_m"));
    assert!(err(&format!("{head}\n45,45,10,-1,0.5,3\n")).contains("must be ≥ 0"));
    assert!(err(&format!("{head}\n45,45,10,0,0.5,abc\n"))
        .contains("(delta_e_pct): `abc` is not a finite number"));
    // Too few slices to hold one out; headings the planner rejects.
    let rows =
        parse_path_table(&format!("{head}\n45,45,10,0,0.5,3\n45,45,10,0.5,1,3\n")).expect("parses");
    let model = hard_ground_for(&husky());
    assert!(matches!(
        diagnose_path_table(&model, &rows),
        Err(PathTableError::TooFewRows(2))
    ));
    let rows = parse_path_table(&format!(
        "{head}\n45,-45,10,0,0.5,3\n45,45,10,0.5,1,3\n45,45,10,1,2,3\n"
    ))
    .expect("parses");
    let e = diagnose_path_table(&model, &rows).expect_err("Eq 50");
    assert!(e.to_string().starts_with("line 2:"), "{e}");
}

/// Issue 34: a 10 MB cell or header quoted whole, a huge bound printed as 309 digits; a row the
/// model cannot price is found in the file's own rows ([`check_rows`]), so the CLI can name it.
#[test]
fn quoted_input_stays_short_and_rows_are_checked_per_table() {
    let head = "start_deg,end_deg,distance_m,r_lo_over_r_prime,r_hi_over_r_prime,delta_e_pct";
    let err = |text: &str| parse_path_table(text).expect_err("invalid").to_string();
    let cell = "9".repeat(10_000_000);
    let e = err(&format!("{head}\n45,45,10,0,0.5,{cell}x\n"));
    assert!(e.len() < 200, "{} bytes", e.len());
    assert!(
        e.starts_with("line 2, column 6 (delta_e_pct): `9999"),
        "{e}"
    );
    let e = err(&format!("{head}{cell}\n"));
    assert!(e.len() < 300, "{} bytes", e.len());
    assert_eq!(
        err(&format!("{head}\n45,45,10,1e308,1,3\n")),
        "line 2: slice 1e308 – 1 of R/R' is empty (r_lo_over_r_prime must be < r_hi_over_r_prime)"
    );
    let model = hard_ground_for(&husky());
    let rows = parse_path_table(&format!("{head}\n45,45,10,0,0.5,3\n45,-45,10,0.5,1,3\n"))
        .expect("parses");
    let e = check_rows(&model, &rows).expect_err("Eq 50");
    assert!(e.to_string().starts_with("line 3:"), "{e}");
    assert!(check_rows(&model, &rows[..1]).is_ok());
}

#[test]
fn p_values_set_the_uncertainty() {
    // Two-tailed: p = 0.05 is |z| = 1.96, p = 1 is z = 0.
    assert!((two_tailed_z(0.05) - 1.959964).abs() < 1e-4);
    assert!(two_tailed_z(1.0) < 1e-6);
}

/// The seed's oracle: the departure sits at R', angular slip explains it, on held-out slices.
#[test]
fn table_6_1_departs_at_r_prime_and_angular_slip_explains_it() {
    let rows = load_path_table(&repo("examples/husky-sand-table-6.1.csv")).expect("parses");
    let d = diagnose_path_table(&hard_ground_for(&husky()), &rows).expect("diagnoses");
    eprintln!("{d}");
    assert_eq!(d.effect, "angular-slip");
    assert_eq!(d.regime, "at-r-prime");
    assert!(d.significant);
    assert_eq!(d.departure.as_deref(), Some("0.5 – 1.5"));
    let best = &d.candidates[0];
    assert_eq!(best.effect, EffectId::AngularSlip);
    assert!(best.shrink_pct >= 30.0, "{best:?}");
    let json = d.to_json();
    assert_eq!(json["effect"], "angular-slip");
    assert_eq!(json["heldout"]["scheme"], "leave-one-slice-out");
}

#[test]
fn a_table_the_model_predicts_has_no_gap() {
    // ΔE from the hard-ground model itself, with p-values of a precise measurement.
    let model = hard_ground_for(&husky());
    let mut text = String::from(
        "start_deg,end_deg,distance_m,r_lo_over_r_prime,r_hi_over_r_prime,delta_e_pct,p_value\n",
    );
    for (lo, hi) in [(0.0, 0.5), (0.5, 1.5), (1.5, 2.0), (2.0, 2.5), (2.5, 3.0)] {
        text.push_str(&format!("45,45,10,{lo},{hi},1,0.5\n"));
    }
    let mut rows = parse_path_table(&text).expect("parses");
    let truth = diagnose_path_table(&model, &rows).expect("diagnoses");
    for (r, s) in rows.iter_mut().zip(&truth.slices) {
        r.delta_e_pct = s.model_pct;
    }
    let d = diagnose_path_table(&model, &rows).expect("diagnoses");
    assert!(!d.significant && d.effect == "none", "{d}");
    assert!(d.slices.iter().all(|s| s.gap_pp.abs() < 1e-9));
}
