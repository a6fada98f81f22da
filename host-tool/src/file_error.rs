//! One error for "this file could not be read, or its content is invalid", naming the file:
//! the rover TOML ([`crate::rover::RoverFileError`]), the plan model
//! ([`crate::plan::ModelFileError`]), the diagnosis' summaries and path tables share it, each
//! with its own content error `E`.

use std::path::{Path, PathBuf};

/// A file that could not be read or whose content is invalid (`E` says why); names the file.
#[derive(Debug, thiserror::Error)]
pub enum FileError<E: std::error::Error + 'static> {
    /// The file could not be read.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// The file's content is invalid.
    #[error("{}: {source}", path.display())]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        #[source]
        source: E,
    },
}

/// Reads `path` as UTF-8 text and parses it with `parse`; either failure names the file.
pub fn read_and_parse<T, E: std::error::Error + 'static>(
    path: &Path,
    parse: impl FnOnce(&str) -> Result<T, E>,
) -> Result<T, FileError<E>> {
    let text = std::fs::read_to_string(path).map_err(|source| FileError::Io {
        path: path.to_owned(),
        source,
    })?;
    parse(&text).map_err(|source| FileError::Invalid {
        path: path.to_owned(),
        source,
    })
}

/// Reads `path` as bytes and parses them with `parse` (which judges the encoding itself, e.g.
/// to name the line that is not UTF-8); either failure names the file.
pub fn read_bytes_and_parse<T, E: std::error::Error + 'static>(
    path: &Path,
    parse: impl FnOnce(&[u8]) -> Result<T, E>,
) -> Result<T, FileError<E>> {
    let bytes = std::fs::read(path).map_err(|source| FileError::Io {
        path: path.to_owned(),
        source,
    })?;
    parse(&bytes).map_err(|source| FileError::Invalid {
        path: path.to_owned(),
        source,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, thiserror::Error, PartialEq)]
    #[error("bad content")]
    struct Bad;

    #[test]
    fn names_the_file_for_both_failures() {
        let dir = std::env::temp_dir().join(format!("file-error-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let path = dir.join("x.toml");
        let missing = read_and_parse(&path, |_| Ok::<_, Bad>(()));
        assert!(matches!(missing, Err(FileError::Io { .. })));
        std::fs::write(&path, "text").expect("write");
        let invalid = read_and_parse(&path, |t| if t == "text" { Err(Bad) } else { Ok(()) });
        match invalid {
            Err(e @ FileError::Invalid { .. }) => {
                assert_eq!(e.to_string(), format!("{}: bad content", path.display()));
                assert!(std::error::Error::source(&e).is_some());
            }
            other => panic!("expected Invalid, got {other:?}"),
        }
        assert_eq!(
            read_and_parse(&path, |t| Ok::<_, Bad>(t.len())).ok(),
            Some(4)
        );
        std::fs::remove_dir_all(&dir).expect("clean up");
    }
}
