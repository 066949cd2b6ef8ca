//! Shading schemes decide what is shaded where. A forward scheme receives the quads of one
//! unit that survived early-z and returns a colour per lane; a scheme that shades after
//! visibility receives each finished tile's samples. Both spend instructions through the
//! cost model. A scheme never knows the scheduler's order beyond the commands it is given.

mod dais;
mod deferred;
mod light_lists;
pub mod multirate;
mod per_pixel;
pub mod registry;
mod reprojection;
pub mod shading_cache;

pub use dais::{Dais, Variant};
pub use deferred::{Deferred, Lists, Target};
pub use multirate::{Multirate, MultirateConfig};
pub use per_pixel::{ForwardPlus, PerPixel};
pub use reprojection::{HoleFill, Reprojection};

use glam::{Mat4, Vec2, Vec3, Vec4};
use shadetrace_formats::results::{DaisStats, ReprojectionStats, ShadingCacheStats, ShadingCost, Traffic};
use wide::f32x4;

use crate::cost::{CostHeatList, StageCosts};
use crate::geometry::{FrameGeometry, Triangle};
use crate::lanes::Vec3x4;
use crate::memory::{AccessLog, FramebufferLayout, MemoOutcome, RenderTarget};
use crate::pipeline::{Counters, SampleBuffer};
use crate::raster::pixel_center;
use crate::shader::{LightingInputs, ShaderEnv, SurfacePoint};
use crate::vertex_stage::SetupTriangle;

/// A quad with at least one sample that passed the depth test.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadeQuad {
    pub x: u32,
    pub y: u32,
    /// Lanes (pixels) with at least one passing sample: the useful lanes.
    pub lanes: u8,
}

/// What every pass may read about the view it shades.
#[derive(Clone, Copy)]
pub struct ViewContext<'a> {
    pub view: u8,
    pub eye: Vec3,
    /// Both views' world-to-clip matrices and eyes (cross-view reuse projects into the other).
    pub view_projections: [Mat4; 2],
    pub eyes: [Vec3; 2],
    /// Near and far plane distances (NDC depth 0 and 1).
    pub depth_range: (f32, f32),
    pub width: u32,
    pub height: u32,
    pub geometry: &'a FrameGeometry,
    pub env: &'a ShaderEnv<'a>,
    /// The view's setup triangles, indexed by its visibility ids (empty for a view the
    /// geometry pass did not draw).
    pub setups: &'a [SetupTriangle],
    /// Where the render targets' lines are.
    pub layout: FramebufferLayout,
}

/// For tests: the unit of the first setup triangle of a `width` x `height` view from the
/// origin (the near and far planes at 0.1 and 10).
#[cfg(test)]
pub(crate) fn test_unit<'a>(
    geometry: &'a FrameGeometry,
    env: &'a ShaderEnv<'a>,
    setups: &'a [SetupTriangle],
    view_projection: Mat4,
    (width, height): (u32, u32),
) -> UnitContext<'a> {
    UnitContext {
        view_ctx: ViewContext {
            view: 0,
            eye: Vec3::ZERO,
            view_projections: [view_projection; 2],
            eyes: [Vec3::ZERO; 2],
            depth_range: (0.1, 10.0),
            width,
            height,
            geometry,
            env,
            setups,
            layout: FramebufferLayout::new(width, height, 1),
        },
        setup: &setups[0],
        triangle: &geometry.triangles[setups[0].prim as usize],
    }
}

/// What a scheme may read while shading one unit: its view and its triangle.
pub struct UnitContext<'a> {
    pub view_ctx: ViewContext<'a>,
    pub setup: &'a SetupTriangle,
    pub triangle: &'a Triangle,
}

impl<'a> std::ops::Deref for UnitContext<'a> {
    type Target = ViewContext<'a>;
    fn deref(&self) -> &ViewContext<'a> {
        &self.view_ctx
    }
}

/// Interpolated attributes of one lane.
#[derive(Clone, Copy, Debug)]
pub struct LaneAttributes {
    pub position: Vec3,
    pub normal: Vec3,
    pub uv: Vec2,
}

