//! Ray-traced hole filling: a BVH over the frame's triangles in world space (built by the
//! `obvhs` crate's PLOC builder), traversed by our own loop so every node visit and triangle
//! test is counted and logged, and hits are the nearest (ties to the lower triangle id)
//! whatever the tree. Single-sided surfaces are culled from behind, as the rasterizer culls
//! their back faces.

use glam::{DMat4, DVec4, Mat4, Vec3};

use crate::geometry::FrameGeometry;
use crate::memory::{AccessLog, Stream, LINE_BYTES};
use crate::shader::ShaderEnv;

/// Bytes of a node as a GPU stores it (a box of six floats, child or primitive index and
/// count) and of a triangle (three positions).
pub const NODE_BYTES: u64 = 32;
pub const TRIANGLE_BYTES: u64 = 36;

/// The frame's geometry as rays see it.
pub struct RayScene {
    bvh: obvhs::bvh2::Bvh2,
    triangles: Vec<[Vec3; 3]>,
    single_sided: Vec<bool>,
}

/// A ray's nearest hit: the triangle (its index in the frame), the distance and the
/// barycentrics of its second and third vertices.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    pub prim: u32,
    pub t: f32,
    pub u: f32,
    pub v: f32,
}

/// The traversal work of one ray.
#[derive(Clone, Copy, Debug, Default)]
pub struct Traversal {
    pub nodes: u32,
    pub tests: u32,
}

impl RayScene {
    pub fn build(geometry: &FrameGeometry, env: &ShaderEnv) -> RayScene {
        let triangles: Vec<[Vec3; 3]> = geometry
            .triangles
            .iter()
            .map(|t| t.vertices.map(|v| geometry.positions[v as usize]))
            .collect();
        let single_sided = geometry
            .triangles
            .iter()
            .map(|t| !env.materials[t.material as usize].double_sided)
            .collect();
        let input: Vec<obvhs::triangle::Triangle> = triangles
            .iter()
            .map(|t| {
                let [v0, v1, v2] = t.map(|p| glam_bvh::Vec3A::from_array(p.to_array()));
                obvhs::triangle::Triangle { v0, v1, v2 }
            })
            .collect();
        let mut build_time = std::time::Duration::ZERO;
        let bvh = if input.is_empty() {
            obvhs::bvh2::Bvh2::default()
        } else {
            obvhs::bvh2::builder::build_bvh2_from_tris(&input, obvhs::BvhBuildParams::fast_build(), &mut build_time)
        };
        RayScene {
            bvh,
            triangles,
            single_sided,
        }
    }

    pub fn nodes(&self) -> u64 {
        self.bvh.nodes.len() as u64
    }

    pub fn bytes(&self) -> u64 {
        self.nodes() * NODE_BYTES + self.triangles.len() as u64 * TRIANGLE_BYTES
    }

    /// The nearest hit along `origin + t dir` (t >= 0), logging the nodes and triangles it
    /// fetches.
    pub fn trace(&self, origin: Vec3, dir: Vec3, log: &mut AccessLog) -> (Option<Hit>, Traversal) {
        let mut work = Traversal::default();
        let nodes = &self.bvh.nodes;
        if nodes.is_empty() {
            return (None, work);
        }
        let inv = Vec3::ONE / dir;
        let slab = |i: usize| -> f32 {
            let b = nodes[i].aabb();
            let (lo, hi) = (Vec3::from_array(b.min.to_array()), Vec3::from_array(b.max.to_array()));
            let (t1, t2) = ((lo - origin) * inv, (hi - origin) * inv);
            let near = t1.min(t2).max_element().max(0.0);
            let far = t1.max(t2).min_element();
            if near <= far {
                near
            } else {
                f32::INFINITY
            }
        };
        let triangles_base = nodes.len() as u64 * NODE_BYTES;
        let mut best: Option<Hit> = None;
        let mut stack: Vec<(usize, f32)> = vec![(0, slab(0))];
        while let Some((i, enter)) = stack.pop() {
            if enter == f32::INFINITY || best.is_some_and(|b| enter > b.t) {
                continue;
            }
            work.nodes += 1;
            log.touch(Stream::Bvh, i as u64 * NODE_BYTES / LINE_BYTES, false);
            let node = &nodes[i];
            if node.is_leaf() {
                for slot in node.first_index..node.first_index + node.prim_count {
                    work.tests += 1;
                    log.touch(
                        Stream::Bvh,
                        (triangles_base + u64::from(slot) * TRIANGLE_BYTES) / LINE_BYTES,
                        false,
                    );
                    let prim = self.bvh.primitive_indices[slot as usize];
                    if let Some((t, u, v)) = self.intersect(prim, origin, dir) {
                        let nearer = best.is_none_or(|b| t < b.t || (t == b.t && prim < b.prim));
                        if nearer {
                            best = Some(Hit { prim, t, u, v });
                        }
                    }
                }
            } else {
                let (a, b) = (node.first_index as usize, node.first_index as usize + 1);
                let (ta, tb) = (slab(a), slab(b));
                // The nearer child is visited first (pushed last).
                let (first, second) = if tb < ta {
                    ((b, tb), (a, ta))
                } else {
                    ((a, ta), (b, tb))
                };
                stack.push(second);
                stack.push(first);
            }
        }
        (best, work)
    }

