//! A fast path for the JSON `/rover_power/sample` messages of logs written before the protobuf
//! channels, laid out exactly as [`super::McapSink`] wrote them (serde_json's compact output,
//! fields in declaration order). The sample channel is most of a log; serde_json's derived
//! deserializer spends ~1.7 µs on each message, this ~0.3 µs.
//! Anything else (another key order, whitespace, unknown or `null` fields, a number that is not
//! JSON or not finite) gives `None`, and the caller deserializes with serde_json: results and
//! errors stay serde_json's.

use super::{SampleMsg, SampleSide};

/// The sample message in `data` if it has exactly the writer's layout; `None` otherwise.
pub(super) fn parse_sample_msg(data: &[u8]) -> Option<SampleMsg> {
    // One UTF-8 check per message (a non-UTF-8 message is serde_json's to report).
    let mut c = Cursor {
        rest: std::str::from_utf8(data).ok()?,
    };
    c.tag("{\"t_s\":")?;
    let t_s = c.number()?;
    c.tag(",\"left\":")?;
    let left = c.side()?;
    c.tag(",\"right\":")?;
    let right = c.side()?;
    let yaw_rad = c.optional(",\"yaw_rad\":")?;
    let pitch_deg = c.optional(",\"pitch_deg\":")?;
    let x_m = c.optional(",\"x_m\":")?;
    let y_m = c.optional(",\"y_m\":")?;
    c.tag("}")?;
    c.rest.is_empty().then_some(SampleMsg {
        t_s,
        left,
        right,
        yaw_rad,
        pitch_deg,
        x_m,
        y_m,
    })
}

struct Cursor<'a> {
    rest: &'a str,
}

impl Cursor<'_> {
    /// Consumes `tag` if the input starts with it.
    fn tag(&mut self, tag: &str) -> Option<()> {
        self.rest = self.rest.strip_prefix(tag)?;
        Some(())
    }

    /// `Some(Some(number))` after `key`, `Some(None)` if the input does not start with `key`.
    fn optional(&mut self, key: &str) -> Option<Option<f64>> {
        if self.tag(key).is_none() {
            return Some(None);
        }
        self.number().map(Some)
    }

    fn side(&mut self) -> Option<SampleSide> {
        self.tag("{\"bus_v\":")?;
        let bus_v = self.number()?;
        self.tag(",\"current_a\":")?;
        let current_a = self.number()?;
        self.tag(",\"power_w\":")?;
        let power_w = self.number()?;
        self.tag(",\"cmd_mps\":")?;
        let cmd_mps = self.number()?;
        self.tag("}")?;
        Some(SampleSide {
            bus_v,
            current_a,
            power_w,
            cmd_mps,
        })
    }

    /// A JSON number with a finite value (correctly rounded, as serde_json's `float_roundtrip`
    /// reads it; JSON numbers out of f64's range are serde_json errors, left to it).
    fn number(&mut self) -> Option<f64> {
        let n = json_number_len(self.rest.as_bytes())?;
        let (text, rest) = self.rest.split_at_checked(n)?;
        let value: f64 = text.parse().ok()?;
        self.rest = rest;
        value.is_finite().then_some(value)
    }
}

