//! `replay LOG --serve` on a demo log, watched by a WebSocket client that speaks
//! `foxglove.websocket.v1` as the spec writes it (its JSON and byte layout spelt out here, not
//! borrowed from the server's code): serverInfo, advertise, subscribe, binary message data.

use crate::common;
use common::{demo_once, host_tool, temp_dir};

use host_tool::live::client::{Incoming, LiveClient};
use host_tool::log::mcap::read_mcap_run;
use serde_json::{json, Value};
use std::io::{BufRead, BufReader, Read};
use std::net::TcpStream;
use std::process::{Child, Stdio};
use std::time::Duration;
use tungstenite::client::IntoClientRequest;
use tungstenite::http::HeaderValue;
use tungstenite::Message;

/// Kills the server if the test fails half-way.
struct Server(Child);

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn text_op(ws: &mut tungstenite::WebSocket<TcpStream>) -> Value {
    match ws.read().expect("a message") {
        Message::Text(t) => serde_json::from_str(t.as_str()).expect("JSON op"),
        other => panic!("expected a text op, got {other:?}"),
    }
}

#[test]
fn a_foxglove_client_reads_a_demo_log_served_by_replay_in_order_without_gaps() {
    let dir = temp_dir("live-cli");
    let demo = demo_once(&dir);
    let log = demo.join("run-1.mcap");
    let expected = read_mcap_run(&log).expect("demo log").run.samples;
    assert!(expected.len() >= 1000, "{} samples", expected.len());

    let mut server = Server(
        host_tool()
            .arg("replay")
            .arg(&log)
            .args(["--serve", "127.0.0.1:0", "--speed", "20"])
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("replay --serve starts"),
    );
    let mut line = String::new();
    BufReader::new(server.0.stdout.take().expect("stdout"))
        .read_line(&mut line)
        .expect("the address");
    let url = line.trim().to_owned();
    assert!(url.starts_with("ws://127.0.0.1:"), "{line:?}");

    let stream = TcpStream::connect(url.trim_start_matches("ws://")).expect("connects");
    stream
        .set_read_timeout(Some(Duration::from_secs(20)))
        .expect("timeout");
    let mut request = url.as_str().into_client_request().expect("request");
    request.headers_mut().insert(
        "Sec-WebSocket-Protocol",
        HeaderValue::from_static("foxglove.websocket.v1"),
    );
    let (mut ws, response) = tungstenite::client(request, stream).expect("handshake");
    assert_eq!(
        response.headers().get("Sec-WebSocket-Protocol"),
        Some(&HeaderValue::from_static("foxglove.websocket.v1"))
    );

    let info = text_op(&mut ws);
    assert_eq!(info["op"], "serverInfo");
    assert!(info["name"].is_string() && info["capabilities"].is_array());
    let advertise = text_op(&mut ws);
    assert_eq!(advertise["op"], "advertise");
    let channels = advertise["channels"].as_array().expect("channels");
    let topics: Vec<&str> = channels
        .iter()
        .filter_map(|c| c["topic"].as_str())
        .collect();
    for topic in ["sample", "model", "status", "event"] {
        assert!(
            topics.contains(&format!("/rover_power/{topic}").as_str()),
            "{topics:?}"
        );
    }
    let sample = channels
        .iter()
        .find(|c| c["topic"] == "/rover_power/sample")
        .expect("sample channel");
    // Protobuf, its schema a FileDescriptorSet in base64 (the protocol's rule for binary
    // schemas) that names the message.
    assert_eq!(sample["encoding"], "protobuf");
    assert_eq!(sample["schemaName"], "rover_power.Sample");
    assert_eq!(sample["schemaEncoding"], "protobuf");
    let schema = data_encoding::BASE64
        .decode(sample["schema"].as_str().expect("schema").as_bytes())
        .expect("base64");
    assert!(schema.windows(6).any(|w| w == b"Sample"));

    ws.send(Message::text(
        json!({"op": "subscribe", "subscriptions": [{"id": 42, "channelId": sample["id"]}]})
            .to_string(),
    ))
    .expect("subscribe");

    // Every message until the server closes: binary frames `0x01 | u32 LE | u64 LE | message`.
    let mut received = Vec::new();
    let mut last_timestamp = 0u64;
    let mut goodbye = None;
    let close_code = loop {
        match ws.read() {
            Ok(Message::Binary(bytes)) => {
                assert!(bytes.len() > 13);
                assert_eq!(bytes[0], 0x01, "opcode");
                let id = u32::from_le_bytes(bytes[1..5].try_into().expect("4 bytes"));
                let timestamp = u64::from_le_bytes(bytes[5..13].try_into().expect("8 bytes"));
                assert_eq!(id, 42);
                assert!(timestamp >= last_timestamp, "time stamps go forward");
                last_timestamp = timestamp;
                received.push(bytes[13..].to_vec());
            }
            // The end of the stream is said before the close, once.
            Ok(Message::Text(t)) => {
                assert!(goodbye.is_none(), "a second op {t}");
                goodbye = Some(serde_json::from_str::<Value>(t.as_str()).expect("JSON op"));
            }
            Ok(Message::Close(frame)) => break frame.map(|f| u16::from(f.code)),
            Err(tungstenite::Error::ConnectionClosed) => break None,
            Ok(_) => {}
            Err(e) => panic!("after {} messages: {e}", received.len()),
        }
    };
    // A finished replay ends normally (1000), not with "no status" (1005), which a viewer takes
    // for a dropped connection and retries; the status says why it ended.
    assert_eq!(close_code, Some(1000));
    let goodbye = goodbye.expect("a status op before the close");
    assert_eq!(goodbye["op"], "status");
    assert_eq!(goodbye["level"], 0, "info");
    assert_eq!(
        goodbye["message"],
        "rover-power: the replay has ended (the whole log was sent)"
    );
    assert!(received.len() >= 100, "{} frames", received.len());
    eprintln!("{} samples served and decoded in order", received.len());
    // In order, none missing: the i-th message is the log's i-th sample.
    assert_eq!(received.len(), expected.len());
    // rover_power.Sample: t_s = 1; left = 2 and right = 3, each { bus_v = 1; current_a = 2 }.
    for (got, want) in received.iter().zip(&expected) {
        assert_eq!(protobuf_double(got, &[1]), Some(want.t_s));
        assert_eq!(protobuf_double(got, &[2, 2]), Some(want.current_a.left));
        assert_eq!(protobuf_double(got, &[3, 1]), Some(want.bus_v.right));
    }
    // Wall-clock stamps: the replay happened just now.
    let now_ns = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .expect("clock")
        .as_nanos() as u64;
    assert!(now_ns.abs_diff(last_timestamp) < 60_000_000_000);

    let status = server.0.wait().expect("replay ends");
    let mut stderr = String::new();
    server
        .0
        .stderr
        .take()
        .expect("stderr")
        .read_to_string(&mut stderr)
        .expect("stderr");
    assert!(status.success(), "{stderr}");
    assert!(stderr.contains("0 dropped"), "{stderr}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn record_serve_shows_the_recording_live_and_the_log_is_whole() {
    let dir = temp_dir("live-cli-record");
    let source = dir.join("source.csv");
    // 20 s at 200 Hz, replayed at 4x: ~5 s of recording.
    let samples: Vec<host_tool::log::run_csv::RunSample> = (0..4_000)
        .map(|i| host_tool::log::run_csv::RunSample {
            t_s: f64::from(i) * 0.005,
            bus_v: model_core::Sides::new(24.0, 24.1),
            current_a: model_core::Sides::new(2.0 + f64::from(i % 7) * 0.01, 2.5),
            cmd_mps: model_core::Sides::new(0.3, 0.3),
            yaw_rad: None,
            pitch_deg: None,
            x_m: None,
            y_m: None,
        })
        .collect();
    host_tool::log::run_csv::write_run_csv_atomically(
        &source,
        host_tool::log::Existing::Replace,
        &samples,
    )
    .expect("source");
    let mut replay = Server(
        host_tool()
            .arg("replay")
            .arg(&source)
            .args(["--to-pty", "--speed", "4"])
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("replay"),
    );
    let mut pty = String::new();
    BufReader::new(replay.0.stdout.take().expect("stdout"))
        .read_line(&mut pty)
        .expect("pty path");
    let out = dir.join("rec.mcap");
    let mut record = Server(
        host_tool()
            .args([
                "record",
                "--port",
                pty.trim(),
                "--serve",
                "127.0.0.1:0",
                "--out",
            ])
            .arg(&out)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("record"),
    );
    let mut stderr = BufReader::new(record.0.stderr.take().expect("stderr"));
    let mut line = String::new();
    let addr = loop {
        line.clear();
        assert!(
            stderr.read_line(&mut line).expect("stderr") > 0,
            "no address"
        );
        if let Some(rest) = line.strip_prefix("live view: ws://") {
            break rest.split_whitespace().next().expect("addr").to_owned();
        }
    };
    let mut client = LiveClient::connect(addr.parse().expect("addr"), Duration::from_secs(20))
        .expect("connects");
    client
        .subscribe(1, "/rover_power/model")
        .expect("subscribe");
    let mut energies = Vec::new();
    while energies.len() < 10 {
        match client.read().expect("a message") {
            Incoming::Data(d) => {
                // rover_power.Model: total_energy_j = 6.
                energies.push(protobuf_double(&d.payload, &[6]).expect("energy"));
            }
            Incoming::Op(_) => {}
            Incoming::Closed(_) => break,
        }
    }
    assert!(energies.len() >= 10, "{energies:?}");
    assert!(energies.windows(2).all(|w| w[1] >= w[0]), "{energies:?}");

    let status = record.0.wait().expect("record ends");
    let mut rest = String::new();
    stderr.read_to_string(&mut rest).expect("stderr");
    assert!(status.success(), "{rest}");
    assert!(rest.contains("viewer 127.0.0.1:"), "{rest}");
    let back = read_mcap_run(&out).expect("log");
    assert!(back.truncated.is_none());
    assert_eq!(back.run.samples.len(), samples.len());
    let _ = std::fs::remove_dir_all(&dir);
}

/// The `double` at a path of field numbers in a protobuf message (`[2, 1]`: field 1 of the
/// message in field 2), read from the wire format as the protobuf spec writes it: a key is a
/// varint `field << 3 | wire type`; 0 varint, 1 eight bytes, 2 a varint length and its bytes,
/// 5 four bytes.
fn protobuf_double(message: &[u8], path: &[u32]) -> Option<f64> {
    fn varint(bytes: &mut &[u8]) -> Option<u64> {
        let mut value = 0u64;
        for shift in (0..64).step_by(7) {
            let (&b, rest) = bytes.split_first()?;
            *bytes = rest;
            value |= u64::from(b & 0x7f) << shift;
            if b & 0x80 == 0 {
                return Some(value);
            }
        }
        None
    }
    let (&want, deeper) = path.split_first()?;
    let mut rest = message;
    while !rest.is_empty() {
        let key = varint(&mut rest)?;
        let (field, wire_type) = (key >> 3, key & 7);
        let value: &[u8] = match wire_type {
            0 => {
                varint(&mut rest)?;
                continue;
            }
            1 => rest.get(..8)?,
            2 => {
                let len = usize::try_from(varint(&mut rest)?).ok()?;
                rest.get(..len)?
            }
            5 => rest.get(..4)?,
            _ => return None,
        };
        rest = &rest[value.len()..];
        if field == u64::from(want) {
            return match deeper.is_empty() {
                true => Some(f64::from_le_bytes(value.try_into().ok()?)),
                false => protobuf_double(value, deeper),
            };
        }
    }
    None
}
