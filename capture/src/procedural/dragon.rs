//! The arena's skinned character: a tapering tube along a centreline that swims through a
//! travelling wave. Skinning is procedural (each frame's world-space vertices come from the
//! centreline at that time), which is what a skinned glTF mesh gives replay too: per-frame
//! vertices of a mesh whose triangles never change.

use glam::{Vec2, Vec3};
use shadetrace_formats::{Mesh, Motion, SkinnedVertices};

use super::builder::MeshBuilder;
use crate::source::{FrameMotion, SceneMotion};
use shadetrace_formats::Pose;

/// Rings along the body and vertices around each ring.
const RINGS: u32 = 48;
const SEGMENTS: u32 = 16;
/// Body length and the radius at the head (the tail tapers to 30% of it), metres.
const LENGTH: f32 = 9.0;
const HEAD_RADIUS: f32 = 0.8;

/// Seconds of the sideways wave's period (the scene's animation length).
pub const SWIM_PERIOD_S: f32 = 4.0;

/// The dragon's pose over time.
pub struct Dragon;

impl Dragon {
    /// The mesh in its pose at time 0, as skinning slot 0.
    pub fn mesh(material: u32) -> Mesh {
        let (positions, normals) = Dragon::vertices(0.0);
        let mut mb = MeshBuilder::new("dragon", material);
        for (i, (p, n)) in positions.iter().zip(&normals).enumerate() {
            let (ring, seg) = (i as u32 / SEGMENTS, i as u32 % SEGMENTS);
            mb.vertex(
                *p,
                *n,
                Vec2::new(seg as f32 / SEGMENTS as f32, ring as f32 / RINGS as f32) * Vec2::new(2.0, 8.0),
            );
        }
        for ring in 0..RINGS - 1 {
            for seg in 0..SEGMENTS {
                let at = |r: u32, s: u32| r * SEGMENTS + s % SEGMENTS;
                let (a, b, c, d) = (
                    at(ring, seg),
                    at(ring + 1, seg),
                    at(ring + 1, seg + 1),
                    at(ring, seg + 1),
                );
                // Counter-clockwise seen from outside (rings run from head to tail).
                mb.triangle(a, b, c);
                mb.triangle(a, c, d);
            }
        }
        let mut mesh = mb.build();
        mesh.motion = Motion::Skinned { slot: 0 };
        mesh
    }

    /// World-space vertices and normals at `time_s`: ring by ring, head first.
    fn vertices(time_s: f32) -> (Vec<Vec3>, Vec<Vec3>) {
        let mut positions = Vec::with_capacity((RINGS * SEGMENTS) as usize);
        let mut normals = Vec::with_capacity(positions.capacity());
        for ring in 0..RINGS {
            let s = ring as f32 / (RINGS - 1) as f32;
            let (center, tangent) = Dragon::centerline(s, time_s);
            let side = tangent.cross(Vec3::Y).normalize_or(Vec3::Z);
            let up = side.cross(tangent).normalize_or(Vec3::Y);
            let radius = HEAD_RADIUS * (1.0 - 0.7 * s);
            for seg in 0..SEGMENTS {
                let angle = std::f32::consts::TAU * seg as f32 / SEGMENTS as f32;
                let normal = up * libm::cosf(angle) + side * libm::sinf(angle);
                positions.push(center + normal * radius);
                normals.push(normal);
            }
        }
        (positions, normals)
    }

    /// Point and unit tangent of the centreline at `s` in [0, 1] (head at 0): a travelling
    /// wave sideways and a gentle one up and down, circling the arena's centre slowly.
    fn centerline(s: f32, t: f32) -> (Vec3, Vec3) {
        let point = |s: f32| {
            let x = LENGTH * (0.5 - s);
            let sway = 1.4 * libm::sinf(std::f32::consts::TAU * (0.8 * s - 0.25 * t));
            let rise = 1.3 + 0.5 * libm::sinf(std::f32::consts::TAU * (0.5 * s - 0.15 * t));
            let heading = 0.05 * t;
            let (sin, cos) = (libm::sinf(heading), libm::cosf(heading));
            Vec3::new(x * cos - sway * sin, rise, x * sin + sway * cos)
        };
        let h = 1e-3;
        let (a, b) = (point((s - h).max(0.0)), point((s + h).min(1.0)));
        (point(s), (a - b).normalize_or(Vec3::X))
    }
}

impl SceneMotion for Dragon {
    fn sample(&self, time_s: f32) -> FrameMotion {
        let (positions, normals) = Dragon::vertices(time_s);
        FrameMotion {
            rigid_transforms: Vec::new(),
            skinned: vec![SkinnedVertices { positions, normals }],
        }
    }

    fn camera_pose(&self, camera: usize, _time_s: f32) -> Pose {
        unreachable!("the arena has no camera {camera}")
    }
}