/// Length of the JSON number (RFC 8259 grammar) at the start of `b`, if one starts there.
fn json_number_len(b: &[u8]) -> Option<usize> {
    let digits = |mut i: usize| {
        while b.get(i).is_some_and(u8::is_ascii_digit) {
            i += 1;
        }
        i
    };
    let mut i = usize::from(b.first() == Some(&b'-'));
    match b.get(i)? {
        b'0' => i += 1,
        b'1'..=b'9' => i = digits(i + 1),
        _ => return None,
    }
    if b.get(i) == Some(&b'.') {
        let end = digits(i + 1);
        if end == i + 1 {
            return None;
        }
        i = end;
    }
    if matches!(b.get(i), Some(b'e' | b'E')) {
        i += 1;
        if matches!(b.get(i), Some(b'+' | b'-')) {
            i += 1;
        }
        let end = digits(i);
        if end == i {
            return None;
        }
        i = end;
    }
    Some(i)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Equal bit for bit (tells -0.0 from 0.0).
    fn same(a: &SampleMsg, b: &SampleMsg) -> bool {
        let bits = |m: &SampleMsg| {
            let side =
                |s: &SampleSide| [s.bus_v, s.current_a, s.power_w, s.cmd_mps].map(f64::to_bits);
            (
                m.t_s.to_bits(),
                side(&m.left),
                side(&m.right),
                m.yaw_rad.map(f64::to_bits),
                m.pitch_deg.map(f64::to_bits),
            )
        };
        bits(a) == bits(b)
    }

    /// Whenever the fast path reads `data`, serde_json reads the same message from it.
    fn agrees_with_serde(data: &[u8]) -> Result<(), String> {
        if let Some(fast) = parse_sample_msg(data) {
            let slow: SampleMsg = serde_json::from_slice(data).map_err(|e| {
                format!(
                    "fast path read {:?}, serde_json: {e}",
                    String::from_utf8_lossy(data)
                )
            })?;
            if !same(&fast, &slow) {
                return Err(format!(
                    "{:?}: fast {fast:?}, serde_json {slow:?}",
                    String::from_utf8_lossy(data)
                ));
            }
        }
        Ok(())
    }

    fn message(t: &str, n: &str, tail: &str) -> String {
        let side = format!(r#"{{"bus_v":{n},"current_a":1.5,"power_w":36.0,"cmd_mps":0.3}}"#);
        format!(r#"{{"t_s":{t},"left":{side},"right":{side}{tail}}}"#)
    }

    #[test]
    fn reads_what_the_writer_writes() {
        let msg = message("0.005", "24.005", r#","yaw_rad":-0.25,"pitch_deg":1e-7"#);
        let fast = parse_sample_msg(msg.as_bytes()).expect("writer layout");
        assert_eq!(fast.t_s, 0.005);
        assert_eq!(fast.left.bus_v, 24.005);
        assert_eq!(fast.right.cmd_mps, 0.3);
        assert_eq!((fast.yaw_rad, fast.pitch_deg), (Some(-0.25), Some(1e-7)));
        let bare = parse_sample_msg(message("1", "24", "").as_bytes()).expect("no pose");
        assert_eq!((bare.yaw_rad, bare.pitch_deg), (None, None));
        let pitch_only = message("1", "24", r#","pitch_deg":2.0"#);
        let pitch_only = parse_sample_msg(pitch_only.as_bytes()).expect("pitch only");
        assert_eq!(
            (pitch_only.yaw_rad, pitch_only.pitch_deg),
            (None, Some(2.0))
        );
    }

    #[test]
    fn numbers_agree_with_serde_json_or_are_left_to_it() {
        let read = [
            "0",
            "-0",
            "0.0",
            "-0.0",
            "1",
            "-1",
            "0e5",
            "1E+2",
            "2.5e-3",
            "1.5E-400",
            "-1e-400",
            "18446744073709551615",
            "18446744073709551616",
            "-9223372036854775808",
            "-9223372036854775809",
            "123456789012345678901234567890",
            "1.7976931348623157e308",
            "4.9e-324",
            "2.2250738585072011e-308",
            "0.30000000000000004",
        ];
        for n in read {
            let msg = message(n, n, &format!(r#","yaw_rad":{n}"#));
            assert!(parse_sample_msg(msg.as_bytes()).is_some(), "{n}");
            assert_eq!(agrees_with_serde(msg.as_bytes()), Ok(()), "{n}");
        }
        let left_to_serde = [
            "1e400",
            "-1e309",
            "01",
            "-01",
            "1.",
            ".5",
            "-",
            "1e",
            "1e+",
            "+1",
            "NaN",
            "inf",
            "Infinity",
            "-Infinity",
            "null",
            "\"1\"",
            "1 ",
            " 1",
            "0x10",
            "1_0",
        ];
        for n in left_to_serde {
            let msg = message(n, "24", "");
            assert!(parse_sample_msg(msg.as_bytes()).is_none(), "{n}");
            let msg = message("1", n, "");
            assert!(parse_sample_msg(msg.as_bytes()).is_none(), "{n}");
        }
    }

    #[test]
    fn other_layouts_are_left_to_serde_json() {
        let good = message("1", "24", "");
        for other in [
            good.replace(',', ", "),
            format!("{good}\n"),
            format!(" {good}"),
            good.replacen(r#""t_s":1,"#, "", 1)
                .replacen('{', r#"{"t_s":1,"#, 1)
                + "x",
            good.replace(r#""cmd_mps":0.3}}"#, r#""cmd_mps":0.3},"extra":1}"#),
            good.replace('}', r#","yaw_rad":null}"#),
            message("1", "24", r#","pitch_deg":1,"yaw_rad":2"#),
            message("1", "24", r#","yaw_rad":1,"yaw_rad":2"#),
            good[..good.len() - 1].to_owned(),
        ] {
            assert!(parse_sample_msg(other.as_bytes()).is_none(), "{other}");
        }
    }

    fn any_f64() -> impl Strategy<Value = f64> {
        prop_oneof![
            any::<f64>().prop_filter("finite", |v| v.is_finite()),
            (-1e4..1e4f64),
            Just(0.0),
            Just(-0.0),
            Just(f64::MIN_POSITIVE / 3.0),
        ]
    }

    fn side() -> impl Strategy<Value = SampleSide> {
        (any_f64(), any_f64(), any_f64(), any_f64()).prop_map(
            |(bus_v, current_a, power_w, cmd_mps)| SampleSide {
                bus_v,
                current_a,
                power_w,
                cmd_mps,
            },
        )
    }

    fn sample_msg() -> impl Strategy<Value = SampleMsg> {
        (
            any_f64(),
            side(),
            side(),
            proptest::option::of(any_f64()),
            proptest::option::of(any_f64()),
        )
            .prop_map(|(t_s, left, right, yaw_rad, pitch_deg)| SampleMsg {
                t_s,
                left,
                right,
                yaw_rad,
                pitch_deg,
                x_m: None,
                y_m: None,
            })
    }

    proptest! {
        #[test]
        fn the_writers_messages_read_back_exactly(msg in sample_msg()) {
            let data = serde_json::to_vec(&msg).expect("serialize");
            let fast = parse_sample_msg(&data);
            prop_assert!(fast.is_some(), "{}", String::from_utf8_lossy(&data));
            prop_assert!(same(&fast.unwrap_or(msg), &msg));
            prop_assert_eq!(agrees_with_serde(&data), Ok(()));
        }

        #[test]
        fn edited_messages_read_as_serde_json_reads_them(
            msg in sample_msg(),
            edits in proptest::collection::vec(
                (any::<prop::sample::Index>(), 0..3u8, prop::sample::select(
                    b"0123456789-+.eE,:{}\" nulx".to_vec())),
                1..4,
            ),
        ) {
            let mut data = serde_json::to_vec(&msg).expect("serialize");
            for (at, kind, byte) in edits {
                let i = at.index(data.len() + 1);
                match kind {
                    0 if i < data.len() => data[i] = byte,
                    1 if i < data.len() => {
                        data.remove(i);
                    }
                    _ => data.insert(i, byte),
                }
            }
            prop_assert_eq!(agrees_with_serde(&data), Ok(()));
        }
    }
}
