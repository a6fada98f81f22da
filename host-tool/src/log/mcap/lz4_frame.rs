//! An LZ4 chunk's frame decoded block by block in safe Rust, without its content checksum.
//!
//! Our logs' chunks are LZ4 frames as the `mcap` crate writes them through liblz4: linked 64 KiB
//! blocks and an xxHash-32 of the content. liblz4's frame decoder verifies that hash, which took
//! longer than the decompression (an hour's `validate`: 7.2 % of its profile against 5.4 %);
//! the chunk's own CRC-32 (MCAP's `uncompressed_crc`, checked by [`super::walk`]) covers the
//! same bytes, so this reader skips the hash and lets `lz4_flex`'s block decoder do the work. Anything it does
//! not take (a chunk without a CRC, a dictionary id, bytes after the frame, a block that does
//! not decode) is left to liblz4's checked decoder, which also names what is wrong.

/// The frame's magic number.
const MAGIC: u32 = 0x184D_2204;
/// How far back a match of a linked block may reach.
const WINDOW: usize = 64 * 1024;

/// The content of the LZ4 frame `frame`, written into `out` (which then holds exactly `size`
/// bytes, the length the chunk claims); `None` where this reader does not take the frame.
pub(super) fn decode(frame: &[u8], size: usize, out: &mut Vec<u8>) -> Option<()> {
    let (magic, rest) = frame.split_first_chunk::<4>()?;
    let (&[flags, _block_size], rest) = rest.split_first_chunk::<2>()?;
    let flag = |bit: u8| flags & (1 << bit) != 0;
    // Version 01, the reserved bit clear, no dictionary.
    if u32::from_le_bytes(*magic) != MAGIC || flags >> 6 != 0b01 || flag(1) || flag(0) {
        return None;
    }
    let (independent, block_checksum, content_size, content_checksum) =
        (flag(5), flag(4), flag(3), flag(2));
    // The content size (if given) and the descriptor's checksum byte.
    let mut rest = rest.get(usize::from(content_size) * 8 + 1..)?;
    // Every byte is written below (or the frame is refused): a reused buffer's are not zeroed.
    out.resize(size, 0);
    let mut at = 0;
    loop {
        let (len, after) = rest.split_first_chunk::<4>()?;
        let len = u32::from_le_bytes(*len);
        if len == 0 {
            rest = after;
            break;
        }
        let n = (len & 0x7FFF_FFFF) as usize;
        let block = after.get(..n)?;
        rest = after.get(n + usize::from(block_checksum) * 4..)?;
        if len & 0x8000_0000 != 0 {
            // Stored uncompressed.
            out.get_mut(at..at + n)?.copy_from_slice(block);
            at += n;
        } else {
            let (before, after) = out.split_at_mut(at);
            let window = match independent {
                true => &[][..],
                false => &before[at.saturating_sub(WINDOW)..],
            };
            at += lz4_flex::block::decompress_into_with_dict(block, after, window).ok()?;
        }
    }
    (at == size && rest.len() == usize::from(content_checksum) * 4).then_some(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::io::{Read, Write};

    /// `content` as liblz4's frame encoder writes it (as the `mcap` crate configures it, but for
    /// the options given).
    fn encoded(content: &[u8], level: u32, linked: bool, block_checksum: bool) -> Vec<u8> {
        let mut encoder = lz4::EncoderBuilder::new()
            .level(level)
            .block_mode(match linked {
                true => lz4::BlockMode::Linked,
                false => lz4::BlockMode::Independent,
            })
            .block_checksum(match block_checksum {
                true => lz4::liblz4::BlockChecksum::BlockChecksumEnabled,
                false => lz4::liblz4::BlockChecksum::NoBlockChecksum,
            })
            .build(Vec::new())
            .expect("encoder");
        encoder.write_all(content).expect("written");
        let (bytes, result) = encoder.finish();
        result.expect("finished");
        bytes
    }

    /// What liblz4's checked decoder makes of `frame`.
    fn liblz4(frame: &[u8]) -> Option<Vec<u8>> {
        let mut out = Vec::new();
        lz4::Decoder::new(frame).ok()?.read_to_end(&mut out).ok()?;
        Some(out)
    }

    /// Several blocks of text-like repeats and noise, so matches reach into earlier blocks.
    fn content(seed: u64, len: usize) -> Vec<u8> {
        let mut x = seed | 1;
        (0..len)
            .map(|i| {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                match (i / 997) % 3 {
                    0 => (i % 251) as u8,
                    1 => b"rover_power.SampleBatch"[i % 23],
                    _ => x as u8,
                }
            })
            .collect()
    }

    #[test]
    fn frames_of_every_block_mode_decode_as_liblz4_does() {
        for (level, linked, block_checksum) in [
            (0, true, false),
            (4, true, false),
            (9, true, true),
            (4, false, false),
            (0, false, true),
        ] {
            for len in [0, 1, 1000, 64 * 1024, 300_000] {
                let original = content(len as u64 + u64::from(level), len);
                let frame = encoded(&original, level, linked, block_checksum);
                let mut out = vec![7; 3];
                let case = format!("level {level}, linked {linked}, {len} B");
                assert_eq!(decode(&frame, len, &mut out), Some(()), "{case}");
                assert!(out == original, "{case}");
                assert_eq!(liblz4(&frame).as_deref(), Some(&original[..]), "{case}");
            }
        }
    }

    #[test]
    fn a_frame_of_another_length_or_shape_is_left_to_liblz4() {
        let original = content(3, 100_000);
        let frame = encoded(&original, 4, true, false);
        let mut out = Vec::new();
        assert_eq!(decode(&frame, original.len() - 1, &mut out), None);
        assert_eq!(decode(&frame, original.len() + 1, &mut out), None);
        assert_eq!(
            decode(&frame[..frame.len() - 1], original.len(), &mut out),
            None
        );
        let mut longer = frame.clone();
        longer.push(0);
        assert_eq!(decode(&longer, original.len(), &mut out), None);
        let mut dictionary = frame;
        dictionary[4] |= 1;
        assert_eq!(decode(&dictionary, original.len(), &mut out), None);
    }

    proptest! {
        /// Damaged frames never panic, and where both decoders take one they agree (the chunk's
        /// CRC is what catches damage the skipped content checksum would have).
        #[test]
        fn damaged_frames_never_panic(
            seed in any::<u64>(),
            len in 0usize..200_000,
            flips in proptest::collection::vec((any::<u64>(), 1u8..), 0..4),
            cut in any::<u64>(),
        ) {
            let original = content(seed, len);
            let mut frame = encoded(&original, 4, true, false);
            for (at, xor) in flips {
                let at = (at % frame.len() as u64) as usize;
                frame[at] ^= xor;
            }
            let keep = frame.len() - (cut % 3) as usize;
            frame.truncate(keep);
            let mut out = Vec::new();
            if decode(&frame, len, &mut out).is_some() {
                prop_assert_eq!(out.len(), len);
                // Without a flip in the content checksum, liblz4 took the same bytes.
                if let Some(theirs) = liblz4(&frame) {
                    prop_assert!(theirs == out);
                }
            }
        }
    }
}
