//! The server against the protocol client ([`super::client`]) on the loopback, and the recorder
//! with a viewer that never reads.

use super::client::{Incoming, LiveClient, Received};
use super::hub;
use super::protocol::{status_level, ServerOp, SUBPROTOCOL};
use super::*;
use crate::log::mcap::{
    proto, read_mcap_run, SAMPLE_CHANNEL, TOPIC_EVENT, TOPIC_SAMPLE, TOPIC_STATUS,
};
use crate::log::run_csv::RunSample;
use crate::log::run_log::{LogEvent, RunLogSink};
use crate::record::{self, BoardPort, RecordOptions};
use crate::replay::{command_report, encode_frame, synthesise_frames, synthetic_hello};
use crate::serial::SerialError;
use model_core::wire::BoardFrame;
use model_core::Sides;
use std::io::{self, Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

const TIMEOUT: Duration = Duration::from_secs(10);

fn loopback() -> SocketAddr {
    SocketAddr::from(([127, 0, 0, 1], 0))
}

fn samples(n: u32, dt_s: f64) -> Vec<RunSample> {
    (0..n)
        .map(|i| RunSample {
            t_s: f64::from(i) * dt_s,
            bus_v: Sides::new(24.0, 24.1),
            current_a: Sides::new(2.0 + f64::from(i % 11) * 0.01, -0.5),
            cmd_mps: Sides::new(0.3, 0.3),
            yaw_rad: None,
            pitch_deg: None,
            x_m: None,
            y_m: None,
        })
        .collect()
}

fn data(client: &mut LiveClient) -> Received {
    loop {
        match client.read().expect("a frame") {
            Incoming::Data(d) => return d,
            Incoming::Op(_) => continue,
            Incoming::Closed(code) => panic!("closed ({code:?})"),
        }
    }
}

fn wait_for(what: &str, mut done: impl FnMut() -> bool) {
    let start = Instant::now();
    while !done() {
        assert!(start.elapsed() < TIMEOUT, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// A viewer subscribes panel by panel (Foxglove Studio does): one that subscribes to the
/// events only after the stream has started still gets its first events, in order and once,
/// then the later ones as they come.
#[test]
fn a_viewer_subscribing_to_the_events_last_gets_the_first_events() {
    let server = LiveServer::bind(loopback(), LiveOptions::default()).expect("bind");
    let mut client = LiveClient::connect(server.local_addr(), TIMEOUT).expect("connect");
    client.subscribe(1, TOPIC_SAMPLE).expect("subscribe");
    wait_for("the subscription", || {
        server.subscribed_channels() == [LiveChannel::Sample]
    });
    let mut sink = server.recording_sink();
    let started = LogEvent::Started {
        port: "/dev/ttyACM0".into(),
    };
    sink.event(0.0, &started).expect("event");
    sink.event(
        0.0,
        &LogEvent::WallClock {
            unix_ns: 1_700_000_000_000_000_000,
        },
    )
    .expect("event");
    for s in &samples(20, 0.005) {
        sink.sample(s).expect("sample");
    }
    for _ in 0..20 {
        assert_eq!(data(&mut client).subscription_id, 1);
    }
    client.subscribe(2, TOPIC_EVENT).expect("subscribe");
    let kinds = |client: &mut LiveClient, n: usize| -> Vec<String> {
        (0..n)
            .map(|_| {
                let d = data(client);
                assert_eq!(d.subscription_id, 2);
                let json: serde_json::Value = serde_json::from_slice(&d.payload).expect("JSON");
                json["event"]["kind"].as_str().expect("an event").to_owned()
            })
            .collect()
    };
    assert_eq!(kinds(&mut client, 2), ["started", "wall-clock"]);
    sink.event(
        0.2,
        &LogEvent::SamplesLost {
            after_seq: 40,
            missing: 2,
        },
    )
    .expect("event");
    assert_eq!(kinds(&mut client, 1), ["samples-lost"]);
}

#[test]
fn a_viewer_gets_the_mcap_channels_and_its_subscriptions_in_order_with_wall_clock_stamps() {
    let server = LiveServer::bind(loopback(), LiveOptions::default()).expect("bind");
    let mut client = LiveClient::connect(server.local_addr(), TIMEOUT).expect("connect");
    assert!(
        matches!(&client.server_info, ServerOp::ServerInfo { capabilities, .. } if capabilities.is_empty())
    );
    let sample = client.channel(TOPIC_SAMPLE).expect("advertised").clone();
    assert_eq!(sample, LiveChannel::Sample.advertised());
    assert_eq!(sample.schema_name, SAMPLE_CHANNEL.schema_name);
    assert_eq!(sample.encoding, "protobuf");
    assert_eq!(client.channels.len(), LiveChannel::COUNT);
    client.subscribe(7, TOPIC_SAMPLE).expect("subscribe");
    wait_for("the subscription", || {
        server.subscribed_channels() == [LiveChannel::Sample]
    });

    let mut sink = server.recording_sink();
    let unix_zero = 1_700_000_000_000_000_000u64;
    sink.event(0.0, &LogEvent::WallClock { unix_ns: unix_zero })
        .expect("event");
    let sent = samples(300, 0.005);
    for s in &sent {
        sink.sample(s).expect("sample");
    }
    for s in &sent {
        let d = data(&mut client);
        assert_eq!(d.subscription_id, 7);
        assert_eq!(d.timestamp_ns, unix_zero + (s.t_s * 1e9).round() as u64);
        let json = proto::to_json(proto::SAMPLE, &d.payload).expect("a sample");
        assert_eq!(json["t_s"].as_f64(), Some(s.t_s));
        assert_eq!(
            json["left"]["power_w"].as_f64(),
            Some(s.bus_v.left * s.current_a.left)
        );
    }

    // Unsubscribed: the samples stop; the status channel, subscribed after, comes through.
    client.unsubscribe(7).expect("unsubscribe");
    client.subscribe(9, TOPIC_STATUS).expect("subscribe");
    wait_for("the new subscription", || {
        server.subscribed_channels() == [LiveChannel::Status]
    });
    for s in samples(50, 0.005) {
        sink.sample(&RunSample {
            t_s: s.t_s + 10.0,
            ..s
        })
        .expect("sample");
    }
    let status = command_report(
        None,
        &synthetic_hello(5_000),
        11_000_000,
        2_200,
        Sides::new(1.0, 1.0),
    );
    sink.frame(11.0, &BoardFrame::Status(status))
        .expect("status");
    let d = data(&mut client);
    assert_eq!(d.subscription_id, 9);
    let json = proto::to_json(proto::STATUS, &d.payload).expect("a status");
    assert_eq!(json["t_s"].as_f64(), Some(11.0));
    assert_eq!(json["running"], true);

    let summary = server.finish(Duration::from_secs(1), "done");
    assert_eq!(summary.viewers.len(), 1);
    assert_eq!(summary.viewers[0].sent, 301);
    assert_eq!(summary.dropped(), 0);
}

#[test]
fn ops_the_server_does_not_offer_are_answered_with_a_warning() {
    let server = LiveServer::bind(loopback(), LiveOptions::default()).expect("bind");
    let mut client = LiveClient::connect(server.local_addr(), TIMEOUT).expect("connect");
    client
        .send_text(r#"{"op":"clientAdvertise","channels":[]}"#.into())
        .expect("send");
    client
        .send_text(r#"{"op":"subscribe","subscriptions":[{"id":1,"channelId":99}]}"#.into())
        .expect("send");
    for expected in ["not supported", "no channel 99"] {
        match client.read().expect("an op") {
            Incoming::Op(ServerOp::Status { level, message }) => {
                assert_eq!(level, status_level::WARNING);
                assert!(message.contains(expected), "{message}");
            }
            other => panic!("expected a status, got {other:?}"),
        }
    }
}

#[test]
fn a_client_without_the_foxglove_subprotocol_is_refused_and_reported() {
    let server = LiveServer::bind(loopback(), LiveOptions::default()).expect("bind");
    let stream = TcpStream::connect(server.local_addr()).expect("connect");
    let refused = tungstenite::client(format!("ws://{}/", server.local_addr()), stream);
    assert!(refused.is_err());
    wait_for("the report", || !server.refusals().is_empty());
    let refusals = server.refusals();
    assert!(
        refusals[0].0.contains(SUBPROTOCOL) && refusals[0].1 == 1,
        "{refusals:?}"
    );
    assert!(server.reports().is_empty());
}

/// Publishes `n` events on the latched event channel.
fn events(server: &LiveServer, n: u32) {
    let mut sink = server.recording_sink();
    for i in 0..n {
        let lost = LogEvent::SamplesLost {
            after_seq: i,
            missing: 1,
        };
        sink.event(f64::from(i) * 1e-3, &lost).expect("event");
    }
}

/// A viewer that subscribes and unsubscribes the latched events as fast as it can and never
/// reads: it is owed one event history at most, whatever it asks, and is let go for the rate
/// of its ops.
#[test]
fn a_subscribe_flood_that_never_reads_holds_one_history_and_is_let_go() {
    let server = LiveServer::bind(loopback(), LiveOptions::default()).expect("bind");
    events(&server, 2 * hub::LATCHED_MAX as u32);
    let mut flood = LiveClient::connect(server.local_addr(), TIMEOUT).expect("connect");
    let start = Instant::now();
    let mut ops = 0u64;
    let mut peak = 0;
    while start.elapsed() < TIMEOUT {
        let sent = flood
            .subscribe(1, TOPIC_EVENT)
            .and_then(|()| flood.unsubscribe(1));
        peak = server.backlog_peaks().into_iter().fold(peak, usize::max);
        if sent.is_err() {
            break;
        }
        ops += 2;
    }
    wait_for("the viewer to be let go", || server.viewers() == 0);
    let report = &server.reports()[0];
    assert!(
        report
            .ended
            .as_deref()
            .is_some_and(|e| e.contains("ops faster")),
        "{report:?} after {ops} ops in {:?}",
        start.elapsed()
    );
    assert!(
        (1..=hub::LATCHED_MAX).contains(&peak),
        "{peak} latched messages held for one viewer after {ops} ops"
    );
}

/// Connections that never finish their handshake, and viewers that never subscribe, do not
/// keep a viewer out: the silent ones hold no viewer's place, and an idle viewer gives its
/// place to a new one.
#[test]
fn idle_connections_do_not_lock_a_new_viewer_out() {
    let server = LiveServer::bind(loopback(), LiveOptions::default()).expect("bind");
    let max = LiveOptions::default().max_viewers;
    let silent: Vec<TcpStream> = (0..max)
        .map(|_| TcpStream::connect(server.local_addr()).expect("connect"))
        .collect();
    let idle: Vec<LiveClient> = (0..max)
        .map(|_| LiveClient::connect(server.local_addr(), TIMEOUT).expect("an idle viewer"))
        .collect();
    wait_for("the idle viewers", || server.viewers() == max);
    let mut viewer = LiveClient::connect(server.local_addr(), TIMEOUT).expect("a place");
    viewer.subscribe(1, TOPIC_EVENT).expect("subscribe");
    events(&server, 1);
    assert_eq!(data(&mut viewer).subscription_id, 1);
    wait_for("the idle one's report", || {
        server.reports().iter().any(|r| {
            r.ended
                .as_deref()
                .is_some_and(|e| e.contains("subscribed to nothing"))
        })
    });
    drop((silent, idle));
}

/// With every place taken by a subscribed viewer, a new one is told why (an error status and
/// "try again later", 1013); past the connections the server keeps open, a new connection gets
/// an HTTP 503 with the reason, not a reset. Each refusal is counted once.
#[test]
fn a_full_server_answers_why_it_refuses() {
    let one = LiveOptions {
        max_viewers: 1,
        ..LiveOptions::default()
    };
    let server = LiveServer::bind(loopback(), one).expect("bind");
    let mut first = LiveClient::connect(server.local_addr(), TIMEOUT).expect("connect");
    first.subscribe(1, TOPIC_SAMPLE).expect("subscribe");
    wait_for("the subscription", || {
        !server.subscribed_channels().is_empty()
    });
    let mut second = LiveClient::connect(server.local_addr(), TIMEOUT).expect("handshake");
    match second.read().expect("a status") {
        Incoming::Op(ServerOp::Status { level, message }) => {
            assert_eq!(level, status_level::ERROR);
            assert!(message.contains("1 viewers already"), "{message}");
        }
        other => panic!("expected a status, got {other:?}"),
    }
    assert_eq!(
        second.read().expect("a close"),
        Incoming::Closed(Some(1013))
    );

    // More silent connections than the server keeps open for handshakes (33 here): the
    // last ones are answered at once.
    let silent: Vec<TcpStream> = (0..40)
        .map(|_| TcpStream::connect(server.local_addr()).expect("connect"))
        .collect();
    let mut answer = String::new();
    for mut stream in silent.iter().rev() {
        stream
            .set_read_timeout(Some(Duration::from_millis(200)))
            .expect("timeout");
        if stream.read_to_string(&mut answer).is_ok() && !answer.is_empty() {
            break;
        }
    }
    assert!(answer.starts_with("HTTP/1.1 503"), "{answer}");
    assert!(answer.contains("busy"), "{answer}");
    let refusals = server.refusals();
    let busy = refusals
        .iter()
        .find(|r| r.0.contains("busy"))
        .expect("counted");
    // 33 open at once: the subscribed viewer's and 32 handshakes (the refused viewer's thread
    // may not have ended yet).
    assert!((7..=8).contains(&busy.1), "{refusals:?}");
    drop(silent);
}

/// A client that sends its request a byte at a time (slower than tungstenite's own check of
/// tiny packets catches) is let go at the handshake's deadline.
#[test]
fn a_handshake_dribbled_byte_by_byte_is_let_go() {
    let options = LiveOptions {
        handshake_timeout: Duration::from_secs(1),
        ..LiveOptions::default()
    };
    let server = LiveServer::bind(loopback(), options).expect("bind");
    let mut stream = TcpStream::connect(server.local_addr()).expect("connect");
    let start = Instant::now();
    let request = b"GET / HTTP/1.1\r\n"
        .iter()
        .chain(b"X-Slow: 1\r\n".iter().cycle());
    for byte in request {
        if stream.write_all(&[*byte]).is_err() || !server.refusals().is_empty() {
            break;
        }
        assert!(start.elapsed() < TIMEOUT, "still in its handshake");
        std::thread::sleep(Duration::from_millis(120));
    }
    wait_for("the refusal", || !server.refusals().is_empty());
    assert!(
        server.refusals()[0]
            .0
            .contains("no complete WebSocket request"),
        "{:?}",
        server.refusals()
    );
}

/// A board port reading a fixed byte stream, then end of file (the device is gone).
struct Stream(io::Cursor<Vec<u8>>);

impl Read for Stream {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        self.0.read(buf)
    }
}

impl Write for Stream {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        Ok(buf.len())
    }
    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

#[test]
fn a_viewer_that_never_reads_costs_the_file_nothing_and_its_drops_are_counted() {
    // 120 000 samples at 2 kHz (60 s of run time, ~24 MB of JSON per viewer), recorded as fast
    // as the recorder can read them: far more than the sockets and a 256-message queue hold.
    let source = samples(120_000, 0.0005);
    let mut bytes = Vec::new();
    for (_, frame) in synthesise_frames(&source, None) {
        bytes.extend(encode_frame(&frame).expect("encodes"));
    }
    let options = LiveOptions {
        queue_len: 256,
        ..LiveOptions::default()
    };
    let server = LiveServer::bind(loopback(), options).expect("bind");
    let mut stalled = LiveClient::connect(server.local_addr(), TIMEOUT).expect("connect");
    for c in LiveChannel::ALL {
        stalled
            .subscribe(c.id(), c.log_channel().topic)
            .expect("subscribe");
    }
    // A second viewer vanishes a moment into the run (no close handshake).
    let mut vanishing = LiveClient::connect(server.local_addr(), TIMEOUT).expect("connect");
    vanishing.subscribe(1, TOPIC_SAMPLE).expect("subscribe");
    wait_for("both subscriptions", || {
        server.subscribed_channels().len() == LiveChannel::COUNT
            && server.reports().iter().all(|r| r.ended.is_none())
            && server.reports().len() == 2
    });
    let vanisher = std::thread::spawn(move || {
        for _ in 0..100 {
            let _ = vanishing.read();
        }
        drop(vanishing);
    });

    let dir = std::env::temp_dir().join(format!("live-slow-viewer-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let path = dir.join("run.mcap");
    let mut file = record::create_sink(&path, true).expect("sink");
    let mut tee = LiveTee::new(file.as_mut(), Some(server.recording_sink()));
    let port: Box<dyn BoardPort> = Box::new(Stream(io::Cursor::new(bytes)));
    let mut open = |p: &str| -> Result<Box<dyn BoardPort>, SerialError> {
        Err(SerialError::Open {
            path: p.into(),
            source: serialport::Error::new(serialport::ErrorKind::NoDevice, "gone"),
        })
    };
    let record_options = RecordOptions {
        reconnect_timeout: Duration::from_millis(50),
        retry_every: Duration::from_millis(10),
        ..RecordOptions::new("/dev/test")
    };
    let summary = record::record_on(
        &record_options,
        port,
        &mut open,
        &mut tee,
        &AtomicBool::new(false),
        &mut |_| {},
    )
    .expect("recorded");
    drop(tee);
    drop(file);
    vanisher.join().expect("vanisher");

    assert_eq!(summary.samples, 120_000);
    let back = read_mcap_run(&path).expect("reads");
    assert!(back.truncated.is_none() && back.losses.is_empty());
    assert_eq!(back.run.samples.len(), source.len());
    for (a, b) in back.run.samples.iter().zip(&source) {
        // Run time comes from the board's µs stamps.
        assert!((a.t_s - b.t_s).abs() < 1e-9, "{} vs {}", a.t_s, b.t_s);
        assert_eq!(a.current_a, b.current_a);
    }

    let live = server.finish(Duration::ZERO, "done");
    eprintln!("{live}");
    let stalled_report = live
        .viewers
        .iter()
        .find(|v| v.ended.as_deref() == Some("server stopped"))
        .expect("the stalled viewer's report");
    assert!(stalled_report.dropped > 0, "{live}");
    // Everything offered to it was sent into its socket, dropped, or still queued (≤ 256).
    let accounted = stalled_report.sent + stalled_report.dropped;
    assert!(
        accounted <= live.published && accounted + 256 >= live.published,
        "{live}"
    );
    assert!(
        live.viewers
            .iter()
            .any(|v| v.ended.as_deref().is_some_and(|e| e != "server stopped")),
        "the vanished viewer left: {live}"
    );
    drop(stalled);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_viewer_whose_socket_takes_nothing_past_the_stall_timeout_is_disconnected() {
    let options = LiveOptions {
        queue_len: 64,
        stall_timeout: Duration::from_millis(300),
        ..LiveOptions::default()
    };
    let server = LiveServer::bind(loopback(), options).expect("bind");
    let mut client = LiveClient::connect(server.local_addr(), TIMEOUT).expect("connect");
    client.subscribe(1, TOPIC_SAMPLE).expect("subscribe");
    wait_for("the subscription", || {
        !server.subscribed_channels().is_empty()
    });
    let mut sink = server.recording_sink();
    // Far more than the sockets hold, until the viewer is let go (or 10 s).
    let start = Instant::now();
    let mut t_s = 0.0;
    while server.viewers() > 0 {
        assert!(
            start.elapsed() < TIMEOUT,
            "never disconnected: {:?}",
            server.reports()
        );
        for s in samples(1_000, 0.0005) {
            sink.sample(&RunSample {
                t_s: t_s + s.t_s,
                ..s
            })
            .expect("sample");
        }
        t_s += 0.5;
        std::thread::sleep(Duration::from_millis(5));
    }
    let report = &server.reports()[0];
    assert!(
        report
            .ended
            .as_deref()
            .is_some_and(|e| e.contains("took nothing")),
        "{report:?}"
    );
    assert!(report.dropped > 0, "{report:?}");
    drop(client);
}
