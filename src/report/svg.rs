//! The report's plots as inline SVG, written by hand: a stacked bar chart of DRAM traffic
//! per class and a cost-vs-quality scatter plot. Inline SVG needs no `xmlns` inside HTML,
//! so the report carries no URL at all.

use std::fmt::Write;

use super::escape;

/// Okabe-Ito colours (readable by colour-blind viewers), one per traffic class in report
/// order, repeating past eight classes.
const PALETTE: [&str; 8] = [
    "#0072B2", "#E69F00", "#009E73", "#CC79A7", "#56B4E9", "#D55E00", "#F0E442", "#000000",
];

/// The colour of the `i`-th traffic class.
pub fn class_colour(i: usize) -> &'static str {
    PALETTE[i % PALETTE.len()]
}

/// A class name as a label (`triangle_data` -> `triangle data`).
pub fn class_label(class: &str) -> String {
    class.replace('_', " ")
}

const FONT: &str = r#"font-family="sans-serif" font-size="12""#;
/// Rough advance of a 12 px sans-serif character, to size the label column.
const CHAR_WIDTH: f64 = 7.0;

/// One stacked bar per run: `(label, bytes per class in `classes` order)`.
pub fn traffic_bars(classes: &[String], bars: &[(String, Vec<u64>)]) -> String {
    let label_width = bars
        .iter()
        .map(|(l, _)| l.chars().count() as f64 * CHAR_WIDTH + 12.0)
        .fold(60.0, f64::max)
        .min(260.0);
    let (plot_width, bar_height, gap, legend_height, axis_height) = (520.0, 22.0, 8.0, 28.0, 34.0);
    let width = label_width + plot_width + 40.0;
    let height = legend_height + bars.len() as f64 * (bar_height + gap) + axis_height;
    let max = bars.iter().map(|(_, c)| c.iter().sum::<u64>()).max().unwrap_or(0);
    let (unit, scale) = byte_unit(max);
    let ticks = nice_ticks(0.0, (max as f64 / scale).max(1e-9), 5);
    let top = ticks.last().copied().unwrap_or(1.0).max(1e-9) * scale;
    let x_of = |bytes: f64| label_width + plot_width * bytes / top;

    let mut s = svg_open(width, height, "DRAM traffic per class and run (stacked bars)");
    let mut lx = label_width;
    for (i, class) in classes.iter().enumerate() {
        let (name, colour) = (class_label(class), class_colour(i));
        let _ = write!(
            s,
            r#"<rect x="{lx:.1}" y="6" width="12" height="12" fill="{colour}"/><text x="{:.1}" y="16" {FONT}>{}</text>"#,
            lx + 16.0,
            escape(&name)
        );
        lx += 16.0 + name.len() as f64 * CHAR_WIDTH + 18.0;
    }
    let plot_bottom = height - axis_height;
    for &t in &ticks {
        let x = x_of(t * scale);
        let _ = write!(
            s,
            r##"<line x1="{x:.1}" y1="{legend_height}" x2="{x:.1}" y2="{plot_bottom:.1}" stroke="#ddd"/><text x="{x:.1}" y="{:.1}" text-anchor="middle" {FONT}>{} {unit}</text>"##,
            plot_bottom + 16.0,
            format_tick(t)
        );
    }
    let _ = write!(
        s,
        r#"<text x="{:.1}" y="{:.1}" text-anchor="middle" {FONT}>bytes to DRAM</text>"#,
        label_width + plot_width / 2.0,
        height - 3.0
    );
    for (i, (label, values)) in bars.iter().enumerate() {
        let y = legend_height + i as f64 * (bar_height + gap) + gap / 2.0;
        let _ = write!(
            s,
            r#"<text x="{:.1}" y="{:.1}" text-anchor="end" {FONT}>{}</text>"#,
            label_width - 8.0,
            y + bar_height / 2.0 + 4.0,
            escape(label)
        );
        let mut start = 0u64;
        for (i, (&bytes, class)) in values.iter().zip(classes).enumerate() {
            let (class, colour) = (class_label(class), class_colour(i));
            let (x0, x1) = (x_of(start as f64), x_of((start + bytes) as f64));
            let _ = write!(
                s,
                r#"<rect x="{x0:.2}" y="{y:.1}" width="{:.2}" height="{bar_height}" fill="{colour}"><title>{}: {} {bytes} bytes</title></rect>"#,
                x1 - x0,
                escape(label),
                escape(&class)
            );
            start += bytes;
        }
    }
    let _ = write!(
        s,
        r#"<line x1="{label_width:.1}" y1="{legend_height}" x2="{label_width:.1}" y2="{plot_bottom:.1}" stroke="black"/>"#
    );
    s.push_str("</svg>");
    s
}

