//! Structural checks run on every trace read and written, so that replay can index
//! without bounds surprises and never sees NaN geometry.

use glam::{Mat4, Vec2, Vec3};

use crate::error::{Error, Result};
use crate::schema::{Counts, Frame, LightKind, Meta, Motion, Scene, SurfaceMaps};

fn invalid(msg: String) -> Error {
    Error::Invalid(msg)
}

fn finite3(v: &[Vec3]) -> bool {
    v.iter().all(|p| p.is_finite())
}

fn finite2(v: &[Vec2]) -> bool {
    v.iter().all(|p| p.is_finite())
}

pub fn check_meta(meta: &Meta) -> Result<()> {
    let c = &meta.capture;
    if c.eye_width == 0 || c.eye_height == 0 {
        return Err(invalid(format!(
            "eye resolution {}x{} is empty",
            c.eye_width, c.eye_height
        )));
    }
    if !c.ipd_m.is_finite() || c.ipd_m < 0.0 {
        return Err(invalid(format!(
            "IPD {} m is not a finite non-negative number",
            c.ipd_m
        )));
    }
    let finite_bounds = meta.bounds.min.is_finite() && meta.bounds.max.is_finite();
    if !(meta.bounds.is_empty() || finite_bounds) {
        return Err(invalid("scene bounds are not finite".into()));
    }
    if meta.counts.frames != c.frames {
        return Err(invalid(format!(
            "meta counts {} frames but capture settings say {}",
            meta.counts.frames, c.frames
        )));
    }
    Ok(())
}

/// The `SurfaceMaps` chunk against the scene: it has a map (a writer leaves an empty one
/// out), textures exist, factors are finite, no normal map is on a skinned mesh (frames
/// carry no skinned tangents), and there is one tangent list per mesh with one unit
/// tangent per vertex exactly where a normal map needs them.
fn check_surface_maps(scene: &Scene) -> Result<()> {
    let maps = &scene.surface_maps;
    if *maps == SurfaceMaps::default() {
        return Ok(());
    }
    if maps.is_empty() {
        return Err(invalid(
            "surface maps without a single map (a writer leaves the chunk out)".to_string(),
        ));
    }
    let textures = scene.textures.len();
    if maps.materials.len() != scene.materials.len() {
        return Err(invalid(format!(
            "surface maps for {} materials, but the scene has {}",
            maps.materials.len(),
            scene.materials.len()
        )));
    }
    if let Some(t) = maps.linear_textures.iter().find(|&&t| t as usize >= textures) {
        return Err(invalid(format!("surface maps name missing texture {t} as linear")));
    }
    for (i, m) in maps.materials.iter().enumerate() {
        let what = |msg: String| invalid(format!("surface maps of material {i}: {msg}"));
        let used = [
            m.normal.map(|n| n.0),
            m.metallic_roughness.map(|r| r.0),
            m.occlusion.map(|o| o.0),
            m.emissive_texture,
        ];
        if let Some(t) = used.into_iter().flatten().find(|&t| t as usize >= textures) {
            return Err(what(format!("texture {t} does not exist")));
        }
        let factors = [
            m.normal.map_or(0.0, |n| n.1),
            m.metallic_roughness.map_or(0.0, |r| r.1),
            m.metallic_roughness.map_or(0.0, |r| r.2),
            m.occlusion.map_or(0.0, |o| o.1),
        ];
        if !factors.iter().chain(&m.emissive).all(|f| f.is_finite()) {
            return Err(what("non-finite factor".to_string()));
        }
    }
    let meshes = &scene.geometry.meshes;
    if maps.tangents.len() != meshes.len() {
        return Err(invalid(format!(
            "surface maps hold tangents for {} meshes, but the scene has {}",
            maps.tangents.len(),
            meshes.len()
        )));
    }
    for (i, (mesh, tangents)) in meshes.iter().zip(&maps.tangents).enumerate() {
        let needs = maps.of(mesh.material).normal.is_some();
        if needs && matches!(mesh.motion, Motion::Skinned { .. }) {
            return Err(invalid(format!(
                "mesh {i} ({}) is skinned but its material has a normal map (frames carry no skinned tangents)",
                mesh.name
            )));
        }
        let ok = if needs {
            tangents.len() == mesh.positions.len()
                && tangents
                    .iter()
                    .all(|t| t.is_finite() && (t.truncate().length() - 1.0).abs() < 1e-3)
        } else {
            tangents.is_empty()
        };
        if !ok {
            return Err(invalid(format!(
                "mesh {i} ({}): tangents must be one finite unit vector per vertex exactly when its material has a normal map",
                mesh.name
            )));
        }
    }
    Ok(())
}