impl LaneAttributes {
    /// The lighting's inputs at the lane, seen from `eye`, its surface maps sampled at `at`.
    #[inline]
    pub fn lighting_inputs(&self, eye: Vec3, material: u32, at: SurfacePoint) -> LightingInputs {
        LightingInputs {
            position: self.position,
            normal: self.normal,
            eye,
            material,
            surface: at,
        }
    }
}

/// Interpolated attributes of a quad's four lanes, positions and normals by component
/// ([`UnitContext::quad_attributes`]).
#[derive(Clone, Copy, Debug)]
pub struct QuadAttributes {
    pub position: Vec3x4,
    pub normal: Vec3x4,
    pub uv: [Vec2; 4],
}

/// A quad's surface points ([`UnitContext::quad_surface_points`]). A material without
/// textures reads nothing of them: none are built for it, a few hundred bytes a quad. A
/// value on the stack, never stored, whose empty variant is there to skip writing the
/// large one (a box would allocate per quad).
#[allow(clippy::large_enum_variant)]
pub enum QuadPoints {
    Untextured,
    Textured([SurfacePoint; 4]),
}

impl QuadPoints {
    pub fn get(&self) -> &[SurfacePoint; 4] {
        match self {
            QuadPoints::Untextured => &[SurfacePoint::UNTEXTURED; 4],
            QuadPoints::Textured(points) => points,
        }
    }
}

impl QuadAttributes {
    /// Lane `l`'s attributes.
    pub fn lane(&self, l: usize) -> LaneAttributes {
        LaneAttributes {
            position: self.position.lane(l),
            normal: self.normal.lane(l),
            uv: self.uv[l],
        }
    }

    /// The four lanes' attributes.
    pub fn lanes(&self) -> [LaneAttributes; 4] {
        let (position, normal) = (self.position.to_lanes(), self.normal.to_lanes());
        std::array::from_fn(|l| LaneAttributes {
            position: position[l],
            normal: normal[l],
            uv: self.uv[l],
        })
    }
}

