//! Every log the tool writes is one Foxglove Studio reads: the demo's recordings (made by the
//! recorder through a pty), and `convert`'s MCAP from a run CSV and from an MCAP log, held to
//! Studio's reader rules ([`host_tool::log::mcap::studio`]) channel by channel and message by
//! message. `foxglove/check/run.sh` opens the demo's log in the real Studio.

use crate::common;
use common::{demo_once, host_tool, temp_dir};

use host_tool::log::mcap::studio;
use std::path::Path;

fn problems(path: &Path) -> Vec<String> {
    let bytes = std::fs::read(path).expect("log");
    studio::problems(&bytes).expect("an MCAP file")
}

#[test]
fn the_demo_record_and_convert_write_logs_studio_reads() {
    let dir = temp_dir("studio-rules");
    let demo = demo_once(&dir);
    let recorded = demo.join("run-1.mcap");
    assert_eq!(problems(&recorded), Vec::<String>::new(), "demo (recorder)");

    for (from, to) in [
        ("run-1.csv", "from-csv.mcap"),
        ("run-1.mcap", "from-mcap.mcap"),
    ] {
        let out = dir.join(to);
        let converted = host_tool()
            .arg("convert")
            .arg(demo.join(from))
            .arg(&out)
            .output()
            .expect("convert runs");
        assert!(
            converted.status.success(),
            "{}",
            String::from_utf8_lossy(&converted.stderr)
        );
        assert_eq!(problems(&out), Vec::<String>::new(), "convert {from}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
