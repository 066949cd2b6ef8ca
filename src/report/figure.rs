//! The report's figures, drawn with plotters: every [`Plot`] is drawn twice from the same
//! code, as SVG (inline on the page, and a file for papers) and as PNG at [`PNG_SCALE`]
//! times the size (for slides and documents that take no SVG). Text is measured and
//! rasterized with an embedded DejaVu Sans, so figures look the same on every machine and
//! need no system fonts.

use std::sync::Once;

use image::{codecs::png::PngEncoder, ExtendedColorType, ImageEncoder};
use plotters::coord::ranged1d::SegmentValue;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::escape;

/// A PNG figure has this many pixels per SVG unit.
pub const PNG_SCALE: u32 = 2;

/// Okabe-Ito colours (readable by colour-blind viewers), one per traffic class or preset
/// in report order, repeating past eight (markers then change shape).
const PALETTE: [(u8, u8, u8); 8] = [
    (0x00, 0x72, 0xB2),
    (0xE6, 0x9F, 0x00),
    (0x00, 0x9E, 0x73),
    (0xCC, 0x79, 0xA7),
    (0x56, 0xB4, 0xE9),
    (0xD5, 0x5E, 0x00),
    (0xF0, 0xE4, 0x42),
    (0x00, 0x00, 0x00),
];

/// The `i`-th colour of the palette as CSS (`#0072B2`), for the table's swatches.
pub fn class_colour(i: usize) -> String {
    let (r, g, b) = PALETTE[i % PALETTE.len()];
    format!("#{r:02X}{g:02X}{b:02X}")
}

fn colour(i: usize) -> RGBColor {
    let (r, g, b) = PALETTE[i % PALETTE.len()];
    RGBColor(r, g, b)
}

/// A class name as a label (`triangle_data` -> `triangle data`).
pub fn class_label(class: &str) -> String {
    class.replace('_', " ")
}

/// SSIM losses below this are drawn on the plot's floor (identical images have none).
const LOSS_FLOOR: f64 = 1e-7;
/// Width of the legend column right of a plot, in SVG units.
const LEGEND_WIDTH: u32 = 170;
/// Plotters' font size: it writes SVG `font-size` as this over 1.24, so this is 12 px text.
const FONT_SIZE: f64 = 15.0;
/// Frames beyond this many are drawn as lines without markers.
const MARKED_FRAMES: usize = 40;

/// A figure's drawing, independent of the back-end it is drawn on.
pub trait Plot {
    /// Width and height in SVG units (CSS pixels).
    fn size(&self) -> (u32, u32);
    /// What the figure shows, as the SVG's title.
    fn title(&self) -> &'static str;
    /// Draws on `root`, with every length (fonts, strokes, margins) times `k`.
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>, k: f64) -> DrawResult<DB>;
}

type DrawResult<DB> = Result<(), DrawingAreaErrorKind<<DB as DrawingBackend>::ErrorType>>;

/// A figure as the files written beside the report.
pub struct Figure {
    /// A standalone SVG (with its namespace), also valid inline in HTML.
    pub svg: String,
    pub png: Vec<u8>,
}

/// Draws `plot` as SVG and as PNG.
pub fn render(plot: &impl Plot) -> Result<Figure, String> {
    static FONT: Once = Once::new();
    FONT.call_once(|| {
        // DejaVu Sans is a valid font; failing to parse it would leave text unmeasured.
        plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular())
            .unwrap_or_else(|_| unreachable!("the embedded DejaVu Sans parses"));
    });
    let fail = |e: String| format!("drawing the figure '{}': {e}", plot.title());
    let (width, height) = plot.size();
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (width, height)).into_drawing_area();
        plot.draw(&root, 1.0).map_err(|e| fail(e.to_string()))?;
        root.present().map_err(|e| fail(e.to_string()))?;
    }
    let (w, h) = (width * PNG_SCALE, height * PNG_SCALE);
    let mut rgb = vec![0u8; w as usize * h as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area();
        plot.draw(&root, f64::from(PNG_SCALE))
            .map_err(|e| fail(e.to_string()))?;
        root.present().map_err(|e| fail(e.to_string()))?;
    }
    let mut png = Vec::new();
    PngEncoder::new(&mut png)
        .write_image(&rgb, w, h, ExtendedColorType::Rgb8)
        .map_err(|e| fail(e.to_string()))?;
    // A title for screen readers and viewers, right after the opening tag.
    let svg = match svg.find('>') {
        Some(end) => format!(
            "{}<title>{}</title>{}",
            &svg[..=end],
            escape(plot.title()),
            &svg[end + 1..]
        ),
        None => svg,
    };
    Ok(Figure {
        svg: format!("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n{svg}"),
        png,
    })
}

