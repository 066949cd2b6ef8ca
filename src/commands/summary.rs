//! The one-row-per-run summary of `compare` and `demo`: `summary.csv` (exact numbers, for
//! scripts) and the same table aligned for the terminal (percentages and KiB, for people).

use std::path::Path;

use shadetrace_formats::results::{stage_names, traffic_names, FrameResult, ListStats, RunResult};

use shadetrace_formats::atomic_file::write_atomically;

/// The columns of a set of runs: fixed ones, one per shading stage and one per traffic class
/// that any run reports (so a new stage or class appears without edits here).
struct Columns {
    stages: Vec<String>,
    classes: Vec<String>,
    /// Per-frame counters of particular back-ends ([`frame_extras`]), for `frames.csv`.
    extras: Vec<String>,
}

impl Columns {
    fn of(runs: &[&RunResult]) -> Columns {
        Columns {
            stages: stage_names(runs.iter().map(|r| &r.total.cost)),
            classes: traffic_names(runs.iter().map(|r| &r.total.traffic)),
            extras: extra_names(runs.iter().copied()),
        }
    }

    fn csv_header(&self) -> Vec<String> {
        let mut h: Vec<String> = ["preset", "scheduler", "scheme", "frames", "issued"]
            .map(String::from)
            .to_vec();
        h.extend(self.stages.iter().map(|s| format!("{s}_issued")));
        h.extend(
            [
                "relative_cost_pct",
                "simd_utilization_pct",
                "min_ssim",
                "min_ssim_covered",
                "min_psnr_db",
            ]
            .map(String::from),
        );
        h.extend(self.classes.iter().map(|c| format!("{c}_bytes")));
        h.extend(
            [
                "total_bytes",
                "tile_list_entries",
                "tile_list_bytes",
                "tile_pair_entries",
                "tile_pair_list_bytes",
                "wall_s",
                "mpixels_per_s",
            ]
            .map(String::from),
        );
        h
    }
}

/// Columns printed left-aligned (names); the rest are numbers, right-aligned.
const TEXT_COLUMNS: usize = 1;

/// Writes `summary.csv` at `path`, one row per run.
pub fn write_csv(path: &Path, runs: &[&RunResult]) -> Result<(), String> {
    let fail = |e: csv::Error| format!("{}: {e}", path.display());
    write_atomically(path, |w| {
        let columns = Columns::of(runs);
        let mut csv = csv::Writer::from_writer(w);
        csv.write_record(columns.csv_header()).map_err(fail)?;
        for r in runs {
            csv.write_record(csv_row(r, &columns)).map_err(fail)?;
        }
        csv.flush().map_err(|e| format!("{}: {e}", path.display()))
    })
}

/// A value of a per-frame row: `frames.csv` writes it as text, the sweep store with its type.
#[derive(Clone, Debug, PartialEq)]
pub enum Cell {
    Int(i64),
    Real(f64),
    Text(String),
    /// Not measured (e.g. no reference run): an empty CSV field, NULL in the store.
    Empty,
}

impl Cell {
    fn csv(&self) -> String {
        match self {
            Cell::Int(v) => v.to_string(),
            Cell::Real(v) => v.to_string(),
            Cell::Text(v) => v.clone(),
            Cell::Empty => String::new(),
        }
    }

    fn int(v: u64) -> Cell {
        i64::try_from(v).map_or(Cell::Real(v as f64), Cell::Int)
    }

    fn opt(v: Option<f64>) -> Cell {
        v.map_or(Cell::Empty, Cell::Real)
    }
}

/// The counters a back-end adds to a frame (`dais`, `reprojection`), as `dais_FIELD` and
/// `repro_FIELD` columns.
fn frame_extras(frame: &FrameResult) -> Vec<(String, u64)> {
    let mut out = Vec::new();
    let mut add = |prefix: &str, value: serde_json::Result<serde_json::Value>| {
        if let Ok(serde_json::Value::Object(fields)) = value {
            for (field, v) in fields {
                match v {
                    serde_json::Value::Object(inner) => out.extend(
                        inner
                            .iter()
                            .filter_map(|(sub, v)| Some((format!("{prefix}_{field}_{sub}"), v.as_u64()?))),
                    ),
                    v => out.extend(v.as_u64().map(|n| (format!("{prefix}_{field}"), n))),
                }
            }
        }
    };
    if let Some(d) = &frame.dais {
        add("dais", serde_json::to_value(d));
    }
    if let Some(r) = &frame.reprojection {
        add("repro", serde_json::to_value(r));
    }
    out
}

