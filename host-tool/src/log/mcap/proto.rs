//! The run log's protobuf messages: their schema (one `rover_power.proto`, stored in the file as
//! a `google.protobuf.FileDescriptorSet` so that Foxglove, Rerun, PlotJuggler and Python's
//! `mcap-protobuf-support` decode them without our package), and the wire format's few pieces
//! the writer and reader need.
//!
//! ```proto
//! syntax = "proto2";  // every field optional: a value that is not known is absent
//! package rover_power;
//! message SampleSide { optional double bus_v = 1; optional double current_a = 2;
//!                      optional double power_w = 3; optional double cmd_mps = 4; }
//! message BoardSample { optional uint64 t_us = 1; optional uint32 seq = 2;
//!                       optional sint32 shunt_left = 3; optional sint32 shunt_right = 4;
//!                       optional sint32 current_left = 5; optional sint32 current_right = 6;
//!                       optional uint32 stale = 7; }  // the board's sample frame: board_sample.rs
//! message Sample { optional double t_s = 1; optional SampleSide left = 2;
//!                  optional SampleSide right = 3; optional double yaw_rad = 4;
//!                  optional double pitch_deg = 5; optional double x_m = 6; optional double y_m = 7;
//!                  optional BoardSample board = 8; }  // the live view's; files before batches
//! message SampleColumns {  // one side of a batch: one value per sample
//!   repeated float power_w = 1 [packed = true];  // bus × current, for viewers
//!   repeated double bus_v = 2 [packed = true]; repeated double current_a = 3 [packed = true];
//!   repeated double cmd_mps = 4 [packed = true];
//!   repeated uint32 bus_raw = 5 [packed = true]; repeated sint32 current_raw = 6 [packed = true]; }
//! message BoardColumns { repeated uint64 t_us = 1 [packed = true]; repeated uint32 seq = 2 [packed = true];
//!                        repeated sint32 shunt_left = 3 [packed = true];
//!                        repeated sint32 shunt_right = 4 [packed = true];
//!                        repeated uint32 stale = 5 [packed = true];
//!                        repeated sint32 current_left = 6 [packed = true];
//!                        repeated sint32 current_right = 7 [packed = true];
//!                        optional uint64 t_us_first = 8; optional uint32 seq_first = 9; }
//! message SampleBatch {  // a log file's samples: sample_batch.rs
//!   repeated double t_s = 1 [packed = true];
//!   optional SampleColumns left = 2; optional SampleColumns right = 3;
//!   repeated double yaw_rad = 4 [packed = true]; repeated double pitch_deg = 5 [packed = true];
//!   repeated double x_m = 6 [packed = true]; repeated double y_m = 7 [packed = true];
//!   optional BoardColumns board = 8; optional uint32 current_lsb_na = 9; }
//! message ModelSide { optional double power_w = 1; optional double energy_j = 2;
//!                     optional float tau_w_per_rad_s = 3; }
//! message Model { optional double t_s = 1; optional uint64 board_t_us = 2; optional uint32 seq = 3;
//!                 optional ModelSide left = 4; optional ModelSide right = 5;
//!                 optional double total_energy_j = 6; }
//! message SideCounts { optional uint32 left = 1; optional uint32 right = 2; }
//! message SideFaults { optional string left = 1; optional string right = 2; }
//! message SideRates { optional float left = 1; optional float right = 2; }
//! message Adc { optional string averaging = 1; optional string bus_conversion = 2;
//!               optional string shunt_conversion = 3; }
//! message Status { optional double t_s = 1; optional uint64 uptime_us = 2; optional uint32 samples = 3;
//!                  optional bool running = 4; optional SideCounts i2c_errors = 5;
//!                  optional SideCounts reinits = 6; optional SideCounts skipped_results = 7;
//!                  optional SideFaults last_fault = 8; optional uint32 queue_drops = 9;
//!                  optional uint32 rx_errors = 10; optional Adc adc = 11;
//!                  optional uint32 sample_period_us = 12; optional SideRates wheel_rates_rad_s = 13; }
//! message Frame { optional bytes wire = 1; }  // one wire frame exactly as the board sent it
//! ```
//!
//! proto2 because its `optional` keeps presence in every decoder (proto3's needs synthetic
//! oneofs that not every reader of descriptors handles); its repeated numbers are unpacked by
//! default, so the columns say `packed`. The field names are the JSON channels' of earlier logs,
//! so a Foxglove layout's message paths (`/rover_power/model.left.power_w`) read old and new
//! logs alike. Hand-written rather than generated: the messages are flat numbers, and the
//! sample decoder is on the path that reads an hour of samples.

