//! Built-in procedural scenes, addressed as `builtin:NAME` or `builtin:NAME?key=value`.

mod builder;
mod dragon;
mod rng;
mod scenes;
mod sphere;
mod texture;

use shadetrace_formats::Source;

use crate::camera_path::Orbit;
use crate::error::{Error, Result};
use crate::source::{NoMotion, SourceScene};

pub use scenes::SPHERE_LEVELS;

/// Names of the built-in scenes with a one-line description each.
pub const BUILTIN_SCENES: [(&str, &str); 6] = [
    ("floor", "textured floor of large triangles with shadow-casting boxes"),
    ("spheres", "five textured specular spheres at tessellation levels 2..32 quads/patch, with patch ids (?subdiv=0..6 for one level)"),
    ("hairball", "ball of thin ribbons of tiny triangles (a few pixels each)"),
    ("depth-stack", "six staggered fence layers in front of a wall: overdraw and disocclusions"),
    ("light-room", "closed room lit by 48 point lights, no shadowed light (?lights=0..1024: a 3D grid of N shorter-ranged lights)"),
    ("arena", "the tile-pair paper's regime: a sunlit, open-topped arena of large textured triangles with a skinned dragon, seen from inside"),
];

/// Largest `subdiv` of the spheres scene (64 quads per patch edge, ~200K triangles each).
const MAX_SUBDIV: u32 = 6;
/// Most lights of `light-room?lights=N` (the light-count study's range, as RTR4 §20.4's).
const MAX_LIGHTS: u32 = 1024;

/// Builds a built-in scene from `NAME` or `NAME?key=value&...` (the part after `builtin:`).
pub fn build(spec: &str) -> Result<(SourceScene, Orbit)> {
    let (name, params) = spec.split_once('?').unwrap_or((spec, ""));
    let mut subdiv = None;
    let mut lights = None;
    for pair in params.split('&').filter(|p| !p.is_empty()) {
        match pair.split_once('=') {
            Some(("lights", value)) if name == "light-room" => {
                let n: u32 = value
                    .parse()
                    .ok()
                    .filter(|n| *n <= MAX_LIGHTS)
                    .ok_or_else(|| Error::Options(format!("builtin:{spec}: lights must be 0..={MAX_LIGHTS}")))?;
                lights = Some(n);
            }
            Some(("subdiv", value)) if name == "spheres" => {
                let level: u32 = value
                    .parse()
                    .ok()
                    .filter(|&l| l <= MAX_SUBDIV)
                    .ok_or_else(|| Error::Options(format!("builtin:{spec}: subdiv must be 0..={MAX_SUBDIV}")))?;
                subdiv = Some(level);
            }
            _ => return Err(Error::Options(format!("builtin:{spec}: unknown parameter `{pair}`"))),
        }
    }
    let built = match name {
        "floor" => scenes::floor(),
        "spheres" => scenes::spheres(subdiv),
        "hairball" => scenes::hairball(),
        "depth-stack" => scenes::depth_stack(),
        "light-room" => scenes::light_room(lights),
        "arena" => scenes::arena(),
        _ => {
            let names: Vec<&str> = BUILTIN_SCENES.iter().map(|(n, _)| *n).collect();
            return Err(Error::Options(format!(
                "unknown built-in scene `{name}` (available: {})",
                names.join(", ")
            )));
        }
    };
    let source = SourceScene {
        name: name.to_string(),
        source: Source::Builtin {
            name: name.to_string(),
            params: params.to_string(),
        },
        scene: built.scene,
        cameras: Vec::new(),
        motion: if name == "arena" {
            Box::new(dragon::Dragon)
        } else {
            Box::new(NoMotion)
        },
        animation_duration_s: if name == "arena" { dragon::SWIM_PERIOD_S } else { 0.0 },
        warnings: Vec::new(),
    };
    Ok((source, built.orbit))
}
