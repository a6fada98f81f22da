//! Rover TOML: the geometry file a user brings with their runs (`rovers/husky-a200.toml`).
//!
//! A flat table of exactly five numbers, all required, all finite and > 0:
//!
//! ```toml
//! track_width_m = 0.545   # B [m]
//! length_m = 0.52         # L [m]
//! wheel_radius_m = 0.165  # r [m]
//! mass_kg = 63.0          # m [kg]
//! slip_track_m = 1.1      # B_s, the controller's slip track [m]
//! ```
//!
//! One optional key: `tracker_offset_m`, the lateral offset of the point a pose tracker follows
//! (the `x_m,y_m` columns of a run) from the rover's centre, positive to the right (the thesis'
//! prism: 0.21, Fig. 5.3), any finite number, 0 when absent (the tracker reports the centre).
//!
//! Integers are accepted for any key (`mass_kg = 63`). Any other key is an error, so that a typo
//! (`slip_trak_m`) cannot silently leave a value out.

use crate::excerpt::{self, Number};
use crate::file_error::{read_and_parse, FileError};
use crate::toml_syntax::{self, TomlSyntaxError};
use model_core::Rover;
use std::path::Path;

/// The f64 nearest the shortest decimal that reads back as `x` (0.55f32 → 0.55, where
/// `f64::from` gives 0.550000011920929). Rover values and the board-side kinematics are f32
/// (shared with the board); host models and logs use the decimal the user wrote or the
/// controller sent.
pub fn decimal_f64(x: f32) -> f64 {
    x.to_string().parse().unwrap_or(f64::from(x))
}

/// The keys of a rover TOML, in the order of [`Rover`]'s fields.
pub const ROVER_KEYS: [&str; 5] = [
    "track_width_m",
    "length_m",
    "wheel_radius_m",
    "mass_kg",
    "slip_track_m",
];

/// The optional key of a rover TOML: the tracked point's lateral offset [m], right positive.
pub const TRACKER_OFFSET_KEY: &str = "tracker_offset_m";

/// A rover TOML: the rover, and where on it a pose tracker's point sits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoverFile {
    /// The rover's geometry.
    pub rover: Rover,
    /// Lateral offset of the tracked point from the rover's centre, positive to the right [m].
    pub tracker_offset_m: f64,
}

/// What is wrong with the text of a rover TOML.
#[derive(Debug, thiserror::Error)]
pub enum RoverTomlError {
    /// The text is not TOML at all (the message carries the line and column).
    #[error("not valid TOML: {0}")]
    Syntax(#[source] TomlSyntaxError),
    /// A key that a rover file does not have (usually a typo).
    #[error("unknown key `{}` (a rover file has exactly: {}, and optionally {TRACKER_OFFSET_KEY})", excerpt::cut(key), ROVER_KEYS.join(", "))]
    UnknownKey {
        /// The key as written.
        key: String,
    },
    /// A required key is absent.
    #[error("missing key `{key}`")]
    MissingKey {
        /// The key that should be there.
        key: &'static str,
    },
    /// The key holds something other than a number (a string, table, ...).
    #[error("{}`{key}` must be a number, found {found}", line.map_or(String::new(), |l| format!("line {l}: ")))]
    NotANumber {
        /// The key.
        key: &'static str,
        /// What was found instead, with its type ([`crate::toml_syntax::found`]).
        found: String,
        /// The 1-based line of the key.
        line: Option<usize>,
    },
    /// The number is not finite, not > 0, or does not fit the model's `f32`.
    #[error("`{key}` = {} must be finite and > 0", Number(*.value))]
    OutOfRange {
        /// The key.
        key: &'static str,
        /// The value as written (converted to f64).
        value: f64,
    },
    /// The tracker offset is not a finite number.
    #[error("`{key}` = {} must be a finite number", Number(*.value))]
    NotFinite {
        /// The key.
        key: &'static str,
        /// The value as written (converted to f64).
        value: f64,
    },
}

/// A rover TOML that could not be read or is invalid; names the file.
pub type RoverFileError = FileError<RoverTomlError>;

/// Parses the text of a rover TOML (the rover only; see [`parse_rover_file`]).
pub fn parse_rover(text: &str) -> Result<Rover, RoverTomlError> {
    parse_rover_file(text).map(|f| f.rover)
}

/// The number at `key` of `table` (parsed from `text`, if known); `None` when absent.
fn number(
    text: Option<&str>,
    table: &toml::Table,
    key: &'static str,
) -> Result<Option<f64>, RoverTomlError> {
    match table.get(key) {
        None => Ok(None),
        Some(toml::Value::Float(x)) => Ok(Some(*x)),
        // i64 → f64 may round for |i| > 2^53, irrelevant at the f32 the model keeps.
        Some(toml::Value::Integer(i)) => Ok(Some(*i as f64)),
        Some(other) => Err(RoverTomlError::NotANumber {
            key,
            found: toml_syntax::found(other),
            line: text.and_then(|text| toml_syntax::key_line(text, key)),
        }),
    }
}

/// Parses the text of a rover TOML with its optional tracker offset.
pub fn parse_rover_file(text: &str) -> Result<RoverFile, RoverTomlError> {
    let table: toml::Table = text
        .parse()
        .map_err(|e| RoverTomlError::Syntax(TomlSyntaxError::new(text, &e)))?;
    rover_file_of(&table, Some(text))
}

/// The rover of a table read from a larger file (the plan model's `[rover]`): validated as a
/// rover TOML, but an error names no line (the table's own text is not the file's).
pub fn rover_of_table(table: &toml::Table) -> Result<Rover, RoverTomlError> {
    rover_file_of(table, None).map(|f| f.rover)
}

/// `table` as a rover file; `text` is the whole file it was parsed from, to locate a key.
fn rover_file_of(table: &toml::Table, text: Option<&str>) -> Result<RoverFile, RoverTomlError> {
    if let Some(key) = table
        .keys()
        .find(|k| !ROVER_KEYS.contains(&k.as_str()) && k.as_str() != TRACKER_OFFSET_KEY)
    {
        return Err(RoverTomlError::UnknownKey { key: key.clone() });
    }
    let get = |key: &'static str| -> Result<f32, RoverTomlError> {
        let value = number(text, table, key)?.ok_or(RoverTomlError::MissingKey { key })?;
        let narrow = value as f32;
        if value.is_finite() && value > 0.0 && narrow.is_finite() && narrow > 0.0 {
            Ok(narrow)
        } else {
            Err(RoverTomlError::OutOfRange { key, value })
        }
    };
    let rover = Rover {
        track_width_m: get("track_width_m")?,
        length_m: get("length_m")?,
        wheel_radius_m: get("wheel_radius_m")?,
        mass_kg: get("mass_kg")?,
        slip_track_m: get("slip_track_m")?,
    };
    let tracker_offset_m = number(text, table, TRACKER_OFFSET_KEY)?.unwrap_or(0.0);
    if !tracker_offset_m.is_finite() {
        return Err(RoverTomlError::NotFinite {
            key: TRACKER_OFFSET_KEY,
            value: tracker_offset_m,
        });
    }
    Ok(RoverFile {
        rover,
        tracker_offset_m,
    })
}

