//! The board's wiring diagram, drawn from this source: `docs/wiring.svg` is its output (a test
//! fails when the committed file is stale; `UPDATE_WIRING=1 cargo test -p host-tool wiring`
//! rewrites it). The designators are the README's bill of materials ([`PARTS`]).
//!
//! Drawn: the battery's + through each 5 mΩ shunt to its motor driver, the drivers' return to
//! the battery's −; each INA226's VBUS on the battery side and VIN+/VIN− as Kelvin traces from
//! the shunt's pads; the address straps (left 0x40: A0, A1 to GND; right 0x45: A0, A1 to VS);
//! the I²C bus to the Black Pill's PB8 (SCL) / PB9 (SDA) with its pull-ups; 3V3, decoupling,
//! the one link from logic ground to the battery's −, and USB to the host.

use std::fmt::Write as _;

/// A part of the bill of materials, by its designator in the diagram.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Part {
    pub designator: &'static str,
    pub part_number: &'static str,
}

/// Every designator the diagram draws, with its part number (the README's BOM lists each).
pub const PARTS: [Part; 9] = [
    Part {
        designator: "A1",
        part_number: "WeAct BlackPill STM32F411CEU6",
    },
    Part {
        designator: "U1",
        part_number: "INA226AIDGSR",
    },
    Part {
        designator: "U2",
        part_number: "INA226AIDGSR",
    },
    Part {
        designator: "R1",
        part_number: "CSS2H-2512K-5L00F",
    },
    Part {
        designator: "R2",
        part_number: "CSS2H-2512K-5L00F",
    },
    Part {
        designator: "R3",
        part_number: "RC0603FR-072K2L",
    },
    Part {
        designator: "R4",
        part_number: "RC0603FR-072K2L",
    },
    Part {
        designator: "C1",
        part_number: "CC0603KRX7R9BB104",
    },
    Part {
        designator: "C2",
        part_number: "CC0603KRX7R9BB104",
    },
];

const WIDTH: u32 = 1120;
const HEIGHT: u32 = 760;

