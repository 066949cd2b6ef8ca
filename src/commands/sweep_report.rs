//! `shadetrace sweep-report STORE`: a sweep's results summarized per preset and point, and
//! per preset and value of each swept option: the mean, spread and range over frames, views
//! and traces of relative cost and SSIM, as `sweep-summary.csv` and `sweep-report.html` with
//! the cost-quality figure (Pareto front marked) beside it.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::PathBuf;

use rusqlite::types::Value;
use shadetrace_formats::atomic_file::{write_atomically, write_bytes_atomically};

use crate::report::escape;
use crate::report::figure::{self, CostQuality};
use crate::sweep::store::{csv_text, Store};

#[derive(clap::Args)]
pub struct Args {
    /// A sweep's store (sweep.db, a shard's, or a merged one).
    store: PathBuf,
    /// Output folder (default: the store's).
    #[arg(short, long)]
    out: Option<PathBuf>,
    #[arg(short, long)]
    quiet: bool,
}

/// Mean, population standard deviation, minimum and maximum of some values.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Spread {
    mean: f64,
    std: f64,
    min: f64,
    max: f64,
}

impl Spread {
    fn of(values: &[f64]) -> Option<Spread> {
        if values.is_empty() {
            return None;
        }
        let n = values.len() as f64;
        let mean = values.iter().sum::<f64>() / n;
        let var = values.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / n;
        Some(Spread {
            mean,
            std: var.sqrt(),
            min: values.iter().copied().fold(f64::INFINITY, f64::min),
            max: values.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        })
    }
}

/// The rows of one summary line: what they share, and their cost and SSIM values.
#[derive(Default)]
struct Bucket {
    rows: u64,
    traces: Vec<String>,
    cost: Vec<f64>,
    ssim: Vec<f64>,
}

/// One summary line: grouped `by` ("point" or an option), for `preset` at `value`.
struct Line {
    by: String,
    preset: String,
    value: String,
    bucket: Bucket,
}

