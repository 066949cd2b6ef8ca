//! A sweep's spec file (TOML) and its expansion into jobs. The format (README, Sweeps):
//!
//! ```toml
//! traces = ["traces/floor.strace", "corpus/"]  # files, or folders (their *.strace)
//! presets = ["forward", "tile-pair", "amfs"]
//! frames = "0..2"                # optional: every frame of each trace
//! [options]                      # for every job: any replay flag without its dashes
//! res = "320x360"
//! [grid]                         # the Cartesian product of these lists
//! tile = [8, 16]
//! texture-cache-kb = [8, 32]
//! [[point]]                      # explicit extra points
//! tile = 32
//! ```
//!
//! Every option is parsed by the same clap definition as the command line, so a spec accepts
//! exactly the flags `replay` does, with the same checks. Errors name the spec and the line.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use clap::Parser;
use serde::Deserialize;
use toml::Spanned;

use shadetrace_replay::{Preset, ReplayOptions};

/// A spec, checked and expanded: every (trace, point) with the presets run on it.
pub struct Spec {
    pub traces: Vec<PathBuf>,
    pub presets: Vec<Preset>,
    pub points: Vec<Point>,
}

/// One combination of option values.
#[derive(Clone, Debug)]
pub struct Point {
    /// The values set by the grid or the explicit point, as written (`tile=16 msaa=4`), and
    /// `base` when none are.
    pub label: String,
    /// `(option, value)` as set by the grid or the explicit point, for store columns.
    pub values: Vec<(String, String)>,
    pub options: ReplayOptions,
}

/// A grid key's list of values, with their places in the spec.
type GridValues = Spanned<Vec<Spanned<toml::Value>>>;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSpec {
    traces: Spanned<Vec<Spanned<String>>>,
    presets: Spanned<Vec<Spanned<String>>>,
    frames: Option<Spanned<String>>,
    #[serde(default)]
    options: BTreeMap<Spanned<String>, Spanned<toml::Value>>,
    #[serde(default)]
    grid: BTreeMap<Spanned<String>, GridValues>,
    #[serde(default)]
    point: Vec<Spanned<BTreeMap<Spanned<String>, Spanned<toml::Value>>>>,
}

/// The command line's replay options, for parsing a spec's.
#[derive(Parser)]
#[command(no_binary_name = true)]
struct OptionsCli {
    #[command(flatten)]
    replay: ReplayOptions,
}

/// An option set in the spec: its name, value and line.
#[derive(Clone)]
struct Setting {
    name: String,
    value: toml::Value,
    line: usize,
}

/// Reads, checks and expands the spec at `path`.
pub fn read(path: &Path) -> Result<Spec, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    parse(&text, path)
}