/// The message and schema encoding of every protobuf channel.
pub(crate) const ENCODING: &str = "protobuf";
/// The package of the messages.
const PACKAGE: &str = "rover_power";

/// Wire types.
const VARINT: u8 = 0;
const FIXED64: u8 = 1;
const LEN: u8 = 2;
const FIXED32: u8 = 5;

/// A field's type in the schema (`FieldDescriptorProto.Type`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Type {
    Double,
    Float,
    Uint64,
    Uint32,
    Sint32,
    Bool,
    Str,
    Bytes,
    /// A message of this package, by its short name.
    Message(&'static str),
    /// A `repeated` number field, written packed (one length-delimited run of values).
    Packed(&'static Type),
}

impl Type {
    fn number(self) -> u64 {
        match self {
            Type::Double => 1,
            Type::Float => 2,
            Type::Uint64 => 4,
            Type::Bool => 8,
            Type::Str => 9,
            Type::Message(_) => 11,
            Type::Bytes => 12,
            Type::Uint32 => 13,
            Type::Sint32 => 17,
            Type::Packed(element) => element.number(),
        }
    }
}

/// A message of the schema: its short name and its fields (name, number, type).
struct MessageDef {
    name: &'static str,
    fields: &'static [(&'static str, u32, Type)],
}

use Type::*;

