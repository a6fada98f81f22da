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
}