impl UnitContext<'_> {
    /// Attributes at a pixel centre (perspective-correct, extrapolated outside the triangle).
    pub fn attributes(&self, x: u32, y: u32) -> LaneAttributes {
        let (px, py) = pixel_center(x, y);
        self.attributes_at(px, py)
    }

    /// Attributes at the pixel centres of the quad whose top-left pixel is (`x`, `y`), lane
    /// `l` at (`x + (l & 1)`, `y + (l >> 1)`): [`Self::attributes`] of each lane, bit for bit
    /// (the barycentrics and [`Self::interpolate`]'s operations four lanes at a time).
    #[inline]
    pub fn quad_attributes(&self, x: u32, y: u32) -> QuadAttributes {
        let (px, py) = pixel_center(x, y);
        self.attributes_of_edges(self.setup.quad_edges(px, py))
    }

    /// [`Self::attributes_at`] of four fixed-point screen positions, bit for bit, four at a
    /// time (a multi-rate block's corners).
    #[inline]
    pub fn attributes_at_four(&self, at: [(i64, i64); 4]) -> QuadAttributes {
        self.attributes_of_edges(at.map(|(px, py)| self.setup.edges(px, py)))
    }

    /// The attributes at four samples from their edge values: [`Self::attributes_at`]'s
    /// barycentrics and [`Self::interpolate`]'s operations, four lanes at a time.
    #[inline(always)]
    fn attributes_of_edges(&self, edges: [[i64; 3]; 4]) -> QuadAttributes {
        let b = self.setup.original_barys(edges).map(f32x4::new);
        let [i, j, k] = self.triangle.vertices.map(|v| v as usize);
        let g = self.geometry;
        // glam's `p[i] * b.x + p[j] * b.y + p[k] * b.z`, lane by lane.
        let mix = |p: &[Vec3]| {
            Vec3x4::splat(p[i]).scale(b[0]) + Vec3x4::splat(p[j]).scale(b[1]) + Vec3x4::splat(p[k]).scale(b[2])
        };
        let uv = |c: usize| {
            f32x4::splat(g.uvs[i][c]) * b[0] + f32x4::splat(g.uvs[j][c]) * b[1] + f32x4::splat(g.uvs[k][c]) * b[2]
        };
        let (u, v) = (uv(0).to_array(), uv(1).to_array());
        QuadAttributes {
            position: mix(&g.positions),
            normal: mix(&g.normals),
            uv: std::array::from_fn(|l| Vec2::new(u[l], v[l])),
        }
    }

    /// Attributes at a fixed-point screen position (8 sub-pixel bits).
    #[inline]
    pub fn attributes_at(&self, px: i64, py: i64) -> LaneAttributes {
        self.interpolate(self.setup.original_bary(self.setup.edges(px, py)))
    }

    /// Attributes at barycentric coordinates `b` of the triangle's vertices.
    #[inline(always)]
    pub fn interpolate(&self, b: Vec3) -> LaneAttributes {
        let [i, j, k] = self.triangle.vertices.map(|v| v as usize);
        let g = self.geometry;
        LaneAttributes {
            position: g.positions[i] * b.x + g.positions[j] * b.y + g.positions[k] * b.z,
            normal: g.normals[i] * b.x + g.normals[j] * b.y + g.normals[k] * b.z,
            uv: g.uvs[i] * b.x + g.uvs[j] * b.y + g.uvs[k] * b.z,
        }
    }

    /// Where lane (`x`, `y`), at `uv` with its quad's derivatives, samples the surface maps
    /// (the tangent only where a normal map reads it).
    #[inline]
    pub fn surface_point(&self, uv: Vec2, duv_dx: Vec2, duv_dy: Vec2, x: u32, y: u32) -> SurfacePoint {
        let tangent = if self.needs_tangents() {
            self.tangent(x, y)
        } else {
            Vec4::ZERO
        };
        SurfacePoint {
            uv,
            duv_dx,
            duv_dy,
            tangent,
            lods: None,
        }
    }

    /// The surface points of the quad whose top-left pixel is (`x`, `y`), lane `l` at
    /// `uvs[l]`: the derivatives, and so its textures' levels of detail, are the quad's,
    /// found once for the four lanes.
    pub fn quad_surface_points(&self, uvs: [Vec2; 4], x: u32, y: u32) -> QuadPoints {
        if !self.env.samples_textures(self.triangle.material) {
            return QuadPoints::Untextured;
        }
        let (duv_dx, duv_dy) = (uvs[1] - uvs[0], uvs[2] - uvs[0]);
        let lods = self.env.texture_lods(self.triangle.material, duv_dx, duv_dy);
        // The lanes' tangents from their barycentrics, found four at a time
        // ([`Self::tangent`]'s, bit for bit).
        let tangents = match self.needs_tangents() {
            true => {
                let (px, py) = pixel_center(x, y);
                let b = self.setup.original_barys(self.setup.quad_edges(px, py));
                std::array::from_fn(|l| self.tangent_at_bary(Vec3::new(b[0][l], b[1][l], b[2][l])))
            }
            false => [Vec4::ZERO; 4],
        };
        QuadPoints::Textured(std::array::from_fn(|l| SurfacePoint {
            uv: uvs[l],
            duv_dx,
            duv_dy,
            tangent: tangents[l],
            lods,
        }))
    }

    /// Whether the triangle's material has a normal map, so its lanes need [`Self::tangent_at`].
    pub fn needs_tangents(&self) -> bool {
        !self.geometry.tangents.is_empty() && self.env.maps.of(self.triangle.material).normal.is_some()
    }

    /// The tangent at a pixel centre (zero without tangents). Apart from
    /// [`Self::attributes`], so that scenes without normal maps never interpolate one.
    pub fn tangent(&self, x: u32, y: u32) -> Vec4 {
        let (px, py) = pixel_center(x, y);
        self.tangent_at_bary(self.setup.original_bary(self.setup.edges(px, py)))
    }

    /// The tangent at a fixed-point screen position (zero without tangents).
    pub fn tangent_at(&self, px: i64, py: i64) -> Vec4 {
        self.tangent_at_bary(self.setup.original_bary(self.setup.edges(px, py)))
    }

    /// The tangent at barycentrics `b` of the triangle's vertices (zero without tangents).
    pub fn tangent_at_bary(&self, b: Vec3) -> Vec4 {
        self.geometry.tangent(self.triangle.vertices, b)
    }

    /// Heat-map id of a pixel (`u32::MAX` outside the view).
    pub fn pixel_id(&self, x: u32, y: u32) -> u32 {
        if x < self.width && y < self.height {
            (self.view as u32) << 30 | (y * self.width + x)
        } else {
            u32::MAX
        }
    }
}

