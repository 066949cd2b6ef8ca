//! Triangle primitives: reading their attributes, converting strips and fans to lists,
//! generating or repairing normals, applying the texture transform, and placing them in
//! world space.

use glam::{Mat2, Mat3, Mat4, Vec2, Vec3, Vec4};
use gltf::json::{self, mesh::Semantic, validation::Checked};

use super::data::Reader;
use super::{input, Fallible, Warnings};

/// How a primitive's vertex sequence forms triangles.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum TriangleMode {
    List,
    Strip,
    Fan,
}

/// Triangle list for a vertex sequence, following the glTF spec's definitions (which keep
/// every strip and fan triangle counter-clockwise); an incomplete last triangle is dropped.
pub(super) fn triangle_list(mode: TriangleMode, v: &[u32]) -> Vec<u32> {
    match mode {
        TriangleMode::List => v[..v.len() / 3 * 3].to_vec(),
        TriangleMode::Strip => (0..v.len().saturating_sub(2))
            .flat_map(|i| {
                if i % 2 == 0 {
                    [v[i], v[i + 1], v[i + 2]]
                } else {
                    [v[i], v[i + 2], v[i + 1]]
                }
            })
            .collect(),
        TriangleMode::Fan => (1..v.len().saturating_sub(1))
            .flat_map(|i| [v[i], v[i + 1], v[0]])
            .collect(),
    }
}

/// Up to four joint influences of one vertex. Joint indices point into the skin's joint
/// list.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Influence {
    pub joints: [u32; 4],
    pub weights: [f32; 4],
}

impl Influence {
    /// Weights clamped to be non-negative and scaled to sum to one; all zero when they
    /// sum to zero (the vertex then follows its node). Joints with zero weight are reset
    /// to 0, and any other joint must exist in a skin of `joint_count` joints.
    pub fn normalized(&self, joint_count: usize, label: &str) -> Fallible<Influence> {
        let clamped = self.weights.map(|w| if w.is_finite() { w.max(0.0) } else { 0.0 });
        let sum: f32 = clamped.iter().sum();
        let scale = if sum > 0.0 { 1.0 / sum } else { 0.0 };
        let weights = clamped.map(|w| w * scale);
        let mut joints = self.joints;
        for (joint, &weight) in joints.iter_mut().zip(&weights) {
            if weight == 0.0 {
                *joint = 0;
            } else if *joint as usize >= joint_count {
                return Err(input(format!(
                    "joint {joint} out of range (the skin has {joint_count} joints) in {label}"
                )));
            }
        }
        Ok(Influence { joints, weights })
    }
}

/// KHR_texture_transform: `uv' = T * R * S * uv`, where the spec's rotation matrix
/// `[[cos, sin], [-sin, cos]]` turns UVs clockwise by `rotation` radians.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct UvTransform {
    pub offset: Vec2,
    pub rotation: f32,
    pub scale: Vec2,
}

impl UvTransform {
    pub const IDENTITY: UvTransform = UvTransform {
        offset: Vec2::ZERO,
        rotation: 0.0,
        scale: Vec2::ONE,
    };

    pub fn is_finite(&self) -> bool {
        self.offset.is_finite() && self.rotation.is_finite() && self.scale.is_finite()
    }

    pub fn apply(&self, uv: Vec2) -> Vec2 {
        // glam's from_angle(a) rotates counter-clockwise by `a`, hence the minus.
        Mat2::from_angle(-self.rotation) * (uv * self.scale) + self.offset
    }
}

/// Where a material's base-colour texture takes its UVs from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct UvSource {
    /// `TEXCOORD_n` set (the transform's `texCoord` override when present).
    pub set: u32,
    pub transform: UvTransform,
}

/// A triangle primitive's vertices and triangle list, in mesh space until placed.
#[derive(Clone, Debug, Default, PartialEq)]
pub(super) struct Triangles {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    /// Transformed UVs; empty when the material has no base-colour texture.
    pub uvs: Vec<Vec2>,
    /// Joint influences; empty unless the primitive is skinned.
    pub influences: Vec<Influence>,
    /// Unit tangents with the bitangent's sign in w; empty unless a normal map needs them.
    pub tangents: Vec<Vec4>,
    /// Counter-clockwise triangles.
    pub indices: Vec<u32>,
}