/// The figure as it goes inline into HTML (without the XML declaration).
pub fn inline(figure: &Figure) -> &str {
    figure.svg.split_once('\n').map_or(&figure.svg, |(_, svg)| svg)
}

/// `v` SVG units at scale `k`, in pixels.
fn px(v: f64, k: f64) -> u32 {
    (v * k).round() as u32
}

fn font(k: f64) -> TextStyle<'static> {
    ("sans-serif", FONT_SIZE * k).into_font().color(&BLACK)
}

/// One stacked bar per run of its bytes to DRAM by traffic class.
pub struct TrafficBars<'a> {
    pub classes: &'a [String],
    /// `(run label, bytes per class in `classes` order)`, drawn top to bottom.
    pub bars: &'a [(String, Vec<u64>)],
}

impl Plot for TrafficBars<'_> {
    fn size(&self) -> (u32, u32) {
        (760, 80 + 30 * self.bars.len().max(1) as u32)
    }

    fn title(&self) -> &'static str {
        "DRAM traffic per class and run (stacked bars)"
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>, k: f64) -> DrawResult<DB> {
        root.fill(&WHITE)?;
        let (width, _) = root.dim_in_pixel();
        let (plot, legend_area) = root.split_horizontally(width - px(f64::from(LEGEND_WIDTH), k));
        let max = self.bars.iter().map(|(_, c)| c.iter().sum::<u64>()).max().unwrap_or(0);
        let (unit, scale) = byte_unit(max);
        // Bottom to top, so the first run is drawn at the top; one empty row when none.
        let mut rows: Vec<&str> = self.bars.iter().rev().map(|b| b.0.as_str()).collect();
        if rows.is_empty() {
            rows.push("");
        }
        let label_width = rows
            .iter()
            .map(|label| root.estimate_text_size(label, &font(k)).map_or(0, |(w, _)| w))
            .max()
            .unwrap_or(0)
            .max(px(40.0, k));
        let mut chart = ChartBuilder::on(&plot)
            .margin(px(10.0, k))
            .x_label_area_size(px(40.0, k))
            .y_label_area_size(label_width + px(12.0, k))
            .build_cartesian_2d(
                0.0..(max as f64 / scale).max(1e-9) * 1.02,
                rows.as_slice().into_segmented(),
            )?;
        chart
            .configure_mesh()
            .disable_y_mesh()
            .max_light_lines(1)
            .label_style(font(k))
            .axis_desc_style(font(k))
            .x_desc(format!("bytes to DRAM ({unit})"))
            .x_label_formatter(&|v| format_tick(*v))
            .y_label_formatter(&|_| String::new())
            .draw()?;
        // Row labels drawn here: plotters gives a single segment no label of its own.
        let right_centre = font(k).pos(Pos::new(HPos::Right, VPos::Center));
        for label in &rows {
            let (x, y) = chart.backend_coord(&(0.0, SegmentValue::CenterOf(label)));
            root.draw(&Text::new(
                label.to_string(),
                (x - px(8.0, k) as i32, y),
                right_centre.clone(),
            ))?;
        }
        for (row, (_, values)) in self.bars.iter().rev().enumerate() {
            let (bottom, top) = (
                SegmentValue::Exact(&rows[row]),
                rows.get(row + 1).map_or(SegmentValue::Last, SegmentValue::Exact),
            );
            let mut start = 0u64;
            for (c, &bytes) in values.iter().enumerate() {
                let (x0, x1) = (start as f64 / scale, (start + bytes) as f64 / scale);
                let mut bar = Rectangle::new([(x0, bottom.clone()), (x1, top.clone())], colour(c).filled());
                bar.set_margin(px(4.0, k), px(4.0, k), 0, 0);
                chart.draw_series([bar])?;
                start += bytes;
            }
        }
        let keys: Vec<(Key, String)> = self
            .classes
            .iter()
            .enumerate()
            .map(|(i, class)| (Key::Swatch(i), class_label(class)))
            .collect();
        legend(&legend_area, &keys, k)
    }
}