/// Where a scheme's spending goes.
pub struct Accounting<'a> {
    pub cost: &'a mut StageCosts,
    pub log: &'a mut AccessLog,
    /// Per-pixel cost heat.
    pub heat: &'a mut CostHeatList,
    /// Effects refined to per-pixel rate: `(pixel id, Effects bits)`.
    pub refinement: &'a mut dyn FnMut(u32, u8),
    /// Shading-cache activity of the unit's view.
    pub cache: &'a mut ShadingCacheStats,
    /// DRAM bytes moved past the caches: `(traffic class, bytes)` (light lists).
    pub traffic: &'a mut dyn FnMut(&'static str, u64),
    /// A named event count, summed over the frame for [`ShadingScheme::finish_frame`].
    pub count: &'a mut dyn FnMut(&'static str, u64),
}

/// Refinement bits reported per pixel (heat maps of Fig. 5/13 of He et al.).
pub use crate::shader::Effects;

/// The passes a scheme runs over the scheduler's geometry.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Passes {
    /// Shade quads as they are rasterized ([`SchemeJob::shade_unit`]), then blend.
    Forward,
    /// Rasterize for visibility only (opaque surfaces), then shade each finished tile from
    /// its samples ([`SchemeJob::shade_tile`]).
    ShadeAfterVisibility,
}

/// Which view a view pass makes from which.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ViewPass {
    pub from: u8,
    pub to: u8,
    /// View `to` is drawn by the geometry pass all the same (its visibility is the pass's
    /// starting point): a pass that re-rasterizes where the other view leaves holes.
    pub draw_to: bool,
}

/// What a view pass hands every chunk of its work list (built once per frame, e.g. a BVH).
pub type WorkListState = std::sync::Arc<dyn std::any::Any + Send + Sync>;

/// A shading scheme; `begin_job` makes the per-job state (caches live there, so a cache sees
/// exactly the commands of one job: a tile under `immediate`, `sort-middle` and `multiview`,
/// an epipolar tile row of both views under `tile-pair`).
pub trait ShadingScheme: Sync {
    fn name(&self) -> &'static str;
    fn passes(&self) -> Passes {
        Passes::Forward
    }
    /// A pass over whole views after the geometry pass ([`SchemeJob::derive_view`], then
    /// [`SchemeJob::shade_pixels`] over its work list): view-to-view when `to != from` (view
    /// `to` is then not drawn, unless `draw_to`), a per-view screen pass over a drawn view when
    /// they are equal.
    fn view_pass(&self) -> Option<ViewPass> {
        None
    }
    /// The edge-receiver threshold when the scheme needs the receiver hierarchy.
    fn edge_receiver_delta(&self) -> Option<f32> {
        None
    }
    fn begin_job(&self, lights: usize, simd_width: u32) -> Box<dyn SchemeJob>;

    /// Runs a depth pre-pass whatever the options say (visibility after it is exact).
    fn depth_prepass(&self) -> bool {
        false
    }

    /// The targets the scheme keeps in the visibility stream (they size its cache and
    /// make `visibility_bytes`).
    fn visibility_targets(&self) -> &'static [RenderTarget] {
        &[RenderTarget::Visibility]
    }

    /// The frame is done and its memory replayed: charge what depends on the replay (the
    /// stores a memoization cache's misses made) and report the scheme's buffers.
    fn finish_frame(
        &self,
        _frame: &FinishedFrame,
        _costs: [&mut ShadingCost; 2],
        _traffic: &mut Traffic,
    ) -> SchemeStats {
        SchemeStats::default()
    }
}

