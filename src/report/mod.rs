//! The self-contained HTML report of `compare` and `demo`: one file with inline CSS, inline
//! SVG figures and thumbnails embedded as `data:` URIs, so it can be mailed, archived or
//! opened offline without the files beside it. No JavaScript.

mod embed;
pub mod figure;

use std::fmt::Write as _;
use std::path::Path;

use shadetrace_formats::results::{stage_names, traffic_names};
use shadetrace_replay::images::{
    heat_map, robust_max, side_by_side, Rgba8Image, ERROR_LABEL, ERROR_SCALE, SSIM_LOSS_LABEL, SSIM_LOSS_SCALE,
};
use shadetrace_replay::run::{FrameImages, ViewImages};
use shadetrace_replay::{LoadedTrace, RunOutput};

use shadetrace_formats::atomic_file::write_bytes_atomically;

/// Width, in pixels, of each view in the report's thumbnails (nearest neighbour), so that the
/// page stays small however many presets and scenes it shows; the full-size pictures are
/// files beside it.
const THUMBNAIL_VIEW_WIDTH: u32 = 120;
const HEAT_LABEL: &str = "issued instructions per pixel";

/// What the report says about a trace, taken from its header.
pub struct TraceSummary {
    pub name: String,
    pub hash: String,
    pub eye_width: u32,
    pub eye_height: u32,
    pub frames: usize,
    pub features: String,
}

impl TraceSummary {
    pub fn of(trace: &LoadedTrace) -> Self {
        TraceSummary {
            name: trace.name.clone(),
            hash: trace.hash.short(),
            eye_width: trace.meta.capture.eye_width,
            eye_height: trace.meta.capture.eye_height,
            frames: trace.frames.len(),
            features: trace.meta.features.to_string(),
        }
    }
}

/// One trace replayed with several presets: a section of the report.
pub struct ReportSection<'a> {
    pub trace: TraceSummary,
    /// The runs in table order; only their first replayed frame's images are shown.
    pub runs: &'a [RunOutput],
    /// Why presets that were asked for did not run on this trace (one line each).
    pub skipped: &'a [String],
    /// Where this section's `summary.csv` and per-preset folders are, relative to the
    /// report ("" when beside it), for links.
    pub files: String,
    /// The shown frame's full-size pictures were written to the preset folders (thumbnails
    /// link to them).
    pub pictures: bool,
}

/// Names of the figure files a report writes into each section's folder (`NAME.svg` and
/// `NAME.png`), so that a new run can remove an earlier run's.
pub const FIGURES: [&str; 3] = ["traffic", "cost-quality", "per-frame"];

/// Writes the report to `path` (atomically). `note` tells readers how the runs were
/// reduced (resolution, frames) or that they were not.
/// Each figure is also written as a standalone SVG and PNG beside the page (in the
/// section's folder), ready for a paper; the page links to them under the figure.
pub fn write_html(path: &Path, title: &str, note: &str, sections: &[ReportSection]) -> Result<(), String> {
    let (html, figures) = render(title, note, sections)?;
    let dir = path.parent().unwrap_or(Path::new(""));
    for (stem, figure) in &figures {
        write_bytes_atomically(&dir.join(format!("{stem}.svg")), figure.svg.as_bytes())?;
        write_bytes_atomically(&dir.join(format!("{stem}.png")), &figure.png)?;
    }
    write_bytes_atomically(path, html.as_bytes())
}

/// A figure and the path of its files relative to the page, without extension.
type PlacedFigure = (String, figure::Figure);

