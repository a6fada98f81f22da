//! The frame channel's message: each wire frame wrapped as the protobuf message
//!
//! ```proto
//! package rover_power;
//! message Frame { optional bytes wire = 1; }  // one frame exactly as the board sent it
//! ```
//!
//! Protobuf because Foxglove Studio decodes it from the schema stored in the file (a message
//! encoding of our own shows as "Unsupported encoding" in its Problems panel), at two bytes per
//! frame; the schema is [`super::proto`]'s, with the other channels' messages. Files written
//! before kept the bare frame under the message encoding `rover-power-wire-v<N>`; the reader
//! takes both.

use super::proto::{varint, Writer};

/// Protobuf's length-delimited wire type.
const LEN: u8 = 2;

/// The message holding `wire`.
pub(crate) fn encode(wire: &[u8]) -> Vec<u8> {
    let mut message = Writer::new();
    message.bytes(1, wire);
    message.into_bytes()
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_frame_survives_the_wrapping_at_every_length_around_the_varint_steps() {
        for n in [0usize, 1, 127, 128, 300, 16_383, 16_384] {
            let wire: Vec<u8> = (0..n).map(|i| (i % 251) as u8 + 1).collect();
            let message = encode(&wire);
            assert_eq!(decode(&message).expect("decodes"), wire.as_slice(), "{n}");
        }
    }

    #[test]
    fn damaged_messages_are_errors_not_panics() {
        let message = encode(&[1, 2, 3]);
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
}
