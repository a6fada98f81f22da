//! A TOML file's parse error in one line: where (line, column) and what, without the quoted
//! source line `toml`'s own message carries (a 10 MB line would make a 10 MB error). Shared by
//! the rover TOML, the plan model and the sim's world and scenario files.

use crate::excerpt;

/// Characters of the parser's message kept (it can quote a key or value).
const MAX_MESSAGE_CHARS: usize = 200;

/// A TOML parse error, located in the text.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{}{message}", location(*line, *column))]
pub struct TomlSyntaxError {
    /// 1-based line of the error, if the parser knows where it is.
    pub line: Option<usize>,
    /// 1-based column (in characters) on that line.
    pub column: usize,
    /// What is wrong, as the parser says it (cut if very long).
    pub message: String,
}

fn location(line: Option<usize>, column: usize) -> String {
    match line {
        Some(line) => format!("line {line}, column {column}: "),
        None => String::new(),
    }
}

impl TomlSyntaxError {
    /// `error`, which `toml` raised parsing `text`.
    pub fn new(text: &str, error: &toml::de::Error) -> Self {
        let (line, column) = match error.span() {
            Some(span) => {
                let before = text.get(..span.start).unwrap_or(text);
                let line_start = before.rfind('\n').map_or(0, |i| i + 1);
                (
                    Some(before.matches('\n').count() + 1),
                    before[line_start..].chars().count() + 1,
                )
            }
            None => (None, 0),
        };
        Self {
            line,
            column,
            message: excerpt::cut_to(error.message().trim(), MAX_MESSAGE_CHARS),
        }
    }
}

/// Characters of a value shown after its type in a type error.
const MAX_VALUE_CHARS: usize = 40;

/// What was found where another type belongs, as a sentence says it: the type with its article
/// and the value as written, cut if long ("an array ([0.5, 0.6])").
pub fn found(value: &toml::Value) -> String {
    // Every type here, with its own article: "a array" is what `type_str` alone gave.
    let kind = match value {
        toml::Value::String(_) => "a string",
        toml::Value::Integer(_) => "an integer",
        toml::Value::Float(_) => "a float",
        toml::Value::Boolean(_) => "a boolean",
        toml::Value::Datetime(_) => "a datetime",
        toml::Value::Array(_) => "an array",
        toml::Value::Table(_) => "a table",
    };
    let shown = value.to_string();
    format!(
        "{kind} ({})",
        excerpt::cut_to(shown.trim(), MAX_VALUE_CHARS)
    )
}

/// The 1-based line where the top-level `key` of `text` is written, if `text` parses.
pub fn key_line(text: &str, key: &str) -> Option<usize> {
    let table = toml::de::DeTable::parse(text).ok()?;
    let (written, _) = table
        .get_ref()
        .iter()
        .find(|(k, _)| k.get_ref().as_ref() == key)?;
    let before = text.get(..written.span().start)?;
    Some(before.matches('\n').count() + 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn syntax(text: &str) -> TomlSyntaxError {
        let e = text.parse::<toml::Table>().expect_err("invalid TOML");
        TomlSyntaxError::new(text, &e)
    }

    #[test]
    fn names_line_and_column_in_one_short_line() {
        let e = syntax("a = 1\nb = \"open");
        assert_eq!(e.line, Some(2));
        assert!(e.to_string().starts_with("line 2, column "), "{e}");
        assert!(!e.to_string().contains('\n'), "{e}");
        let long = format!("a = 1\nx = \"{}\n", "a".repeat(10_000_000));
        let e = syntax(&long);
        assert!(e.to_string().len() < 300, "{} bytes", e.to_string().len());
        assert!(e.to_string().starts_with("line 2, column "), "{e}");
    }

    #[test]
    fn found_says_each_type_with_its_article_and_value() {
        let table: toml::Table = "s = \"x\"\ni = 3\nf = 0.5\nb = true\nd = 1979-05-27\n\
                                  a = [0.5, 0.6]\nt = { x = 1 }\nlong = \"\
                                  0123456789012345678901234567890123456789xyz\""
            .parse()
            .expect("TOML");
        let found_at = |key: &str| found(&table[key]);
        assert_eq!(found_at("s"), "a string (\"x\")");
        assert_eq!(found_at("i"), "an integer (3)");
        assert_eq!(found_at("f"), "a float (0.5)");
        assert_eq!(found_at("b"), "a boolean (true)");
        assert_eq!(found_at("d"), "a datetime (1979-05-27)");
        assert_eq!(found_at("a"), "an array ([0.5, 0.6])");
        assert_eq!(found_at("t"), "a table ({ x = 1 })");
        assert_eq!(
            found_at("long"),
            "a string (\"012345678901234567890123456789012345678…)"
        );
    }

    #[test]
    fn key_line_finds_a_top_level_key() {
        let text = "# rover\na = 1\n\nb = [\n  1,\n]\n";
        assert_eq!(key_line(text, "a"), Some(2));
        assert_eq!(key_line(text, "b"), Some(4));
        assert_eq!(key_line(text, "c"), None);
        assert_eq!(key_line("a = = 1", "a"), None);
    }
}