/// The whole page, and its figures.
fn render(title: &str, note: &str, sections: &[ReportSection]) -> Result<(String, Vec<PlacedFigure>), String> {
    let images = sections
        .iter()
        .map(|s| SectionImages::encode(s.runs, THUMBNAIL_VIEW_WIDTH))
        .collect::<Result<Vec<_>, _>>()?;

    let mut h = String::new();
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>{}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n<h1>{}</h1>\n<p class=\"note\">{}</p>\n",
        escape(title),
        escape(title),
        escape(note)
    );
    let _ = writeln!(
        h,
        "<p class=\"note\">Pictures are thumbnails, {THUMBNAIL_VIEW_WIDTH} px wide per view (nearest neighbour); \
         where the full-size PNGs were written, a click opens them.</p>"
    );
    if sections.len() > 1 {
        h.push_str("<nav>Traces:");
        for s in sections {
            let _ = write!(
                h,
                " <a href=\"#{}\">{}</a>",
                anchor(&s.trace.name),
                escape(&s.trace.name)
            );
        }
        h.push_str("</nav>\n");
    }
    let mut figures = Vec::new();
    for (section, images) in sections.iter().zip(&images) {
        render_section(&mut h, section, images, &mut figures)?;
    }
    let _ = write!(
        h,
        "<footer>Written by shadetrace {}. Relative shading cost: issued SIMD instructions over those of the \
         reference preset <code>forward</code> on the same frames and views. SSIM: Gaussian 11x11 window on 8-bit \
         sRGB luma against <code>forward</code>, lowest over frames and views. Traffic: bytes to DRAM after the \
         on-chip caches (ARCHITECTURE.md, Definitions).</footer>\n</body>\n</html>\n",
        env!("CARGO_PKG_VERSION")
    );
    Ok((h, figures))
}

/// Draws `plot`, puts it on the page with links to its standalone files, and records them.
/// The `<figure>` is left open for a note.
fn plot(
    h: &mut String,
    section: &ReportSection,
    name: &str,
    plot: &impl figure::Plot,
    figures: &mut Vec<PlacedFigure>,
) -> Result<(), String> {
    let drawn = figure::render(plot)?;
    let stem = file_href(&section.files, name);
    let _ = write!(
        h,
        "<figure>{}<figcaption><a href=\"{}.svg\">{name}.svg</a>, <a href=\"{}.png\">{name}.png</a></figcaption>",
        figure::inline(&drawn),
        escape(&stem),
        escape(&stem)
    );
    figures.push((stem, drawn));
    Ok(())
}