impl Triangles {
    /// Reads a triangle primitive. `label` names it in messages; `uv` says which UV set
    /// the material samples; `skinned` asks for `JOINTS_0`/`WEIGHTS_0`, `tangents` for
    /// tangents (the file's `TANGENT`, or MikkTSpace's).
    #[allow(clippy::too_many_arguments)]
    pub fn read(
        reader: &Reader,
        primitive: &json::mesh::Primitive,
        mode: TriangleMode,
        label: &str,
        uv: Option<UvSource>,
        skinned: bool,
        tangents: bool,
        warnings: &mut Warnings,
    ) -> Fallible<Triangles> {
        let attribute = |semantic: Semantic| primitive.attributes.get(&Checked::Valid(semantic)).copied();
        let read_vec3s = |semantic: Semantic, name: &str| -> Fallible<Option<Vec<Vec3>>> {
            attribute(semantic)
                .map(|a| reader.vec3s(a, &format!("{name} of {label}")))
                .transpose()
        };
        let positions = read_vec3s(Semantic::Positions, "POSITION")?
            .ok_or_else(|| input(format!("missing POSITION in {label}")))?;
        if !positions.iter().all(|p| p.is_finite()) {
            return Err(input(format!("non-finite vertex position in {label}")));
        }
        let n = positions.len();
        let count_u32 = u32::try_from(n).map_err(|_| input(format!("{label} has too many vertices")))?;
        let same_count = |name: &str, len: usize| {
            if len == n {
                Ok(())
            } else {
                Err(input(format!(
                    "{name} of {label} has {len} elements but POSITION has {n}"
                )))
            }
        };

        let normals = read_vec3s(Semantic::Normals, "NORMAL")?;
        if let Some(normals) = &normals {
            same_count("NORMAL", normals.len())?;
        }

        let uvs = match uv {
            None => Vec::new(),
            Some(source) => {
                let name = format!("TEXCOORD_{}", source.set);
                match attribute(Semantic::TexCoords(source.set)) {
                    Some(a) => {
                        let raw = reader.vec2s(a, &format!("{name} of {label}"))?;
                        same_count(&name, raw.len())?;
                        let uvs: Vec<Vec2> = raw.into_iter().map(|t| source.transform.apply(t)).collect();
                        if !uvs.iter().all(|t| t.is_finite()) {
                            return Err(input(format!("non-finite texture coordinate in {label}")));
                        }
                        uvs
                    }
                    None => {
                        warnings.push(format!("{label} has no {name} for its texture; using (0, 0)"));
                        vec![Vec2::ZERO; n]
                    }
                }
            }
        };

        let influences = if skinned {
            let (Some(joints), Some(weights)) = (attribute(Semantic::Joints(0)), attribute(Semantic::Weights(0)))
            else {
                return Err(input(format!("{label} is skinned but lacks JOINTS_0 or WEIGHTS_0")));
            };
            let joints = reader.uvec4s(joints, &format!("JOINTS_0 of {label}"))?;
            let weights = reader.vec4s(weights, &format!("WEIGHTS_0 of {label}"))?;
            same_count("JOINTS_0", joints.len())?;
            same_count("WEIGHTS_0", weights.len())?;
            joints
                .into_iter()
                .zip(weights)
                .map(|(joints, weights)| Influence { joints, weights })
                .collect()
        } else {
            Vec::new()
        };

        let vertices = match primitive.indices {
            Some(a) => {
                let indices = reader.uints(a, &format!("indices of {label}"))?;
                if let Some(bad) = indices.iter().find(|&&i| i >= count_u32) {
                    return Err(input(format!("index {bad} out of range ({n} vertices) in {label}")));
                }
                indices
            }
            None => (0..count_u32).collect(),
        };

        // glTF: without normals, a file's tangents are to be ignored.
        let file_tangents = match (attribute(Semantic::Tangents), &normals) {
            (Some(a), Some(_)) if tangents => {
                let raw = reader.vec4s(a, &format!("TANGENT of {label}"))?;
                same_count("TANGENT", raw.len())?;
                Some(raw)
            }
            _ => None,
        };
        let mut triangles = Triangles {
            positions,
            normals: normals.clone().unwrap_or_default(),
            uvs,
            influences,
            tangents: Vec::new(),
            indices: triangle_list(mode, &vertices),
        };
        if normals.is_none() {
            // Without indices the file gives no connectivity, so facets stay flat:
            // give every corner its own vertex before accumulating.
            if primitive.indices.is_none() {
                triangles.unweld();
            }
            triangles.normals = area_weighted_normals(&triangles.positions, &triangles.indices);
        }
        repair_normals(&mut triangles.normals, &triangles.positions, &triangles.indices);
        if tangents {
            match file_tangents {
                Some(raw) => triangles.tangents = super::tangents::from_file(&raw, &triangles.normals),
                None => super::tangents::generate(&mut triangles),
            }
        }
        Ok(triangles)
    }