fn parse(text: &str, path: &Path) -> Result<Spec, String> {
    let line_of = |offset: usize| text[..offset.min(text.len())].matches('\n').count() + 1;
    let at = |line: usize, what: String| format!("{}:{line}: {what}", path.display());
    let raw: RawSpec = toml::from_str(text).map_err(|e| {
        let line = e.span().map_or(1, |s| line_of(s.start));
        at(line, e.message().to_string())
    })?;
    let dir = path.parent().unwrap_or(Path::new(""));

    let mut traces = Vec::new();
    for name in raw.traces.get_ref() {
        let line = line_of(name.span().start);
        let file = dir.join(name.get_ref());
        if file.is_dir() {
            let mut found: Vec<PathBuf> = std::fs::read_dir(&file)
                .map_err(|e| at(line, format!("traces: {}: {e}", file.display())))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.extension().is_some_and(|x| x == "strace"))
                .collect();
            if found.is_empty() {
                return Err(at(line, format!("traces: {} holds no .strace file", file.display())));
            }
            found.sort();
            traces.extend(found);
        } else if file.is_file() {
            traces.push(file);
        } else {
            return Err(at(line, format!("traces: {}: no such file or folder", file.display())));
        }
    }
    if traces.is_empty() {
        return Err(at(line_of(raw.traces.span().start), "traces: the list is empty".into()));
    }

    let mut presets: Vec<Preset> = Vec::new();
    for name in raw.presets.get_ref() {
        let line = line_of(name.span().start);
        let preset = Preset::find(name.get_ref()).map_err(|e| at(line, format!("presets: {e}")))?;
        if presets.iter().any(|p| p.label() == preset.label()) {
            return Err(at(line, format!("presets: `{}` is listed twice", name.get_ref())));
        }
        presets.push(preset);
    }
    if presets.is_empty() {
        return Err(at(
            line_of(raw.presets.span().start),
            "presets: the list is empty".into(),
        ));
    }

    let setting = |name: &Spanned<String>, value: &Spanned<toml::Value>| Setting {
        name: name.get_ref().clone(),
        value: value.get_ref().clone(),
        line: line_of(name.span().start),
    };
    let mut base: Vec<Setting> = raw.options.iter().map(|(k, v)| setting(k, v)).collect();
    if let Some(frames) = &raw.frames {
        base.push(Setting {
            name: "frames".into(),
            value: toml::Value::String(frames.get_ref().clone()),
            line: line_of(frames.span().start),
        });
    }
    // Each base option alone, so that a bad one is reported on its own line.
    for s in &base {
        options_of(std::slice::from_ref(s)).map_err(|e| at(s.line, e))?;
    }

    // The grid's Cartesian product (in the spec's key order, last key fastest), then the
    // explicit points.
    let mut combos: Vec<(Vec<Setting>, usize)> = vec![(Vec::new(), 1)];
    let mut grid: Vec<(&Spanned<String>, &GridValues)> = raw.grid.iter().collect();
    grid.sort_by_key(|(k, _)| k.span().start);
    for (name, values) in grid {
        let line = line_of(name.span().start);
        if values.get_ref().is_empty() {
            return Err(at(line, format!("grid: `{}` has no values", name.get_ref())));
        }
        // Each value alone first, so that a bad one is reported on its own line.
        for v in values.get_ref() {
            options_of(&[setting(name, v)]).map_err(|e| at(line_of(v.span().start), e))?;
        }
        combos = combos
            .into_iter()
            .flat_map(|(combo, _)| {
                values.get_ref().iter().map(move |v| {
                    let mut combo = combo.clone();
                    combo.push(setting(name, v));
                    (combo, line_of(v.span().start))
                })
            })
            .collect();
    }
    if raw.grid.is_empty() && !raw.point.is_empty() {
        combos.clear();
    }
    for point in &raw.point {
        let line = line_of(point.span().start);
        let mut settings: Vec<Setting> = point.get_ref().iter().map(|(k, v)| setting(k, v)).collect();
        settings.sort_by_key(|s| s.line);
        combos.push((settings, line));
    }

    let mut points: Vec<Point> = Vec::new();
    let mut hashes: BTreeMap<String, usize> = BTreeMap::new();
    for (combo, line) in combos {
        let mut all = base.clone();
        // A point's value replaces a base option of the same name.
        all.retain(|b| !combo.iter().any(|c| c.name == b.name));
        all.extend(combo.iter().cloned());
        let options = options_of(&all).map_err(|e| at(combo.iter().map(|s| s.line).max().unwrap_or(line), e))?;
        let hash = options.hash();
        if let Some(first) = hashes.insert(hash, line) {
            return Err(at(line, format!("this point repeats the one on line {first}")));
        }
        let values: Vec<(String, String)> = combo.iter().map(|s| (s.name.clone(), text_of(&s.value))).collect();
        let label = if values.is_empty() {
            "base".to_string()
        } else {
            values
                .iter()
                .map(|(k, v)| format!("{k}={v}"))
                .collect::<Vec<_>>()
                .join(" ")
        };
        points.push(Point { label, values, options });
    }
    Ok(Spec {
        traces,
        presets,
        points,
    })
}

/// A TOML value as a command-line value (`16`, `inf`, `320x360`).
fn text_of(value: &toml::Value) -> String {
    match value {
        toml::Value::String(s) => s.clone(),
        toml::Value::Float(f) if f.is_infinite() => if *f > 0.0 { "inf" } else { "-inf" }.to_string(),
        other => other.to_string(),
    }
}