pub fn run(args: Args) -> Result<(), String> {
    let store = Store::open_existing(&args.store)?;
    let (columns, rows) = store.frame_table()?;
    let col = |name: &str| columns.iter().position(|c| c == name);
    let need = |name: &str| col(name).ok_or_else(|| format!("{}: no `{name}` column", args.store.display()));
    let (preset, point, trace) = (need("preset")?, need("point")?, need("trace")?);
    let (cost, ssim) = (col("relative_cost_pct"), col("ssim"));
    let options: Vec<(String, usize)> = columns
        .iter()
        .enumerate()
        .filter_map(|(i, c)| c.strip_prefix("opt_").map(|o| (o.to_string(), i)))
        .collect();

    // Lines in the order their first row appears (the spec's order).
    let mut lines: Vec<Line> = Vec::new();
    let mut index: BTreeMap<(String, String, String), usize> = BTreeMap::new();
    let real = |row: &[Value], i: Option<usize>| match i.map(|i| &row[i]) {
        Some(Value::Real(v)) => Some(*v),
        Some(Value::Integer(v)) => Some(*v as f64),
        _ => None,
    };
    for row in &rows {
        let p = csv_text(&row[preset]);
        let mut keys = vec![("point".to_string(), csv_text(&row[point]))];
        keys.extend(
            options
                .iter()
                .filter(|(_, i)| row[*i] != Value::Null)
                .map(|(o, i)| (o.clone(), csv_text(&row[*i]))),
        );
        for (by, value) in keys {
            let key = (by.clone(), p.clone(), value.clone());
            let at = *index.entry(key).or_insert_with(|| {
                lines.push(Line {
                    by,
                    preset: p.clone(),
                    value,
                    bucket: Bucket::default(),
                });
                lines.len() - 1
            });
            let b = &mut lines[at].bucket;
            b.rows += 1;
            let t = csv_text(&row[trace]);
            if !b.traces.contains(&t) {
                b.traces.push(t);
            }
            b.cost.extend(real(row, cost));
            b.ssim.extend(real(row, ssim));
        }
    }
    // Options grouped together in the CSV and the page: points first, then each option.
    lines.sort_by_key(|l| (l.by != "point", l.by.clone()));

    let out = args
        .out
        .clone()
        .unwrap_or_else(|| args.store.parent().map(PathBuf::from).unwrap_or_default());
    std::fs::create_dir_all(&out).map_err(|e| format!("{}: {e}", out.display()))?;
    let csv_path = out.join("sweep-summary.csv");
    let fail = |e: csv::Error| format!("{}: {e}", csv_path.display());
    write_atomically(&csv_path, |w| {
        let mut csv = csv::Writer::from_writer(w);
        csv.write_record([
            "by",
            "preset",
            "value",
            "rows",
            "traces",
            "relative_cost_pct_mean",
            "relative_cost_pct_std",
            "relative_cost_pct_min",
            "relative_cost_pct_max",
            "ssim_mean",
            "ssim_std",
            "ssim_min",
            "ssim_max",
        ])
        .map_err(fail)?;
        for l in &lines {
            let mut record = vec![
                l.by.clone(),
                l.preset.clone(),
                l.value.clone(),
                l.bucket.rows.to_string(),
                l.bucket.traces.len().to_string(),
            ];
            for spread in [Spread::of(&l.bucket.cost), Spread::of(&l.bucket.ssim)] {
                record.extend(match spread {
                    Some(s) => [s.mean, s.std, s.min, s.max].map(|v| v.to_string()),
                    None => Default::default(),
                });
            }
            csv.write_record(&record).map_err(fail)?;
        }
        csv.flush().map_err(|e| format!("{}: {e}", csv_path.display()))
    })?;

    // The figure: one point per preset and point, mean cost against the lowest SSIM.
    let points: Vec<(String, f64, f64)> = lines
        .iter()
        .filter(|l| l.by == "point")
        .filter_map(|l| {
            let (c, s) = (Spread::of(&l.bucket.cost)?, Spread::of(&l.bucket.ssim)?);
            Some((format!("{} {}", l.preset, l.value), c.mean, s.min))
        })
        .collect();
    let plot = figure::render(&CostQuality {
        points: &points,
        joined: false,
    })?;
    write_bytes_atomically(&out.join("sweep-cost-quality.svg"), plot.svg.as_bytes())?;
    write_bytes_atomically(&out.join("sweep-cost-quality.png"), &plot.png)?;

    let mut h = String::new();
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>sweep report</title>\n\
         <style>body{{font-family:sans-serif;margin:1.5em}}table{{border-collapse:collapse;font-size:.9em}}\
         th,td{{border:1px solid #bbb;padding:.2em .5em}}td{{text-align:right}}td:nth-child(-n+2){{text-align:left}}</style>\n\
         </head>\n<body>\n<h1>Sweep report: {}</h1>\n<p>{} jobs, {} rows (frames x views). Relative cost in % of \
         <code>forward</code> at the same point; mean ± standard deviation [min, max] over frames, views and traces.</p>\n\
         <h2>Cost against quality</h2>\n<figure>{}<figcaption>Mean relative cost against the lowest SSIM of each preset \
         and point; the Pareto front is joined. <a href=\"sweep-cost-quality.svg\">svg</a>, \
         <a href=\"sweep-cost-quality.png\">png</a></figcaption></figure>\n",
        escape(&args.store.display().to_string()),
        store.job_count()?,
        rows.len(),
        figure::inline(&plot)
    );
    let mut current = String::new();
    for l in &lines {
        if l.by != current {
            if !current.is_empty() {
                h.push_str("</tbody></table>\n");
            }
            current = l.by.clone();
            let title = if current == "point" {
                "Per preset and point".to_string()
            } else {
                format!("Per preset and value of <code>{}</code>", escape(&current))
            };
            let _ = write!(
                h,
                "<h2>{title}</h2>\n<table><thead><tr><th>preset</th><th>value</th><th>rows</th><th>traces</th>\
                 <th>relative cost</th><th>SSIM</th></tr></thead><tbody>\n"
            );
        }
        let cell = |s: Option<Spread>, digits: usize| {
            s.map_or("-".to_string(), |s| {
                format!(
                    "{:.d$} ± {:.d$} [{:.d$}, {:.d$}]",
                    s.mean,
                    s.std,
                    s.min,
                    s.max,
                    d = digits
                )
            })
        };
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            escape(&l.preset),
            escape(&l.value),
            l.bucket.rows,
            l.bucket.traces.len(),
            cell(Spread::of(&l.bucket.cost), 2),
            cell(Spread::of(&l.bucket.ssim), 6)
        );
    }
    if !current.is_empty() {
        h.push_str("</tbody></table>\n");
    }
    h.push_str("</body>\n</html>\n");
    let html = out.join("sweep-report.html");
    write_bytes_atomically(&html, h.as_bytes())?;
    if !args.quiet {
        println!("wrote {} and {}", csv_path.display(), html.display());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spread_is_mean_std_and_range() {
        let s = Spread::of(&[1.0, 3.0]).unwrap();
        assert_eq!(
            s,
            Spread {
                mean: 2.0,
                std: 1.0,
                min: 1.0,
                max: 3.0
            }
        );
        assert!(Spread::of(&[]).is_none());
    }
}
