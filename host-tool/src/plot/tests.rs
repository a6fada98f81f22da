#[test]
fn panels_side_by_side_share_one_y_range() {
    let chart = |ys: &[f64]| {
        let mut c = Chart::new("p", "x", "y");
        let points = ys.iter().enumerate().map(|(i, y)| (i as f64, *y)).collect();
        c.series
            .push(Series::new("s", points, SeriesStyle::Points, 0));
        c
    };
    let figure = Figure::new("f", vec![chart(&[0.0, 10.0]), chart(&[-20.0, 5.0])], 2).share_y();
    let ranges: Vec<_> = figure.charts.iter().map(|c| c.y_range).collect();
    assert_eq!(ranges[0], ranges[1]);
    let (lo, hi) = ranges[0].expect("range");
    assert!(lo < -20.0 && hi > 10.0);
}

#[test]
fn interval_bars_widen_the_y_range_and_are_drawn() {
    let mut chart = Chart::new("p", "x", "y");
    chart.series.push(
        Series::new("ci", vec![(0.0, 1.0), (1.0, 2.0)], SeriesStyle::Points, 0)
            .with_intervals(vec![(-40.0, 3.0), (f64::NEG_INFINITY, 90.0)]),
    );
    // A non-finite end draws no bar but its finite end still counts.
    let (_, (lo, hi)) = ranges(&chart).expect("ranges");
    assert!(lo <= -40.0 && hi >= 90.0, "{lo} {hi}");
    let shared = Figure::new("f", vec![chart.clone()], 1).share_y();
    let (lo, hi) = shared.charts[0].y_range.expect("range");
    assert!(lo < -40.0 && hi > 90.0);
    // The bar is ink: a figure with it has more elements than one without (same axes).
    chart.y_range = Some((-50.0, 100.0));
    let mut bare = chart.clone();
    bare.series[0].intervals.clear();
    let with = render_bytes(&Figure::single(chart), Format::Svg).expect("svg");
    let without = render_bytes(&Figure::single(bare), Format::Svg).expect("svg");
    let lines = |b: &[u8]| String::from_utf8_lossy(b).matches('<').count();
    assert!(lines(&with) >= lines(&without) + 3, "bar and two caps");
}

use super::axes::{auto_range, clip_segment, inside, polylines, ranges, tick_label};
use super::chart::FIGURE_TITLE_PX;
use super::*;
use proptest::prelude::*;

fn model_curve() -> Vec<(f64, f64)> {
    (1..=40)
        .map(|i| {
            let r = f64::from(i) * 0.1;
            (r, 140.0 + 130.0 / r)
        })
        .collect()
}

fn demo_chart() -> Chart {
    let mut chart = Chart::new("Average power vs R/R′", "R/R′ [-]", "P [W]");
    chart.series.push(Series::new(
        "measured",
        vec![(0.5, 410.0), (1.0, 260.0), (2.0, 180.0), (4.0, 150.0)],
        SeriesStyle::Points,
        0,
    ));
    chart
        .series
        .push(Series::new("model", model_curve(), SeriesStyle::Line, 1));
    chart.markers.push(Marker::new(1.0, "R = R′"));
    chart
}

fn svg_of(figure: &Figure) -> String {
    String::from_utf8(render_bytes(figure, Format::Svg).expect("renders")).expect("utf-8")
}

/// The contents of the SVG's `<text>` elements, trimmed.
fn svg_texts(svg: &str) -> Vec<String> {
    svg.split("<text")
        .skip(1)
        .filter_map(|t| {
            let start = t.find('>')? + 1;
            let end = t.find("</text>")?;
            Some(t[start..end].trim().to_owned())
        })
        .collect()
}

/// The `<tag>` elements whose `attr` (`stroke` or `fill`) is `rgb`.
fn elements_in(svg: &str, tag: &str, attr: &str, rgb: (u8, u8, u8)) -> usize {
    let colour = format!("{attr}=\"#{:02X}{:02X}{:02X}\"", rgb.0, rgb.1, rgb.2);
    svg.split(&format!("<{tag}"))
        .skip(1)
        .filter(|p| {
            p.split('>')
                .next()
                .is_some_and(|attrs| attrs.contains(&colour))
        })
        .count()
}

/// The `<polyline>` elements stroked in `rgb`.
fn polylines_in(svg: &str, rgb: (u8, u8, u8)) -> usize {
    elements_in(svg, "polyline", "stroke", rgb)
}

