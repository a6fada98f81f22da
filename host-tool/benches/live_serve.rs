//! The live view's cost: a 2 kHz recording served to three Foxglove viewers subscribed to
//! every channel, at real time: `cargo bench -p host-tool --bench live_serve` (20 s of run;
//! `LIVE_BENCH_S=N` to change it; under `cargo test --benches` 2 s).
//!
//! Prints, per thread group, the CPU time over the run as % of one core (from
//! `/proc/self/task/*/schedstat`, Linux): the publisher (the recorder's side: JSON of each
//! message, offered to each viewer's queue), the server's viewer threads (framing, writing the
//! sockets), its accept thread; the three in-process viewers (our protocol client, decoding
//! every frame) are shown apart, as they would run on the laptop. Then messages delivered and
//! dropped per viewer.

use host_tool::live::client::{Incoming, LiveClient};
use host_tool::live::{serve_run, LiveChannel, LiveOptions, LiveServer};
use host_tool::log::run_csv::RunSample;
use host_tool::log::run_log::RunLog;
use host_tool::replay::{command_report, synthesise_frames, synthetic_hello};
use model_core::wire::BoardFrame;
use model_core::{Rover, Sides};
use std::collections::BTreeMap;
use std::net::SocketAddr;
use std::sync::atomic::AtomicBool;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