fn render_section(
    h: &mut String,
    section: &ReportSection,
    images: &SectionImages,
    figures: &mut Vec<PlacedFigure>,
) -> Result<(), String> {
    let t = &section.trace;
    let _ = write!(
        h,
        "<section id=\"{}\">\n<h2>{}</h2>\n<dl>\
         <dt>content hash</dt><dd><code>{}</code></dd>\
         <dt>captured</dt><dd>{}x{} per eye, {} frame{}</dd>",
        anchor(&t.name),
        escape(&t.name),
        escape(&t.hash),
        t.eye_width,
        t.eye_height,
        t.frames,
        if t.frames == 1 { "" } else { "s" }
    );
    if let Some(first) = section.runs.first() {
        let r = &first.result;
        let _ = write!(
            h,
            "<dt>replayed</dt><dd>{}x{} per eye, {} frame{}</dd>",
            r.eye_width,
            r.eye_height,
            r.frames.len(),
            if r.frames.len() == 1 { "" } else { "s" }
        );
    }
    let _ = writeln!(h, "<dt>features</dt><dd>{}</dd></dl>", escape(&t.features));
    render_table(h, section);
    for why in section.skipped {
        let _ = writeln!(h, "<p class=\"skipped\">Not run on this trace: {}</p>", escape(why));
    }

    let classes = traffic_names(section.runs.iter().map(|run| &run.result.total.traffic));
    let bars: Vec<(String, Vec<u64>)> = section
        .runs
        .iter()
        .map(|run| {
            let tr = &run.result.total.traffic;
            (run.result.preset.clone(), classes.iter().map(|c| tr.bytes(c)).collect())
        })
        .collect();
    h.push_str("<h3>DRAM traffic per class</h3>\n");
    let traffic = figure::TrafficBars {
        classes: &classes,
        bars: &bars,
    };
    plot(h, section, "traffic", &traffic, figures)?;
    h.push_str("</figure>\n");

    let points: Vec<(String, f64, f64)> = section
        .runs
        .iter()
        .filter_map(|run| {
            let t = &run.result.total;
            Some((run.result.preset.clone(), 100.0 * t.relative_cost?, t.min_ssim?))
        })
        .collect();
    h.push_str("<h3>Shading cost against quality</h3>\n");
    let scatter = figure::CostQuality {
        points: &points,
        joined: false,
    };
    plot(h, section, "cost-quality", &scatter, figures)?;
    h.push_str("<p class=\"note\">The Pareto front (black line, ringed points): no other preset is both cheaper and closer to the reference.</p>");
    if points.len() < section.runs.len() {
        h.push_str("<p class=\"note\">Runs without a relative cost or an SSIM (views smaller than the 11x11 SSIM window) are not plotted.</p>");
    }
    h.push_str("</figure>\n");

    // Over an animation: the cost and quality of every frame, so that a frame that stands out shows.
    let per_frame: Vec<figure::FrameSeries> = section
        .runs
        .iter()
        .map(|run| {
            let frames = &run.result.frames;
            let cost = frames
                .iter()
                .filter_map(|f| {
                    let costs: Vec<f64> = f.views.iter().filter_map(|v| v.relative_cost).collect();
                    (!costs.is_empty()).then(|| (f.frame, 100.0 * costs.iter().sum::<f64>() / costs.len() as f64))
                })
                .collect();
            let min_ssim = frames
                .iter()
                .filter_map(|f| {
                    let ssim = f.views.iter().filter_map(|v| v.quality.and_then(|q| q.ssim));
                    Some((f.frame, ssim.reduce(f64::min)?))
                })
                .collect();
            figure::FrameSeries {
                label: run.result.preset.clone(),
                cost,
                min_ssim,
            }
        })
        .collect();
    if section.runs.first().is_some_and(|r| r.result.frames.len() > 1) {
        h.push_str("<h3>Cost and quality per frame</h3>\n");
        plot(
            h,
            section,
            "per-frame",
            &figure::PerFrame { series: &per_frame },
            figures,
        )?;
        h.push_str("<p class=\"note\">Cost: the mean of both views' relative cost. Quality: the lower SSIM of the two views. Per frame and view numbers are in <code>frames.csv</code>.</p></figure>\n");
    }

    match &images.frame {
        Some(frame) => {
            let link = |run: &RunOutput, picture: &str| {
                section.pictures.then(|| {
                    let file = format!("{}/frame{frame:04}-{picture}.png", run.result.preset);
                    file_href(&section.files, &file)
                })
            };
            // Presets whose pictures are identical share one thumbnail in the picture grids.
            let groups = identical_pictures(section.runs);
            let _ = write!(
                h,
                "<h3>Frame {frame}: stereo images (left | right)</h3>\n\
                 <p class=\"note\">Presets with identical pictures (<code>a = b</code>) share a thumbnail here and \
                 in the error and SSIM grids.</p>\n<div class=\"grid\">"
            );
            for group in &groups {
                let run = &section.runs[group[0]];
                let caption = group_caption(section.runs, group);
                figure(h, &caption, &images.stereo[group[0]], link(run, "stereo").as_deref());
            }
            let _ = write!(
                h,
                "</div>\n<h3>Frame {frame}: error against the reference (left | right)</h3>\n\
                 <p>Per pixel the largest 8-bit channel difference from <code>forward</code>, on a fixed 0 to \
                 {ERROR_SCALE} scale for every preset and frame (larger errors saturate).</p>\n\
                 <div class=\"grid\">"
            );
            compared_grid(h, section, &groups, &images.error, &|run| link(run, "left-error"));
            let _ = write!(
                h,
                "</div>\n<h3>Frame {frame}: SSIM loss against the reference (left | right)</h3>\n\
                 <p>Per pixel <code>1 - SSIM</code> of the 11x11 Gaussian window centred on it (the map the SSIM \
                 column averages), on a fixed 0 to {SSIM_LOSS_SCALE} scale (larger losses saturate).</p>\n\
                 <div class=\"grid\">"
            );
            compared_grid(h, section, &groups, &images.ssim_loss, &|run| link(run, "left-ssim"));
            let _ = write!(
                h,
                "</div>\n<h3>Frame {frame}: shading cost per pixel (left | right)</h3>\n\
                 <p>One colour scale for every preset of this trace (0 to {}, the 99th percentile of all \
                 their pixels; brighter pixels are clipped), so the maps compare directly.</p>\n\
                 <div class=\"grid\">",
                images.heat_max
            );
            for (run, uri) in section.runs.iter().zip(&images.heat) {
                figure(h, &run.result.preset, uri, link(run, "left-cost").as_deref());
            }
            h.push_str("</div>\n");
        }
        None => h.push_str("<p>No images: no frame was replayed.</p>\n"),
    }

    let _ = write!(
        h,
        "<p class=\"files\">Files: <a href=\"{}\">summary.csv</a>",
        escape(&file_href(&section.files, "summary.csv"))
    );
    for run in section.runs {
        let file = format!("{}/results.json", run.result.preset);
        let _ = write!(
            h,
            ", <a href=\"{}\">{}</a>",
            escape(&file_href(&section.files, &file)),
            escape(&file)
        );
    }
    h.push_str("</p>\n</section>\n");
    Ok(())
}