/// Relative cost (x, % of forward) against image quality: one point per `(label, cost %,
/// min SSIM)`, each with its own colour and marker and a legend row. Quality is drawn as the
/// SSIM loss `1 - SSIM` on a log scale, where 0.999 and 0.99999 are two decades apart
/// instead of overprinting near 1. The Pareto front (no other point is both cheaper and
/// better) is joined and its points ringed; `joined` also links all points in order (a
/// sweep's curve).
pub struct CostQuality<'a> {
    pub points: &'a [(String, f64, f64)],
    pub joined: bool,
}

impl Plot for CostQuality<'_> {
    fn size(&self) -> (u32, u32) {
        (640, 400.max(60 + 16 * self.points.len() as u32))
    }

    fn title(&self) -> &'static str {
        "relative shading cost against SSIM loss"
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>, k: f64) -> DrawResult<DB> {
        root.fill(&WHITE)?;
        let points: Vec<(usize, &(String, f64, f64))> = self
            .points
            .iter()
            .enumerate()
            .filter(|(_, (_, x, y))| x.is_finite() && y.is_finite())
            .collect();
        let (width, _) = root.dim_in_pixel();
        let (plot, legend_area) = root.split_horizontally(width - px(f64::from(LEGEND_WIDTH), k));
        let x_max = points.iter().map(|p| p.1 .1).fold(100.0, f64::max) * 1.05;
        let top = loss_axis_top(points.iter().map(|p| loss(p.1 .2)));
        let mut chart = ChartBuilder::on(&plot)
            .margin(px(10.0, k))
            .x_label_area_size(px(40.0, k))
            .y_label_area_size(px(64.0, k))
            .build_cartesian_2d(0.0..x_max, (LOSS_FLOOR..top).log_scale())?;
        chart
            .configure_mesh()
            .max_light_lines(1)
            .label_style(font(k))
            .axis_desc_style(font(k))
            .x_desc("relative shading cost (% of forward)")
            .y_desc("1 − min SSIM (log scale)")
            .x_label_formatter(&|v| format!("{}%", format_tick(*v)))
            .y_label_formatter(&|v| decade_label(*v))
            .draw()?;
        let at = |p: &(String, f64, f64)| chart.backend_coord(&(p.1, loss(p.2)));
        if self.joined && points.len() > 1 {
            let path: Vec<_> = points.iter().map(|(_, p)| at(p)).collect();
            root.draw(&PathElement::new(
                path,
                RGBColor(0x77, 0x77, 0x77).stroke_width(px(1.5, k)),
            ))?;
        }
        let front = pareto_front(&points.iter().map(|(_, p)| (p.1, loss(p.2))).collect::<Vec<_>>());
        if front.len() > 1 {
            let path: Vec<_> = front.iter().map(|&f| at(points[f].1)).collect();
            root.draw(&PathElement::new(path, BLACK.stroke_width(px(2.0, k))))?;
        }
        for (f, (i, p)) in points.iter().enumerate() {
            marker(root, *i, at(p), k, front.contains(&f))?;
        }
        let mut keys: Vec<(Key, String)> = points.iter().map(|(i, p)| (Key::Marker(*i), p.0.clone())).collect();
        if !front.is_empty() {
            keys.push((Key::Front, "Pareto front".to_string()));
        }
        legend(&legend_area, &keys, k)
    }
}