/// What a scheme reports about its frame beside the common counters.
#[derive(Clone, Copy, Debug, Default)]
pub struct SchemeStats {
    pub dais: Option<DaisStats>,
    pub reprojection: Option<ReprojectionStats>,
}

/// What [`ShadingScheme::finish_frame`] reads.
pub struct FinishedFrame<'a> {
    pub layout: FramebufferLayout,
    pub memo: Option<MemoOutcome>,
    pub counters: &'a Counters,
    pub simd_width: u32,
    /// Entries of the memoization cache (`--memo-entries`).
    pub memo_entries: u64,
}

/// Per-job state of a scheme: one required method and lifecycle hooks that default to
/// nothing.
pub trait SchemeJob {
    /// Shades `quads` of one unit, writing four lane colours per quad into `colors` (never
    /// called under [`Passes::ShadeAfterVisibility`]).
    fn shade_unit(&mut self, ctx: &UnitContext, quads: &[ShadeQuad], colors: &mut Vec<[Vec4; 4]>, acc: &mut Accounting);

    /// The scheduler starts a group of units that may share shading (a tile-pair sequence).
    fn begin_sequence(&mut self) {}

    /// A `Visibility` unit's quads that passed the depth test (under
    /// [`Passes::ShadeAfterVisibility`]): what a G-buffer pass writes.
    fn visible_quads(&mut self, _ctx: &UnitContext, _visible: &VisibleQuads, _acc: &mut Accounting) {}

    /// After a depth pre-pass, before the tile's first draw: the tile's depth is final (a
    /// forward pass may cull lights against it).
    fn tile_prepared(&mut self, _ctx: &TileContext, _tile: &SampleBuffer, _acc: &mut Accounting) {}

    /// A tile's visibility is final (every geometry command of the tile has run): a screen
    /// pass reads `tile`'s depth and ids and writes its colour.
    fn shade_tile(&mut self, _ctx: &TileContext, _tile: &mut SampleBuffer, _acc: &mut Accounting) {}

    /// A view pass: writes view `to` (`ctx.view`; it starts cleared, as a copy of `from`
    /// when they are the same view, or as the geometry pass drew it with `draw_to`) from the
    /// finished view `from`, lists the pixels (`y * width + x`) it leaves for
    /// [`SchemeJob::shade_pixels`] and returns what their chunks share.
    fn derive_view(
        &mut self,
        _ctx: &ViewContext,
        _from: &SampleBuffer,
        _to: &mut SampleBuffer,
        _work: &mut Vec<u32>,
        _acc: &mut Accounting,
    ) -> Option<WorkListState> {
        None
    }

    /// A chunk of a work list: one colour per pixel of `pixels` into `colors` (written to
    /// every sample of the pixel). Chunks run in parallel, each with its own scheme job;
    /// `shared` is what [`SchemeJob::derive_view`] returned.
    fn shade_pixels(
        &mut self,
        _ctx: &ViewContext,
        _view: &SampleBuffer,
        _pixels: &[u32],
        _shared: Option<&WorkListState>,
        _colors: &mut Vec<Vec4>,
        _acc: &mut Accounting,
    ) {
    }
}

/// The distinct triangles among a pixel's samples `tris` (visibility ids), in the order of
/// their first sample, each with the mask of the samples it covers: what a deferred pass
/// shades once per pixel and triangle (the MSAA deduplication of DAIS's baseline and its
/// Listing 1, where the mask's count weights the shade).
pub fn distinct_triangles(tris: &[u32], out: &mut Vec<(u32, u32)>) {
    out.clear();
    for (s, &tri) in tris
        .iter()
        .enumerate()
        .filter(|&(_, &t)| t != crate::pipeline::NO_PRIMITIVE)
    {
        match out.iter_mut().find(|(t, _)| *t == tri) {
            Some((_, mask)) => *mask |= 1 << s,
            None => out.push((tri, 1 << s)),
        }
    }
}

/// The quads of one unit that passed the depth test in a visibility pass.
pub struct VisibleQuads<'a> {
    /// Each quad with its passing samples (bit `lane * samples + sample`).
    pub quads: &'a [(ShadeQuad, u32)],
    /// The unit's setup triangle (its index in the view).
    pub tri: u32,
    /// The tile (its index in the view's grid) and its rectangle.
    pub tile: u32,
    pub rect: crate::raster::Rect,
    pub samples: usize,
    pub layout: FramebufferLayout,
}

