//! Model only what the scene requires: drop materials no mesh uses, textures no kept
//! material samples, and uvs of meshes whose material samples no texture.

use shadetrace_formats::{MaterialMaps, Scene};

/// Removes unused materials and textures (renumbering references, order kept) and
/// strips uvs that no texture lookup will read.
pub fn prune(scene: &mut Scene) {
    let mut material_used = vec![false; scene.materials.len()];
    for mesh in &scene.geometry.meshes {
        if let Some(used) = material_used.get_mut(mesh.material as usize) {
            *used = true;
        }
    }
    let material_map = compact(&mut scene.materials, &material_used);
    let maps = &mut scene.surface_maps;
    if !maps.materials.is_empty() {
        compact(&mut maps.materials, &material_used);
    }
    for mesh in &mut scene.geometry.meshes {
        // Out-of-range references are left for trace validation to report.
        if let Some(Some(new)) = material_map.get(mesh.material as usize) {
            mesh.material = *new;
        }
    }

    let mut texture_used = vec![false; scene.textures.len()];
    let used_by_maps = scene.surface_maps.materials.iter().flat_map(map_textures);
    for t in scene
        .materials
        .iter()
        .filter_map(|m| m.base_color_texture)
        .chain(used_by_maps)
    {
        if let Some(used) = texture_used.get_mut(t as usize) {
            *used = true;
        }
    }
    let texture_map = compact(&mut scene.textures, &texture_used);
    // Out-of-range references are left for trace validation to report.
    let renumber = |t: &mut u32| {
        if let Some(Some(new)) = texture_map.get(*t as usize) {
            *t = *new;
        }
    };
    for material in &mut scene.materials {
        if let Some(t) = &mut material.base_color_texture {
            renumber(t);
        }
    }
    let maps = &mut scene.surface_maps;
    for m in &mut maps.materials {
        m.normal.iter_mut().for_each(|n| renumber(&mut n.0));
        m.metallic_roughness.iter_mut().for_each(|r| renumber(&mut r.0));
        m.occlusion.iter_mut().for_each(|o| renumber(&mut o.0));
        m.emissive_texture.iter_mut().for_each(renumber);
    }
    maps.linear_textures
        .retain(|&t| texture_used.get(t as usize).copied().unwrap_or(true));
    maps.linear_textures.iter_mut().for_each(renumber);

    if scene.surface_maps.is_empty() {
        scene.surface_maps = Default::default();
    }
    for mesh in &mut scene.geometry.meshes {
        let m = mesh.material;
        let textured = scene
            .materials
            .get(m as usize)
            .is_some_and(|m| m.base_color_texture.is_some())
            || map_textures(scene.surface_maps.of(m)).next().is_some();
        if !textured {
            mesh.uvs = Vec::new();
        }
    }
}

/// The textures a material's maps sample.
fn map_textures(m: &MaterialMaps) -> impl Iterator<Item = u32> {
    [
        m.normal.map(|n| n.0),
        m.metallic_roughness.map(|r| r.0),
        m.occlusion.map(|o| o.0),
        m.emissive_texture,
    ]
    .into_iter()
    .flatten()
}

/// Keeps the items whose flag is set and returns the old-to-new index map.
fn compact<T>(items: &mut Vec<T>, keep: &[bool]) -> Vec<Option<u32>> {
    let mut map = Vec::with_capacity(items.len());
    let mut next = 0u32;
    for &k in keep {
        map.push(k.then(|| {
            next += 1;
            next - 1
        }));
    }
    let mut flags = keep.iter();
    items.retain(|_| *flags.next().expect("one flag per item"));
    map
}

#[cfg(test)]
mod tests {
    use super::*;
    use shadetrace_formats::{AlphaMode, Geometry, Material, Mesh, Texture, Wrap};

    fn material(name: &str, texture: Option<u32>) -> Material {
        Material {
            name: name.into(),
            base_color: [1.0; 4],
            base_color_texture: texture,
            specular_exponent: 1.0,
            specular_strength: 0.0,
            alpha: AlphaMode::Opaque,
            double_sided: false,
        }
    }

    fn texture(name: &str) -> Texture {
        Texture {
            name: name.into(),
            width: 1,
            height: 1,
            wrap_u: Wrap::Repeat,
            wrap_v: Wrap::Repeat,
            rgba8: vec![0; 4],
        }
    }

    #[test]
    fn drops_unused_and_renumbers() {
        let mesh = |material, uvs: usize| Mesh {
            material,
            uvs: vec![glam::Vec2::ZERO; uvs],
            ..Mesh::default()
        };
        let mut scene = Scene {
            geometry: Geometry {
                meshes: vec![mesh(2, 3), mesh(3, 3)],
            },
            materials: vec![
                material("unused", Some(0)),
                material("also-unused", None),
                material("textured", Some(2)),
                material("plain", None),
            ],
            textures: vec![texture("a"), texture("b"), texture("c")],
            lights: vec![],
            surface_maps: Default::default(),
        };
        prune(&mut scene);
        let names: Vec<_> = scene.materials.iter().map(|m| m.name.as_str()).collect();
        assert_eq!(names, ["textured", "plain"]);
        assert_eq!(scene.textures.len(), 1);
        assert_eq!(scene.textures[0].name, "c");
        assert_eq!(scene.materials[0].base_color_texture, Some(0));
        assert_eq!(scene.geometry.meshes[0].material, 0);
        assert_eq!(scene.geometry.meshes[1].material, 1);
        assert_eq!(scene.geometry.meshes[0].uvs.len(), 3);
        assert!(scene.geometry.meshes[1].uvs.is_empty());
    }
}