/// One run's numbers per frame: `(frame, value)` pairs in frame order.
pub struct FrameSeries {
    pub label: String,
    /// Relative cost in % of forward (mean of both views).
    pub cost: Vec<(u32, f64)>,
    /// The lower SSIM of the two views.
    pub min_ssim: Vec<(u32, f64)>,
}

/// Cost (top) and quality (bottom, SSIM loss on a log scale) of every run per frame, so
/// that a frame that stands out over an animation shows at a glance.
pub struct PerFrame<'a> {
    pub series: &'a [FrameSeries],
}

impl Plot for PerFrame<'_> {
    fn size(&self) -> (u32, u32) {
        (640, 520.max(60 + 16 * self.series.len() as u32))
    }

    fn title(&self) -> &'static str {
        "relative shading cost and SSIM loss per frame"
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>, k: f64) -> DrawResult<DB> {
        root.fill(&WHITE)?;
        let (width, height) = root.dim_in_pixel();
        let (plots, legend_area) = root.split_horizontally(width - px(f64::from(LEGEND_WIDTH), k));
        let (upper, lower) = plots.split_vertically(height / 2);
        let frames = || {
            self.series
                .iter()
                .flat_map(|s| s.cost.iter().chain(&s.min_ssim))
                .map(|p| p.0)
        };
        let (f0, f1) = (frames().min().unwrap_or(0), frames().max().unwrap_or(0));
        let frame_range = || f64::from(f0) - 0.5..f64::from(f1.max(f0 + 1)) + 0.5;
        let finite = |v: &[(u32, f64)]| v.iter().filter(|p| p.1.is_finite()).copied().collect::<Vec<_>>();

        let cost_max = self
            .series
            .iter()
            .flat_map(|s| finite(&s.cost))
            .map(|p| p.1)
            .fold(1.0, f64::max)
            * 1.05;
        let mut cost = ChartBuilder::on(&upper)
            .margin(px(10.0, k))
            .x_label_area_size(px(24.0, k))
            .y_label_area_size(px(64.0, k))
            .build_cartesian_2d(frame_range(), 0.0..cost_max)?;
        cost.configure_mesh()
            .max_light_lines(1)
            .label_style(font(k))
            .axis_desc_style(font(k))
            .y_desc("relative cost (% of forward)")
            .x_label_formatter(&|v| frame_label(*v))
            .y_label_formatter(&|v| format!("{}%", format_tick(*v)))
            .draw()?;
        let losses: Vec<Vec<(u32, f64)>> = self
            .series
            .iter()
            .map(|s| finite(&s.min_ssim).into_iter().map(|(f, v)| (f, loss(v))).collect())
            .collect();
        let top = loss_axis_top(losses.iter().flatten().map(|p| p.1));
        let mut quality = ChartBuilder::on(&lower)
            .margin(px(10.0, k))
            .x_label_area_size(px(40.0, k))
            .y_label_area_size(px(64.0, k))
            .build_cartesian_2d(frame_range(), (LOSS_FLOOR..top).log_scale())?;
        quality
            .configure_mesh()
            .max_light_lines(1)
            .label_style(font(k))
            .axis_desc_style(font(k))
            .x_desc("frame")
            .y_desc("1 − min SSIM of the views (log)")
            .x_label_formatter(&|v| frame_label(*v))
            .y_label_formatter(&|v| decade_label(*v))
            .draw()?;
        for (i, (series, loss)) in self.series.iter().zip(&losses).enumerate() {
            let style = colour(i).stroke_width(px(1.5, k));
            let cost_points: Vec<_> = finite(&series.cost)
                .iter()
                .map(|&(f, c)| cost.backend_coord(&(f64::from(f), c)))
                .collect();
            let loss_points: Vec<_> = loss
                .iter()
                .map(|&(f, l)| quality.backend_coord(&(f64::from(f), l)))
                .collect();
            for points in [&cost_points, &loss_points] {
                root.draw(&PathElement::new(points.clone(), style))?;
                if points.len() <= MARKED_FRAMES {
                    for &p in points {
                        marker(root, i, p, k * 0.7, false)?;
                    }
                }
            }
        }
        let keys: Vec<(Key, String)> = self
            .series
            .iter()
            .enumerate()
            .map(|(i, s)| (Key::Marker(i), s.label.clone()))
            .collect();
        legend(&legend_area, &keys, k)
    }
}