/// SSIM losses below this are drawn on the plot's floor (identical images have none).
const LOSS_FLOOR: f64 = 1e-7;

/// Relative cost (x, % of forward) against image quality: one point per `(label, cost,
/// min SSIM)`, each in its own colour with a legend beside the plot. Quality is drawn as
/// the SSIM loss `1 - SSIM` on a log scale, where 0.999 and 0.99999 are two decades apart
/// instead of overprinting near 1. `joined` links the points in order (a sweep's curve).
pub fn cost_quality_scatter(points: &[(String, f64, f64)], joined: bool) -> String {
    let points: Vec<&(String, f64, f64)> = points
        .iter()
        .filter(|(_, x, y)| x.is_finite() && y.is_finite())
        .collect();
    let (width, height) = (600.0, 380.0);
    let (left, right, top, bottom) = (70.0, 170.0, 16.0, 46.0);
    let (plot_w, plot_h) = (width - left - right, height - top - bottom);

    let x_max = points.iter().map(|p| p.1).fold(100.0, f64::max);
    let x_ticks = nice_ticks(0.0, x_max * 1.05, 6);
    let (x0, x1) = (x_ticks[0], *x_ticks.last().unwrap_or(&1.0));
    let loss = |ssim: f64| (1.0 - ssim).max(LOSS_FLOOR);
    // Whole decades from the floor to at least 1e-4 and at least the largest loss.
    let top_decade = points
        .iter()
        .map(|p| loss(p.2).log10().ceil())
        .fold(-4.0, f64::max)
        .min(0.0);
    let floor_decade = LOSS_FLOOR.log10();
    let px = |x: f64| left + plot_w * (x - x0) / (x1 - x0).max(1e-12);
    let py = |ssim: f64| top + plot_h * (1.0 - (loss(ssim).log10() - floor_decade) / (top_decade - floor_decade));

    let mut s = svg_open(width, height, "relative shading cost against SSIM loss");
    for &t in &x_ticks {
        let x = px(t);
        let _ = write!(
            s,
            r##"<line x1="{x:.1}" y1="{top}" x2="{x:.1}" y2="{:.1}" stroke="#ddd"/><text x="{x:.1}" y="{:.1}" text-anchor="middle" {FONT}>{}%</text>"##,
            top + plot_h,
            top + plot_h + 16.0,
            format_tick(t)
        );
    }
    for decade in (floor_decade as i32)..=(top_decade as i32) {
        let y = top + plot_h * (1.0 - (f64::from(decade) - floor_decade) / (top_decade - floor_decade));
        let label = if f64::from(decade) == floor_decade {
            format!("≤1e{decade}")
        } else {
            format!("1e{decade}")
        };
        let _ = write!(
            s,
            r##"<line x1="{left}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="#ddd"/><text x="{:.1}" y="{:.1}" text-anchor="end" {FONT}>{label}</text>"##,
            left + plot_w,
            left - 6.0,
            y + 4.0,
        );
    }
    let _ = write!(
        s,
        r#"<rect x="{left}" y="{top}" width="{plot_w}" height="{plot_h}" fill="none" stroke="black"/><text x="{:.1}" y="{:.1}" text-anchor="middle" {FONT}>relative shading cost (% of forward)</text><text transform="translate(14 {:.1}) rotate(-90)" text-anchor="middle" {FONT}>1 - min SSIM (log)</text>"#,
        left + plot_w / 2.0,
        height - 8.0,
        top + plot_h / 2.0
    );
    if joined && points.len() > 1 {
        let path: Vec<String> = points
            .iter()
            .map(|p| format!("{:.1},{:.1}", px(p.1), py(p.2)))
            .collect();
        let _ = write!(
            s,
            r##"<polyline points="{}" fill="none" stroke="#777" stroke-width="1.5"/>"##,
            path.join(" ")
        );
    }
    for (i, (label, x, y)) in points.iter().enumerate() {
        let title = format!("<title>{}: {x:.2}%, SSIM {y:.6}</title>", escape(label));
        s.push_str(&marker(i, px(*x), py(*y), &title));
        legend_row(&mut s, i, left + plot_w + 16.0, top, label);
    }
    s.push_str("</svg>");
    s
}