/// The extra columns any frame of `runs` reports, sorted.
pub fn extra_names<'a>(runs: impl IntoIterator<Item = &'a RunResult>) -> Vec<String> {
    let mut names = std::collections::BTreeSet::new();
    for r in runs {
        for frame in &r.frames {
            names.extend(frame_extras(frame).into_iter().map(|(name, _)| name));
        }
    }
    names.into_iter().collect()
}

/// The columns of `frames.csv` for runs that report `stages`, traffic `classes` and back-end
/// counters `extras` (README, Output files).
pub fn frame_header(stages: &[String], classes: &[String], extras: &[String]) -> Vec<String> {
    let mut header: Vec<String> = ["preset", "scheduler", "scheme", "frame", "eye", "issued"]
        .map(String::from)
        .to_vec();
    header.extend(stages.iter().map(|s| format!("{s}_issued")));
    header.extend(
        [
            "relative_cost_pct",
            "simd_utilization_pct",
            "ssim",
            "ssim_covered",
            "psnr_db",
            "max_abs_error",
            "fragments_shaded",
            "pixels_covered",
        ]
        .map(String::from),
    );
    header.extend(classes.iter().map(|c| format!("frame_{c}_bytes")));
    header.extend(extras.iter().cloned());
    header
}

/// One row per frame and view of `r`, in [`frame_header`]'s columns.
pub fn frame_rows(r: &RunResult, stages: &[String], classes: &[String], extras: &[String]) -> Vec<Vec<Cell>> {
    let mut rows = Vec::new();
    for frame in &r.frames {
        let reported = frame_extras(frame);
        for view in &frame.views {
            let q = view.quality;
            let mut row = vec![
                Cell::Text(r.preset.clone()),
                Cell::Text(r.scheduler.clone()),
                Cell::Text(r.scheme.clone()),
                Cell::Int(i64::from(frame.frame)),
                Cell::Text(view.eye.clone()),
                Cell::int(view.cost.issued()),
            ];
            row.extend(stages.iter().map(|s| Cell::int(view.cost.stage(s).issued())));
            row.extend([
                Cell::opt(view.relative_cost.map(|c| 100.0 * c)),
                Cell::Real(100.0 * view.cost.simd_utilization()),
                Cell::opt(q.and_then(|q| q.ssim)),
                Cell::opt(q.and_then(|q| q.ssim_covered)),
                Cell::opt(q.and_then(|q| q.psnr_db)),
                q.map_or(Cell::Empty, |q| Cell::Int(i64::from(q.max_abs_error))),
                Cell::int(view.raster.fragments_shaded),
                Cell::int(view.raster.pixels_covered),
            ]);
            row.extend(classes.iter().map(|c| Cell::int(frame.traffic.bytes(c))));
            row.extend(extras.iter().map(|name| {
                reported
                    .iter()
                    .find(|(n, _)| n == name)
                    .map_or(Cell::Empty, |&(_, v)| Cell::int(v))
            }));
            rows.push(row);
        }
    }
    rows
}

/// Writes `frames.csv` at `path`: one row per run, frame and view, with the view's counters,
/// relative cost and quality, and the frame's DRAM bytes per class (shared by its two views,
/// so they repeat on both rows).
pub fn write_frames_csv(path: &Path, runs: &[&RunResult]) -> Result<(), String> {
    let fail = |e: csv::Error| format!("{}: {e}", path.display());
    let columns = Columns::of(runs);
    write_atomically(path, |w| {
        let mut csv = csv::Writer::from_writer(w);
        csv.write_record(frame_header(&columns.stages, &columns.classes, &columns.extras))
            .map_err(fail)?;
        for r in runs {
            for row in frame_rows(r, &columns.stages, &columns.classes, &columns.extras) {
                csv.write_record(row.iter().map(Cell::csv)).map_err(fail)?;
            }
        }
        csv.flush().map_err(|e| format!("{}: {e}", path.display()))
    })
}