/// Checks the static chunks against each other and against the counts in `Meta`.
pub fn check_scene(scene: &Scene, counts: &Counts) -> Result<()> {
    let expected = scene.counts(counts.frames);
    if &expected != counts {
        return Err(invalid(format!(
            "meta counts do not match the chunks (meta {counts:?}, chunks {expected:?})"
        )));
    }
    for (i, tex) in scene.textures.iter().enumerate() {
        let want = tex.width as u64 * tex.height as u64 * 4;
        if tex.width == 0 || tex.height == 0 || tex.rgba8.len() as u64 != want {
            return Err(invalid(format!(
                "texture {i} ({}) is {}x{} but holds {} bytes",
                tex.name,
                tex.width,
                tex.height,
                tex.rgba8.len()
            )));
        }
    }
    for (i, mat) in scene.materials.iter().enumerate() {
        if let Some(t) = mat.base_color_texture {
            if t as usize >= scene.textures.len() {
                return Err(invalid(format!("material {i} ({}) uses missing texture {t}", mat.name)));
            }
        }
        if !(mat.base_color.iter().all(|c| c.is_finite())
            && mat.specular_exponent.is_finite()
            && mat.specular_strength.is_finite())
        {
            return Err(invalid(format!(
                "material {i} ({}) has non-finite parameters",
                mat.name
            )));
        }
    }
    check_surface_maps(scene)?;
    for (i, mesh) in scene.geometry.meshes.iter().enumerate() {
        let what = |msg: &str| invalid(format!("mesh {i} ({}): {msg}", mesh.name));
        let n = mesh.positions.len();
        if mesh.indices.len() % 3 != 0 {
            return Err(what("index count is not a multiple of 3"));
        }
        if let Some(bad) = mesh.indices.iter().find(|&&ix| ix as usize >= n) {
            return Err(what(&format!("index {bad} out of range ({n} vertices)")));
        }
        if mesh.normals.len() != n {
            return Err(what("normal count differs from position count"));
        }
        if !mesh.uvs.is_empty() && mesh.uvs.len() != n {
            return Err(what("uv count differs from position count"));
        }
        if !mesh.patch_ids.is_empty() && mesh.patch_ids.len() != mesh.triangle_count() {
            return Err(what("patch id count differs from triangle count"));
        }
        if !(finite3(&mesh.positions) && finite3(&mesh.normals) && finite2(&mesh.uvs)) {
            return Err(what("non-finite vertex attribute (NaN or Inf)"));
        }
        if mesh.material as usize >= scene.materials.len() {
            return Err(what(&format!("material {} does not exist", mesh.material)));
        }
    }
    let mut skinned: Vec<u32> = scene
        .geometry
        .meshes
        .iter()
        .filter_map(|m| match m.motion {
            Motion::Skinned { slot } => Some(slot),
            _ => None,
        })
        .collect();
    skinned.sort_unstable();
    if skinned.iter().enumerate().any(|(i, &s)| s as usize != i) {
        return Err(invalid("skinned slots are not 0..n, one per mesh".into()));
    }
    let mut shadowed = 0;
    for (i, light) in scene.lights.iter().enumerate() {
        let finite = light.color.is_finite()
            && light.intensity.is_finite()
            && match light.kind {
                LightKind::Directional { direction } => direction.is_finite() && direction.length() > 0.0,
                LightKind::Point { position, range } => position.is_finite() && range.is_none_or(f32::is_finite),
                LightKind::Spot {
                    position,
                    direction,
                    inner_cone,
                    outer_cone,
                    range,
                } => {
                    position.is_finite()
                        && direction.is_finite()
                        && inner_cone.is_finite()
                        && outer_cone.is_finite()
                        && range.is_none_or(f32::is_finite)
                }
            };
        if !finite {
            return Err(invalid(format!("light {i} ({}) has non-finite parameters", light.name)));
        }
        if light.shadowed {
            shadowed += 1;
            if !matches!(light.kind, LightKind::Directional { .. }) {
                return Err(invalid(format!(
                    "light {i} ({}) is shadowed but not directional",
                    light.name
                )));
            }
        }
    }
    if shadowed > 1 {
        return Err(invalid(format!("{shadowed} shadowed lights; at most one is supported")));
    }
    Ok(())
}

/// Checks one frame against the counts in `Meta`.
pub fn check_frame(frame: &Frame, counts: &Counts) -> Result<()> {
    let r = &frame.rig;
    let what = |msg: String| invalid(format!("frame {}: {msg}", frame.index));
    let finite = r.head.position.is_finite()
        && r.head.orientation.is_finite()
        && r.ipd_m.is_finite()
        && r.yfov.is_finite()
        && r.near.is_finite()
        && r.far.is_finite()
        && r.convergence_m.is_finite();
    if !finite {
        return Err(what("stereo rig has non-finite parameters".into()));
    }
    if r.eye_width == 0 || r.eye_height == 0 {
        return Err(what(format!(
            "eye resolution {}x{} is empty",
            r.eye_width, r.eye_height
        )));
    }
    if !(r.near > 0.0 && r.far > r.near && r.yfov > 0.0 && r.yfov < std::f32::consts::PI)
        || r.ipd_m < 0.0
        || r.convergence_m <= 0.0
    {
        return Err(what(format!(
            "stereo rig out of range (near {}, far {}, yfov {}, ipd {}, convergence {})",
            r.near, r.far, r.yfov, r.ipd_m, r.convergence_m
        )));
    }
    if frame.rigid_transforms.len() != counts.rigid_slots as usize {
        return Err(what(format!(
            "{} rigid transforms, meta says {}",
            frame.rigid_transforms.len(),
            counts.rigid_slots
        )));
    }
    if !frame.rigid_transforms.iter().all(Mat4::is_finite) {
        return Err(what("non-finite rigid transform".into()));
    }
    if frame.skinned.len() != counts.skinned_slots.len() {
        return Err(what(format!(
            "{} skinned meshes, meta says {}",
            frame.skinned.len(),
            counts.skinned_slots.len()
        )));
    }
    for (slot, (sk, &n)) in frame.skinned.iter().zip(&counts.skinned_slots).enumerate() {
        if sk.positions.len() != n as usize || sk.normals.len() != n as usize {
            return Err(what(format!("skinned slot {slot} has the wrong vertex count")));
        }
        if !(finite3(&sk.positions) && finite3(&sk.normals)) {
            return Err(what(format!("skinned slot {slot} has non-finite vertices")));
        }
    }
    Ok(())
}
