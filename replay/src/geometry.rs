//! World-space geometry of one frame: every mesh's vertices moved by its motion, all meshes
//! concatenated, triangles in submission order. The triangle index is the primitive id that
//! breaks depth ties, and the vertex index addresses the triangle data in the memory model.

use glam::{Mat3, Vec2, Vec3, Vec4};
use shadetrace_formats::{Frame, Motion, Scene};

/// One triangle in submission order.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Triangle {
    /// Indices into [`FrameGeometry`]'s vertex arrays.
    pub vertices: [u32; 3],
    pub material: u32,
    /// Surface patch id (AMFS) or `u32::MAX` when the mesh has none.
    pub patch: u32,
    /// Index of the mesh in the trace (texel shading keys its UV atlas by mesh).
    pub mesh: u32,
}

/// World-space vertices and triangles of one frame.
#[derive(Clone, Debug, Default)]
pub struct FrameGeometry {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    /// Zero for meshes without uvs (their materials sample no texture).
    pub uvs: Vec<Vec2>,
    /// World-space tangents (bitangent sign in w), zero where no normal map reads them;
    /// empty when the scene has no normal map.
    pub tangents: Vec<Vec4>,
    pub triangles: Vec<Triangle>,
}

impl FrameGeometry {
    /// The tangent at barycentrics `b` of `vertices` (zero when no mesh has tangents).
    pub fn tangent(&self, vertices: [u32; 3], b: Vec3) -> Vec4 {
        let t = &self.tangents;
        if t.is_empty() {
            return Vec4::ZERO;
        }
        let [i, j, k] = vertices.map(|v| v as usize);
        t[i] * b.x + t[j] * b.y + t[k] * b.z
    }

    pub fn build(scene: &Scene, frame: &Frame) -> FrameGeometry {
        let mut g = FrameGeometry::default();
        // Tangents only when some mesh has them (a normal map): none are built otherwise.
        let has_tangents = scene.surface_maps.tangents.iter().any(|t| !t.is_empty());
        for (mesh_index, mesh) in scene.geometry.meshes.iter().enumerate() {
            let base = g.positions.len() as u32;
            match mesh.motion {
                Motion::Static => {
                    g.positions.extend_from_slice(&mesh.positions);
                    g.normals.extend_from_slice(&mesh.normals);
                }
                Motion::Rigid { slot } => {
                    let m = frame.rigid_transforms[slot as usize];
                    let normal_matrix = Mat3::from_mat4(m).inverse().transpose();
                    g.positions
                        .extend(mesh.positions.iter().map(|&p| m.transform_point3(p)));
                    g.normals
                        .extend(mesh.normals.iter().map(|&n| (normal_matrix * n).normalize_or(Vec3::Y)));
                }
                Motion::Skinned { slot } => {
                    let skinned = &frame.skinned[slot as usize];
                    g.positions.extend_from_slice(&skinned.positions);
                    g.normals.extend_from_slice(&skinned.normals);
                }
            }
            if mesh.uvs.is_empty() {
                g.uvs.resize(g.positions.len(), Vec2::ZERO);
            } else {
                g.uvs.extend_from_slice(&mesh.uvs);
            }
            let tangents = scene
                .surface_maps
                .tangents
                .get(mesh_index)
                .map_or(&[][..], Vec::as_slice);
            if has_tangents {
                match mesh.motion {
                    // Capture gives skinned meshes no tangents (frames carry none).
                    Motion::Static | Motion::Skinned { .. } => g.tangents.extend_from_slice(tangents),
                    Motion::Rigid { slot } => {
                        let m = frame.rigid_transforms[slot as usize];
                        let sign = if m.determinant() < 0.0 { -1.0 } else { 1.0 };
                        g.tangents.extend(tangents.iter().map(|t| {
                            let xyz = m.transform_vector3(t.truncate()).normalize_or(Vec3::X);
                            xyz.extend(t.w * sign)
                        }));
                    }
                }
                g.tangents.resize(g.positions.len(), Vec4::ZERO);
            }
            for (t, tri) in mesh.indices.chunks_exact(3).enumerate() {
                g.triangles.push(Triangle {
                    vertices: [base + tri[0], base + tri[1], base + tri[2]],
                    material: mesh.material,
                    patch: mesh.patch_ids.get(t).copied().unwrap_or(u32::MAX),
                    mesh: mesh_index as u32,
                });
            }
        }
        g
    }
}
