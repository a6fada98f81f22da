//! Which board is talking: the STM32's 96-bit unique ID and its crystal, sent in the hello frame,
//! and the USB serial number built from the ID.
//!
//! The board enumerates as 16c0:27dd, the VID:PID that Objective Development (V-USB,
//! `USB-IDs-for-free.txt`) shares among CDC-ACM devices told apart by serial number; its rules
//! require the serial number to be `your-domain-or-email:something-unique`. Two boards with the same serial collide in
//! `/dev/serial/by-id` and in Windows' COM-port assignment, so the unique part is the chip's ID.

use serde::{Deserialize, Serialize};

/// The serial number's owner prefix. A builder of their own boards changes it to a domain or
/// e-mail address they control (docs/board.md, "Testing the first board").
pub const SERIAL_PREFIX: &str = "rover-power.github.io:";

/// Bytes of the STM32F4 unique device ID (RM0383, "Unique device ID register", at 0x1FFF_7A10).
pub const UID_LEN: usize = 12;

/// Length of the USB serial number: the prefix and two hex digits per ID byte.
pub const SERIAL_LEN: usize = SERIAL_PREFIX.len() + 2 * UID_LEN;

/// The board's identity as the hello frame reports it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct BoardIdentity {
    /// The MCU's unique ID, in memory order (X, Y little-endian words, wafer, lot).
    pub uid: [u8; UID_LEN],
    /// HSE crystal frequency the firmware was built for [MHz] (0: not a real board).
    pub hse_mhz: u8,
}

impl BoardIdentity {
    /// A board without a known ID (host simulations before they set one).
    pub const UNKNOWN: BoardIdentity = BoardIdentity {
        uid: [0; UID_LEN],
        hse_mhz: 0,
    };

    /// The USB serial number: [`SERIAL_PREFIX`] then the ID as lower-case hex, in memory order.
    /// Written into `out` (the board formats it once into a static buffer: usb-device keeps a
    /// `&'static str`).
    pub fn usb_serial<'a>(&self, out: &'a mut [u8; SERIAL_LEN]) -> &'a str {
        const HEX: &[u8; 16] = b"0123456789abcdef";
        let (prefix, digits) = out.split_at_mut(SERIAL_PREFIX.len());
        prefix.copy_from_slice(SERIAL_PREFIX.as_bytes());
        for (pair, byte) in digits.chunks_exact_mut(2).zip(self.uid) {
            pair[0] = HEX[usize::from(byte >> 4)];
            pair[1] = HEX[usize::from(byte & 0x0F)];
        }
        // ASCII by construction; the fallback cannot be taken.
        core::str::from_utf8(out).unwrap_or(SERIAL_PREFIX)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn serial_is_the_prefix_and_the_uid_in_hex() {
        let id = BoardIdentity {
            uid: [
                0x33, 0x00, 0x3a, 0x00, 0x12, 0x51, 0x33, 0x30, 0x36, 0x34, 0x39, 0xff,
            ],
            hse_mhz: 25,
        };
        let mut buf = [0u8; SERIAL_LEN];
        let serial = id.usb_serial(&mut buf);
        assert_eq!(serial, "rover-power.github.io:33003a0012513330363439ff");
        assert_eq!(serial.len(), SERIAL_LEN);
        // The shared-PID rule: "owner:unique", one colon, and short enough for a USB string
        // descriptor (126 UTF-16 units).
        assert_eq!(serial.matches(':').count(), 1);
        assert!(serial.len() <= 126);
        let mut other = [0u8; SERIAL_LEN];
        let second = BoardIdentity {
            uid: [0x34; UID_LEN],
            ..id
        }
        .usb_serial(&mut other);
        assert_ne!(serial, second, "two boards, two serials");
    }
}
