//! `shadetrace presets`: every preset with its scheduler, scheme and what it models, then the
//! schedulers and schemes that `SCHEDULER+SCHEME` can pair.

use shadetrace_replay::preset::SCHEDULERS;
use shadetrace_replay::scheme::registry::SCHEMES;
use shadetrace_replay::PRESETS;

#[derive(clap::Args)]
pub struct Args {}

pub fn run(_: Args) -> Result<(), String> {
    print!("{}", listing());
    Ok(())
}

fn listing() -> String {
    let width = PRESETS.iter().map(|p| p.name.len()).max().unwrap_or(0);
    let mut out = String::from("presets (scheduler x scheme):\n");
    for p in PRESETS {
        out.push_str(&format!(
            "  {:<width$}  {} x {}: {}\n",
            p.name, p.scheduler, p.scheme, p.description
        ));
    }
    out.push_str(&format!(
        "\nschedulers: {}\n\nschemes (any scheduler+scheme pair is a preset too):\n",
        SCHEDULERS.join(", ")
    ));
    let width = SCHEMES.iter().map(|s| s.name.len()).max().unwrap_or(0);
    for s in SCHEMES {
        out.push_str(&format!("  {:<width$}  {}\n", s.name, s.models));
    }
    out
}

#[cfg(test)]
mod tests {
    #[test]
    fn lists_every_preset_and_scheme() {
        let text = super::listing();
        for p in shadetrace_replay::PRESETS {
            assert!(text.contains(&format!("{} x {}", p.scheduler, p.scheme)), "{}", p.name);
        }
        for s in shadetrace_replay::scheme::registry::SCHEMES {
            assert!(text.contains(s.models));
        }
    }
}
