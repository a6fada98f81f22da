//! What is wrong with a damaged MCAP file, in one line. `mcap` reports a record whose fields do
//! not parse as `binrw`'s error, whose text is a backtrace with terminal colour codes and the
//! crate's source paths; here it is the record, the field and what was wrong with it.

use ::mcap::McapError;
use std::io;

/// `error`, which `mcap` raised reading a file, as a user reads it (no colour codes, no source
/// paths, one line).
pub fn describe(error: &McapError) -> String {
    match error {
        McapError::Parse(e) => parse_failure(e),
        // Every other variant is one plain sentence of `mcap`'s own.
        other => other.to_string(),
    }
}

/// A record that did not parse: "the Channel record's field `topic`: ends before the field
/// does". binrw's context frames read "While parsing field 'f' in T", innermost first; the
/// outermost names the record and its field, the inner ones `mcap`'s helper types.
fn parse_failure(error: &binrw::Error) -> String {
    let (root, frames) = match error {
        binrw::Error::Backtrace(bt) => (&*bt.error, bt.frames.as_slice()),
        e => (e, &[][..]),
    };
    let what = root_cause(root);
    let field = frames.iter().rev().find_map(|frame| match frame {
        binrw::error::BacktraceFrame::Full { message, .. }
        | binrw::error::BacktraceFrame::Message(message) => field_and_type(message),
        binrw::error::BacktraceFrame::Custom(_) => None,
    });
    match field {
        Some((field, record)) => format!("the {record} record's field `{field}`: {what}"),
        None => format!("a record: {what}"),
    }
}

/// "While parsing field 'profile' in Header" → ("profile", "Header"); `mcap` parses the fixed
/// part of a Schema, Message, Chunk or Attachment record as `SchemaHeader` etc., named here as
/// the record it is.
fn field_and_type(message: &str) -> Option<(&str, &str)> {
    let rest = message.strip_prefix("While parsing field '")?;
    let (field, ty) = rest.split_once("' in ")?;
    let record = ty.strip_suffix("Header").filter(|r| !r.is_empty());
    Some((field, record.unwrap_or(ty)))
}

/// What binrw found wrong, without the record-relative positions' hex.
fn root_cause(error: &binrw::Error) -> String {
    match error {
        binrw::Error::Io(e) if e.kind() == io::ErrorKind::UnexpectedEof => {
            "the record ends before this field does (a damaged length)".into()
        }
        binrw::Error::Io(e) => e.to_string(),
        binrw::Error::BadMagic { pos, .. } => {
            format!("unexpected bytes at byte {pos} of the record")
        }
        binrw::Error::AssertFail { pos, message } => {
            format!("{message} (byte {pos} of the record)")
        }
        binrw::Error::Custom { pos, err } => format!("{err} (byte {pos} of the record)"),
        binrw::Error::NoVariantMatch { pos } | binrw::Error::EnumErrors { pos, .. } => {
            format!("no known form at byte {pos} of the record")
        }
        binrw::Error::Backtrace(bt) => root_cause(&bt.error),
        // `binrw::Error` is `#[non_exhaustive]`; a later kind still must not print raw.
        _ => "its bytes do not parse".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A Header record (opcode 0x01) whose profile string claims more bytes than it has.
    fn torn_header() -> McapError {
        let body = [200, 0, 0, 0, b'r', b'o'];
        ::mcap::parse_record(0x01, &body).expect_err("the profile does not fit")
    }

    #[test]
    fn a_record_that_does_not_parse_is_named_in_plain_words() {
        let e = torn_header();
        assert!(matches!(e, McapError::Parse(_)), "{e:?}");
        let text = describe(&e);
        assert_eq!(
            text,
            "the Header record's field `profile`: the record ends before this field does (a damaged length)"
        );
        // What `mcap`'s own chain prints: colours and the crate's sources.
        let raw = std::error::Error::source(&e).map(ToString::to_string);
        assert!(raw.is_some_and(|raw| raw.contains("\x1b[") && raw.contains(".rs:")));
    }

    #[test]
    fn a_records_fixed_part_is_named_as_the_record() {
        // A Schema record (0x03): id 1, then a name claiming 200 bytes of the 1 left.
        let e = ::mcap::parse_record(0x03, &[1, 0, 200, 0, 0, 0, b'a']).expect_err("torn");
        assert_eq!(
            describe(&e),
            "the Schema record's field `name`: the record ends before this field does (a damaged length)"
        );
    }

    #[test]
    fn other_errors_keep_mcaps_sentence() {
        let e = McapError::BadChunkCrc {
            saved: 1,
            calculated: 2,
        };
        assert_eq!(
            describe(&e),
            "Chunk CRC failed (expected 00000001, got 00000002)"
        );
    }
}
