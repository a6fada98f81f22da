//! Arbitrary bytes into both directions' decoders: they must never panic, and after any input a
//! delimiter followed by a valid frame must decode (resynchronisation).
#![no_main]

use libfuzzer_sys::fuzz_target;
use model_core::wire::{self, BoardFrame, Command, FrameDecoder, HostFrame, MAX_FRAME};

fuzz_target!(|data: &[u8]| {
    let mut board = FrameDecoder::new();
    board.feed::<BoardFrame>(data, |_| {});
    let mut host = FrameDecoder::new();
    host.feed::<HostFrame>(data, |_| {});
    let _ = wire::decode_frame::<BoardFrame>(&mut data.to_vec());

    let good = HostFrame { id: 7, command: Command::GetStatus };
    let mut buf = [0u8; MAX_FRAME];
    let n = wire::encode(&good, &mut buf).expect("fits");
    let mut last = None;
    host.feed::<HostFrame>(&[0], |_| {});
    host.feed::<HostFrame>(&buf[..n], |r| last = Some(r));
    assert_eq!(last, Some(Ok(good)));
});
