//! The rules Foxglove Studio's message readers apply to a channel (its `mcap-support` package,
//! `parseChannel` and `parseJsonSchema`, as in the Studio 1.48 bundle and the Lichtblick fork),
//! held against every channel and message of a file, so that a schema Studio would refuse
//! ("Unsupported type undefined for left", "Unsupported encoding …") fails a test here first.
//! `foxglove/check` runs the real Studio on the same files.
//!
//! - A `json` channel's `jsonschema` has `"type": "object"` at the top and every property one
//!   `"type"` string of `boolean`, `string`, `number`, `integer`, `object` (walked the same
//!   way) or `array` of one of those; no `$ref`, no type arrays, no `null`.
//! - Every message of such a channel is a JSON object whose values have their property's type;
//!   an unknown value is an absent field, never `null`.
//! - Every chunk has message indexes (Studio's indexed reader refuses one without).
//! - Other channels use an encoding Studio decodes from the file alone: `protobuf` (with a
//!   `protobuf` schema), `ros1`, `cdr`, `flatbuffer` with their schemas.

use serde_json::Value;
use std::collections::BTreeMap;

/// What Studio would refuse in `file` (an MCAP file's bytes): one line per channel or message
/// (the first 5 messages of a channel at most), empty when Studio reads every channel.
pub fn problems(file: &[u8]) -> Result<Vec<String>, ::mcap::McapError> {
    let mut problems = Vec::new();
    // Studio's indexed reader refuses a chunk without message indexes, and takes the file's
    // start from the earliest chunk (a chunk of channel records alone starts at 0: 1970).
    if let Some(summary) = ::mcap::Summary::read(file)? {
        for chunk in summary
            .chunk_indexes
            .iter()
            .filter(|c| c.message_index_length == 0)
        {
            problems.push(format!(
                "chunk at byte {}: Chunks without message indexes are not currently supported",
                chunk.chunk_start_offset
            ));
        }
    }
    let mut schemas: BTreeMap<u16, Option<Value>> = BTreeMap::new();
    let mut per_channel: BTreeMap<u16, usize> = BTreeMap::new();
    for message in ::mcap::MessageStream::new(file)? {
        let message = message?;
        let channel = &message.channel;
        let schema = schemas
            .entry(channel.id)
            .or_insert_with(|| match channel_problem(channel) {
                Err(problem) => {
                    problems.push(format!("{}: {problem}", channel.topic));
                    None
                }
                Ok(schema) => schema,
            });
        let Some(schema) = schema else { continue };
        let reported = per_channel.entry(channel.id).or_default();
        if *reported >= 5 {
            continue;
        }
        let value: Value = match serde_json::from_slice(&message.data) {
            Ok(v) => v,
            Err(e) => {
                problems.push(format!("{} message: not JSON: {e}", channel.topic));
                *reported += 1;
                continue;
            }
        };
        let mut found = Vec::new();
        value_problems(schema, &value, &channel.topic, &mut found);
        for p in found.into_iter().take(5 - *reported) {
            problems.push(format!(
                "{} message at {} ns: {p}",
                channel.topic, message.publish_time
            ));
            *reported += 1;
        }
    }
    Ok(problems)
}

/// Why Studio would not read `channel`, or the JSON schema its messages follow (`None`: not a
/// JSON channel, read from its own schema).
fn channel_problem(channel: &::mcap::Channel) -> Result<Option<Value>, String> {
    let schema = channel.schema.as_deref();
    let schema_encoding = schema.map(|s| s.encoding.as_str());
    let expected = match channel.message_encoding.as_str() {
        "json" => {
            let Some(schema) = schema.filter(|s| !s.data.is_empty()) else {
                return Ok(None);
            };
            if schema.encoding != "jsonschema" {
                return Err(format!("json with schema encoding {:?}", schema.encoding));
            }
            let value: Value = serde_json::from_slice(&schema.data)
                .map_err(|e| format!("schema {} is not JSON: {e}", schema.name))?;
            let mut found = Vec::new();
            schema_problems(&value, &schema.name, &mut found);
            return match found.is_empty() {
                true => Ok(Some(value)),
                false => Err(found.join("; ")),
            };
        }
        "protobuf" => &["protobuf"][..],
        "ros1" => &["ros1msg"][..],
        "cdr" => &["ros2msg", "ros2idl"][..],
        "flatbuffer" => &["flatbuffer"][..],
        other => return Err(format!("Unsupported encoding {other}")),
    };
    match schema_encoding {
        Some(e) if expected.contains(&e) => Ok(None),
        e => Err(format!(
            "message encoding {} with schema encoding {e:?} (Studio expects one of {expected:?})",
            channel.message_encoding
        )),
    }
}