const RATE_HZ: u32 = 2_000;
const VIEWERS: usize = 3;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let test_mode = args.iter().any(|a| a == "--test") || !args.iter().any(|a| a == "--bench");
    let seconds: u32 = match std::env::var("LIVE_BENCH_S") {
        Ok(s) => s.parse().unwrap_or(20),
        Err(_) if test_mode => 2,
        Err(_) => 20,
    };
    let run = two_khz_run(seconds);
    println!(
        "live view at {RATE_HZ} Hz, {VIEWERS} viewers on every channel, {seconds} s at real time \
         ({} samples, {} frames)",
        run.samples.len(),
        run.frames.len()
    );
    let server = match LiveServer::bind(
        SocketAddr::from(([127, 0, 0, 1], 0)),
        LiveOptions::default(),
    ) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("live_serve: {e}");
            std::process::exit(1);
        }
    };
    // The same run with nobody subscribed: the pacing loop's own cost (nothing is
    // serialised), subtracted from the publisher's figure below.
    let main = std::fs::read_to_string("/proc/self/comm").unwrap_or_default();
    let main = main.trim().to_owned();
    let idle_before = cpu_by_thread_name();
    let idle_wall = Instant::now();
    serve_run(
        &server,
        &run,
        &Rover::HUSKY_A200,
        1.0,
        &AtomicBool::new(false),
    );
    let idle_pct = cpu_pct(
        &idle_before,
        &cpu_by_thread_name(),
        &main,
        idle_wall.elapsed(),
    );
    println!("  pacing loop alone (no viewer) {idle_pct:6.2} % of one core");

    let viewers: Vec<JoinHandle<u64>> = (0..VIEWERS)
        .map(|_| spawn_viewer(server.local_addr()))
        .collect();
    let stop = AtomicBool::new(false);
    if !server.wait_for_subscriber(Some(Duration::from_secs(10)), &stop) {
        eprintln!("live_serve: no viewer subscribed");
        std::process::exit(1);
    }
    // Every viewer subscribed to every channel before the run starts.
    let start = Instant::now();
    while server.subscribed_channels().len() < LiveChannel::COUNT || server.viewers() < VIEWERS {
        if start.elapsed() > Duration::from_secs(10) {
            eprintln!("live_serve: viewers did not subscribe");
            std::process::exit(1);
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    std::thread::sleep(Duration::from_millis(200));

    let before = cpu_by_thread_name();
    let wall = Instant::now();
    let stats = serve_run(&server, &run, &Rover::HUSKY_A200, 1.0, &stop);
    // The viewers' last messages out, then the figures (before the threads end with their
    // counts).
    std::thread::sleep(Duration::from_millis(200));
    let elapsed = wall.elapsed();
    let after = cpu_by_thread_name();
    let summary = server.finish(Duration::from_secs(5), "bench done");
    let delivered: Vec<u64> = viewers
        .into_iter()
        .map(|v| v.join().unwrap_or_default())
        .collect();

    println!(
        "  served {} records over {:.2} s of run in {:.2} s wall",
        stats.records,
        stats.run_s,
        elapsed.as_secs_f64()
    );
    let groups = [
        ("publisher incl. pacing loop", main.as_str()),
        ("server viewer threads", "live-viewer"),
        ("server accept thread", "live-accept"),
        ("the 3 viewers (clients)", "bench-viewer"),
    ];
    let mut server_total = -idle_pct;
    for (label, name) in groups {
        let pct = cpu_pct(&before, &after, name, elapsed);
        if name != "bench-viewer" {
            server_total += pct;
        }
        println!("  {label:<28} {pct:6.2} % of one core");
    }
    println!(
        "  {:<28} {server_total:6.2} % of one core",
        "live view's cost (server + publishing, less the pacing loop)"
    );
    for (v, got) in summary.viewers.iter().zip(&delivered) {
        println!(
            "  viewer {}: {} sent, {} decoded, {} dropped",
            v.peer, v.sent, got, v.dropped
        );
    }
}

/// A 2 kHz run: samples, model frames every 100 ms (model-core's running measurements, as
/// the board computes them) and a status frame every second.
fn two_khz_run(seconds: u32) -> RunLog {
    let n = seconds * RATE_HZ;
    let samples: Vec<RunSample> = (0..n)
        .map(|i| {
            let t_s = f64::from(i) / f64::from(RATE_HZ);
            let swing = (t_s * 0.7).sin();
            RunSample {
                t_s,
                bus_v: Sides::new(24.0 - 0.2 * swing, 24.0 + 0.1 * swing),
                current_a: Sides::new(3.0 + 2.0 * swing, 2.5 - 1.5 * swing),
                cmd_mps: Sides::new(0.3, 0.3 + 0.2 * swing.signum()),
                yaw_rad: None,
                pitch_deg: None,
                x_m: None,
                y_m: None,
            }
        })
        .collect();
    let mut frames = synthesise_frames(&samples, Some(&Rover::HUSKY_A200));
    let hello = synthetic_hello(500);
    frames.extend((0..seconds).map(|s| {
        let status = command_report(
            None,
            &hello,
            u64::from(s) * 1_000_000,
            s * RATE_HZ,
            Sides::new(1.0, 1.0),
        );
        (f64::from(s), BoardFrame::Status(status))
    }));
    frames.sort_by(|a, b| a.0.total_cmp(&b.0));
    RunLog {
        samples,
        frames,
        ..RunLog::default()
    }
}

/// A viewer on its own thread, subscribed to every channel, decoding until the server closes;
/// returns the message frames it got.
fn spawn_viewer(addr: SocketAddr) -> JoinHandle<u64> {
    std::thread::Builder::new()
        .name("bench-viewer".into())
        .spawn(move || {
            let Ok(mut client) = LiveClient::connect(addr, Duration::from_secs(10)) else {
                return 0;
            };
            for c in LiveChannel::ALL {
                if client.subscribe(c.id(), c.log_channel().topic).is_err() {
                    return 0;
                }
            }
            let mut got = 0;
            while let Ok(incoming) = client.read() {
                match incoming {
                    Incoming::Data(d) => {
                        if serde_json::from_slice::<serde_json::Value>(&d.payload).is_ok() {
                            got += 1;
                        }
                    }
                    Incoming::Op(_) => {}
                    Incoming::Closed(_) => break,
                }
            }
            got
        })
        .unwrap_or_else(|e| {
            eprintln!("live_serve: {e}");
            std::process::exit(1)
        })
}

/// CPU of the threads named `name` between two snapshots, as % of one core over `wall`.
fn cpu_pct(
    before: &BTreeMap<String, u64>,
    after: &BTreeMap<String, u64>,
    name: &str,
    wall: Duration,
) -> f64 {
    let ns = after
        .get(name)
        .copied()
        .unwrap_or(0)
        .saturating_sub(before.get(name).copied().unwrap_or(0));
    100.0 * ns as f64 / 1e9 / wall.as_secs_f64()
}

/// CPU time [ns] of this process's threads, summed by thread name (`/proc/self/task/*/comm`
/// and `schedstat`'s first field, time on a CPU).
fn cpu_by_thread_name() -> BTreeMap<String, u64> {
    let mut by_name = BTreeMap::new();
    let Ok(tasks) = std::fs::read_dir("/proc/self/task") else {
        return by_name;
    };
    for task in tasks.flatten() {
        let path = task.path();
        let name = std::fs::read_to_string(path.join("comm")).unwrap_or_default();
        let ns = std::fs::read_to_string(path.join("schedstat"))
            .ok()
            .and_then(|s| s.split_whitespace().next()?.parse::<u64>().ok())
            .unwrap_or(0);
        *by_name.entry(name.trim().to_owned()).or_insert(0) += ns;
    }
    by_name
}