/// The replay options that `settings` give, parsed and checked as on the command line.
fn options_of(settings: &[Setting]) -> Result<ReplayOptions, String> {
    let mut args = Vec::new();
    for s in settings {
        match &s.value {
            toml::Value::Boolean(true) if is_flag(&s.name) => args.push(format!("--{}", s.name)),
            toml::Value::Boolean(false) if is_flag(&s.name) => {}
            toml::Value::Array(_) | toml::Value::Table(_) | toml::Value::Datetime(_) => {
                return Err(format!("option `{}`: give one value (lists belong in [grid])", s.name))
            }
            value => args.push(format!("--{}={}", s.name, text_of(value))),
        }
    }
    let cli = OptionsCli::try_parse_from(&args).map_err(|e| {
        let message = e.to_string();
        let first = message
            .lines()
            .next()
            .unwrap_or("invalid option")
            .trim_start_matches("error: ");
        format!("{first} (a replay option, as `shadetrace replay --help` lists them)")
    })?;
    cli.replay.check()?;
    Ok(cli.replay)
}

/// Whether `--name` is a flag without a value (such as `--z-prepass`).
fn is_flag(name: &str) -> bool {
    OptionsCli::try_parse_from([format!("--{name}")]).is_ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(text: &str) -> Result<Spec, String> {
        let dir = env!("CARGO_MANIFEST_DIR");
        parse(text, &Path::new(dir).join("spec.toml"))
    }

    const HEAD: &str = "traces = [\"traces/floor.strace\"]\npresets = [\"forward\", \"tile-pair\"]\n";

    #[test]
    fn grid_and_points_expand_in_order() {
        let s = spec(&format!(
            "{HEAD}frames = \"0..1\"\n[options]\nres = \"64x72\"\n[grid]\ntile = [8, 16]\nmsaa = [1, 4]\n[[point]]\ntile = 32\n"
        ))
        .unwrap();
        let labels: Vec<&str> = s.points.iter().map(|p| p.label.as_str()).collect();
        assert_eq!(
            labels,
            [
                "tile=8 msaa=1",
                "tile=8 msaa=4",
                "tile=16 msaa=1",
                "tile=16 msaa=4",
                "tile=32"
            ]
        );
        assert!(s
            .points
            .iter()
            .all(|p| p.options.resolution == Some((64, 72)) && p.options.frames == Some((0, 1))));
        assert_eq!(s.points[3].options.msaa, 4);
        assert_eq!(s.points[4].options.tile, 32);
        assert_eq!(spec(HEAD).unwrap().points[0].label, "base");
        let flag = spec(&format!("{HEAD}[grid]\nz-prepass = [false, true]\n")).unwrap();
        assert!(!flag.points[0].options.z_prepass && flag.points[1].options.z_prepass);
    }

    #[test]
    fn bad_specs_are_one_line_errors_naming_the_line() {
        let cases = [
            (format!("{HEAD}[grid]\ntiles = [8]\n"), "spec.toml:4:", "tiles"),
            (format!("{HEAD}[grid]\ntile = []\n"), "spec.toml:4:", "no values"),
            (
                format!("{HEAD}[grid]\ntile = [8, 8]\n"),
                "spec.toml:4:",
                "repeats the one on line 4",
            ),
            (
                format!("{HEAD}[grid]\ntile = [16]\n[[point]]\ntile = 16\n"),
                "spec.toml:5:",
                "repeats",
            ),
            (format!("{HEAD}[options]\nmsaa = 3\n"), "spec.toml:4:", "msaa"),
            (
                "traces = [\"nope.strace\"]\npresets = [\"forward\"]\n".into(),
                "spec.toml:1:",
                "no such file",
            ),
            (
                "traces = [\"traces/floor.strace\"]\npresets = [\"fast\"]\n".into(),
                "spec.toml:2:",
                "fast",
            ),
            (format!("{HEAD}colour = 1\n"), "spec.toml:3:", "colour"),
        ];
        for (text, place, word) in cases {
            let e = spec(&text).err().unwrap_or_else(|| panic!("accepted: {text}"));
            assert!(e.contains(place) && e.contains(word) && !e.contains('\n'), "{e}");
        }
    }
}