/// `parseJsonSchema`'s rules on an object schema at `path`.
pub fn schema_problems(schema: &Value, path: &str, found: &mut Vec<String>) {
    if schema["type"] != "object" {
        found.push(format!(
            "{path}: expected \"type\": \"object\", got {}",
            schema["type"]
        ));
        return;
    }
    let Some(properties) = schema["properties"].as_object() else {
        found.push(format!("{path}: an object without properties"));
        return;
    };
    for (name, field) in properties {
        let at = format!("{path}.{name}");
        match field["type"].as_str() {
            Some("boolean" | "string" | "number" | "integer") => {}
            Some("object") => schema_problems(field, &at, found),
            Some("array") => match field["items"]["type"].as_str() {
                Some("boolean" | "string" | "number" | "integer") => {}
                Some("object") => schema_problems(&field["items"], &at, found),
                _ => found.push(format!(
                    "{at}: unsupported array item type {}",
                    field["items"]["type"]
                )),
            },
            _ => found.push(format!("Unsupported type {} for {at}", field["type"])),
        }
    }
}

/// Whether `value` holds what `schema` says, field by field (`null` never does).
fn value_problems(schema: &Value, value: &Value, path: &str, found: &mut Vec<String>) {
    let fits = match (schema["type"].as_str(), value) {
        (Some("boolean"), Value::Bool(_)) | (Some("string"), Value::String(_)) => true,
        (Some("number"), Value::Number(_)) => true,
        (Some("integer"), Value::Number(n)) => n.is_i64() || n.is_u64(),
        (Some("array"), Value::Array(items)) => {
            for (i, item) in items.iter().enumerate() {
                value_problems(&schema["items"], item, &format!("{path}[{i}]"), found);
            }
            true
        }
        (Some("object"), Value::Object(fields)) => {
            for name in schema["required"].as_array().into_iter().flatten() {
                if let Some(name) = name.as_str().filter(|n| !fields.contains_key(*n)) {
                    found.push(format!("{path}.{name}: required, absent"));
                }
            }
            for (name, field) in fields {
                match schema["properties"].get(name) {
                    Some(s) => value_problems(s, field, &format!("{path}.{name}"), found),
                    None => found.push(format!("{path}.{name}: not in the schema")),
                }
            }
            true
        }
        _ => false,
    };
    if !fits {
        found.push(format!("{path}: {value} is not of type {}", schema["type"]));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn refs_type_arrays_and_nulls_are_what_studio_refuses() {
        let mut found = Vec::new();
        let schema = json!({"type": "object", "properties": {
            "left": {"$ref": "#/$defs/side"},
            "power_w": {"type": ["number", "null"]},
            "ok": {"type": "object", "properties": {"x": {"type": "integer"}}}
        }});
        schema_problems(&schema, "T", &mut found);
        assert_eq!(found.len(), 2, "{found:?}");
        assert!(
            found[0].contains("T.left") && found[1].contains("T.power_w"),
            "{found:?}"
        );

        let schema = json!({"type": "object", "required": ["x"], "properties": {
            "x": {"type": "integer"}, "s": {"type": "string"}}});
        let mut found = Vec::new();
        value_problems(
            &schema,
            &json!({"x": 1.5, "s": null, "extra": 1}),
            "m",
            &mut found,
        );
        assert_eq!(found.len(), 3, "{found:?}");
        let mut found = Vec::new();
        value_problems(&schema, &json!({"s": "a"}), "m", &mut found);
        assert_eq!(found, ["m.x: required, absent"]);
    }
}