/// Every message of `rover_power.proto` (the module docs show it as `.proto`).
const MESSAGES: &[MessageDef] = &[
    MessageDef {
        name: "SampleSide",
        fields: &[
            ("bus_v", 1, Double),
            ("current_a", 2, Double),
            ("power_w", 3, Double),
            ("cmd_mps", 4, Double),
        ],
    },
    MessageDef {
        name: "BoardSample",
        fields: &[
            ("t_us", 1, Uint64),
            ("seq", 2, Uint32),
            ("shunt_left", 3, Sint32),
            ("shunt_right", 4, Sint32),
            ("current_left", 5, Sint32),
            ("current_right", 6, Sint32),
            ("stale", 7, Uint32),
        ],
    },
    MessageDef {
        name: "Sample",
        fields: &[
            ("t_s", 1, Double),
            ("left", 2, Message("SampleSide")),
            ("right", 3, Message("SampleSide")),
            ("yaw_rad", 4, Double),
            ("pitch_deg", 5, Double),
            ("x_m", 6, Double),
            ("y_m", 7, Double),
            ("board", 8, Message("BoardSample")),
        ],
    },
    MessageDef {
        name: "SampleColumns",
        fields: &[
            ("power_w", 1, Packed(&Float)),
            ("bus_v", 2, Packed(&Double)),
            ("current_a", 3, Packed(&Double)),
            ("cmd_mps", 4, Packed(&Double)),
            ("bus_raw", 5, Packed(&Uint32)),
            ("current_raw", 6, Packed(&Sint32)),
        ],
    },
    MessageDef {
        name: "BoardColumns",
        fields: &[
            ("t_us", 1, Packed(&Uint64)),
            ("seq", 2, Packed(&Uint32)),
            ("shunt_left", 3, Packed(&Sint32)),
            ("shunt_right", 4, Packed(&Sint32)),
            ("stale", 5, Packed(&Uint32)),
            ("current_left", 6, Packed(&Sint32)),
            ("current_right", 7, Packed(&Sint32)),
            ("t_us_first", 8, Uint64),
            ("seq_first", 9, Uint32),
        ],
    },
    MessageDef {
        name: "SampleBatch",
        fields: &[
            ("t_s", 1, Packed(&Double)),
            ("left", 2, Message("SampleColumns")),
            ("right", 3, Message("SampleColumns")),
            ("yaw_rad", 4, Packed(&Double)),
            ("pitch_deg", 5, Packed(&Double)),
            ("x_m", 6, Packed(&Double)),
            ("y_m", 7, Packed(&Double)),
            ("board", 8, Message("BoardColumns")),
            ("current_lsb_na", 9, Uint32),
        ],
    },
    MessageDef {
        name: "ModelSide",
        fields: &[
            ("power_w", 1, Double),
            ("energy_j", 2, Double),
            ("tau_w_per_rad_s", 3, Float),
        ],
    },
    MessageDef {
        name: "Model",
        fields: &[
            ("t_s", 1, Double),
            ("board_t_us", 2, Uint64),
            ("seq", 3, Uint32),
            ("left", 4, Message("ModelSide")),
            ("right", 5, Message("ModelSide")),
            ("total_energy_j", 6, Double),
        ],
    },
    MessageDef {
        name: "SideCounts",
        fields: &[("left", 1, Uint32), ("right", 2, Uint32)],
    },
    MessageDef {
        name: "SideFaults",
        fields: &[("left", 1, Str), ("right", 2, Str)],
    },
    MessageDef {
        name: "SideRates",
        fields: &[("left", 1, Float), ("right", 2, Float)],
    },
    MessageDef {
        name: "Adc",
        fields: &[
            ("averaging", 1, Str),
            ("bus_conversion", 2, Str),
            ("shunt_conversion", 3, Str),
        ],
    },
    MessageDef {
        name: "Status",
        fields: &[
            ("t_s", 1, Double),
            ("uptime_us", 2, Uint64),
            ("samples", 3, Uint32),
            ("running", 4, Bool),
            ("i2c_errors", 5, Message("SideCounts")),
            ("reinits", 6, Message("SideCounts")),
            ("skipped_results", 7, Message("SideCounts")),
            ("last_fault", 8, Message("SideFaults")),
            ("queue_drops", 9, Uint32),
            ("rx_errors", 10, Uint32),
            ("adc", 11, Message("Adc")),
            ("sample_period_us", 12, Uint32),
            ("wheel_rates_rad_s", 13, Message("SideRates")),
        ],
    },
    MessageDef {
        name: "Frame",
        fields: &[("wire", 1, Bytes)],
    },
];

/// Fully qualified names of the channels' messages.
pub(crate) const SAMPLE: &str = "rover_power.Sample";
pub(crate) const SAMPLE_BATCH: &str = "rover_power.SampleBatch";
pub(crate) const MODEL: &str = "rover_power.Model";
pub(crate) const STATUS: &str = "rover_power.Status";
pub(crate) const FRAME: &str = "rover_power.Frame";

/// The messages `message` (short name) needs: the messages its fields name, then itself.
fn closure(message: &str, into: &mut Vec<&'static MessageDef>) {
    let Some(def) = MESSAGES.iter().find(|m| m.name == message) else {
        return;
    };
    for &(_, _, ty) in def.fields {
        if let Message(nested) = ty {
            closure(nested, into);
        }
    }
    if !into.iter().any(|m| m.name == def.name) {
        into.push(def);
    }
}