/// What a legend row shows before its label.
enum Key {
    /// The `i`-th series' marker.
    Marker(usize),
    /// A square of the `i`-th colour (stacked bars).
    Swatch(usize),
    /// The Pareto front's line.
    Front,
}

/// The legend as a column of rows in `area`, top first.
fn legend<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, keys: &[(Key, String)], k: f64) -> DrawResult<DB> {
    let (x, row) = (px(12.0, k) as i32, px(16.0, k) as i32);
    for (n, (key, label)) in keys.iter().enumerate() {
        let y = px(18.0, k) as i32 + row * n as i32;
        match key {
            Key::Marker(i) => marker(area, *i, (x, y), k, false)?,
            Key::Swatch(i) => {
                let r = px(6.0, k) as i32;
                area.draw(&Rectangle::new([(x - r, y - r), (x + r, y + r)], colour(*i).filled()))?;
            }
            Key::Front => {
                let r = px(8.0, k) as i32;
                area.draw(&PathElement::new(
                    vec![(x - r, y), (x + r, y)],
                    BLACK.stroke_width(px(2.0, k)),
                ))?;
            }
        }
        let label_style = font(k).pos(Pos::new(HPos::Left, VPos::Center));
        area.draw(&Text::new(label.clone(), (x + px(12.0, k) as i32, y), label_style))?;
    }
    Ok(())
}

/// The marker of the `i`-th series at pixel `at` of `area`: its palette colour with a black
/// edge, and past each run through the palette another shape (circle, square, diamond), so
/// that no two series look alike. `ringed` draws a heavier edge (a point on the Pareto front).
fn marker<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    i: usize,
    at: (i32, i32),
    k: f64,
    ringed: bool,
) -> DrawResult<DB> {
    let (x, y) = at;
    let r = px(5.0, k) as i32;
    let fill = colour(i).filled();
    let edge = BLACK.stroke_width(px(if ringed { 2.5 } else { 1.0 }, k).max(1));
    match (i / PALETTE.len()) % 3 {
        0 => {
            area.draw(&Circle::new(at, r as u32, fill))?;
            area.draw(&Circle::new(at, r as u32, edge))
        }
        1 => {
            area.draw(&Rectangle::new([(x - r, y - r), (x + r, y + r)], fill))?;
            area.draw(&Rectangle::new([(x - r, y - r), (x + r, y + r)], edge))
        }
        _ => {
            let d = r + r / 3;
            let corners = vec![(x, y - d), (x + d, y), (x, y + d), (x - d, y)];
            area.draw(&Polygon::new(corners.clone(), fill))?;
            let mut closed = corners;
            closed.push((x, y - d));
            area.draw(&PathElement::new(closed, edge))
        }
    }
}

/// `1 - ssim`, raised to the plot's floor.
fn loss(ssim: f64) -> f64 {
    (1.0 - ssim).max(LOSS_FLOOR)
}

/// Top of an SSIM-loss axis: the whole decade above the largest of `losses`, at least 1e-4
/// (so near-perfect runs do not fill the plot) and at most 1.
fn loss_axis_top(losses: impl Iterator<Item = f64>) -> f64 {
    10f64.powf(losses.map(|l| l.log10().ceil()).fold(-4.0, f64::max).min(0.0))
}