/// Relative shading cost per frame: one line per run `(label, [(frame, cost %)])`, markers
/// and legend as in the scatter plot, so a run's cost over an animation can be read at a
/// glance (and a frame that stands out found).
pub fn cost_per_frame(series: &[(String, Vec<(u32, f64)>)]) -> String {
    let (width, height) = (600.0, 320.0);
    let (left, right, top, bottom) = (60.0, 170.0, 16.0, 46.0);
    let (plot_w, plot_h) = (width - left - right, height - top - bottom);
    let values = || series.iter().flat_map(|(_, s)| s.iter()).filter(|p| p.1.is_finite());
    let (f0, f1) = values().fold((u32::MAX, 0), |(a, b), p| (a.min(p.0), b.max(p.0)));
    let (f0, f1) = if f0 > f1 { (0, 1) } else { (f0, f1.max(f0 + 1)) };
    let y_ticks = nice_ticks(0.0, values().map(|p| p.1).fold(1.0, f64::max) * 1.05, 5);
    let y1 = *y_ticks.last().unwrap_or(&1.0);
    let px = |f: u32| left + plot_w * f64::from(f - f0) / f64::from(f1 - f0);
    let py = |c: f64| top + plot_h * (1.0 - c / y1.max(1e-12));

    let mut s = svg_open(width, height, "relative shading cost per frame");
    for &t in &y_ticks {
        let y = py(t);
        let _ = write!(
            s,
            r##"<line x1="{left}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="#ddd"/><text x="{:.1}" y="{:.1}" text-anchor="end" {FONT}>{}%</text>"##,
            left + plot_w,
            left - 6.0,
            y + 4.0,
            format_tick(t)
        );
    }
    for t in nice_ticks(f64::from(f0), f64::from(f1), 6) {
        if t.fract() != 0.0 || t < f64::from(f0) || t > f64::from(f1) {
            continue;
        }
        let _ = write!(
            s,
            r#"<text x="{:.1}" y="{:.1}" text-anchor="middle" {FONT}>{t}</text>"#,
            px(t as u32),
            top + plot_h + 16.0
        );
    }
    let _ = write!(
        s,
        r#"<rect x="{left}" y="{top}" width="{plot_w}" height="{plot_h}" fill="none" stroke="black"/><text x="{:.1}" y="{:.1}" text-anchor="middle" {FONT}>frame</text><text transform="translate(14 {:.1}) rotate(-90)" text-anchor="middle" {FONT}>relative cost (% of forward, both views)</text>"#,
        left + plot_w / 2.0,
        height - 8.0,
        top + plot_h / 2.0
    );
    for (i, (label, points)) in series.iter().enumerate() {
        let points: Vec<&(u32, f64)> = points.iter().filter(|p| p.1.is_finite()).collect();
        let path: Vec<String> = points
            .iter()
            .map(|p| format!("{:.1},{:.1}", px(p.0), py(p.1)))
            .collect();
        let _ = write!(
            s,
            r#"<polyline points="{}" fill="none" stroke="{}" stroke-width="1.5"/>"#,
            path.join(" "),
            class_colour(i)
        );
        for &&(f, c) in &points {
            let title = format!("<title>{}: frame {f}, {c:.2}%</title>", escape(label));
            s.push_str(&marker(i, px(f), py(c), &title));
        }
        legend_row(&mut s, i, left + plot_w + 16.0, top, label);
    }
    s.push_str("</svg>");
    s
}