/// The `google.protobuf.FileDescriptorSet` of `message` (fully qualified: [`SAMPLE`], ...): one
/// file, `rover_power.proto`, with that message and the ones it holds.
pub(crate) fn descriptor_set(message: &str) -> Vec<u8> {
    const LABEL_OPTIONAL: u64 = 1;
    const LABEL_REPEATED: u64 = 3;
    let mut messages = Vec::new();
    closure(
        message.strip_prefix("rover_power.").unwrap_or(message),
        &mut messages,
    );
    let mut file = Writer::new();
    // FileDescriptorProto: name = 1, package = 2, message_type = 4, syntax = 12.
    file.bytes(1, b"rover_power.proto");
    file.bytes(2, PACKAGE.as_bytes());
    for message in messages {
        // DescriptorProto: name = 1, field = 2.
        let mut m = Writer::new();
        m.bytes(1, message.name.as_bytes());
        for &(name, number, ty) in message.fields {
            // FieldDescriptorProto: name = 1, number = 3, label = 4, type = 5, type_name = 6,
            // json_name = 10.
            let mut f = Writer::new();
            f.bytes(1, name.as_bytes());
            f.varint(3, u64::from(number));
            let label = match ty {
                Packed(_) => LABEL_REPEATED,
                _ => LABEL_OPTIONAL,
            };
            f.varint(4, label);
            f.varint(5, ty.number());
            if let Message(short) = ty {
                f.bytes(6, format!(".{PACKAGE}.{short}").as_bytes());
            }
            if let Packed(_) = ty {
                // FieldOptions: packed = 2 (proto2 repeated numbers are unpacked by default).
                f.message(8, |o| o.bool(2, true));
            }
            f.bytes(10, name.as_bytes());
            m.bytes(2, &f.into_bytes());
        }
        file.bytes(4, &m.into_bytes());
    }
    file.bytes(12, b"proto2");
    let mut set = Writer::new();
    set.bytes(1, &file.into_bytes());
    set.into_bytes()
}

/// Whether `path` (`left.power_w`) in `message` (fully qualified) names a number field, one a
/// plot can draw.
#[cfg(test)]
pub(crate) fn is_number(message: &str, path: &str) -> bool {
    let Some(mut short) = message.strip_prefix("rover_power.") else {
        return false;
    };
    let mut names = path.split('.').peekable();
    while let Some(name) = names.next() {
        let Some(def) = MESSAGES.iter().find(|m| m.name == short) else {
            return false;
        };
        let Some(&(_, _, ty)) = def.fields.iter().find(|f| f.0 == name) else {
            return false;
        };
        match (ty, names.peek()) {
            (Message(nested), Some(_)) => short = nested,
            (Double | Float | Uint64 | Uint32 | Sint32, None) => return true,
            _ => return false,
        }
    }
    false
}

/// A message decoded by the schema into JSON (fields by name, absent ones left out), for tests
/// that read what a channel carries.
#[cfg(test)]
pub(crate) fn to_json(message: &str, data: &[u8]) -> Result<serde_json::Value, String> {
    fn decode(short: &str, data: &[u8]) -> Result<serde_json::Value, String> {
        let def = MESSAGES
            .iter()
            .find(|m| m.name == short)
            .ok_or_else(|| format!("no message {short}"))?;
        let mut out = serde_json::Map::new();
        for item in Fields::of(data) {
            let (number, value) = item?;
            let Some(&(name, _, ty)) = def.fields.iter().find(|f| f.1 == number) else {
                continue;
            };
            let v = match (ty, value) {
                (Double, Value::Fixed64(b)) => serde_json::json!(f64::from_bits(b)),
                (Float, Value::Fixed32(b)) => serde_json::json!(f32::from_bits(b)),
                (Uint64 | Uint32, Value::Varint(v)) => serde_json::json!(v),
                (Sint32, Value::Varint(v)) => serde_json::json!(unzigzag(v)),
                (Bool, Value::Varint(v)) => serde_json::json!(v != 0),
                (Str, Value::Len(b)) => {
                    serde_json::json!(std::str::from_utf8(b).map_err(|e| e.to_string())?)
                }
                (Bytes, Value::Len(b)) => serde_json::json!(b),
                (Message(nested), Value::Len(b)) => decode(nested, b)?,
                (Packed(element), Value::Len(b)) => {
                    let mut values = Vec::new();
                    let mut rest = b;
                    while !rest.is_empty() {
                        let (value, tail) = match element {
                            Double => rest
                                .split_first_chunk::<8>()
                                .map(|(v, t)| (serde_json::json!(f64::from_le_bytes(*v)), t)),
                            Float => rest
                                .split_first_chunk::<4>()
                                .map(|(v, t)| (serde_json::json!(f32::from_le_bytes(*v)), t)),
                            Sint32 => {
                                varint(rest).map(|(v, t)| (serde_json::json!(unzigzag(v)), t))
                            }
                            _ => varint(rest).map(|(v, t)| (serde_json::json!(v), t)),
                        }
                        .ok_or_else(|| format!("{short}.{name}: a packed value is cut short"))?;
                        values.push(value);
                        rest = tail;
                    }
                    serde_json::Value::Array(values)
                }
                (ty, v) => return Err(format!("{short}.{name}: {ty:?} field holds {v:?}")),
            };
            out.insert(name.to_owned(), v);
        }
        Ok(serde_json::Value::Object(out))
    }
    decode(
        message
            .strip_prefix("rover_power.")
            .ok_or_else(|| format!("{message} is not ours"))?,
        data,
    )
}