/// The indices of the points `(cost, loss)` on the Pareto front, cheapest first: those that
/// no other point matches or beats in both cost and loss (of equal points, the first).
fn pareto_front(points: &[(f64, f64)]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..points.len()).collect();
    order.sort_by(|&a, &b| {
        points[a]
            .0
            .total_cmp(&points[b].0)
            .then(points[a].1.total_cmp(&points[b].1))
    });
    let mut front = Vec::new();
    let mut best_loss = f64::INFINITY;
    for i in order {
        if points[i].1 < best_loss {
            best_loss = points[i].1;
            front.push(i);
        }
    }
    front
}

/// A log axis label: decades only (`1e-5`), the floor as `≤1e-7`.
fn decade_label(v: f64) -> String {
    let decade = v.log10().round();
    if (v.log10() - decade).abs() > 1e-6 {
        String::new()
    } else if v <= LOSS_FLOOR * (1.0 + 1e-9) {
        format!("≤1e{decade}")
    } else {
        format!("1e{decade}")
    }
}

/// Whole frames only on a frame axis.
fn frame_label(v: f64) -> String {
    if v.fract() == 0.0 && v >= 0.0 {
        format!("{v}")
    } else {
        String::new()
    }
}

/// The binary unit that shows `max` bytes with a short number: its name and size.
fn byte_unit(max: u64) -> (&'static str, f64) {
    [("GiB", 1u64 << 30), ("MiB", 1 << 20), ("KiB", 1 << 10)]
        .into_iter()
        .find(|&(_, size)| max >= size)
        .map_or(("B", 1.0), |(name, size)| (name, size as f64))
}

