//! `host-tool ports`: the serial ports, with the rover-power boards marked.

use super::output::{self, JsonOut};
use anyhow::Result;
use host_tool::serial::list_ports;

/// `ports [--json FILE|-]`.
#[derive(clap::Args, Debug)]
pub struct PortsArgs {
    #[command(flatten)]
    json: JsonOut,
    /// Overwrite an existing --json file.
    #[arg(long)]
    force: bool,
}

impl PortsArgs {
    /// Lists the ports.
    pub fn run(self) -> Result<()> {
        self.json.check(self.force)?;
        let ports = list_ports()?;
        let list: Vec<serde_json::Value> = ports
            .iter()
            .map(|p| {
                serde_json::json!({
                    "name": p.name,
                    "vid": p.usb.as_ref().map(|u| u.vid),
                    "pid": p.usb.as_ref().map(|u| u.pid),
                    "product": p.product,
                    "manufacturer": p.manufacturer,
                    "serial_number": p.serial_number,
                    "rover_power": p.is_rover_power(),
                })
            })
            .collect();
        if self.json.emit(&list, "port list", self.force)? || self.json.json.is_some() {
            return Ok(());
        }
        if ports.is_empty() {
            return output::print("no serial ports found\n");
        }
        let rows: Vec<[String; 6]> = ports
            .iter()
            .map(|p| {
                let opt = |s: &Option<String>| s.clone().unwrap_or_else(|| "-".into());
                [
                    p.name.clone(),
                    p.usb
                        .as_ref()
                        .map_or("-".into(), |u| format!("{:04x}:{:04x}", u.vid, u.pid)),
                    opt(&p.product),
                    opt(&p.manufacturer),
                    opt(&p.serial_number),
                    if p.is_rover_power() { "yes" } else { "-" }.into(),
                ]
            })
            .collect();
        let header = [
            "PORT",
            "VID:PID",
            "PRODUCT",
            "MANUFACTURER",
            "SERIAL",
            "ROVER-POWER",
        ];
        let mut widths = header.map(str::len);
        for row in &rows {
            for (w, cell) in widths.iter_mut().zip(row) {
                *w = (*w).max(cell.chars().count());
            }
        }
        let mut text = String::new();
        for row in std::iter::once(header.map(String::from)).chain(rows) {
            let cells: Vec<String> = row
                .iter()
                .zip(widths)
                .map(|(c, w)| format!("{c:<w$}"))
                .collect();
            text += cells.join("  ").trim_end();
            text.push('\n');
        }
        output::print(text)
    }
}