/// A link to `file` in the section's folder `dir` ("" when beside the report).
fn file_href(dir: &str, file: &str) -> String {
    match dir.trim_end_matches('/') {
        "" => file.to_string(),
        dir => format!("{dir}/{file}"),
    }
}

fn render_table(h: &mut String, section: &ReportSection) {
    let stages = stage_names(section.runs.iter().map(|run| &run.result.total.cost));
    let classes = traffic_names(section.runs.iter().map(|run| &run.result.total.traffic));
    // Wide tables scroll inside their box rather than widening the page.
    h.push_str("<div class=\"wide\"><table>\n<thead><tr><th>preset</th><th>scheduler</th><th>scheme</th><th>relative cost</th>");
    for stage in &stages {
        let _ = write!(h, "<th>{} instr.</th>", escape(stage));
    }
    h.push_str("<th>SIMD utilization</th><th>min SSIM</th><th>min SSIM, covered pixels</th>");
    for (i, class) in classes.iter().enumerate() {
        let _ = write!(
            h,
            "<th><span class=\"swatch\" style=\"background:{}\"></span>{} KiB</th>",
            figure::class_colour(i),
            escape(&figure::class_label(class))
        );
    }
    h.push_str("<th>total KiB</th></tr></thead>\n<tbody>\n");
    for run in section.runs {
        let r = &run.result;
        let t = &r.total;
        let tr = &t.traffic;
        let _ = write!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td>",
            escape(&r.preset),
            escape(&r.scheduler),
            escape(&r.scheme),
            t.relative_cost
                .map_or("-".to_string(), |c| format!("{:.2}%", 100.0 * c)),
        );
        for stage in &stages {
            let _ = write!(h, "<td>{}</td>", group_digits(t.cost.stage(stage).issued()));
        }
        let _ = write!(
            h,
            "<td>{:.1}%</td><td>{}</td><td>{}</td>",
            100.0 * t.cost.simd_utilization(),
            t.min_ssim.map_or("-".to_string(), |s| format!("{s:.6}")),
            t.min_ssim_covered.map_or("-".to_string(), |s| format!("{s:.6}"))
        );
        let bytes = classes.iter().map(|c| tr.bytes(c)).chain([tr.total()]);
        for bytes in bytes {
            let _ = write!(h, "<td>{:.1}</td>", bytes as f64 / 1024.0);
        }
        h.push_str("</tr>\n");
    }
    h.push_str("</tbody>\n</table></div>\n");
}

/// One thumbnail per group of runs with identical pictures, of a picture made against the
/// reference (`uris`, None for a run that has none), linked to the full-size file `link`
/// gives.
fn compared_grid(
    h: &mut String,
    section: &ReportSection,
    groups: &[Vec<usize>],
    uris: &[Option<String>],
    link: &dyn Fn(&RunOutput) -> Option<String>,
) {
    for group in groups {
        let run = &section.runs[group[0]];
        let caption = group_caption(section.runs, group);
        match &uris[group[0]] {
            Some(uri) => figure(h, &caption, uri, link(run).as_deref()),
            None => {
                let _ = write!(
                    h,
                    "<figure><figcaption>{}: not compared</figcaption></figure>",
                    escape(&caption)
                );
            }
        }
    }
}

/// The runs grouped by identical pictures of the shown frame (both views, every pixel), in
/// order of first appearance.
fn identical_pictures(runs: &[RunOutput]) -> Vec<Vec<usize>> {
    let pictures = |i: usize| {
        runs[i]
            .first_images
            .as_ref()
            .map(|f| [&f.views[0].color, &f.views[1].color])
    };
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for i in 0..runs.len() {
        let same = |g: &&mut Vec<usize>| pictures(i).is_some() && pictures(g[0]) == pictures(i);
        match groups.iter_mut().find(same) {
            Some(group) => group.push(i),
            None => groups.push(vec![i]),
        }
    }
    groups
}