/// A tick value without float noise: up to four decimals, trailing zeros dropped.
fn format_tick(v: f64) -> String {
    let s = format!("{v:.4}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".to_string()
    } else {
        s.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn points(list: &[(&str, f64, f64)]) -> Vec<(String, f64, f64)> {
        list.iter().map(|&(l, x, y)| (l.to_string(), x, y)).collect()
    }

    #[test]
    fn labels_and_units() {
        assert_eq!(format_tick(0.30000000000000004), "0.3");
        assert_eq!(format_tick(-0.0), "0");
        assert_eq!(byte_unit(3 << 20), ("MiB", 1048576.0));
        assert_eq!(byte_unit(10), ("B", 1.0));
        assert_eq!(decade_label(1e-3), "1e-3");
        assert_eq!(decade_label(LOSS_FLOOR), "≤1e-7");
        assert_eq!(decade_label(2e-3), "");
        assert_eq!(frame_label(3.0), "3");
        assert_eq!(frame_label(2.5), "");
        assert_eq!(class_colour(0), "#0072B2");
        assert_eq!(class_colour(9), class_colour(1));
    }

    /// No other point is both cheaper and better than a point on the front.
    #[test]
    fn pareto_front_keeps_the_undominated_points_cheapest_first() {
        let p = [(100.0, 1e-7), (30.0, 1e-3), (40.0, 1e-4), (50.0, 1e-3), (30.0, 1e-3)];
        assert_eq!(pareto_front(&p), [1, 2, 0]);
        assert!(pareto_front(&[]).is_empty());
    }

    #[test]
    fn figures_render_as_svg_and_png_and_escape_labels() {
        let classes: Vec<String> = ["depth_color", "texture"].map(String::from).to_vec();
        let bars = [("a<b".to_string(), vec![1 << 20, 3 << 20])];
        for figure in [
            render(&TrafficBars {
                classes: &classes,
                bars: &bars,
            })
            .unwrap(),
            render(&TrafficBars {
                classes: &classes,
                bars: &[],
            })
            .unwrap(),
            render(&CostQuality {
                points: &[],
                joined: true,
            })
            .unwrap(),
            render(&PerFrame { series: &[] }).unwrap(),
        ] {
            assert!(figure.svg.starts_with("<?xml") && figure.svg.trim_end().ends_with("</svg>"));
            assert!(figure.svg.contains("<svg ") && figure.svg.contains("xmlns=\"http://www.w3.org/2000/svg\""));
            assert!(!inline(&figure).starts_with("<?xml"));
            assert!(!figure.svg.contains("NaN"));
            let png = image::load_from_memory(&figure.png).unwrap();
            assert!(png.width() >= 640 * PNG_SCALE);
        }
        let svg = render(&TrafficBars {
            classes: &classes,
            bars: &bars,
        })
        .unwrap()
        .svg;
        assert!(svg.contains("a&lt;b") && !svg.contains("a<b"), "labels are escaped");
        assert!(has_text(&svg, "depth color") && has_text(&svg, "bytes to DRAM (MiB)"));
    }

    /// Whether `svg` draws the text `label` (plotters ends every text with a newline).
    fn has_text(svg: &str, label: &str) -> bool {
        svg.contains(&format!(">\n{label}\n</text>"))
    }

    /// The centres of the circles drawn in colour `i` (markers and legend keys).
    fn circles(svg: &str, i: usize) -> Vec<(i32, i32)> {
        svg.split("<circle ")
            .skip(1)
            .map(|c| c.split('>').next().unwrap_or(""))
            .filter(|c| c.contains(&format!("fill=\"{}\"", class_colour(i))))
            .map(|c| {
                let attr = |name: &str| -> i32 {
                    let start = c.find(&format!("{name}=\"")).unwrap() + name.len() + 2;
                    c[start..].split('"').next().unwrap().parse().unwrap()
                };
                (attr("cx"), attr("cy"))
            })
            .collect()
    }

    #[test]
    fn scatter_draws_ssim_loss_on_a_log_scale_with_a_legend() {
        let list = points(&[
            ("forward", 100.0, 1.0),
            ("a", 40.0, 0.99999),
            ("b", 30.0, 0.999),
            ("nan", f64::NAN, 1.0),
        ]);
        let svg = render(&CostQuality {
            points: &list,
            joined: false,
        })
        .unwrap()
        .svg;
        // Each finite point has a marker and a legend key in its own colour; no loss sits lowest.
        let y = |i: usize| circles(&svg, i)[0].1;
        for i in 0..3 {
            assert_eq!(circles(&svg, i).len(), 2, "point {i}");
        }
        assert!(circles(&svg, 3).is_empty(), "a NaN point is not drawn");
        assert!(y(0) > y(1) && y(1) > y(2), "{} {} {}", y(0), y(1), y(2));
        assert!(y(1) - y(2) > 50, "two decades apart, not pinned together near SSIM 1");
        for label in ["forward", "a", "b", "Pareto front", "1 − min SSIM (log scale)"] {
            assert!(has_text(&svg, label), "{label}");
        }
        // A sweep's points are joined in order (in grey, apart from the black Pareto front).
        let joined = render(&CostQuality {
            points: &list,
            joined: true,
        })
        .unwrap()
        .svg;
        assert!(!svg.contains("stroke=\"#777777\"") && joined.contains("stroke=\"#777777\""));
        // Past the palette's eight colours, markers change shape: no two points look alike.
        let many = (0..10)
            .map(|i| (format!("p{i}"), 10.0 * i as f64, 0.999))
            .collect::<Vec<_>>();
        let svg = render(&CostQuality {
            points: &many,
            joined: true,
        })
        .unwrap()
        .svg;
        assert_eq!(
            (0..8).map(|i| circles(&svg, i).len()).sum::<usize>(),
            2 * 8,
            "a marker and a legend key per colour"
        );
        assert!(has_text(&svg, "p9"));
    }

    #[test]
    fn per_frame_plot_draws_cost_and_quality_of_every_run() {
        let series = [FrameSeries {
            label: "tile-pair".into(),
            cost: vec![(1, 30.0), (2, 32.0)],
            min_ssim: vec![(1, 0.9999), (2, 0.999)],
        }];
        let svg = render(&PerFrame { series: &series }).unwrap().svg;
        // Two markers per panel and the legend key.
        assert_eq!(circles(&svg, 0).len(), 2 + 2 + 1);
        assert!(has_text(&svg, "tile-pair") && has_text(&svg, "frame"));
    }
}