    /// Gives every triangle corner its own vertex.
    fn unweld(&mut self) {
        fn expand<T: Copy>(values: &[T], indices: &[u32]) -> Vec<T> {
            if values.is_empty() {
                return Vec::new();
            }
            indices.iter().map(|&i| values[i as usize]).collect()
        }
        self.positions = expand(&self.positions, &self.indices);
        self.normals = expand(&self.normals, &self.indices);
        self.uvs = expand(&self.uvs, &self.indices);
        self.influences = expand(&self.influences, &self.indices);
        self.tangents = expand(&self.tangents, &self.indices);
        self.indices = (0..self.indices.len() as u32).collect();
    }

    /// Appends a copy of vertex `v` (every attribute but the tangent, which the caller
    /// gives the copy).
    pub fn duplicate_vertex(&mut self, v: u32) {
        let v = v as usize;
        self.positions.push(self.positions[v]);
        self.normals.push(self.normals[v]);
        if !self.uvs.is_empty() {
            self.uvs.push(self.uvs[v]);
        }
        if !self.influences.is_empty() {
            self.influences.push(self.influences[v]);
        }
    }

    /// Moves the triangles to world space with `world`.
    pub fn transform(&mut self, world: Mat4) {
        for p in &mut self.positions {
            *p = world.transform_point3(*p);
        }
        let normal = normal_matrix(world);
        for n in &mut self.normals {
            *n = normal * *n;
        }
        self.keep_front_faces(world);
        repair_normals(&mut self.normals, &self.positions, &self.indices);
        super::tangents::transform(&mut self.tangents, &self.normals, world);
    }

    /// Reverses the winding when `world` mirrors, so that front faces stay
    /// counter-clockwise after it is applied.
    pub fn keep_front_faces(&mut self, world: Mat4) {
        if world.determinant() < 0.0 {
            for triangle in self.indices.chunks_exact_mut(3) {
                triangle.swap(1, 2);
            }
        }
    }
}

/// Matrix that transforms normals under `m`: the inverse transpose of its upper 3x3, up to
/// a positive factor (the cofactor matrix times the determinant's sign), so it exists even
/// for singular `m`. Results need normalizing.
pub(super) fn normal_matrix(m: Mat4) -> Mat3 {
    let (a, b, c) = (m.x_axis.truncate(), m.y_axis.truncate(), m.z_axis.truncate());
    let cofactor = Mat3::from_cols(b.cross(c), c.cross(a), a.cross(b));
    if a.dot(b.cross(c)) < 0.0 {
        -cofactor
    } else {
        cofactor
    }
}

/// Smooth vertex normals: unnormalized face normals (twice the triangle area in length, so
/// larger triangles weigh more) summed per vertex.
fn area_weighted_normals(positions: &[Vec3], indices: &[u32]) -> Vec<Vec3> {
    let mut sums = vec![Vec3::ZERO; positions.len()];
    for t in indices.chunks_exact(3) {
        let [a, b, c] = [t[0], t[1], t[2]].map(|i| i as usize);
        let face = (positions[b] - positions[a]).cross(positions[c] - positions[a]);
        sums[a] += face;
        sums[b] += face;
        sums[c] += face;
    }
    sums
}