/// The presets of a group of runs, `a = b = c`.
fn group_caption(runs: &[RunOutput], group: &[usize]) -> String {
    let names: Vec<&str> = group.iter().map(|&i| runs[i].result.preset.as_str()).collect();
    names.join(" = ")
}

/// A thumbnail with its caption, a link to the full-size picture when there is one.
fn figure(h: &mut String, caption: &str, uri: &str, full_size: Option<&str>) {
    let caption = escape(caption);
    let img = format!("<img src=\"{uri}\" alt=\"{caption}\">");
    let img = match full_size {
        Some(href) => format!("<a href=\"{}\">{img}</a>", escape(href)),
        None => img,
    };
    let _ = write!(h, "<figure>{img}<figcaption>{caption}</figcaption></figure>");
}

/// The first replayed frame's pictures of every run of a section, as `data:` URIs.
struct SectionImages {
    /// The frame shown; None when the runs replayed no frame.
    frame: Option<u32>,
    stereo: Vec<String>,
    /// The error against the reference, for runs that were compared with it.
    error: Vec<Option<String>>,
    /// The SSIM loss map, for runs that were compared (at least 11x11 views).
    ssim_loss: Vec<Option<String>>,
    heat: Vec<String>,
    /// Top of the common heat-map scale.
    heat_max: f32,
}

impl SectionImages {
    /// Encodes the pictures, each view scaled down to at most `max_view_width`.
    fn encode(runs: &[RunOutput], max_view_width: u32) -> Result<Self, String> {
        let firsts: Vec<_> = runs.iter().filter_map(|r| r.first_images.as_ref()).collect();
        let heat_max = robust_max(
            firsts
                .iter()
                .flat_map(|f| f.views.iter())
                .flat_map(|v| v.cost_heat.iter())
                .map(|&c| c as f32),
        )
        .unwrap_or(0.0);
        let mut images = SectionImages {
            frame: firsts.first().map(|f| f.frame),
            stereo: Vec::new(),
            error: Vec::new(),
            ssim_loss: Vec::new(),
            heat: Vec::new(),
            heat_max,
        };
        // A run without images would shift the figures against their captions.
        if firsts.len() != runs.len() {
            images.frame = None;
            return Ok(images);
        }
        let shrink = |img: &Rgba8Image| embed::downscale(img, max_view_width);
        for frame in firsts {
            let [left, right] = &frame.views;
            let stereo = side_by_side(&shrink(&left.color), &shrink(&right.color));
            images.stereo.push(embed::jpeg_data_uri(&stereo)?);
            let per_view =
                |values: &dyn Fn(&ViewImages) -> Option<Vec<f32>>| stereo_grid(frame, max_view_width, values);
            let map = |values: Option<(Vec<f32>, u32, u32)>, scale: f32, label: &str| match values {
                Some((values, width, height)) => {
                    let map = heat_map(&values, width, height, Some(scale), label);
                    embed::png_data_uri(&map).map(Some)
                }
                None => Ok(None),
            };
            let cost = per_view(&|v| Some(v.cost_heat.iter().map(|&c| c as f32).collect()));
            images.heat.push(map(cost, heat_max, HEAT_LABEL)?.ok_or("no cost map")?);
            let error = per_view(&|v| v.error.as_ref().map(|e| e.iter().map(|&x| f32::from(x)).collect()));
            images.error.push(map(error, ERROR_SCALE, ERROR_LABEL)?);
            let ssim_loss = per_view(&|v| v.ssim_loss.clone());
            images.ssim_loss.push(map(ssim_loss, SSIM_LOSS_SCALE, SSIM_LOSS_LABEL)?);
        }
        Ok(images)
    }
}