/// The summary as an aligned text table (header line, then one line per run).
pub fn table(runs: &[&RunResult]) -> String {
    let header = TABLE_HEADER.map(String::from);
    let rows: Vec<Vec<String>> = runs.iter().map(|r| table_row(r)).collect();
    let widths: Vec<usize> = (0..header.len())
        .map(|c| rows.iter().map(|r| r[c].len()).fold(header[c].len(), usize::max))
        .collect();
    let line = |cells: &[String]| {
        let padded: Vec<String> = cells
            .iter()
            .zip(&widths)
            .enumerate()
            .map(|(c, (cell, &w))| {
                if c < TEXT_COLUMNS {
                    format!("{cell:<w$}")
                } else {
                    format!("{cell:>w$}")
                }
            })
            .collect();
        padded.join("  ").trim_end().to_string()
    };
    let mut out = line(&header);
    for row in &rows {
        out.push('\n');
        out.push_str(&line(row));
    }
    out
}

/// Lowest PSNR over all frames and views; None when every view is identical to the
/// reference (infinite PSNR) or no quality was measured.
fn min_psnr(r: &RunResult) -> Option<f64> {
    r.frames
        .iter()
        .flat_map(|f| &f.views)
        .filter_map(|v| v.quality?.psnr_db)
        .reduce(f64::min)
}

/// Whether the run was compared with the reference at all.
fn measured(r: &RunResult) -> bool {
    r.frames.iter().flat_map(|f| &f.views).any(|v| v.quality.is_some())
}

/// Binning list statistics summed over frames.
fn lists(r: &RunResult) -> ListStats {
    r.frames.iter().fold(ListStats::default(), |mut sum, f| {
        sum.tile_entries += f.lists.tile_entries;
        sum.tile_list_bytes += f.lists.tile_list_bytes;
        sum.tile_pair_entries += f.lists.tile_pair_entries;
        sum.tile_pair_list_bytes += f.lists.tile_pair_list_bytes;
        sum
    })
}

fn opt(v: Option<f64>, f: impl Fn(f64) -> String) -> String {
    v.map_or_else(String::new, f)
}

fn csv_row(r: &RunResult, columns: &Columns) -> Vec<String> {
    let t = &r.total;
    let tr = &t.traffic;
    let l = lists(r);
    let mut row = vec![
        r.preset.clone(),
        r.scheduler.clone(),
        r.scheme.clone(),
        r.frames.len().to_string(),
        t.cost.issued().to_string(),
    ];
    row.extend(columns.stages.iter().map(|s| t.cost.stage(s).issued().to_string()));
    row.extend([
        opt(t.relative_cost, |c| (100.0 * c).to_string()),
        (100.0 * t.cost.simd_utilization()).to_string(),
        opt(t.min_ssim, |s| s.to_string()),
        opt(t.min_ssim_covered, |s| s.to_string()),
        opt(min_psnr(r), |p| p.to_string()),
    ]);
    row.extend(columns.classes.iter().map(|c| tr.bytes(c).to_string()));
    row.extend([
        tr.total().to_string(),
        l.tile_entries.to_string(),
        l.tile_list_bytes.to_string(),
        l.tile_pair_entries.to_string(),
        l.tile_pair_list_bytes.to_string(),
        r.timing.wall_s.to_string(),
        (r.timing.pixels_per_s / 1e6).to_string(),
    ]);
    row
}

/// The terminal table's columns: what one compares at a glance, within 100 columns; the
/// counters per stage, traffic per class and list sizes are in `summary.csv`.
const TABLE_HEADER: [&str; 9] = [
    "preset", "frames", "rel.cost", "SIMD", "min SSIM", "covered", "min PSNR", "DRAM MiB", "wall s",
];

fn table_row(r: &RunResult) -> Vec<String> {
    let t = &r.total;
    vec![
        r.preset.clone(),
        r.frames.len().to_string(),
        t.relative_cost
            .map_or_else(|| "-".to_string(), |c| format!("{:.2}%", 100.0 * c)),
        format!("{:.1}%", 100.0 * t.cost.simd_utilization()),
        t.min_ssim.map_or_else(|| "-".to_string(), |s| format!("{s:.6}")),
        t.min_ssim_covered
            .map_or_else(|| "-".to_string(), |s| format!("{s:.6}")),
        match min_psnr(r) {
            Some(p) => format!("{p:.2}"),
            None if measured(r) => "inf".to_string(),
            None => "-".to_string(),
        },
        format!("{:.2}", t.traffic.total() as f64 / (1024.0 * 1024.0)),
        format!("{:.2}", r.timing.wall_s),
    ]
}
