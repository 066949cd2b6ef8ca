//! A triangle as DAIS's triangle buffer stores it (Schied and Dachsbacher §3.2, §4.1-4.2):
//! 1/w and normal and uv over w, each as its value at the screen centre and its x and y
//! screen derivatives, in f32. Attributes at a pixel come from Eq. 2, extrapolating from the
//! centre, so their rounding error grows with distance from it and with the steepness of
//! the triangle, as the paper's Fig. 6 shows; uv's derivatives are analytic.

use glam::{Vec2, Vec3};

use crate::geometry::{FrameGeometry, Triangle};
use crate::vertex_stage::{SetupTriangle, SUBPIXEL};

/// Attributes stored over w: normal (3) and uv (2).
const ATTRIBUTES: usize = 5;

/// Value at the screen centre, x derivative, y derivative (per pixel).
type Plane = [f32; 3];

pub struct TriangleRecord {
    centre: [f32; 2],
    inv_w: Plane,
    over_w: [Plane; ATTRIBUTES],
}

/// Attributes at one screen point, from a record.
pub struct Interpolated {
    pub normal: Vec3,
    pub uv: Vec2,
    pub duv_dx: Vec2,
    pub duv_dy: Vec2,
}

impl TriangleRecord {
    /// The record of `setup` (a clipped triangle of `triangle`) in a `width` x `height` view;
    /// the derivative pass computes it analytically in double precision and stores f32.
    pub fn new(setup: &SetupTriangle, triangle: &Triangle, geometry: &FrameGeometry, size: (u32, u32)) -> Self {
        let centre = [f64::from(size.0) / 2.0, f64::from(size.1) / 2.0];
        let [i, j, k] = triangle.vertices.map(|v| v as usize);
        let original = |n: usize| -> [f64; ATTRIBUTES] {
            let (nrm, uv) = (geometry.normals[n], geometry.uvs[n]);
            [nrm.x, nrm.y, nrm.z, uv.x, uv.y].map(f64::from)
        };
        let (oa, ob, oc) = (original(i), original(j), original(k));
        // Each setup vertex's attributes, from its barycentrics in the original triangle.
        let vertex = |v: usize| -> [f64; ATTRIBUTES] {
            let b = setup.bary[v].as_dvec3();
            std::array::from_fn(|a| b.x * oa[a] + b.y * ob[a] + b.z * oc[a])
        };
        let attrs = [vertex(0), vertex(1), vertex(2)];
        // Screen-linear barycentrics: lambda_i = E_i / area2, E_i opposite vertex i.
        let s = SUBPIXEL as f64;
        let area = setup.area2 as f64;
        let p = setup.v.map(|v| [v[0] as f64 / s, v[1] as f64 / s]);
        let edge = |a: [f64; 2], b: [f64; 2]| {
            // E(x, y) = (b.x - a.x)(y - a.y) - (b.y - a.y)(x - a.x), in pixels, scaled to
            // the fixed-point area.
            let scale = s * s / area;
            let dx = -(b[1] - a[1]) * scale;
            let dy = (b[0] - a[0]) * scale;
            let at_centre = ((b[0] - a[0]) * (centre[1] - a[1]) - (b[1] - a[1]) * (centre[0] - a[0])) * scale;
            [at_centre, dx, dy]
        };
        let lambda = [edge(p[1], p[2]), edge(p[2], p[0]), edge(p[0], p[1])];
        let plane = |f: &dyn Fn(usize) -> f64| -> Plane {
            std::array::from_fn(|d| (0..3).map(|v| lambda[v][d] * f(v)).sum::<f64>() as f32)
        };
        let inv_w = |v: usize| f64::from(setup.inv_w[v]);
        TriangleRecord {
            centre: centre.map(|c| c as f32),
            inv_w: plane(&inv_w),
            over_w: std::array::from_fn(|a| plane(&|v| inv_w(v) * attrs[v][a])),
        }
    }

    /// Eq. 2 at pixel-space point (`x`, `y`) (a pixel's centre is `x + 0.5`), in f32.
    pub fn at(&self, x: f32, y: f32) -> Interpolated {
        let (dx, dy) = (x - self.centre[0], y - self.centre[1]);
        let eval = |p: &Plane| p[0] + dx * p[1] + dy * p[2];
        let w = eval(&self.inv_w);
        let rcp = 1.0 / w;
        let a: [f32; ATTRIBUTES] = std::array::from_fn(|i| eval(&self.over_w[i]) * rcp);
        // d(a)/dx = (d(a/w)/dx - a d(1/w)/dx) w: the quotient rule on Eq. 2.
        let derivative = |i: usize, d: usize| (self.over_w[i][d] - a[i] * self.inv_w[d]) * rcp;
        Interpolated {
            normal: Vec3::new(a[0], a[1], a[2]),
            uv: Vec2::new(a[3], a[4]),
            duv_dx: Vec2::new(derivative(3, 1), derivative(4, 1)),
            duv_dy: Vec2::new(derivative(3, 2), derivative(4, 2)),
        }
    }
}