/// Normalizes normals in place; a zero-length or non-finite one becomes the face normal of
/// the first non-degenerate triangle using the vertex, or +Y when there is none.
fn repair_normals(normals: &mut [Vec3], positions: &[Vec3], indices: &[u32]) {
    let mut broken = false;
    for n in normals.iter_mut() {
        match n.try_normalize() {
            Some(unit) => *n = unit,
            None => {
                *n = Vec3::ZERO;
                broken = true;
            }
        }
    }
    if !broken {
        return;
    }
    for t in indices.chunks_exact(3) {
        let [a, b, c] = [t[0], t[1], t[2]].map(|i| i as usize);
        let Some(face) = (positions[b] - positions[a])
            .cross(positions[c] - positions[a])
            .try_normalize()
        else {
            continue;
        };
        for v in [a, b, c] {
            if normals[v] == Vec3::ZERO {
                normals[v] = face;
            }
        }
    }
    for n in normals.iter_mut().filter(|n| **n == Vec3::ZERO) {
        *n = Vec3::Y;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strips_and_fans_become_counter_clockwise_lists() {
        let v = [0, 1, 2, 3, 4];
        assert_eq!(triangle_list(TriangleMode::List, &v), [0, 1, 2]);
        assert_eq!(triangle_list(TriangleMode::Strip, &v), [0, 1, 2, 1, 3, 2, 2, 3, 4]);
        assert_eq!(triangle_list(TriangleMode::Fan, &v), [1, 2, 0, 2, 3, 0, 3, 4, 0]);
        assert!(triangle_list(TriangleMode::Strip, &[0, 1]).is_empty());
        assert!(triangle_list(TriangleMode::Fan, &[]).is_empty());
    }

    #[test]
    fn generated_normals_are_area_weighted_and_degenerate_ones_fall_back() {
        // Two triangles sharing vertex 0: a big one facing +Z, a small one facing +X.
        let positions = [
            Vec3::ZERO,
            Vec3::new(10.0, 0.0, 0.0),
            Vec3::new(0.0, 10.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(0.0, 0.0, 1.0),
        ];
        let indices = [0, 1, 2, 0, 3, 4];
        let mut normals = area_weighted_normals(&positions, &indices);
        repair_normals(&mut normals, &positions, &indices);
        assert!(normals[0].z > 0.99 && normals[0].x > 0.0);
        assert_eq!(normals[3], Vec3::X);

        let mut broken = vec![
            Vec3::ZERO,
            Vec3::new(f32::NAN, 0.0, 0.0),
            Vec3::Z * 3.0,
            Vec3::ZERO,
            Vec3::ZERO,
        ];
        repair_normals(&mut broken, &positions, &[0, 1, 2]);
        assert_eq!(broken, [Vec3::Z, Vec3::Z, Vec3::Z, Vec3::Y, Vec3::Y]);
    }

    #[test]
    fn mirroring_flips_winding_and_keeps_normals_outward() {
        let mut t = Triangles {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            normals: vec![Vec3::Z; 3],
            indices: vec![0, 1, 2],
            ..Triangles::default()
        };
        let mirror = Mat4::from_scale(Vec3::new(-1.0, 2.0, 1.0));
        t.transform(mirror);
        assert_eq!(t.indices, [0, 2, 1]);
        let [a, b, c] = [0, 2, 1].map(|i| t.positions[i]);
        let face = (b - a).cross(c - a).normalize();
        assert_eq!(face, Vec3::Z);
        assert_eq!(t.normals[0], Vec3::Z);
    }

    #[test]
    fn normal_matrix_handles_non_uniform_scale() {
        let m = Mat4::from_scale(Vec3::new(4.0, 1.0, 1.0));
        // A 45-degree normal in x/y leans towards y after stretching x.
        let n = (normal_matrix(m) * Vec3::new(1.0, 1.0, 0.0)).normalize();
        assert!((n - Vec3::new(0.25, 1.0, 0.0).normalize()).length() < 1e-6);
    }

    #[test]
    fn texture_transform_follows_the_extension_spec() {
        let t = UvTransform {
            offset: Vec2::new(0.5, 0.25),
            rotation: std::f32::consts::FRAC_PI_2,
            scale: Vec2::new(2.0, 2.0),
        };
        // S: (2, 0); R with rows (cos, sin), (-sin, cos): (0, -2); T: (0.5, -1.75).
        assert!((t.apply(Vec2::new(1.0, 0.0)) - Vec2::new(0.5, -1.75)).length() < 1e-6);
        assert_eq!(UvTransform::IDENTITY.apply(Vec2::new(0.3, 0.7)), Vec2::new(0.3, 0.7));
    }

    #[test]
    fn influences_are_normalized_and_checked() {
        let raw = Influence {
            joints: [0, 1, 7, 9],
            weights: [1.0, 1.0, 0.0, -1.0],
        };
        let n = raw.normalized(2, "m").unwrap();
        assert_eq!(n.weights, [0.5, 0.5, 0.0, 0.0]);
        assert_eq!(n.joints, [0, 1, 0, 0]);
        let bad = Influence {
            joints: [5, 0, 0, 0],
            weights: [1.0, 0.0, 0.0, 0.0],
        };
        assert!(bad.normalized(2, "m").is_err());
    }
}