/// Builds one message, fields in the order written.
#[derive(Debug, Default)]
pub(crate) struct Writer {
    out: Vec<u8>,
}

impl Writer {
    pub(crate) fn new() -> Self {
        Self::default()
    }

    pub(crate) fn into_bytes(self) -> Vec<u8> {
        self.out
    }

    fn key(&mut self, field: u32, wire_type: u8) {
        put_varint(&mut self.out, u64::from(field) << 3 | u64::from(wire_type));
    }

    pub(crate) fn double(&mut self, field: u32, value: f64) {
        self.key(field, FIXED64);
        self.out.extend_from_slice(&value.to_le_bytes());
    }

    pub(crate) fn opt_double(&mut self, field: u32, value: Option<f64>) {
        if let Some(v) = value {
            self.double(field, v);
        }
    }

    pub(crate) fn float(&mut self, field: u32, value: f32) {
        self.key(field, FIXED32);
        self.out.extend_from_slice(&value.to_le_bytes());
    }

    pub(crate) fn varint(&mut self, field: u32, value: u64) {
        self.key(field, VARINT);
        put_varint(&mut self.out, value);
    }

    /// A `sint32`/`sint64` field (zigzag: small magnitudes of either sign are short).
    pub(crate) fn sint(&mut self, field: u32, value: i64) {
        self.varint(field, zigzag(value));
    }

    pub(crate) fn bool(&mut self, field: u32, value: bool) {
        self.varint(field, u64::from(value));
    }

    pub(crate) fn bytes(&mut self, field: u32, value: &[u8]) {
        self.key(field, LEN);
        put_varint(&mut self.out, value.len() as u64);
        self.out.extend_from_slice(value);
    }

    /// A packed `repeated double` field; nothing for no values.
    pub(crate) fn packed_doubles(
        &mut self,
        field: u32,
        values: impl ExactSizeIterator<Item = f64>,
    ) {
        self.packed_fixed(field, values.map(f64::to_le_bytes));
    }

    /// A packed `repeated float` field; nothing for no values.
    pub(crate) fn packed_floats(&mut self, field: u32, values: impl ExactSizeIterator<Item = f32>) {
        self.packed_fixed(field, values.map(f32::to_le_bytes));
    }

    /// A packed field of fixed-size values (their little-endian bytes); nothing for no values.
    fn packed_fixed<const N: usize>(
        &mut self,
        field: u32,
        values: impl ExactSizeIterator<Item = [u8; N]>,
    ) {
        if values.len() > 0 {
            self.key(field, LEN);
            put_varint(&mut self.out, (N * values.len()) as u64);
            for v in values {
                self.out.extend_from_slice(&v);
            }
        }
    }