/// The `<circle>` elements filled with `rgb`.
fn circles_in(svg: &str, rgb: (u8, u8, u8)) -> usize {
    elements_in(svg, "circle", "fill", rgb)
}

struct Decoded {
    width: u32,
    height: u32,
    rgb: Vec<u8>,
}

impl Decoded {
    fn pixels(&self) -> impl Iterator<Item = (u32, u32, (u8, u8, u8))> + '_ {
        self.rgb.chunks_exact(3).enumerate().map(|(i, p)| {
            let i = i as u32;
            (i % self.width, i / self.width, (p[0], p[1], p[2]))
        })
    }

    fn count(&self, pred: impl Fn(u32, u32, (u8, u8, u8)) -> bool) -> usize {
        self.pixels().filter(|&(x, y, c)| pred(x, y, c)).count()
    }
}

fn decode_png(bytes: &[u8]) -> Decoded {
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "PNG signature");
    let mut reader = png::Decoder::new(std::io::Cursor::new(bytes))
        .read_info()
        .expect("PNG header");
    let mut rgb = vec![0; reader.output_buffer_size().expect("size")];
    let info = reader.next_frame(&mut rgb).expect("PNG data");
    assert_eq!(info.color_type, png::ColorType::Rgb);
    rgb.truncate(info.buffer_size());
    Decoded {
        width: info.width,
        height: info.height,
        rgb,
    }
}

#[test]
fn format_follows_the_extension() {
    assert_eq!(
        Format::from_path(Path::new("a/b.png")).ok(),
        Some(Format::Png)
    );
    assert_eq!(
        Format::from_path(Path::new("B.SVG")).ok(),
        Some(Format::Svg)
    );
    for bad in ["fig.pdf", "fig", "fig.png.txt", ".png"] {
        assert!(
            matches!(
                Format::from_path(Path::new(bad)),
                Err(PlotError::UnsupportedFormat { .. })
            ),
            "{bad}"
        );
    }
}