/// Reads and parses a rover TOML file (the rover only; see [`load_rover_file`]).
pub fn load_rover(path: &Path) -> Result<Rover, RoverFileError> {
    load_rover_file(path).map(|f| f.rover)
}

/// Reads and parses a rover TOML file with its optional tracker offset.
pub fn load_rover_file(path: &Path) -> Result<RoverFile, RoverFileError> {
    read_and_parse(path, parse_rover_file)
}

/// The repository's Husky A200 file, the rover every command (and the Python package) takes
/// when none is given: no rover and `rovers/husky-a200.toml` are the same.
pub const HUSKY_A200_TOML: &str = include_str!("../../rovers/husky-a200.toml");

/// The rover file at `path`, or the Husky A200's ([`HUSKY_A200_TOML`]).
pub fn load_rover_file_or_husky(path: Option<&Path>) -> Result<RoverFile, RoverFileError> {
    match path {
        Some(path) => load_rover_file(path),
        None => Ok(parse_rover_file(HUSKY_A200_TOML).expect("rovers/husky-a200.toml parses")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    const HUSKY: &str = "track_width_m = 0.545\nlength_m = 0.52\nwheel_radius_m = 0.165\n\
                         mass_kg = 63\nslip_track_m = 1.1\n";

    fn husky_file() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../rovers/husky-a200.toml")
    }

    #[test]
    fn shipped_husky_file_is_the_seed_husky() {
        let rover = load_rover(&husky_file()).expect("shipped file loads");
        assert_eq!(rover, Rover::HUSKY_A200);
    }

    #[test]
    fn integers_are_accepted() {
        assert_eq!(parse_rover(HUSKY).expect("valid"), Rover::HUSKY_A200);
    }

    #[test]
    fn unknown_key_is_named() {
        let text = HUSKY.replace("slip_track_m", "slip_trak_m");
        let e = parse_rover(&text).expect_err("typo");
        assert!(matches!(&e, RoverTomlError::UnknownKey { key } if key == "slip_trak_m"));
        assert!(e.to_string().contains("unknown key `slip_trak_m`"), "{e}");
    }

    #[test]
    fn a_table_is_an_unknown_key() {
        let text = format!("{HUSKY}[motor]\ngear = 78.71\n");
        let e = parse_rover(&text).expect_err("section");
        assert!(matches!(&e, RoverTomlError::UnknownKey { key } if key == "motor"));
    }

    #[test]
    fn missing_key_is_named() {
        let text = HUSKY.replace("mass_kg = 63\n", "");
        let e = parse_rover(&text).expect_err("missing");
        assert!(matches!(e, RoverTomlError::MissingKey { key: "mass_kg" }));
        assert_eq!(e.to_string(), "missing key `mass_kg`");
    }

    #[test]
    fn bad_values_are_named_with_their_value() {
        for (written, shown) in [
            ("0", "0"),
            ("-0.5", "-0.5"),
            ("nan", "NaN"),
            ("inf", "inf"),
            ("-inf", "-inf"),
            ("1e300", "1e300 "),   // beyond f32 (not 301 digits)
            ("1e-300", "1e-300 "), // flushes to 0 in f32
        ] {
            let text = HUSKY.replace("length_m = 0.52", &format!("length_m = {written}"));
            let e = parse_rover(&text).expect_err(written);
            assert!(
                matches!(
                    e,
                    RoverTomlError::OutOfRange {
                        key: "length_m",
                        ..
                    }
                ),
                "{written}: {e:?}"
            );
            let msg = e.to_string();
            assert!(
                msg.starts_with(&format!("`length_m` = {shown}")) && msg.ends_with("> 0"),
                "{msg}"
            );
        }
    }

    #[test]
    fn tracker_offset_is_optional_signed_and_finite() {
        assert_eq!(
            parse_rover_file(HUSKY).expect("valid").tracker_offset_m,
            0.0
        );
        for (written, want) in [("0.21", 0.21), ("-0.1", -0.1), ("0", 0.0)] {
            let f =
                parse_rover_file(&format!("{HUSKY}tracker_offset_m = {written}\n")).expect(written);
            assert_eq!((f.rover, f.tracker_offset_m), (Rover::HUSKY_A200, want));
        }
        let e = parse_rover_file(&format!("{HUSKY}tracker_offset_m = nan\n")).expect_err("nan");
        assert!(e.to_string().contains("tracker_offset_m"), "{e}");
        let e = parse_rover(&format!("{HUSKY}tracker_ofset_m = 0.2\n")).expect_err("typo");
        assert!(e.to_string().contains("optionally tracker_offset_m"), "{e}");
    }

    #[test]
    fn non_numbers_are_named_with_their_type_value_and_line() {
        for (value, found) in [
            ("\"0.165\"", "a string (\"0.165\")"),
            ("[0.5, 0.6]", "an array ([0.5, 0.6])"),
            ("{ r = 0.165 }", "a table ({ r = 0.165 })"),
            ("true", "a boolean (true)"),
            ("1979-05-27", "a datetime (1979-05-27)"),
        ] {
            let text = HUSKY.replace("0.165", value);
            let e = parse_rover(&text).expect_err(value);
            assert_eq!(
                e.to_string(),
                format!("line 3: `wheel_radius_m` must be a number, found {found}")
            );
        }
        // Integers and floats are numbers: the type error never names them.
        assert!(parse_rover(&HUSKY.replace("0.165", "1")).is_ok());
    }

    #[test]
    fn syntax_error_has_a_position() {
        let e = parse_rover("track_width_m = = 0.5\n").expect_err("syntax");
        assert!(matches!(e, RoverTomlError::Syntax(_)));
        assert!(e.to_string().contains("line 1"), "{e}");
    }

    /// Issue 34: a huge value printed as 309 digits, a 10 MB key or line quoted whole.
    #[test]
    fn quoted_input_stays_short() {
        let e = parse_rover(&HUSKY.replace("0.545", "1e308")).expect_err("beyond f32");
        assert_eq!(
            e.to_string(),
            "`track_width_m` = 1e308 must be finite and > 0"
        );
        let key = "k".repeat(10_000_000);
        let e = parse_rover(&format!("{HUSKY}{key} = 1\n")).expect_err("unknown key");
        let shown = e.to_string();
        assert!(shown.len() < 300, "{} bytes", shown.len());
        assert!(shown.starts_with("unknown key `kkkk"), "{shown}");
        let value = "a".repeat(10_000_000);
        let e = parse_rover(&format!("{HUSKY}x = \"{value}\n")).expect_err("open string");
        let shown = e.to_string();
        assert!(shown.len() < 300, "{} bytes", shown.len());
        assert!(
            shown.starts_with("not valid TOML: line 6, column "),
            "{shown}"
        );
        // The source is not a second copy of the toml crate's message with the line.
        let source = std::error::Error::source(&e).map(ToString::to_string);
        assert!(source.is_some_and(|s| shown.ends_with(&s)), "{shown}");
    }

    #[test]
    fn file_errors_name_the_file() {
        let missing = Path::new("/nonexistent/rover.toml");
        let e = load_rover(missing).expect_err("no file");
        assert!(matches!(e, RoverFileError::Io { .. }));
        assert!(
            e.to_string().starts_with("/nonexistent/rover.toml: "),
            "{e}"
        );

        let dir = crate::log::tests_support::TempDir::new("rover");
        let path = dir.path().join("bad.toml");
        std::fs::write(&path, HUSKY.replace("0.545", "-1")).expect("write");
        let e = load_rover(&path).expect_err("invalid");
        assert_eq!(
            e.to_string(),
            format!(
                "{}: `track_width_m` = -1 must be finite and > 0",
                path.display()
            )
        );
    }
}