/// A per-pixel quantity of both views (`values`, None when a view has none) as one grid,
/// left view then right view on each row (like `side_by_side`), each view scaled to at most
/// `max_view_width`, so one heat map with one legend shows the pair.
fn stereo_grid(
    frame: &FrameImages,
    max_view_width: u32,
    values: &dyn Fn(&ViewImages) -> Option<Vec<f32>>,
) -> Option<(Vec<f32>, u32, u32)> {
    let mut views = Vec::new();
    for v in &frame.views {
        let (w, h) = (v.color.width, v.color.height);
        let to = embed::fit_width(w, h, max_view_width);
        views.push((embed::resample(&values(v)?, w, h, to, 0.0), to.0, to.1));
    }
    let width = views.iter().map(|v| v.1).fold(0u32, u32::saturating_add);
    let height = views.iter().map(|v| v.2).max().unwrap_or(0);
    let mut grid = Vec::with_capacity(width as usize * height as usize);
    for y in 0..height as usize {
        for (data, w, _) in &views {
            let w = *w as usize;
            grid.extend((0..w).map(|x| data.get(y * w + x).copied().unwrap_or(0.0)));
        }
    }
    Some((grid, width, height))
}

/// Text safe inside HTML and SVG elements and quoted attributes.
pub fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            _ => out.push(c),
        }
    }
    out
}

/// An id for a section: lower-case letters, digits and dashes.
fn anchor(name: &str) -> String {
    let id: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() {
                c.to_ascii_lowercase()
            } else {
                '-'
            }
        })
        .collect();
    format!("trace-{id}")
}

/// `1234567` as `1,234,567`, for instruction counts.
fn group_digits(n: u64) -> String {
    let digits = n.to_string();
    let mut out = String::with_capacity(digits.len() + digits.len() / 3);
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i) % 3 == 0 {
            out.push(',');
        }
        out.push(c);
    }
    out
}

const STYLE: &str = "\
body{font-family:sans-serif;margin:1.5em;color:#222;max-width:1400px}\
h2{border-bottom:2px solid #888;margin-top:2em}\
.note{background:#fff6d5;border-left:4px solid #e6b800;padding:.4em .8em}\
dl{display:grid;grid-template-columns:max-content auto;gap:.2em 1em}dt{font-weight:bold}dd{margin:0}\
.wide{overflow-x:auto;max-width:100%}table{border-collapse:collapse;font-size:.9em}th,td{border:1px solid #bbb;padding:.25em .5em}\
td{text-align:right;font-variant-numeric:tabular-nums}td:nth-child(-n+3){text-align:left}th{background:#eee}\
.swatch{display:inline-block;width:.8em;height:.8em;margin-right:.3em;vertical-align:middle}\
.grid{display:flex;flex-wrap:wrap;gap:1em}\
figure{margin:.5em 0}figure img{max-width:100%;height:auto;image-rendering:pixelated;border:1px solid #888}\
figcaption{font-size:.9em;text-align:center}\
footer{margin-top:3em;font-size:.85em;color:#555}";

#[cfg(test)]
mod tests {
    use super::*;

    /// demo puts each scene's files in a folder named after it (the links read
    /// `floorforward/results.json` before the separator was added).
    #[test]
    fn file_links_join_the_section_folder() {
        assert_eq!(file_href("", "summary.csv"), "summary.csv");
        assert_eq!(file_href("floor", "forward/results.json"), "floor/forward/results.json");
        assert_eq!(file_href("floor/", "summary.csv"), "floor/summary.csv");
    }

    #[test]
    fn text_helpers() {
        assert_eq!(
            escape(r#"<a href="x">&'</a>"#),
            "&lt;a href=&quot;x&quot;&gt;&amp;&#39;&lt;/a&gt;"
        );
        assert_eq!(anchor("Depth Stack"), "trace-depth-stack");
        assert_eq!(group_digits(0), "0");
        assert_eq!(group_digits(1234), "1,234");
        assert_eq!(group_digits(1234567), "1,234,567");
        assert_eq!(group_digits(123456), "123,456");
    }

    #[test]
    fn empty_report_is_well_formed() {
        let (html, figures) = render("t <1>", "note & more", &[]).unwrap();
        assert!(figures.is_empty());
        assert!(html.starts_with("<!DOCTYPE html>") && html.ends_with("</html>\n"));
        assert!(html.contains("t &lt;1&gt;") && html.contains("note &amp; more"));
        assert!(!html.contains("http://") && !html.contains("https://"));
    }
}
