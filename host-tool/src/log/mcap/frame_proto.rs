//! The frame channel's message: each wire frame wrapped as the protobuf message
//!
//! ```proto
//! syntax = "proto3";
//! package rover_power;
//! message Frame { bytes wire = 1; }  // one frame exactly as the board sent it
//! ```
//!
//! Protobuf because Foxglove Studio decodes it from the schema stored in the file (a message
//! encoding of our own shows as "Unsupported encoding" in its Problems panel), at two bytes per
//! frame. Files written before kept the bare frame under the message encoding
//! `rover-power-wire-v<N>`; the reader takes both.

/// The schema's (fully qualified message) name.
pub(crate) const SCHEMA_NAME: &str = "rover_power.Frame";
/// The message and schema encoding.
pub(crate) const ENCODING: &str = "protobuf";

/// Protobuf wire types.
const LEN: u8 = 2;
const VARINT: u8 = 0;

/// The `google.protobuf.FileDescriptorSet` of `rover_power.Frame`, as Studio reads it.
pub(crate) fn descriptor_set() -> Vec<u8> {
    const LABEL_OPTIONAL: u64 = 1;
    const TYPE_BYTES: u64 = 12;
    // FieldDescriptorProto: name = 1, number = 3, label = 4, type = 5, json_name = 10.
    let mut field = Vec::new();
    put_len(&mut field, 1, b"wire");
    put_varint_field(&mut field, 3, 1);
    put_varint_field(&mut field, 4, LABEL_OPTIONAL);
    put_varint_field(&mut field, 5, TYPE_BYTES);
    put_len(&mut field, 10, b"wire");
    // DescriptorProto: name = 1, field = 2.
    let mut message = Vec::new();
    put_len(&mut message, 1, b"Frame");
    put_len(&mut message, 2, &field);
    // FileDescriptorProto: name = 1, package = 2, message_type = 4, syntax = 12.
    let mut file = Vec::new();
    put_len(&mut file, 1, b"rover_power/Frame.proto");
    put_len(&mut file, 2, b"rover_power");
    put_len(&mut file, 4, &message);
    put_len(&mut file, 12, b"proto3");
    // FileDescriptorSet: file = 1.
    let mut set = Vec::new();
    put_len(&mut set, 1, &file);
    set
}

/// Appends the message holding `wire` to `out`.
pub(crate) fn encode(wire: &[u8], out: &mut Vec<u8>) {
    put_len(out, 1, wire);
}

/// The wire frame a message holds.
pub(crate) fn decode(message: &[u8]) -> Result<&[u8], String> {
    let Some((&key, rest)) = message.split_first() else {
        return Err("empty message (no wire frame)".into());
    };
    if key != (1 << 3) | LEN {
        return Err(format!(
            "not a rover_power.Frame message (first key 0x{key:02x}, expected 0x0a)"
        ));
    }
    let (len, rest) = varint(rest).ok_or("rover_power.Frame: truncated length")?;
    if u64::try_from(rest.len()).ok() != Some(len) {
        return Err(format!(
            "rover_power.Frame: the wire field says {len} bytes, the message holds {}",
            rest.len()
        ));
    }
    Ok(rest)
}

fn put_len(out: &mut Vec<u8>, field: u8, bytes: &[u8]) {
    out.push((field << 3) | LEN);
    put_varint(out, bytes.len() as u64);
    out.extend_from_slice(bytes);
}

fn put_varint_field(out: &mut Vec<u8>, field: u8, value: u64) {
    out.push((field << 3) | VARINT);
    put_varint(out, value);
}

fn put_varint(out: &mut Vec<u8>, mut value: u64) {
    while value >= 0x80 {
        out.push((value as u8 & 0x7f) | 0x80);
        value >>= 7;
    }
    out.push(value as u8);
}

/// A base-128 varint and what follows it; `None` if cut short or longer than 64 bits.
fn varint(bytes: &[u8]) -> Option<(u64, &[u8])> {
    let mut value = 0u64;
    for (i, &b) in bytes.iter().enumerate().take(10) {
        value |= u64::from(b & 0x7f) << (7 * i);
        if b & 0x80 == 0 {
            return Some((value, &bytes[i + 1..]));
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_frame_survives_the_wrapping_at_every_length_around_the_varint_steps() {
        for n in [0usize, 1, 127, 128, 300, 16_383, 16_384] {
            let wire: Vec<u8> = (0..n).map(|i| (i % 251) as u8 + 1).collect();
            let mut message = Vec::new();
            encode(&wire, &mut message);
            assert_eq!(decode(&message).expect("decodes"), wire.as_slice(), "{n}");
        }
    }

    #[test]
    fn damaged_messages_are_errors_not_panics() {
        let mut message = Vec::new();
        encode(&[1, 2, 3], &mut message);
        assert!(decode(&[]).is_err());
        assert!(decode(&[0x12, 0]).expect_err("wrong key").contains("0x12"));
        assert!(decode(&message[..4])
            .expect_err("cut short")
            .contains("says 3 bytes"));
        assert!(decode(&[0x0a, 0x80]).is_err());
        assert!(
            decode(&[0x0a, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0x01])
                .is_err()
        );
        let mut longer = message.clone();
        longer.push(0);
        assert!(decode(&longer).is_err());
    }

    /// The descriptor, read back field by field (the encoding `protoc
    /// --descriptor_set_out` gives for the `.proto` above, checked against Studio's own
    /// protobuf reader in `foxglove/check`).
    #[test]
    fn the_descriptor_names_the_message_and_its_bytes_field() {
        let set = descriptor_set();
        let fields = |bytes: &[u8]| -> Vec<(u8, Vec<u8>)> {
            let mut out = Vec::new();
            let mut rest = bytes;
            while let Some((&key, tail)) = rest.split_first() {
                let (len, tail) = varint(tail).expect("length or value");
                if key & 7 == LEN {
                    out.push((key >> 3, tail[..len as usize].to_vec()));
                    rest = &tail[len as usize..];
                } else {
                    out.push((key >> 3, vec![len as u8]));
                    rest = tail;
                }
            }
            out
        };
        let file = &fields(&set)[0];
        assert_eq!(file.0, 1);
        let file = fields(&file.1);
        assert_eq!(file[1], (2, b"rover_power".to_vec()));
        assert_eq!(file[3], (12, b"proto3".to_vec()));
        let message = fields(&file[2].1);
        assert_eq!(message[0], (1, b"Frame".to_vec()));
        assert_eq!(format!("{}.Frame", "rover_power"), SCHEMA_NAME);
        let field = fields(&message[1].1);
        assert_eq!(field[0], (1, b"wire".to_vec()));
        assert_eq!(field[1], (3, vec![1]));
        assert_eq!(field[3], (5, vec![12]));
    }
}