    /// A packed `repeated` varint field (`uint32`, `uint64`; zigzag the values of a `sint32`
    /// with [`zigzag`]); nothing for no values.
    pub(crate) fn packed_varints(&mut self, field: u32, values: impl Iterator<Item = u64>) {
        let mut run = Vec::new();
        for v in values {
            put_varint(&mut run, v);
        }
        if !run.is_empty() {
            self.bytes(field, &run);
        }
    }

    /// A nested message, built by `build`.
    pub(crate) fn message(&mut self, field: u32, build: impl FnOnce(&mut Writer)) {
        let mut nested = Writer::new();
        build(&mut nested);
        self.bytes(field, &nested.out);
    }
}

/// One field's value as the wire carries it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Value<'a> {
    Varint(u64),
    Fixed64(u64),
    Len(&'a [u8]),
    Fixed32(u32),
}

impl Value<'_> {
    /// The value of a `double` field.
    pub(crate) fn double(self) -> Result<f64, String> {
        match self {
            Value::Fixed64(bits) => Ok(f64::from_bits(bits)),
            other => Err(format!("expected a double, found {other:?}")),
        }
    }
}

/// The fields of a message in wire order: `(number, value)`, or an error where the bytes stop
/// being a message (a group, a reserved wire type, a length past the end).
pub(crate) struct Fields<'a> {
    rest: &'a [u8],
}

impl<'a> Fields<'a> {
    pub(crate) fn of(message: &'a [u8]) -> Self {
        Fields { rest: message }
    }
}

impl<'a> Iterator for Fields<'a> {
    type Item = Result<(u32, Value<'a>), String>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.rest.is_empty() {
            return None;
        }
        let item = (|| {
            let (key, rest) = varint(self.rest).ok_or("a field key is cut short")?;
            let field = u32::try_from(key >> 3)
                .ok()
                .filter(|&f| f > 0)
                .ok_or_else(|| format!("field number {} is out of range", key >> 3))?;
            let (value, rest) = match (key & 7) as u8 {
                VARINT => {
                    let (v, rest) = varint(rest).ok_or("a varint is cut short")?;
                    (Value::Varint(v), rest)
                }
                FIXED64 => {
                    let (v, rest) = rest
                        .split_first_chunk::<8>()
                        .ok_or("a 64-bit value is cut short")?;
                    (Value::Fixed64(u64::from_le_bytes(*v)), rest)
                }
                FIXED32 => {
                    let (v, rest) = rest
                        .split_first_chunk::<4>()
                        .ok_or("a 32-bit value is cut short")?;
                    (Value::Fixed32(u32::from_le_bytes(*v)), rest)
                }
                LEN => {
                    let (len, rest) = varint(rest).ok_or("a length is cut short")?;
                    let len = usize::try_from(len)
                        .ok()
                        .filter(|&n| n <= rest.len())
                        .ok_or_else(|| {
                            format!("field {field} says {len} bytes, {} are left", rest.len())
                        })?;
                    let (v, rest) = rest.split_at(len);
                    (Value::Len(v), rest)
                }
                other => return Err(format!("field {field} has wire type {other}")),
            };
            self.rest = rest;
            Ok((field, value))
        })();
        if item.is_err() {
            // One error, then the end: the rest cannot be framed.
            self.rest = &[];
        }
        Some(item)
    }
}

/// The varint of a `sint` value (zigzag: small magnitudes of either sign are short).
pub(crate) fn zigzag(value: i64) -> u64 {
    ((value << 1) ^ (value >> 63)) as u64
}

/// The value of a zigzag-encoded (`sint`) varint.
pub(crate) fn unzigzag(v: u64) -> i64 {
    (v >> 1) as i64 ^ -((v & 1) as i64)
}

pub(crate) fn put_varint(out: &mut Vec<u8>, mut value: u64) {
    while value >= 0x80 {
        out.push((value as u8 & 0x7f) | 0x80);
        value >>= 7;
    }
    out.push(value as u8);
}