/// Row `i` of a plot's legend, in the margin right of the plot (at `x`, below `top`): the
/// series' marker and its label.
fn legend_row(s: &mut String, i: usize, x: f64, top: f64, label: &str) {
    let y = top + 8.0 + 15.0 * i as f64;
    s.push_str(&marker(i, x, y - 4.0, ""));
    let _ = write!(
        s,
        r##"<text x="{:.1}" y="{y:.1}" {FONT}>{}</text>"##,
        x + 10.0,
        escape(label)
    );
}

/// The marker of the `i`-th point: its palette colour, and past each run through the
/// palette another shape (circle, square, diamond), so that no two points look alike.
fn marker(i: usize, x: f64, y: f64, inner: &str) -> String {
    let colour = class_colour(i);
    match (i / PALETTE.len()) % 3 {
        0 => format!(r#"<circle cx="{x:.1}" cy="{y:.1}" r="5" fill="{colour}" stroke="black">{inner}</circle>"#),
        1 => format!(
            r#"<rect x="{:.1}" y="{:.1}" width="9" height="9" fill="{colour}" stroke="black">{inner}</rect>"#,
            x - 4.5,
            y - 4.5
        ),
        _ => format!(
            r#"<polygon points="{x:.1},{:.1} {:.1},{y:.1} {x:.1},{:.1} {:.1},{y:.1}" fill="{colour}" stroke="black">{inner}</polygon>"#,
            y - 6.0,
            x + 6.0,
            y + 6.0,
            x - 6.0
        ),
    }
}

/// A plot made for the page as a file of its own: with the SVG namespace (which HTML does not
/// need, but a file opened alone or imported into a document does) and an XML declaration.
pub fn standalone(svg: &str) -> String {
    format!(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n{}\n",
        svg.replacen("<svg ", "<svg xmlns=\"http://www.w3.org/2000/svg\" ", 1)
    )
}

fn svg_open(width: f64, height: f64, title: &str) -> String {
    format!(
        r#"<svg width="{width:.0}" height="{height:.0}" viewBox="0 0 {width:.0} {height:.0}" role="img"><title>{}</title>"#,
        escape(title)
    )
}

/// The binary unit that shows `max` bytes with a short number: its name and size.
fn byte_unit(max: u64) -> (&'static str, f64) {
    [("GiB", 1u64 << 30), ("MiB", 1 << 20), ("KiB", 1 << 10)]
        .into_iter()
        .find(|&(_, size)| max >= size)
        .map_or(("B", 1.0), |(name, size)| (name, size as f64))
}

/// Tick positions covering [`lo`, `hi`] with about `target` steps of 1, 2 or 5 times a
/// power of ten; always at least two ticks.
fn nice_ticks(lo: f64, hi: f64, target: u32) -> Vec<f64> {
    let (lo, hi) = if hi > lo { (lo, hi) } else { (lo, lo + 1.0) };
    let raw = (hi - lo) / f64::from(target.max(1));
    let magnitude = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * magnitude)
        .find(|&s| s >= raw)
        .unwrap_or(10.0 * magnitude);
    let (first, last) = ((lo / step).floor() as i64, (hi / step).ceil() as i64);
    let last = last.max(first + 1);
    // A few dozen ticks at most, since `step` is at least (hi - lo) / target.
    (first..=last).map(|k| k as f64 * step).collect()
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

    #[test]
    fn ticks_are_round_and_cover_the_range() {
        assert_eq!(nice_ticks(0.0, 100.0, 5), [0.0, 20.0, 40.0, 60.0, 80.0, 100.0]);
        let t = nice_ticks(0.99, 1.0, 5);
        assert!(t[0] <= 0.99 && *t.last().unwrap() >= 1.0 && t.len() <= 7);
        assert!(nice_ticks(0.0, 0.0, 5).len() >= 2);
        assert_eq!(format_tick(0.30000000000000004), "0.3");
        assert_eq!(format_tick(-0.0), "0");
        assert_eq!(byte_unit(3 << 20), ("MiB", 1048576.0));
        assert_eq!(byte_unit(10), ("B", 1.0));
    }

    #[test]
    fn plots_escape_labels_and_survive_empty_input() {
        let classes: Vec<String> = ["depth_color", "indices", "triangle_data", "texture"]
            .map(String::from)
            .to_vec();
        let bars = traffic_bars(&classes, &[("a<b".to_string(), vec![1, 2, 3, 4])]);
        assert!(bars.starts_with("<svg") && bars.ends_with("</svg>"));
        assert!(bars.contains("a&lt;b") && !bars.contains("a<b"));
        assert!(traffic_bars(&classes, &[]).ends_with("</svg>"));
        let scatter = cost_quality_scatter(
            &[
                ("x&y".to_string(), 100.0, 1.0),
                ("z".to_string(), 100.0, 1.0),
                ("nan".to_string(), f64::NAN, 1.0),
            ],
            false,
        );
        assert!(scatter.contains("x&amp;y") && !scatter.contains(">nan<"));
        assert_eq!(scatter.matches("<title>").count(), 3, "the plot's title and two points");
        assert!(!scatter.contains("NaN") && !bars.contains("NaN"));
        assert!(cost_quality_scatter(&[], true).ends_with("</svg>"));
    }

    #[test]
    fn scatter_draws_ssim_loss_on_a_log_scale_with_a_legend() {
        let point_y = |svg: &str, label: &str| -> f64 {
            let end = svg.find(&format!("<title>{label}:")).unwrap();
            let start = svg[..end].rfind(" cy=\"").unwrap() + 5;
            svg[start..].split('"').next().unwrap().parse().unwrap()
        };
        let points: Vec<(String, f64, f64)> = [("forward", 100.0, 1.0), ("a", 40.0, 0.99999), ("b", 30.0, 0.999)]
            .iter()
            .map(|&(l, x, y)| (l.to_string(), x, y))
            .collect();
        let svg = cost_quality_scatter(&points, false);
        // Two decades of loss apart, not pinned together near SSIM 1; no loss sits lowest.
        let (f, a, b) = (point_y(&svg, "forward"), point_y(&svg, "a"), point_y(&svg, "b"));
        assert!(f > a && a > b, "{f} {a} {b}");
        assert!(a - b > 50.0, "{a} vs {b}");
        // Every point has its own colour and a legend row.
        for (i, (label, _, _)) in points.iter().enumerate() {
            assert!(svg.contains(&format!(">{label}</text>")));
            assert_eq!(svg.matches(&format!("fill=\"{}\"", class_colour(i))).count(), 2);
        }
        assert!(!svg.contains("<polyline"));
        assert!(cost_quality_scatter(&points, true).contains("<polyline"));
        // Past the palette's eight colours, markers change shape: no two points look alike.
        let many: Vec<(String, f64, f64)> = (0..10).map(|i| (format!("p{i}"), 10.0 * i as f64, 0.999)).collect();
        let svg = cost_quality_scatter(&many, false);
        assert_eq!(svg.matches("<circle").count(), 2 * 8);
        assert_eq!(svg.matches(r#"width="9" height="9""#).count(), 2 * 2, "square markers");
    }
}