    /// Möller-Trumbore; back faces of single-sided triangles miss.
    fn intersect(&self, prim: u32, origin: Vec3, dir: Vec3) -> Option<(f32, f32, f32)> {
        let hit = plane_hit(self.triangles[prim as usize], origin, dir)?;
        let inside = (0.0..=1.0).contains(&hit.u) && hit.v >= 0.0 && hit.u + hit.v <= 1.0 && hit.t >= 0.0;
        (inside && (hit.front || !self.single_sided[prim as usize])).then_some((hit.t, hit.u, hit.v))
    }
}

/// Where a ray meets a triangle's plane (Möller-Trumbore, inside or not).
pub struct PlaneHit {
    pub t: f32,
    /// Barycentrics of the second and third vertices (extrapolated outside the triangle).
    pub u: f32,
    pub v: f32,
    /// The ray sees the side the vertices wind counter-clockwise on.
    pub front: bool,
}

/// The ray's meeting with the plane of `[p0, p1, p2]`; None when parallel to it.
pub fn plane_hit([p0, p1, p2]: [Vec3; 3], origin: Vec3, dir: Vec3) -> Option<PlaneHit> {
    let (e1, e2) = (p1 - p0, p2 - p0);
    let pv = dir.cross(e2);
    let det = e1.dot(pv);
    if det == 0.0 {
        return None;
    }
    let inv = 1.0 / det;
    let tv = origin - p0;
    let qv = tv.cross(e1);
    Some(PlaneHit {
        t: e2.dot(qv) * inv,
        u: tv.dot(pv) * inv,
        v: dir.dot(qv) * inv,
        front: det > 0.0,
    })
}

/// The primary ray of pixel (`x`, `y`) of a `width` x `height` view: from the near plane
/// through the pixel centre (origin, unit direction).
pub fn primary_ray(view_projection: Mat4, size: (u32, u32), x: f32, y: f32) -> (Vec3, Vec3) {
    ray_through(view_projection, size, x + 0.5, y + 0.5)
}

/// The ray from the near plane through pixel-space point (`x`, `y`) (a pixel's centre is
/// `x + 0.5`).
pub fn ray_through(view_projection: Mat4, (width, height): (u32, u32), x: f32, y: f32) -> (Vec3, Vec3) {
    let inverse = view_projection.as_dmat4().inverse();
    let (nx, ny) = (
        2.0 * f64::from(x) / f64::from(width) - 1.0,
        1.0 - 2.0 * f64::from(y) / f64::from(height),
    );
    let point = |z: f64| {
        let p: DVec4 = DMat4::mul_vec4(&inverse, DVec4::new(nx, ny, z, 1.0));
        p.truncate() / p.w
    };
    let (near, far) = (point(0.0), point(1.0));
    (near.as_vec3(), (far - near).normalize_or_zero().as_vec3())
}