/// One drawn element.
#[derive(Debug, Clone, PartialEq)]
enum Shape {
    Line(&'static str, Vec<(i32, i32)>),
    Rect(&'static str, i32, i32, i32, i32),
    Text(&'static str, i32, i32, String),
    Dot(i32, i32),
}

/// The diagram, element by element (written as SVG; a test can also draw it as PNG to look at).
#[derive(Default)]
struct Svg(Vec<Shape>);

impl Svg {
    fn line(&mut self, class: &'static str, points: &[(i32, i32)]) {
        self.0.push(Shape::Line(class, points.to_vec()));
    }

    fn rect(&mut self, class: &'static str, x: i32, y: i32, w: i32, h: i32) {
        self.0.push(Shape::Rect(class, x, y, w, h));
    }

    fn text(&mut self, class: &'static str, x: i32, y: i32, text: &str) {
        self.0.push(Shape::Text(class, x, y, text.to_owned()));
    }

    fn dot(&mut self, x: i32, y: i32) {
        self.0.push(Shape::Dot(x, y));
    }
}

/// One element as SVG.
fn write_shape(out: &mut String, shape: &Shape) {
    let _ = match shape {
        Shape::Line(class, points) => {
            let pts: Vec<String> = points.iter().map(|(x, y)| format!("{x},{y}")).collect();
            writeln!(
                out,
                r#"<polyline class="{class}" points="{}"/>"#,
                pts.join(" ")
            )
        }
        Shape::Rect(class, x, y, w, h) => writeln!(
            out,
            r#"<rect class="{class}" x="{x}" y="{y}" width="{w}" height="{h}"/>"#
        ),
        Shape::Text(class, x, y, text) => {
            let text = text
                .replace('&', "&amp;")
                .replace('<', "&lt;")
                .replace('>', "&gt;");
            writeln!(
                out,
                r#"<text class="{class}" x="{x}" y="{y}">{text}</text>"#
            )
        }
        Shape::Dot(x, y) => writeln!(out, r#"<circle class="dot" cx="{x}" cy="{y}" r="4"/>"#),
    };
}

/// Bus rows in the middle band, and the x of each chip pin on its logic edge.
const SCL_Y: i32 = 310;
const V33_Y: i32 = 340;
const SDA_Y: i32 = 370;
const GND_Y: i32 = 405;
const PIN_VS: i32 = 380;
const PIN_GND: i32 = 410;
const PIN_SCL: i32 = 440;
const PIN_SDA: i32 = 470;
const PIN_A0: i32 = 500;
const PIN_A1: i32 = 525;
const PIN_ALERT: i32 = 550;
/// Sense pins on the shunt edge, and the power rail's x where the shunts hang.
const PIN_VBUS: i32 = 380;
const PIN_VINP: i32 = 420;
const PIN_VINM: i32 = 500;
const RAIL_X: i32 = 210;
const RETURN_X: i32 = 1100;

/// One channel: its rail row, chip box and which way the chip faces the bus band.
struct Channel {
    name: &'static str,
    chip: &'static str,
    shunt: &'static str,
    cap: &'static str,
    address: &'static str,
    rail_y: i32,
    /// Chip box top; the box is 110 high.
    chip_y: i32,
    /// The chip's edge facing the bus band (its logic pins) and the edge facing the shunt.
    logic_y: i32,
    sense_y: i32,
    /// Where the address straps go: the GND bus (0x40) or the 3V3 bus (0x45, "VS").
    strap_y: i32,
}

fn channel(svg: &mut Svg, c: &Channel) {
    // Power: rail → shunt → driver.
    let driver_y = c.rail_y - 40;
    svg.line("power", &[(RAIL_X, c.rail_y), (410, c.rail_y)]);
    svg.rect("shunt", 410, c.rail_y - 10, 100, 20);
    svg.line("power", &[(510, c.rail_y), (880, c.rail_y)]);
    let label_y = if c.rail_y < 300 {
        c.rail_y - 16
    } else {
        c.rail_y + 30
    };
    svg.text(
        "label",
        410,
        label_y,
        &format!("{} 5 mΩ shunt (2512, 4-pad Kelvin)", c.shunt),
    );
    svg.rect("part", 880, driver_y, 190, 90);
    svg.text(
        "title",
        895,
        driver_y + 30,
        &format!("{} motor driver", c.name),
    );
    svg.text("small", 895, driver_y + 64, "→ its side's motors");
    svg.text("pin", 886, c.rail_y + 4, "V+");
    svg.text("pin", 1030, driver_y + 75, "GND");
    svg.line(
        "return",
        &[(1070, driver_y + 70), (RETURN_X, driver_y + 70)],
    );
    svg.dot(RETURN_X, driver_y + 70);

    // The chip.
    svg.rect("part", 360, c.chip_y, 200, 110);
    svg.text(
        "title",
        372,
        c.chip_y + 48,
        &format!("{} INA226 ({}, {})", c.chip, c.name, c.address),
    );
    svg.text("small", 372, c.chip_y + 66, "INA226AIDGSR, VSSOP-10");

    // Sense side: VBUS from the rail on the battery side; VIN+/VIN− from the shunt's pads.
    svg.line("sense", &[(PIN_VBUS, c.rail_y), (PIN_VBUS, c.sense_y)]);
    svg.dot(PIN_VBUS, c.rail_y);
    let pad = if c.sense_y > c.rail_y {
        c.rail_y + 10
    } else {
        c.rail_y - 10
    };
    svg.line("kelvin", &[(PIN_VINP, pad), (PIN_VINP, c.sense_y)]);
    svg.line("kelvin", &[(PIN_VINM, pad), (PIN_VINM, c.sense_y)]);
    let inside = if c.sense_y > c.chip_y + 50 {
        c.sense_y - 8
    } else {
        c.sense_y + 16
    };
    svg.text("pin", PIN_VBUS - 14, inside, "VBUS");
    svg.text("pin", PIN_VINP - 6, inside, "VIN+");
    svg.text("pin", PIN_VINM - 14, inside, "VIN−");

    // Logic side: pins into the bus band.
    let inside = if c.logic_y > c.chip_y + 50 {
        c.logic_y - 8
    } else {
        c.logic_y + 16
    };
    for (x, name, to) in [
        (PIN_VS, "VS", Some(V33_Y)),
        (PIN_GND, "GND", Some(GND_Y)),
        (PIN_SCL, "SCL", Some(SCL_Y)),
        (PIN_SDA, "SDA", Some(SDA_Y)),
        (PIN_A0, "A0", Some(c.strap_y)),
        (PIN_A1, "A1", Some(c.strap_y)),
        (PIN_ALERT, "ALERT", None),
    ] {
        svg.text("pin", x - 9, inside, name);
        match to {
            Some(y) => {
                svg.line("signal", &[(x, c.logic_y), (x, y)]);
                svg.dot(x, y);
            }
            None => {
                let stub = if c.logic_y > c.chip_y {
                    c.logic_y + 12
                } else {
                    c.logic_y - 12
                };
                svg.line("signal", &[(x, c.logic_y), (x, stub)]);
                let t = if c.logic_y > c.chip_y {
                    stub + 12
                } else {
                    stub - 4
                };
                svg.text("small", x - 8, t, "n.c.");
            }
        }
    }
    // Decoupling right at the VS and GND pins.
    let cap_y = if c.logic_y > c.chip_y {
        c.logic_y + 12
    } else {
        c.logic_y - 12
    };
    svg.line("signal", &[(PIN_VS, cap_y), (392, cap_y)]);
    svg.line("signal", &[(392, cap_y - 7), (392, cap_y + 7)]);
    svg.line("signal", &[(398, cap_y - 7), (398, cap_y + 7)]);
    svg.line("signal", &[(398, cap_y), (PIN_GND, cap_y)]);
    svg.dot(PIN_VS, cap_y);
    svg.dot(PIN_GND, cap_y);
    svg.text("small", 300, cap_y + 4, &format!("{} 100 nF", c.cap));
}

/// The diagram as SVG text.
pub fn svg() -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{HEIGHT}" viewBox="0 0 {WIDTH} {HEIGHT}" font-family="DejaVu Sans, Arial, sans-serif">"#
    );
    out.push_str(
        "<style>\
.power{fill:none;stroke:#c0392b;stroke-width:5}\
.return{fill:none;stroke:#222;stroke-width:5}\
.sense{fill:none;stroke:#c0392b;stroke-width:1.5}\
.kelvin{fill:none;stroke:#8e44ad;stroke-width:1.5}\
.signal{fill:none;stroke:#222;stroke-width:1.5}\
.scl{fill:none;stroke:#2471a3;stroke-width:2}\
.sda{fill:none;stroke:#1e8449;stroke-width:2}\
.v33{fill:none;stroke:#d68910;stroke-width:2}\
.gnd{fill:none;stroke:#222;stroke-width:2}\
.usb{fill:none;stroke:#555;stroke-width:3;stroke-dasharray:8 4}\
.part{fill:#f4f6f7;stroke:#222;stroke-width:1.5}\
.shunt{fill:#fdebd0;stroke:#222;stroke-width:1.5}\
.res{fill:#fff;stroke:#222;stroke-width:1.5}\
.dot{fill:#222}\
.title{font-size:14px;font-weight:bold}\
.label{font-size:12px}\
.small{font-size:11px;fill:#444}\
.pin{font-size:10px}\
.heading{font-size:18px;font-weight:bold}\
</style>\n",
    );
    let _ = writeln!(
        out,
        r#"<rect fill="white" width="{WIDTH}" height="{HEIGHT}"/>"#
    );
    for shape in &drawing() {
        write_shape(&mut out, shape);
    }
    out.push_str("</svg>\n");
    out
}

/// Every element of the diagram.
fn drawing() -> Vec<Shape> {
    let mut svg = Svg::default();
    svg.text(
        "heading",
        30,
        34,
        "rover-power wiring: Black Pill + two INA226 on 5 mΩ shunts",
    );
    svg.text(
        "small",
        30,
        52,
        "drawn by host-tool/src/check/wiring.rs; designators as in the README's bill of materials",
    );

    // Battery and its + rail; the return runs round the right and bottom edges to its −.
    svg.rect("part", 40, 330, 110, 100);
    svg.text("title", 52, 362, "BT1 battery");
    svg.text("label", 52, 380, "24 V (Husky A200)");
    svg.text("pin", 136, 354, "+");
    svg.text("pin", 44, 414, "−");
    svg.line("power", &[(150, 350), (RAIL_X, 350)]);
    svg.line("power", &[(RAIL_X, 100), (RAIL_X, 640)]);
    svg.dot(RAIL_X, 350);
    svg.line(
        "return",
        &[
            (RETURN_X, 130),
            (RETURN_X, 730),
            (20, 730),
            (20, 410),
            (40, 410),
        ],
    );
    svg.text("label", 40, 722, "battery − (motor return)");

    channel(
        &mut svg,
        &Channel {
            name: "left",
            chip: "U1",
            shunt: "R1",
            cap: "C1",
            address: "0x40",
            rail_y: 100,
            chip_y: 170,
            logic_y: 280,
            sense_y: 170,
            strap_y: GND_Y,
        },
    );
    channel(
        &mut svg,
        &Channel {
            name: "right",
            chip: "U2",
            shunt: "R2",
            cap: "C2",
            address: "0x45",
            rail_y: 640,
            chip_y: 440,
            logic_y: 440,
            sense_y: 550,
            strap_y: V33_Y,
        },
    );

    // The bus band: SCL, 3V3, SDA, GND from the chips to the Black Pill.
    svg.line("scl", &[(360, SCL_Y), (640, SCL_Y)]);
    svg.line("v33", &[(360, V33_Y), (640, V33_Y)]);
    svg.line("sda", &[(360, SDA_Y), (640, SDA_Y)]);
    svg.line("gnd", &[(360, GND_Y), (RETURN_X, GND_Y)]);
    svg.dot(RETURN_X, GND_Y);
    svg.text("small", 250, SCL_Y + 4, "SCL");
    svg.text("small", 250, V33_Y + 4, "3V3");
    svg.text("small", 250, SDA_Y + 4, "SDA");
    svg.text("small", 250, GND_Y + 4, "GND");
    svg.text(
        "small",
        835,
        GND_Y + 16,
        "logic GND meets battery − here: one link",
    );
    // Pull-ups from 3V3 to SCL (R3) and SDA (R4).
    svg.rect("res", 580, SCL_Y + 6, 10, 18);
    svg.line("signal", &[(585, SCL_Y), (585, SCL_Y + 6)]);
    svg.line("signal", &[(585, SCL_Y + 24), (585, V33_Y)]);
    svg.dot(585, SCL_Y);
    svg.dot(585, V33_Y);
    svg.rect("res", 605, V33_Y + 6, 10, 18);
    svg.line("signal", &[(610, V33_Y), (610, V33_Y + 6)]);
    svg.line("signal", &[(610, V33_Y + 24), (610, SDA_Y)]);
    svg.dot(610, V33_Y);
    svg.dot(610, SDA_Y);
    svg.text("small", 568, SCL_Y - 6, "R3 2.2 kΩ");
    svg.text("small", 572, SDA_Y + 16, "R4 2.2 kΩ");

    // The Black Pill and USB to the host.
    svg.rect("part", 640, 290, 180, 100);
    svg.text("title", 676, 322, "A1 Black Pill");
    svg.text("small", 676, 340, "STM32F411CEU6, 25 MHz");
    svg.text("small", 676, 356, "LED PC13 (on board)");
    svg.text("small", 676, 372, "BOOT0 low to run");
    svg.text("pin", 644, SCL_Y - 2, "PB8");
    svg.text("pin", 644, V33_Y + 12, "3V3");
    svg.text("pin", 644, SDA_Y + 12, "PB9");
    svg.line("gnd", &[(700, 390), (700, GND_Y)]);
    svg.dot(700, GND_Y);
    svg.text("pin", 704, 386, "GND");
    svg.line("usb", &[(820, 340), (900, 340)]);
    svg.text("pin", 826, 334, "USB-C");
    svg.rect("part", 900, 305, 170, 70);
    svg.text("title", 910, 328, "host PC");
    svg.text("small", 910, 346, "host-tool check / record");
    svg.text("small", 910, 362, "/dev/rover-power (udev)");

    // Legend, left of the rail.
    for (k, line) in [
        "thick red: battery + (motor current)",
        "thick black: battery − return",
        "purple: Kelvin sense, VIN+/VIN−",
        "  from the shunt's pads only",
        "red thin: VBUS, battery side",
        "• joins; a crossing without •",
        "  is not connected",
        "ALERT: not connected",
        "  (the firmware polls)",
    ]
    .iter()
    .enumerate()
    {
        svg.text("small", 30, 140 + 18 * k as i32, line);
    }
    svg.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn repo_file(path: &str) -> std::path::PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(path)
    }

    #[test]
    fn the_committed_wiring_svg_is_this_generators_output() {
        let path = repo_file("docs/wiring.svg");
        let generated = svg();
        if std::env::var_os("UPDATE_WIRING").is_some() {
            std::fs::write(&path, &generated).expect("write docs/wiring.svg");
        }
        let committed = std::fs::read_to_string(&path).unwrap_or_default();
        assert!(
            committed == generated,
            "docs/wiring.svg is stale: run UPDATE_WIRING=1 cargo test -p host-tool wiring"
        );
    }

    #[test]
    fn every_element_lies_inside_the_canvas() {
        let inside =
            |x: i32, y: i32| (0..=WIDTH as i32).contains(&x) && (0..=HEIGHT as i32).contains(&y);
        for shape in drawing() {
            let ok = match &shape {
                Shape::Line(_, points) => points.iter().all(|&(x, y)| inside(x, y)),
                Shape::Rect(_, x, y, w, h) => inside(*x, *y) && inside(x + w, y + h),
                // 6 px per character at 11 px is generous for DejaVu Sans.
                Shape::Text(_, x, y, text) => {
                    inside(*x, *y) && inside(x + 7 * text.chars().count() as i32, *y)
                }
                Shape::Dot(x, y) => inside(*x, *y),
            };
            assert!(ok, "{shape:?} leaves the canvas");
        }
    }

    /// Draws the diagram with plotters (the project's PNG path); `WIRING_PNG=FILE cargo test -p
    /// host-tool wiring` also writes it, to look at where no SVG viewer is installed.
    #[test]
    fn the_diagram_draws_as_png() {
        use plotters::prelude::*;
        let font = include_bytes!("../../assets/fonts/DejaVuSans.ttf");
        plotters::style::register_font("wiring", FontStyle::Normal, font)
            .map_err(|_| "font")
            .expect("font");
        let mut rgb = vec![0u8; WIDTH as usize * HEIGHT as usize * 3];
        let backend = BitMapBackend::<plotters::backend::RGBPixel>::with_buffer_and_format(
            &mut rgb,
            (WIDTH, HEIGHT),
        )
        .expect("buffer");
        let root = backend.into_drawing_area();
        root.fill(&WHITE).expect("fill");
        let style = |class: &str| -> (RGBColor, u32) {
            match class {
                "power" => (RGBColor(0xc0, 0x39, 0x2b), 5),
                "return" => (RGBColor(0x22, 0x22, 0x22), 5),
                "sense" => (RGBColor(0xc0, 0x39, 0x2b), 1),
                "kelvin" => (RGBColor(0x8e, 0x44, 0xad), 2),
                "scl" => (RGBColor(0x24, 0x71, 0xa3), 2),
                "sda" => (RGBColor(0x1e, 0x84, 0x49), 2),
                "v33" => (RGBColor(0xd6, 0x89, 0x10), 2),
                "usb" => (RGBColor(0x55, 0x55, 0x55), 3),
                _ => (RGBColor(0x22, 0x22, 0x22), 1),
            }
        };
        for shape in drawing() {
            match shape {
                Shape::Line(class, points) => {
                    let (c, w) = style(class);
                    root.draw(&PathElement::new(points, c.stroke_width(w)))
                        .expect("line");
                }
                Shape::Rect(class, x, y, w, h) => {
                    let fill = if class == "shunt" {
                        RGBColor(0xfd, 0xeb, 0xd0)
                    } else {
                        RGBColor(0xf4, 0xf6, 0xf7)
                    };
                    root.draw(&Rectangle::new([(x, y), (x + w, y + h)], fill.filled()))
                        .expect("rect");
                    root.draw(&Rectangle::new(
                        [(x, y), (x + w, y + h)],
                        BLACK.stroke_width(1),
                    ))
                    .expect("rect");
                }
                Shape::Text(class, x, y, text) => {
                    let size = match class {
                        "heading" => 18,
                        "title" => 14,
                        "label" => 12,
                        "small" => 11,
                        _ => 10,
                    };
                    let font = ("wiring", size).into_font();
                    root.draw(&Text::new(text, (x, y - size + 2), font))
                        .expect("text");
                }
                Shape::Dot(x, y) => {
                    root.draw(&Circle::new((x, y), 4, BLACK.filled()))
                        .expect("dot");
                }
            }
        }
        root.present().expect("draw");
        drop(root);
        let ink = rgb.chunks(3).filter(|p| p.iter().any(|&c| c < 200)).count();
        let share = ink as f64 / f64::from(WIDTH * HEIGHT);
        assert!((0.02..0.3).contains(&share), "{share}");
        let Some(path) = std::env::var_os("WIRING_PNG") else {
            return;
        };
        let file = std::fs::File::create(&path).expect("png file");
        let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), WIDTH, HEIGHT);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header().expect("png");
        writer.write_image_data(&rgb).expect("png");
    }

    #[test]
    fn every_drawn_part_is_in_the_readmes_bill_of_materials() {
        let readme = std::fs::read_to_string(repo_file("docs/board.md")).expect("docs/board.md");
        let drawing = svg();
        for part in PARTS {
            assert!(
                drawing.contains(&format!("{} ", part.designator)),
                "{} is not drawn",
                part.designator
            );
            let row = readme.lines().find(|l| {
                l.starts_with('|') && l.contains(part.designator) && l.contains(part.part_number)
            });
            assert!(
                row.is_some(),
                "docs/board.md's bill of materials lacks {} {}",
                part.designator,
                part.part_number
            );
        }
    }

    #[test]
    fn the_udev_rule_matches_the_boards_usb_id_and_serial_prefix() {
        let rule =
            std::fs::read_to_string(repo_file("firmware/99-rover-power.rules")).expect("the rule");
        let (vid, pid) = crate::serial::ROVER_POWER_VID_PID;
        let line = rule
            .lines()
            .find(|l| !l.starts_with('#') && !l.trim().is_empty())
            .expect("a rule line");
        for needed in [
            format!(r#"ATTRS{{idVendor}}=="{vid:04x}""#),
            format!(r#"ATTRS{{idProduct}}=="{pid:04x}""#),
            format!(
                r#"ATTRS{{serial}}=="{}*""#,
                model_core::board_id::SERIAL_PREFIX
            ),
            "SYMLINK+=\"rover-power\"".into(),
            "MODE=\"0660\"".into(),
            "ENV{ID_MM_DEVICE_IGNORE}=\"1\"".into(),
        ] {
            assert!(line.contains(&needed), "the rule lacks {needed}");
        }
    }
}