/// What a screen pass may read while shading one tile of one view.
pub struct TileContext<'a> {
    pub view_ctx: ViewContext<'a>,
    /// The tile's index in its view's grid.
    pub tile: u32,
    /// Sample offsets of the pixel (MSAA pattern).
    pub offsets: &'a [[i64; 2]],
}

impl<'a> TileContext<'a> {
    /// The unit context of setup triangle `tri` of this view, to interpolate its attributes.
    pub fn unit(&self, tri: u32) -> UnitContext<'a> {
        let setup = &self.view_ctx.setups[tri as usize];
        UnitContext {
            view_ctx: self.view_ctx,
            setup,
            triangle: &self.view_ctx.geometry.triangles[setup.prim as usize],
        }
    }
}

impl<'a> std::ops::Deref for TileContext<'a> {
    type Target = ViewContext<'a>;
    fn deref(&self) -> &ViewContext<'a> {
        &self.view_ctx
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Triangle;
    use crate::vertex_stage::setup_view;
    use proptest::prelude::*;
    use shadetrace_formats::SurfaceMaps;

    fn vec3(range: std::ops::Range<f32>) -> impl Strategy<Value = Vec3> {
        prop::array::uniform3(range).prop_map(Vec3::from_array)
    }

    proptest! {
        /// A quad's attributes, four lanes at a time, are each lane's own, bit for bit, in
        /// perspective and outside the triangle too (helper lanes extrapolate); so are four
        /// samples' anywhere.
        #[test]
        fn quad_attributes_are_each_lanes_own(
            positions in prop::array::uniform3(vec3(-1.0..1.0)),
            depths in prop::array::uniform3(1.5f32..6.0),
            normals in prop::array::uniform3(vec3(-10.0..10.0)),
            uvs in prop::array::uniform3(prop::array::uniform2(-4.0f32..4.0)),
            x in 0u32..32,
            y in 0u32..24,
            // Four fixed-point positions anywhere on the view and beyond (a block's corners).
            at in prop::array::uniform4((-2048i64..18432, -2048i64..14336)),
        ) {
            let geometry = FrameGeometry {
                positions: std::array::from_fn::<_, 3, _>(|v| {
                    (positions[v] * depths[v]).with_z(-depths[v])
                })
                .to_vec(),
                normals: normals.to_vec(),
                uvs: uvs.map(Vec2::from_array).to_vec(),
                tangents: Vec::new(),
                triangles: vec![Triangle { vertices: [0, 1, 2], material: 0, patch: u32::MAX, mesh: 0 }],
            };
            let view_projection = Mat4::perspective_rh(1.2, 64.0 / 48.0, 0.1, 10.0);
            let (setups, _) = setup_view(&geometry, &[true], view_projection, 64, 48);
            prop_assume!(!setups.is_empty());
            let maps = SurfaceMaps::default();
            let env = ShaderEnv { materials: &[], textures: &[], lights: &[], shadow: None, receivers: None, maps: &maps };
            let ctx = test_unit(&geometry, &env, &setups, view_projection, (64, 48));
            let (x, y) = (2 * x, 2 * y);
            let quad = ctx.quad_attributes(x, y);
            let bits = |v: &[f32]| v.iter().map(|c| c.to_bits()).collect::<Vec<_>>();
            for l in 0..4 {
                let (got, want) = (quad.lane(l), ctx.attributes(x + (l as u32 & 1), y + (l as u32 >> 1)));
                prop_assert_eq!(bits(&got.position.to_array()), bits(&want.position.to_array()));
                prop_assert_eq!(bits(&got.normal.to_array()), bits(&want.normal.to_array()));
                prop_assert_eq!(bits(&got.uv.to_array()), bits(&want.uv.to_array()));
                let lanes = quad.lanes();
                prop_assert_eq!(bits(&lanes[l].position.to_array()), bits(&got.position.to_array()));
                let (got, want) = (ctx.attributes_at_four(at).lane(l), ctx.attributes_at(at[l].0, at[l].1));
                prop_assert_eq!(bits(&got.position.to_array()), bits(&want.position.to_array()));
                prop_assert_eq!(bits(&got.normal.to_array()), bits(&want.normal.to_array()));
                prop_assert_eq!(bits(&got.uv.to_array()), bits(&want.uv.to_array()));
            }
        }

        /// A quad's surface points (a normal-mapped material's: tangents, four lanes at a
        /// time) are each lane's own, bit for bit, and carry the quad's levels of detail.
        #[test]
        fn quad_surface_points_are_each_lanes_own(
            positions in prop::array::uniform3(vec3(-1.0..1.0)),
            depths in prop::array::uniform3(1.5f32..6.0),
            uvs in prop::array::uniform3(prop::array::uniform2(-4.0f32..4.0)),
            tangents in prop::array::uniform3(prop::array::uniform4(-1.0f32..1.0)),
            x in 0u32..32,
            y in 0u32..24,
        ) {
            let geometry = FrameGeometry {
                positions: std::array::from_fn::<_, 3, _>(|v| (positions[v] * depths[v]).with_z(-depths[v])).to_vec(),
                normals: vec![Vec3::Z; 3],
                uvs: uvs.map(Vec2::from_array).to_vec(),
                tangents: tangents.map(Vec4::from_array).to_vec(),
                triangles: vec![Triangle { vertices: [0, 1, 2], material: 0, patch: u32::MAX, mesh: 0 }],
            };
            let view_projection = Mat4::perspective_rh(1.2, 64.0 / 48.0, 0.1, 10.0);
            let (setups, _) = setup_view(&geometry, &[true], view_projection, 64, 48);
            prop_assume!(!setups.is_empty());
            let material = shadetrace_formats::Material {
                name: String::new(),
                base_color: [1.0; 4],
                base_color_texture: None,
                specular_exponent: 8.0,
                specular_strength: 0.5,
                alpha: shadetrace_formats::AlphaMode::Opaque,
                double_sided: false,
            };
            let texture = shadetrace_formats::Texture {
                name: String::new(),
                width: 32,
                height: 8,
                wrap_u: shadetrace_formats::Wrap::Repeat,
                wrap_v: shadetrace_formats::Wrap::Repeat,
                rgba8: vec![128; 32 * 8 * 4],
            };
            let (texture, _) = crate::texture::MipTexture::build(&texture, 0, false);
            let maps = SurfaceMaps {
                materials: vec![shadetrace_formats::MaterialMaps {
                    normal: Some((0, 1.0)),
                    ..shadetrace_formats::MaterialMaps::NONE
                }],
                tangents: Vec::new(),
                linear_textures: vec![0],
            };
            let env = ShaderEnv {
                materials: std::slice::from_ref(&material),
                textures: std::slice::from_ref(&texture),
                lights: &[],
                shadow: None,
                receivers: None,
                maps: &maps,
            };
            let ctx = test_unit(&geometry, &env, &setups, view_projection, (64, 48));
            let (x, y) = (2 * x, 2 * y);
            let uvs = ctx.quad_attributes(x, y).uv;
            let (dx, dy) = (uvs[1] - uvs[0], uvs[2] - uvs[0]);
            let points = ctx.quad_surface_points(uvs, x, y);
            let bits = |v: &[f32]| v.iter().map(|c| c.to_bits()).collect::<Vec<_>>();
            for (l, got) in points.get().iter().enumerate() {
                let want = ctx.surface_point(uvs[l], dx, dy, x + (l as u32 & 1), y + (l as u32 >> 1));
                prop_assert_eq!(bits(&got.uv.to_array()), bits(&want.uv.to_array()));
                prop_assert_eq!(bits(&got.tangent.to_array()), bits(&want.tangent.to_array()));
                prop_assert_eq!((got.duv_dx, got.duv_dy), (dx, dy));
                let lod = got.lods.and_then(|lods| lods.of(0));
                prop_assert_eq!(lod, Some(texture.lod(dx, dy)));
            }
        }
    }
}