#[test]
fn bad_extension_is_an_error_and_writes_nothing() {
    let dir = std::env::temp_dir().join(format!("plot-ext-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let path = dir.join("figure.jpg");
    let err = render(&demo_chart(), &path).expect_err("jpg is not supported");
    assert!(err.to_string().contains(".png or .svg"), "{err}");
    assert!(!path.exists());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn svg_holds_the_texts_and_one_path_per_line_series() {
    let mut chart = demo_chart();
    chart.legend = Legend::Hidden;
    let svg = svg_of(&Figure::single(chart));
    let texts = svg_texts(&svg);
    for t in ["Average power vs R/R′", "R/R′ [-]", "P [W]", "R = R′"] {
        assert!(texts.iter().any(|x| x == t), "{t} missing in {texts:?}");
    }
    assert_eq!(
        polylines_in(&svg, palette_rgb(1)),
        1,
        "one path for the model"
    );
    assert_eq!(circles_in(&svg, palette_rgb(0)), 4, "a dot per measurement");
    assert_eq!(polylines_in(&svg, palette_rgb(0)), 0);

    // With the legend, each series gains exactly one legend sample and its name.
    let svg = svg_of(&Figure::single(demo_chart()));
    assert_eq!(polylines_in(&svg, palette_rgb(1)), 2);
    assert_eq!(circles_in(&svg, palette_rgb(0)), 5);
    let texts = svg_texts(&svg);
    assert!(texts.iter().any(|x| x == "measured") && texts.iter().any(|x| x == "model"));
}

#[test]
fn svg_text_is_escaped() {
    let chart = Chart::new("a < b & c", "x", "y");
    let svg = svg_of(&Figure::single(chart));
    assert!(svg.contains("a &lt; b &amp; c"), "{svg}");
}

#[test]
fn nan_points_are_skipped_breaking_the_line_and_are_counted() {
    let mut chart = demo_chart();
    chart.legend = Legend::Hidden;
    chart.series[1].points[10].1 = f64::NAN;
    chart.series[1].points[20].0 = f64::INFINITY;
    chart.series[0].points.push((f64::NAN, 1.0));
    assert_eq!(chart.undrawable_points(), 3);
    let svg = svg_of(&Figure::single(chart));
    assert_eq!(
        polylines_in(&svg, palette_rgb(1)),
        3,
        "two gaps: three pieces"
    );
    assert_eq!(circles_in(&svg, palette_rgb(0)), 4);
    assert!(svg_texts(&svg)
        .iter()
        .any(|t| t == "3 points not shown (non-finite or out of scale)"));
    assert!(!svg.contains("NaN") && !svg.contains("inf"));
}

#[test]
fn empty_series_give_a_no_data_chart() {
    for chart in [
        Chart::new("nothing", "t [s]", "P [W]"),
        Chart {
            series: vec![Series::new(
                "s",
                vec![(f64::NAN, 1.0)],
                SeriesStyle::Line,
                0,
            )],
            ..Chart::new("only NaN", "t [s]", "P [W]")
        },
    ] {
        let svg = svg_of(&Figure::single(chart));
        assert!(svg_texts(&svg).iter().any(|t| t == "no data"));
    }
    let svg = svg_of(&Figure::new("", vec![], 3));
    assert!(svg_texts(&svg).iter().any(|t| t == "no data"));
    let png = decode_png(&render_bytes(&Figure::new("", vec![], 3), Format::Png).expect("png"));
    assert_eq!((png.width, png.height), PANEL_PX);
}

#[test]
fn data_outside_a_fixed_range_says_so_and_lines_are_clipped() {
    let mut chart = demo_chart();
    chart.x_range = Some((10.0, 20.0));
    let svg = svg_of(&Figure::single(chart));
    assert!(svg_texts(&svg).iter().any(|t| t == "no data in range"));

    let mut chart = demo_chart();
    chart.legend = Legend::Hidden;
    chart.y_range = Some((0.0, 300.0));
    let svg = svg_of(&Figure::single(chart));
    // The model curve enters the range at R/R' ≈ 0.8 and stays.
    assert_eq!(polylines_in(&svg, palette_rgb(1)), 1);
    assert_eq!(
        circles_in(&svg, palette_rgb(0)),
        3,
        "the 410 W point is out"
    );
}

#[test]
fn bad_ranges_and_sizes_are_errors() {
    for (range, what) in [
        ((1.0, 1.0), "below"),
        ((2.0, 1.0), "below"),
        ((f64::NAN, 1.0), "finite"),
        ((0.0, f64::INFINITY), "finite"),
        ((0.0, 1e200), "1e150"),
        ((1e9, 1e9 + 1e-6), "narrow"),
    ] {
        let mut chart = demo_chart();
        chart.y_range = Some(range);
        let err = render_bytes(&Figure::single(chart), Format::Svg).expect_err("bad range");
        assert!(
            matches!(err, PlotError::BadRange { axis: "y", .. }) && err.to_string().contains(what),
            "{range:?}: {err}"
        );
    }
    let mut figure = Figure::single(demo_chart());
    figure.panel_px = (0, 100);
    assert!(matches!(figure.size_px(), Err(PlotError::BadSize { .. })));
    figure.panel_px = (MAX_SIDE_PX, 100);
    figure.charts.push(demo_chart());
    figure.columns = 2;
    assert!(matches!(
        render_bytes(&figure, Format::Png),
        Err(PlotError::BadSize { .. })
    ));
}

#[test]
fn png_decodes_with_text_and_series_colours() {
    let png = decode_png(&render_bytes(&Figure::single(demo_chart()), Format::Png).expect("png"));
    assert_eq!((png.width, png.height), PANEL_PX);
    let (b, v) = (palette_rgb(0), palette_rgb(1));
    assert!(
        png.count(|_, _, c| c == b) > 4 * 20,
        "measurement dots drawn"
    );
    assert!(png.count(|_, _, c| c == v) > 500, "model line drawn");
    // The caption band holds dark (text) pixels only when there is a title: the embedded
    // font renders.
    let dark = |c: (u8, u8, u8)| u16::from(c.0) + u16::from(c.1) + u16::from(c.2) < 200;
    assert!(png.count(|_, y, c| y < 30 && dark(c)) > 100);
    let mut untitled = demo_chart();
    untitled.title.clear();
    let png = decode_png(&render_bytes(&Figure::single(untitled), Format::Png).expect("png"));
    assert_eq!(png.count(|_, y, c| y < 10 && dark(c)), 0);
    // A chart without that series has none of its colour.
    let mut only_model = demo_chart();
    only_model.series.remove(0);
    let png = decode_png(&render_bytes(&Figure::single(only_model), Format::Png).expect("png"));
    assert_eq!(png.count(|_, _, c| c == b), 0);
}

#[test]
fn png_dot_lands_where_its_coordinates_map() {
    // One point in the middle of fixed ranges: its colour appears around the plotting area's
    // centre, and nowhere else.
    let mut chart = Chart::new("", "", "");
    chart.legend = Legend::Hidden;
    chart.x_range = Some((0.0, 10.0));
    chart.y_range = Some((0.0, 10.0));
    chart
        .series
        .push(Series::new("", vec![(5.0, 5.0)], SeriesStyle::Points, 2));
    let png = decode_png(&render_bytes(&Figure::single(chart), Format::Png).expect("png"));
    let c = palette_rgb(2);
    let hits: Vec<(u32, u32)> = png
        .pixels()
        .filter(|p| p.2 == c)
        .map(|p| (p.0, p.1))
        .collect();
    assert!(!hits.is_empty());
    let (xs, ys): (Vec<u32>, Vec<u32>) = hits.iter().copied().unzip();
    let (x0, x1) = (
        xs.iter().min().copied().unwrap_or(0),
        xs.iter().max().copied().unwrap_or(0),
    );
    let (y0, y1) = (
        ys.iter().min().copied().unwrap_or(0),
        ys.iter().max().copied().unwrap_or(0),
    );
    assert!(x1 - x0 <= 9 && y1 - y0 <= 9, "one radius-4 dot: {hits:?}");
    let (x0, y0) = ((x0 + x1) / 2, (y0 + y1) / 2);
    // Plot area: left label area 72 + margin 12, right margin 12; bottom label area 48 +
    // margin 12, top margin 12 (no caption).
    let cx = (12 + 72 + (PANEL_PX.0 - 12)) / 2;
    let cy = (12 + (PANEL_PX.1 - 12 - 48)) / 2;
    assert!(
        x0.abs_diff(cx) <= 2 && y0.abs_diff(cy) <= 2,
        "dot at {x0},{y0}, centre {cx},{cy}"
    );
}

#[test]
fn figure_grid_has_panel_sized_cells_and_all_titles() {
    let mut right = demo_chart();
    right.title = "right".into();
    let mut left = demo_chart();
    left.title = "left".into();
    let figure = Figure::new("Turn at R = 2 m", vec![left, right, demo_chart()], 2);
    assert_eq!(
        figure.size_px().ok(),
        Some((2 * PANEL_PX.0, 2 * PANEL_PX.1 + FIGURE_TITLE_PX))
    );
    let texts = svg_texts(&svg_of(&figure));
    for t in ["Turn at R = 2 m", "left", "right", "Average power vs R/R′"] {
        assert!(texts.iter().any(|x| x == t), "{t}");
    }
}

#[test]
fn render_writes_both_formats_atomically() {
    let dir = std::env::temp_dir().join(format!("plot-render-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let svg = dir.join("f.svg");
    let png = dir.join("f.PNG");
    render(&demo_chart(), &svg).expect("svg");
    render(&demo_chart(), &png).expect("png");
    assert!(std::fs::read_to_string(&svg)
        .expect("read")
        .starts_with("<svg"));
    let bytes = std::fs::read(&png).expect("read");
    assert_eq!(decode_png(&bytes).width, PANEL_PX.0);
    // A failing render leaves the previous file alone.
    let mut bad = demo_chart();
    bad.x_range = Some((1.0, 0.0));
    assert!(render(&bad, &svg).is_err());
    assert!(std::fs::read_to_string(&svg)
        .expect("read")
        .contains("R = R′"));
    let leftovers = std::fs::read_dir(&dir).expect("dir").count();
    assert_eq!(leftovers, 2, "no temporary files left");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn clipping_segments() {
    let bx = (0.0, 1.0);
    assert_eq!(
        clip_segment((-1.0, 0.5), (2.0, 0.5), bx, bx),
        Some(((0.0, 0.5), (1.0, 0.5)))
    );
    assert_eq!(clip_segment((2.0, 2.0), (3.0, 3.0), bx, bx), None);
    // A box tiny next to the segment: the cut points stay inside it despite rounding.
    let tiny = (0.0, 6e-66);
    let (p, q) = clip_segment((0.0, -614.27), (0.0, 1e150), (-1.0, 1.0), tiny).expect("hit");
    assert!(
        inside(p, (-1.0, 1.0), tiny) && inside(q, (-1.0, 1.0), tiny),
        "{p:?} {q:?}"
    );
    assert_eq!(clip_segment((-1.0, 2.0), (2.0, 2.0), bx, bx), None);
    let inside = ((0.2, 0.2), (0.8, 0.9));
    assert_eq!(clip_segment(inside.0, inside.1, bx, bx), Some(inside));
    // Out, in, out again: two pieces; NaN splits too; a lone point is kept as a dot.
    let pts = [
        (-1.0, 0.5),
        (0.5, 0.5),
        (2.0, 0.5),
        (0.5, 0.6),
        (0.6, 0.6),
        (f64::NAN, 0.0),
        (0.3, 0.3),
    ];
    let (runs, isolated) = polylines(&pts, bx, bx);
    assert_eq!(
        runs,
        vec![
            vec![(0.0, 0.5), (0.5, 0.5), (1.0, 0.5)],
            vec![(1.0, 0.5 + 0.1 * (1.0 / 1.5)), (0.5, 0.6), (0.6, 0.6)],
        ]
    );
    assert_eq!(isolated, vec![(0.3, 0.3)]);
}

#[test]
fn automatic_ranges() {
    assert_eq!(auto_range([0.0, 10.0].into_iter()), Some((-0.5, 10.5)));
    assert_eq!(auto_range([3.0].into_iter()), Some((2.85, 3.15)));
    assert_eq!(auto_range([0.0, 0.0].into_iter()), Some((-1.0, 1.0)));
    assert_eq!(auto_range(std::iter::empty()), None);
    let (lo, hi) = auto_range([-1e150, 1e150].into_iter()).expect("range");
    assert!(lo.is_finite() && hi.is_finite() && lo < -1e150 && hi > 1e150);
}

#[test]
fn tick_labels() {
    assert_eq!(tick_label(0.0), "0");
    assert_eq!(tick_label(2.5), "2.5");
    assert_eq!(tick_label(-1200.0), "-1200");
    assert_eq!(tick_label(0.0004), "4.00e-4");
    assert_eq!(tick_label(250_000.0), "2.50e5");
    assert_eq!(tick_label(-0.00001), "-1.00e-5");
}

fn coordinate() -> impl Strategy<Value = f64> {
    prop_oneof![
        4 => -1e3..1e3f64,
        1 => any::<f64>(),
        1 => Just(f64::NAN),
        1 => Just(f64::INFINITY),
        1 => Just(f64::NEG_INFINITY),
        1 => Just(0.0),
        1 => Just(1e150),
        1 => Just(-1e150),
        1 => Just(1e-300),
        1 => Just(42.0),
    ]
}

fn series() -> impl Strategy<Value = Series> {
    (
        proptest::collection::vec((coordinate(), coordinate()), 0..12),
        prop_oneof![
            Just(SeriesStyle::Line),
            Just(SeriesStyle::Points),
            Just(SeriesStyle::LineAndPoints)
        ],
        0usize..20,
        "[a-zτ′ ]{0,6}",
    )
        .prop_map(|(points, style, colour, name)| Series::new(name, points, style, colour))
}

fn range() -> impl Strategy<Value = Option<(f64, f64)>> {
    prop_oneof![
        3 => Just(None),
        1 => (coordinate(), coordinate()).prop_map(Some),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Any data, finite or not, renders in both formats or gives a range error; nothing
    /// panics or hangs.
    #[test]
    fn arbitrary_points_never_panic(
        series in proptest::collection::vec(series(), 0..4),
        markers in proptest::collection::vec(coordinate(), 0..3),
        x_range in range(),
        y_range in range(),
    ) {
        let chart = Chart {
            series,
            markers: markers.into_iter().map(|x| Marker::new(x, "m")).collect(),
            x_range,
            y_range,
            ..Chart::new("t", "x", "y")
        };
        let mut figure = Figure::single(chart);
        figure.panel_px = (240, 180);
        for format in [Format::Svg, Format::Png] {
            match render_bytes(&figure, format) {
                Ok(bytes) => prop_assert!(!bytes.is_empty()),
                Err(PlotError::BadRange { .. }) => {
                    prop_assert!(x_range.is_some() || y_range.is_some());
                }
                Err(e) => prop_assert!(false, "{e}"),
            }
        }
    }
}

/// The legend box's rectangle (x, y, width, height) in an SVG: the rect filled white at 0.85.
fn legend_box(svg: &str) -> Option<(f64, f64, f64, f64)> {
    let rect = svg
        .split("<rect")
        .skip(1)
        .map(|r| r.split('>').next().unwrap_or(""))
        .find(|r| r.contains("fill=\"#FFFFFF\"") && r.contains("opacity=\"0.85"))?;
    let attr = |name: &str| -> Option<f64> {
        let start = rect.find(&format!(" {name}=\""))? + name.len() + 3;
        rect[start..].split('"').next()?.parse().ok()
    };
    Some((attr("x")?, attr("y")?, attr("width")?, attr("height")?))
}

#[test]
fn the_legend_goes_where_it_covers_nothing_or_below_the_chart() {
    // Points along the top and down the right side: only the lower left is free.
    let mut chart = Chart::new("t", "x", "y");
    let mut points: Vec<(f64, f64)> = (0..=20).map(|i| (f64::from(i) * 0.5, 10.0)).collect();
    points.extend((0..=20).map(|i| (10.0, f64::from(i) * 0.5)));
    chart.series.push(Series::new(
        "a series with a long name",
        points.clone(),
        SeriesStyle::Points,
        0,
    ));
    let svg = svg_of(&Figure::single(chart.clone()));
    let (x, y, w, h) = legend_box(&svg).expect("a legend box");
    let (panel_w, panel_h) = (f64::from(PANEL_PX.0), f64::from(PANEL_PX.1));
    assert!(
        x + w < panel_w / 2.0 && y > panel_h / 2.0,
        "{x} {y} {w} {h}"
    );

    // Points everywhere: no corner is free, so the legend is a strip below the plot.
    let mut full = Chart::new("t", "x", "y");
    let grid = (0..=40)
        .flat_map(|i| (0..=40).map(move |j| (f64::from(i) * 0.25, f64::from(j) * 0.25)))
        .collect();
    full.series
        .push(Series::new("everywhere", grid, SeriesStyle::Points, 0));
    let svg = svg_of(&Figure::single(full));
    assert_eq!(legend_box(&svg), None, "no box over the data");
    let text_y = svg
        .split("<text")
        .find(|t| t.contains(">everywhere<") || t.contains(">\neverywhere"))
        .and_then(|t| {
            t.split("y=\"")
                .nth(1)?
                .split('"')
                .next()?
                .parse::<f64>()
                .ok()
        })
        .expect("the legend's text");
    let axis_label_y = svg
        .split("<text")
        .filter(|t| t.contains(">x<") || t.contains(">\nx\n<"))
        .filter_map(|t| {
            t.split("y=\"")
                .nth(1)?
                .split('"')
                .next()?
                .parse::<f64>()
                .ok()
        })
        .next()
        .expect("the x label");
    assert!(
        text_y > axis_label_y,
        "legend {text_y} below the x label {axis_label_y}"
    );

    // A corner named by the caller is kept, whatever it covers.
    chart.legend = Legend::UpperRight;
    let (x, y, w, _) = legend_box(&svg_of(&Figure::single(chart))).expect("box");
    assert!(x + w > panel_w / 2.0 && y < panel_h / 2.0);
}

#[test]
fn shapes_draw_their_own_marks_and_legend_samples() {
    let mut chart = Chart::new("t", "x", "y");
    for (k, shape) in [Shape::Dot, Shape::Ring, Shape::Square, Shape::Triangle]
        .into_iter()
        .enumerate()
    {
        chart.series.push(
            Series::new(
                format!("s{k}"),
                vec![(k as f64, 1.0)],
                SeriesStyle::Points,
                k,
            )
            .with_shape(shape),
        );
    }
    let svg = svg_of(&Figure::single(chart));
    // Data and legend sample alike: a filled dot, a stroked ring, a square, a triangle.
    assert_eq!(circles_in(&svg, PALETTE[0]), 2, "{svg}");
    assert_eq!(elements_in(&svg, "circle", "stroke", PALETTE[1]), 2);
    assert_eq!(elements_in(&svg, "rect", "fill", PALETTE[2]), 2);
    assert_eq!(elements_in(&svg, "polygon", "fill", PALETTE[3]), 2);
}
