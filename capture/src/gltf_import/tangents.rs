//! Tangents for normal mapping: the file's `TANGENT` attribute when it has one, otherwise
//! MikkTSpace (what glTF prescribes and normal-map bakers assume), by `bevy_mikktspace`.
//!
//! MikkTSpace gives a tangent per triangle corner; a vertex whose corners disagree (a UV
//! seam, a mirrored island) is split so that each copy carries one tangent.

use std::collections::HashMap;

use bevy_mikktspace::{Geometry, Ops, TangentSpace};
use glam::{Mat4, Vec3, Vec4};

use super::geometry::Triangles;

/// `libm`'s functions, so that tangents are the same bits on every platform.
struct LibmOps;

impl Ops for LibmOps {
    fn sqrt(x: f32) -> f32 {
        libm::sqrtf(x)
    }

    fn acos(x: f32) -> f32 {
        libm::acosf(x)
    }
}

struct Corners<'a> {
    triangles: &'a Triangles,
    tangents: Vec<Vec4>,
}

impl Geometry<LibmOps> for Corners<'_> {
    fn num_faces(&self) -> usize {
        self.triangles.indices.len() / 3
    }

    fn num_vertices_of_face(&self, _face: usize) -> usize {
        3
    }

    fn position(&self, face: usize, vert: usize) -> [f32; 3] {
        self.triangles.positions[self.vertex(face, vert)].to_array()
    }

    fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
        self.triangles.normals[self.vertex(face, vert)].to_array()
    }

    fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
        self.triangles.uvs[self.vertex(face, vert)].to_array()
    }

    fn set_tangent(&mut self, tangent_space: Option<TangentSpace>, face: usize, vert: usize) {
        let encoded = tangent_space.map_or([0.0; 4], |t| t.tangent_encoded());
        self.tangents[face * 3 + vert] = Vec4::from_array(encoded);
    }
}

impl Corners<'_> {
    fn vertex(&self, face: usize, vert: usize) -> usize {
        self.triangles.indices[face * 3 + vert] as usize
    }
}

/// MikkTSpace tangents for `triangles` (which must have UVs), splitting vertices whose
/// corners get different tangents. A corner MikkTSpace leaves without a tangent
/// (degenerate UVs) gets one perpendicular to its normal.
pub(super) fn generate(triangles: &mut Triangles) {
    let mut corners = Corners {
        tangents: vec![Vec4::ZERO; triangles.indices.len()],
        triangles,
    };
    // The error only reports meshes without faces; their tangent list stays empty.
    let _ = bevy_mikktspace::generate_tangents(&mut corners);
    let corner_tangents = corners.tangents;
    let mut copy_of: HashMap<(u32, [u32; 4]), u32> = HashMap::new();
    let mut tangents = vec![Vec4::ZERO; triangles.positions.len()];
    let mut assigned = vec![false; triangles.positions.len()];
    for (corner, tangent) in corner_tangents.into_iter().enumerate() {
        let v = triangles.indices[corner];
        let n = triangles.normals[v as usize];
        let tangent = usable(tangent, n);
        let key = (v, tangent.to_array().map(f32::to_bits));
        let index = match copy_of.get(&key) {
            Some(&copy) => copy,
            None if !assigned[v as usize] => {
                assigned[v as usize] = true;
                tangents[v as usize] = tangent;
                v
            }
            None => {
                triangles.duplicate_vertex(v);
                tangents.push(tangent);
                (triangles.positions.len() - 1) as u32
            }
        };
        copy_of.insert(key, index);
        triangles.indices[corner] = index;
    }
    triangles.tangents = tangents;
}

/// A unit tangent perpendicular enough to `n`, and a sign of ±1.
pub(super) fn usable(t: Vec4, n: Vec3) -> Vec4 {
    let xyz = t.truncate();
    let xyz = (xyz - n * n.dot(xyz))
        .try_normalize()
        .unwrap_or_else(|| n.any_orthonormal_vector());
    xyz.extend(if t.w < 0.0 { -1.0 } else { 1.0 })
}

/// Tangents under `world`: directions move with the matrix, and a mirror flips the
/// bitangent's sign (glTF: bitangent = cross(normal, tangent.xyz) * w).
pub(super) fn transform(tangents: &mut [Vec4], normals: &[Vec3], world: Mat4) {
    let sign = if world.determinant() < 0.0 { -1.0 } else { 1.0 };
    for (t, &n) in tangents.iter_mut().zip(normals) {
        let moved = world.transform_vector3(t.truncate());
        *t = usable(moved.extend(t.w * sign), n);
    }
}

/// Tangents a file gives (`TANGENT`), made unit and perpendicular to their normals.
pub(super) fn from_file(raw: &[[f32; 4]], normals: &[Vec3]) -> Vec<Vec4> {
    raw.iter()
        .zip(normals)
        .map(|(&t, &n)| usable(Vec4::from_array(t), n))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec2;

    /// A quad in the xy plane with u along +x and v along +y: MikkTSpace's tangent is +x
    /// and the bitangent's sign makes cross(n, t) * w point along +v (+y).
    #[test]
    fn a_planar_quad_gets_its_u_direction() {
        let mut t = Triangles {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y],
            normals: vec![Vec3::Z; 4],
            uvs: vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y],
            indices: vec![0, 1, 2, 0, 2, 3],
            ..Triangles::default()
        };
        generate(&mut t);
        assert_eq!(t.positions.len(), 4, "no seam, no split");
        for tangent in &t.tangents {
            assert!((tangent.truncate() - Vec3::X).length() < 1e-5, "{tangent}");
            assert!(Vec3::Z.cross(tangent.truncate()).dot(Vec3::Y) * tangent.w > 0.99);
        }
    }

    /// The same quad with its right half mirrored in UV: the shared edge's vertices get
    /// one copy per side.
    #[test]
    fn a_mirrored_uv_island_splits_its_seam() {
        let mut t = Triangles {
            positions: vec![
                Vec3::ZERO,
                Vec3::X,
                Vec3::new(2.0, 0.0, 0.0),
                Vec3::new(2.0, 1.0, 0.0),
                Vec3::new(1.0, 1.0, 0.0),
                Vec3::Y,
            ],
            normals: vec![Vec3::Z; 6],
            uvs: vec![Vec2::ZERO, Vec2::X, Vec2::ZERO, Vec2::Y, Vec2::ONE, Vec2::Y],
            indices: vec![0, 1, 4, 0, 4, 5, 1, 2, 3, 1, 3, 4],
            ..Triangles::default()
        };
        generate(&mut t);
        assert_eq!(t.positions.len(), 8, "vertices 1 and 4 split");
        assert_eq!(t.tangents.len(), 8);
        let left = t.tangents[t.indices[0] as usize];
        let right = t.tangents[t.indices[7] as usize];
        assert!(left.x > 0.99 && right.x < -0.99, "{left} {right}");
    }

    #[test]
    fn a_mirror_flips_the_bitangent_sign() {
        let mut tangents = vec![Vec4::new(1.0, 0.0, 0.0, 1.0)];
        transform(&mut tangents, &[Vec3::Z], Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)));
        assert_eq!(tangents[0], Vec4::new(-1.0, 0.0, 0.0, -1.0));
    }
}