/// A base-128 varint and what follows it; `None` if cut short or longer than 64 bits.
pub(crate) fn varint(bytes: &[u8]) -> Option<(u64, &[u8])> {
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

    /// Every message type a field names is in the file, and numbers are unique per message.
    #[test]
    fn the_schema_is_closed_and_its_numbers_unique() {
        for m in MESSAGES {
            let mut numbers: Vec<u32> = m.fields.iter().map(|f| f.1).collect();
            numbers.sort_unstable();
            numbers.dedup();
            assert_eq!(numbers.len(), m.fields.len(), "{}", m.name);
            for (_, _, ty) in m.fields {
                if let Message(short) = ty {
                    assert!(MESSAGES.iter().any(|d| d.name == *short), "{short}");
                }
            }
        }
        for name in [SAMPLE, SAMPLE_BATCH, MODEL, STATUS, FRAME] {
            let short = name.strip_prefix("rover_power.").expect("package");
            assert!(MESSAGES.iter().any(|d| d.name == short), "{name}");
        }
    }

    #[test]
    fn fields_read_back_what_the_writer_wrote() {
        let mut w = Writer::new();
        w.double(1, -2.5);
        w.varint(3, 300);
        w.float(4, 1.5);
        w.sint(5, -3);
        w.message(2, |m| m.bool(1, true));
        w.bytes(16, b"xy");
        let bytes = w.into_bytes();
        let fields: Vec<_> = Fields::of(&bytes).collect::<Result<_, _>>().expect("reads");
        assert_eq!(
            fields,
            vec![
                (1, Value::Fixed64((-2.5f64).to_bits())),
                (3, Value::Varint(300)),
                (4, Value::Fixed32(1.5f32.to_bits())),
                (5, Value::Varint(5)),
                (2, Value::Len(&[0x08, 1])),
                (16, Value::Len(b"xy")),
            ]
        );
    }

    #[test]
    fn zigzag_round_trips_at_the_extremes() {
        for v in [0i64, -1, 1, -32768, 32767, i64::MIN, i64::MAX] {
            let mut w = Writer::new();
            w.sint(1, v);
            let bytes = w.into_bytes();
            let Some(Ok((1, Value::Varint(raw)))) = Fields::of(&bytes).next() else {
                panic!("{v}");
            };
            assert_eq!(unzigzag(raw), v);
        }
    }

    #[test]
    fn damaged_messages_are_one_error_then_the_end() {
        for bad in [
            &[0x09, 1, 2][..], // a double cut short
            &[0x12, 5, 1],     // a length past the end
            &[0x0b],           // a group (wire type 3)
            &[0x80],           // a key cut short
            &[0x00, 1],        // field 0
            &[
                0x0a, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff,
            ],
        ] {
            let items: Vec<_> = Fields::of(bad).collect();
            assert_eq!(items.len(), 1, "{bad:?}");
            assert!(items[0].is_err(), "{bad:?}");
        }
    }

    /// The descriptor set holds one file of our package with the message, read back with the
    /// same field reader (the decoders that matter read it in CI: Studio's in `foxglove/check`,
    /// `mcap-protobuf-support` in python/tests).
    #[test]
    fn the_descriptor_holds_the_message_and_what_it_holds() {
        let set = descriptor_set(SAMPLE);
        let mut files = Fields::of(&set);
        let Some(Ok((1, Value::Len(file)))) = files.next() else {
            panic!("no file");
        };
        assert!(files.next().is_none());
        let mut names = Vec::new();
        let mut syntax = None;
        for item in Fields::of(file) {
            match item.expect("file reads") {
                (4, Value::Len(message)) => {
                    let Some(Ok((1, Value::Len(name)))) = Fields::of(message).next() else {
                        panic!("a message without a name");
                    };
                    names.push(std::str::from_utf8(name).expect("utf-8").to_owned());
                }
                (12, Value::Len(s)) => syntax = Some(s),
                _ => {}
            }
        }
        assert_eq!(names, ["SampleSide", "BoardSample", "Sample"]);
        assert_eq!(syntax, Some(&b"proto2"[..]));
    }
}
