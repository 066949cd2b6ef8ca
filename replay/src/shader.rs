//! The shader of ARCHITECTURE.md (Definitions: shader), split into the blocks of the cost table: coarse-able lighting
//! (Lambert diffuse, Phong `(R·L)^n` specular, 5x5 PCF shadow, local lights) and the fine
//! albedo (base colour times texture), composed as `tonemap(albedo * lighting)`.
//!
//! The glTF maps beyond base colour (the trace's `SurfaceMaps`) enter here and nowhere
//! else, each as its own cost-table block:
//! - a **normal map** bends the normal the lighting uses (tangent space, MikkTSpace
//!   tangents; coarse-able: multi-rate schemes sample it at their shading points);
//! - a **metallic-roughness map** sets the Phong exponent and weight per point through the
//!   same mapping capture applies to the factors (coarse-able);
//! - an **occlusion map** darkens the ambient term only, as glTF prescribes for indirect
//!   light (fine);
//! - the **emissive** factor (times `KHR_materials_emissive_strength`) and texture add
//!   radiance before the tone map (fine).
//!
//! Each function records the blocks it executes in a [`BlockSet`], so the cost model counts
//! exactly the work the numbers came from.

use glam::{Vec2, Vec3, Vec4};
use shadetrace_formats::{phong_from_metallic_roughness, LightKind, Material, SurfaceMaps};

use crate::cost::{BlockSet, LightBlocks};
use crate::cost_table::Block;
use crate::lanes::Vec3x4;
use crate::memory::AccessLog;
use crate::shadow::{PcfFootprint, ReceiverHierarchy, ShadowMap};
use crate::texture::{Lod, MipTexture, TexelLines};
use wide::f32x4;

/// Constant ambient term so unlit sides are not black.
const AMBIENT: f32 = 0.06;

/// A light prepared for shading.
#[derive(Clone, Copy, Debug)]
pub struct ShadingLight {
    pub kind: LightKind,
    /// Colour times intensity.
    pub radiance: Vec3,
    pub shadowed: bool,
    /// A directional light's unit vector toward the light, a spot's unit axis (zero for a
    /// point light): worked out once instead of at every point it lights (same bits).
    axis: Vec3,
    /// A spot's cosines of its inner and outer cone angles.
    cone_cosines: (f32, f32),
}

impl ShadingLight {
    pub fn new(kind: LightKind, radiance: Vec3, shadowed: bool) -> ShadingLight {
        let (axis, cone_cosines) = match kind {
            LightKind::Directional { direction } => (-direction.normalize_or(Vec3::NEG_Y), (0.0, 0.0)),
            LightKind::Spot {
                direction,
                inner_cone,
                outer_cone,
                ..
            } => (
                direction.normalize_or(Vec3::NEG_Z),
                (libm::cosf(inner_cone), libm::cosf(outer_cone)),
            ),
            LightKind::Point { .. } => (Vec3::ZERO, (0.0, 0.0)),
        };
        ShadingLight {
            kind,
            radiance,
            shadowed,
            axis,
            cone_cosines,
        }
    }

    /// The unit vector from `point` toward the light.
    #[inline]
    pub fn direction_from(&self, point: Vec3) -> Vec3 {
        match self.kind {
            LightKind::Directional { .. } => self.axis,
            LightKind::Point { position, .. } | LightKind::Spot { position, .. } => {
                (position - point).normalize_or(Vec3::Y)
            }
        }
    }
}

/// Everything the shader reads besides the per-lane inputs.
pub struct ShaderEnv<'a> {
    pub materials: &'a [Material],
    pub textures: &'a [MipTexture],
    pub lights: &'a [ShadingLight],
    pub shadow: Option<&'a ShadowMap>,
    /// Edge-receiver hierarchy of the shadow map, built only when a scheme asks for it.
    pub receivers: Option<&'a ReceiverHierarchy>,
    pub maps: &'a SurfaceMaps,
}

/// Where a point samples the surface maps: its texture coordinates, their screen
/// derivatives (the texture LOD) and its interpolated tangent (xyz, bitangent sign in w;
/// zero without a normal map).
#[derive(Clone, Copy, Debug, Default)]
pub struct SurfacePoint {
    pub uv: Vec2,
    pub duv_dx: Vec2,
    pub duv_dy: Vec2,
    pub tangent: Vec4,
    /// The levels of detail of its material's textures at these derivatives, where its quad
    /// found them once for its lanes ([`ShaderEnv::texture_lods`]); each sample finds its
    /// own otherwise.
    pub lods: Option<TextureLods>,
}

impl SurfacePoint {
    /// The point of a material that samples no texture, which reads nothing of it.
    pub const UNTEXTURED: SurfacePoint = SurfacePoint {
        uv: Vec2::ZERO,
        duv_dx: Vec2::ZERO,
        duv_dy: Vec2::ZERO,
        tangent: Vec4::ZERO,
        lods: None,
    };
}

/// The most textures a material samples: base colour, metallic-roughness, occlusion,
/// emissive and normal maps.
const MATERIAL_TEXTURES: usize = 5;

/// The level of detail of each texture a material samples, at one pair of derivatives.
#[derive(Clone, Copy, Debug, Default)]
pub struct TextureLods {
    textures: [u32; MATERIAL_TEXTURES],
    lods: [Lod; MATERIAL_TEXTURES],
    len: usize,
}

impl TextureLods {
    /// Texture `texture`'s level of detail, if its material samples it.
    #[inline]
    pub fn of(&self, texture: u32) -> Option<Lod> {
        let i = self.textures[..self.len].iter().position(|&t| t == texture)?;
        Some(self.lods[i])
    }
}

/// A quad's texels, each texture its material reads sampled once for the four lanes before
/// the lanes run (the normal map by [`ShaderEnv::quad_lighting`], the surface maps by
/// [`ShaderEnv::sample_surface_maps`]): per texture its four lanes' values and reads, each
/// lane's reads logged when the lane reads the texture in its turn.
#[derive(Default)]
pub struct QuadTexels {
    textures: [u32; MATERIAL_TEXTURES],
    values: [[Vec4; 4]; MATERIAL_TEXTURES],
    reads: [[TexelLines; 4]; MATERIAL_TEXTURES],
    len: usize,
}

impl QuadTexels {
    /// Empty, for the next quad.
    pub fn clear(&mut self) {
        self.len = 0;
    }

    /// Lane `l`'s texel of `texture`, its reads logged as the lane's sample would log them.
    #[inline(always)]
    fn lane(&self, texture: u32, l: usize, log: &mut AccessLog) -> Vec4 {
        let i = self.textures[..self.len]
            .iter()
            .position(|&t| t == texture)
            .expect("a quad samples every map its lanes read");
        self.reads[i][l].log(log);
        self.values[i][l]
    }
}

/// Interpolated inputs of the coarse-able lighting.
#[derive(Clone, Copy, Debug)]
pub struct LightingInputs {
    pub position: Vec3,
    pub normal: Vec3,
    pub eye: Vec3,
    pub material: u32,
    pub surface: SurfacePoint,
}

/// A point's unit normal (mapped, and flipped to the side seen) and reflection vector:
/// what every light's term at the point starts from.
#[derive(Clone, Copy, Debug, Default)]
pub struct PointDirections {
    n: Vec3,
    r: Vec3,
}

/// What every light's term at one point shares: its position, its (possibly mapped and
/// flipped) normal, its reflection vector and the Phong parameters there.
#[derive(Clone, Copy)]
struct PointInputs {
    position: Vec3,
    n: Vec3,
    r: Vec3,
    exponent: f32,
    strength: f32,
}

/// What a directional light's term at a point starts from: the cosines of its direction
/// with the normal and the reflection vector, and the point's Phong parameters.
struct Directional {
    n_dot_l: f32,
    r_dot_l: f32,
    exponent: f32,
    strength: f32,
}

impl Directional {
    /// Whether the point faces the light.
    #[inline(always)]
    fn lit(&self) -> bool {
        self.n_dot_l > 0.0
    }

    /// The Lambert term: N·L on the lit side, 0 behind.
    #[inline(always)]
    fn lambert(&self) -> f32 {
        if self.lit() {
            self.n_dot_l
        } else {
            0.0
        }
    }

    /// The specular term, on the `lit` side where not `hidden`.
    #[inline(always)]
    fn specular(&self, lit: bool, hidden: impl FnOnce() -> bool) -> f32 {
        if lit && !hidden() {
            self.strength * phong(self.r_dot_l, self.exponent)
        } else {
            0.0
        }
    }

    /// Whether a shadow visibility of `scale` hides the specular term from the colour: a
    /// full shadow, with a power in `[0, 1]` and a finite strength, makes
    /// `0 * (diffuse + specular)` zero either way.
    #[inline(always)]
    fn hidden_by_shadow(&self, scale: f32) -> bool {
        scale == 0.0 && self.r_dot_l <= 1.0 && self.exponent >= 0.0 && self.strength.is_finite()
    }
}

/// [`Directional`] at a quad's four lanes: the same tests, as masks.
struct DirectionalQuad {
    n_dot_l: f32x4,
    r_dot_l: f32x4,
    exponent: f32x4,
    strength: f32x4,
}

impl DirectionalQuad {
    /// [`Directional::lit`].
    #[inline(always)]
    fn lit(&self) -> f32x4 {
        self.n_dot_l.simd_gt(f32x4::ZERO)
    }

    /// [`Directional::lambert`].
    #[inline(always)]
    fn lambert(&self) -> f32x4 {
        self.lit().bitselect(self.n_dot_l, f32x4::ZERO)
    }

    /// [`Directional::hidden_by_shadow`] at visibilities `scale`.
    #[inline(always)]
    fn hidden_by_shadow(&self, scale: f32x4) -> f32x4 {
        scale.simd_eq(f32x4::ZERO)
            & self.r_dot_l.simd_le(f32x4::ONE)
            & self.exponent.simd_ge(f32x4::ZERO)
            & self.strength.is_finite()
    }

    /// The lanes (bit `l`) whose [`Directional::specular`] is the power: lit and not hidden
    /// by a visibility of `scale`.
    #[inline(always)]
    fn specular_lanes(&self, scale: f32x4) -> u32 {
        (self.lit() & !self.hidden_by_shadow(scale)).to_bitmask()
    }

    /// Lane `l` alone.
    #[inline(always)]
    fn lane(&self, l: usize) -> Directional {
        Directional {
            n_dot_l: self.n_dot_l.to_array()[l],
            r_dot_l: self.r_dot_l.to_array()[l],
            exponent: self.exponent.to_array()[l],
            strength: self.strength.to_array()[l],
        }
    }
}

/// The most lights a [`QuadLighting`] holds; a scene with more lights its quads lane by lane.
const QUAD_LIGHTS: usize = 4;
/// The indices of a [`QuadLighting`]'s lights: a list of every light.
const EVERY_QUAD_LIGHT: [u32; QUAD_LIGHTS] = [0, 1, 2, 3];

/// The arithmetic of a quad's lighting, done four lanes at a time
/// ([`ShaderEnv::quad_lighting`]): each lane's directions, and per directional light each
/// lane's cosines and shadow-map footprint (None outside the map or where the light casts no
/// shadow). What reads memory or records blocks is left to each lane, in lane order. Kept by
/// a job from quad to quad.
#[derive(Default)]
pub struct QuadLighting {
    positions: Vec3x4,
    directions: [PointDirections; 4],
    n_dot_l: [[f32; 4]; QUAD_LIGHTS],
    r_dot_l: [[f32; 4]; QUAD_LIGHTS],
    footprints: [[Option<PcfFootprint>; 4]; QUAD_LIGHTS],
    /// The quad's texels: its normal map's, and its surface maps' where
    /// [`ShaderEnv::quad_colors`] finishes the quad.
    texels: QuadTexels,
    /// Every light is directional, so the four lanes take the same blocks
    /// ([`ShaderEnv::quad_colors`]).
    directional_only: bool,
}

/// The fine part of a point's colour: albedo, and what the occlusion and emissive maps add.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Surface {
    pub albedo: Vec4,
    /// Linear radiance added before the tone map.
    pub emission: Vec3,
    /// Ambient occlusion after its strength: 1 leaves the ambient term whole.
    pub occlusion: f32,
}

impl Surface {
    /// A surface with albedo only (no occlusion, no emission).
    pub fn of_albedo(albedo: Vec4) -> Surface {
        Surface {
            albedo,
            emission: Vec3::ZERO,
            occlusion: 1.0,
        }
    }
}

/// One light's contribution at a point: `radiance * scale * (diffuse + specular)`.
/// `scale` is the shadow visibility (shadowed light), the distance falloff (local lights) or 1.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LightTerm {
    pub scale: f32,
    pub diffuse: f32,
    pub specular: f32,
}

bitflags::bitflags! {
    /// The coarse-able effects: which ones [`ShaderEnv::light_terms`] evaluates (the others
    /// are left untouched), which ones a multi-rate block refines to per-pixel rate, and the
    /// bits of the per-pixel refinement maps.
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub struct Effects: u8 {
        /// Lambert terms, and the falloff of local lights.
        const DIFFUSE = 1;
        const SPECULAR = 2;
        /// The shadowed light's visibility.
        const SHADOW = 4;
    }
}

impl ShaderEnv<'_> {
    /// Coarse-able lighting (radiance reaching the eye per unit albedo): every effect
    /// evaluated here, combined.
    pub fn lighting(&self, inp: &LightingInputs, blocks: &mut BlockSet, log: &mut AccessLog) -> Vec3 {
        self.lighting_of(inp, None, blocks, log)
    }

    /// [`ShaderEnv::lighting`] of the lights in `list` (indices, ascending) only: a culled
    /// light list. Lights left out contribute nothing, so a list holding every light that
    /// reaches the point gives the same bits as the full loop.
    pub fn lighting_listed(
        &self,
        inp: &LightingInputs,
        list: &[u32],
        blocks: &mut BlockSet,
        log: &mut AccessLog,
    ) -> Vec3 {
        self.lighting_of(inp, Some(list), blocks, log)
    }

    /// [`Self::lighting`], of the lights in `list` when given.
    fn lighting_of(
        &self,
        inp: &LightingInputs,
        list: Option<&[u32]>,
        blocks: &mut BlockSet,
        log: &mut AccessLog,
    ) -> Vec3 {
        let mut terms = [LightTerm::default(); 8];
        if self.lights.len() <= terms.len() {
            let terms = &mut terms[..self.lights.len()];
            self.light_terms_of(inp, Effects::all(), list, terms, blocks, log);
            self.combine(terms)
        } else {
            // Many lights: a per-thread buffer, cleared per call (no allocation per pixel).
            thread_local! {
                static TERMS: std::cell::RefCell<Vec<LightTerm>> = const { std::cell::RefCell::new(Vec::new()) };
            }
            TERMS.with_borrow_mut(|terms| {
                terms.clear();
                terms.resize(self.lights.len(), LightTerm::default());
                self.light_terms_of(inp, Effects::all(), list, terms, blocks, log);
                self.combine(terms)
            })
        }
    }

    /// The arithmetic of [`Self::lighting`] at the four lanes of a quad (one triangle, so one
    /// material), four lanes at a time, into `quad`; each lane then finishes with
    /// [`Self::lane_lighting`]. A normal map's texels are read here for their values only
    /// (`points`, the lanes' surface points): each lane logs its reads of them in its turn.
    /// False (and `quad` not for use) with more lights than a quad holds, or a normal map
    /// and no points.
    pub fn quad_lighting(
        &self,
        material: u32,
        eye: Vec3,
        positions: Vec3x4,
        normals: Vec3x4,
        points: Option<&[SurfacePoint; 4]>,
        quad: &mut QuadLighting,
    ) -> bool {
        let normal_map = self.maps.of(material).normal;
        if (normal_map.is_some() && points.is_none()) || self.lights.len() > QUAD_LIGHTS {
            return false;
        }
        quad.texels.clear();
        let double_sided = self.materials[material as usize].double_sided;
        let p = positions;
        let v = (Vec3x4::splat(eye) - p).normalize_or(Vec3x4::splat(Vec3::Z));
        let n = normals.normalize_or(Vec3x4::splat(Vec3::Y));
        // The side is the interpolated normal's, as in `directions`.
        let n = match (normal_map, points) {
            (Some((texture, scale)), Some(points)) => {
                let texels = self.sample_quad_texture(texture, points, &mut quad.texels);
                self.normal_mapped_quad(n, points, texels, scale)
                    .negate_where_negative(n.dot(v), double_sided)
            }
            _ => n.negate_where_negative(n.dot(v), double_sided),
        };
        let twice = n.dot(v) * f32x4::splat(2.0);
        let r = (n.scale(twice) - v).normalize_or(n);
        quad.directional_only = self
            .lights
            .iter()
            .all(|light| matches!(light.kind, LightKind::Directional { .. }));
        // Each lane's position and directions, which only local lights read.
        if !quad.directional_only {
            quad.positions = positions;
            let (n_lanes, r_lanes) = (n.to_lanes(), r.to_lanes());
            quad.directions = std::array::from_fn(|l| PointDirections {
                n: n_lanes[l],
                r: r_lanes[l],
            });
        }
        // Only the directional lights' entries are written, and only they are read.
        for (k, light) in self.lights.iter().enumerate() {
            if let LightKind::Directional { .. } = light.kind {
                let l = Vec3x4::splat(light.axis);
                let n_dot_l = n.dot(l);
                quad.n_dot_l[k] = n_dot_l.to_array();
                quad.r_dot_l[k] = r.dot(l).to_array();
                quad.footprints[k] = match (light.shadowed, self.shadow) {
                    (true, Some(map)) => map.quad_footprints(p, n_dot_l),
                    _ => [None; 4],
                };
            }
        }
        true
    }

    /// Lane `l`'s [`Self::lighting`] (of the lights in `list` when given, as
    /// [`Self::lighting_listed`]) from its quad's arithmetic: the lane's reads, blocks,
    /// Phong powers and local lights, as the lane's own shader makes them.
    #[allow(clippy::too_many_arguments)]
    pub fn lane_lighting(
        &self,
        quad: &QuadLighting,
        l: usize,
        material: u32,
        surface: &SurfacePoint,
        list: Option<&[u32]>,
        blocks: &mut BlockSet,
        log: &mut AccessLog,
    ) -> Vec3 {
        blocks.take(Block::CoarseSetup);
        Self::log_normal_map(self.maps.of(material).normal, &quad.texels, l, blocks, log);
        let (exponent, strength) = self.phong_parameters(material, surface, blocks, log);
        let mut terms = [LightTerm::default(); QUAD_LIGHTS];
        let terms = &mut terms[..self.lights.len()];
        match (list, &mut *terms, blocks.lights.as_mut_slice()) {
            // One light (the usual scene): its term without a loop around it, whose set-up
            // per light costs a lane more than the loop's one step.
            (None, [term], [flags]) => self.lane_term(quad, l, 0, (exponent, strength), true, term, flags, log),
            (None, terms, lights) => {
                for (k, (term, flags)) in terms.iter_mut().zip(lights).enumerate() {
                    self.lane_term(quad, l, k, (exponent, strength), true, term, flags, log);
                }
            }
            (Some(list), terms, lights) => {
                for &k in list {
                    let k = k as usize;
                    self.lane_term(
                        quad,
                        l,
                        k,
                        (exponent, strength),
                        true,
                        &mut terms[k],
                        &mut lights[k],
                        log,
                    );
                }
            }
        }
        self.combine(terms)
    }

    /// Lane `l`'s [`Self::light_terms`] of every effect (one term per light, into `terms`) from
    /// its quad's arithmetic: the lane's reads, blocks and Phong powers, as
    /// [`Self::light_terms`] makes them. A multi-rate block's coarse stage shades its four
    /// corners so.
    #[allow(clippy::too_many_arguments)]
    pub fn lane_terms(
        &self,
        quad: &QuadLighting,
        l: usize,
        material: u32,
        surface: &SurfacePoint,
        terms: &mut [LightTerm],
        blocks: &mut BlockSet,
        log: &mut AccessLog,
    ) {
        blocks.take(Block::CoarseSetup);
        Self::log_normal_map(self.maps.of(material).normal, &quad.texels, l, blocks, log);
        let phong = self.phong_parameters(material, surface, blocks, log);
        for (k, (term, flags)) in terms.iter_mut().zip(blocks.lights.iter_mut()).enumerate() {
            self.lane_term(quad, l, k, phong, false, term, flags, log);
        }
    }

    /// The four lanes' colours from their quad's arithmetic: each lane's
    /// [`Self::lane_lighting`], [`Self::surface`] and [`compose`], where the lanes take the
    /// same blocks (every light directional: a local light's range test differs from lane
    /// to lane). Each lane's reads stay its own, lane after lane in the lane's order (Phong
    /// map, shadow footprints, surface maps: the maps' texels sampled for the four lanes
    /// first, [`Self::sample_surface_maps`] into `quad`, and each lane's reads logged in its
    /// turn); the rest runs four lanes at a time, with each lane's operations. `blocks`
    /// (cleared by the caller) gets what each lane takes. None, with nothing read or taken,
    /// where lanes could differ.
    pub fn quad_colors(
        &self,
        quad: &mut QuadLighting,
        material: u32,
        points: &[SurfacePoint; 4],
        list: Option<&[u32]>,
        blocks: &mut BlockSet,
        log: &mut AccessLog,
    ) -> Option<[Vec4; 4]> {
        if !quad.directional_only {
            return None;
        }
        // The lights each lane evaluates, in its order; one left out of the list keeps the
        // default term (all zero), as in the lanes'.
        let evaluated = list.unwrap_or(&EVERY_QUAD_LIGHT[..self.lights.len()]);
        let mut listed = [false; QUAD_LIGHTS];
        for &k in evaluated {
            listed[k as usize] = true;
        }
        // Each lane's reads, in the lane's order: its shadow visibilities (1 where a light
        // is unshadowed, or no footprint falls in the map; a light left out of the list adds
        // `1 * (0 + 0)`, the zero its default term adds) and its surface.
        let mut scale = [[1.0f32; 4]; QUAD_LIGHTS];
        // The evaluated lights that read the map, in order, found once for the four lanes.
        let mut shadowing = [0u32; QUAD_LIGHTS];
        let mut shadowing_len = 0;
        if self.shadow.is_some() {
            for &k in evaluated.iter().filter(|&&k| self.lights[k as usize].shadowed) {
                shadowing[shadowing_len] = k;
                shadowing_len += 1;
            }
        }
        let shadowing = &shadowing[..shadowing_len];
        // A material that samples no texture has the same Phong parameters and surface at
        // every lane: lane 0's, which takes their blocks. (A normal map's lanes read it in
        // turn, so they go lane by lane too.)
        let maps = self.maps.of(material);
        let textured = self.materials[material as usize].base_color_texture.is_some()
            || maps.metallic_roughness.is_some()
            || maps.occlusion.is_some()
            || maps.emissive_texture.is_some()
            || maps.normal.is_some();
        // Two loops rather than a test per lane: the one loop compiled to about 100 more
        // instructions per quad.
        let (phong_parameters, surfaces) = if textured {
            self.sample_surface_maps(material, points, true, &mut quad.texels);
            let quad = &*quad;
            let mut phong_parameters = [(0.0, 0.0); 4];
            let mut surfaces = [Surface::of_albedo(Vec4::ZERO); 4];
            for l in 0..4 {
                let texel = |texture: u32, log: &mut AccessLog| quad.texels.lane(texture, l, log);
                blocks.take(Block::CoarseSetup);
                Self::log_normal_map(maps.normal, &quad.texels, l, blocks, log);
                phong_parameters[l] = self.phong_parameters_of(material, blocks, log, texel);
                self.lane_visibilities(quad, l, shadowing, &mut scale, log);
                surfaces[l] = self.lane_surface(material, &quad.texels, l, blocks, log);
            }
            (phong_parameters, surfaces)
        } else {
            blocks.take(Block::CoarseSetup);
            let phong_parameters = self.phong_parameters(material, &points[0], blocks, log);
            self.lane_visibilities(quad, 0, shadowing, &mut scale, log);
            let surface = self.surface(material, &points[0], blocks, log);
            for l in 1..4 {
                self.lane_visibilities(quad, l, shadowing, &mut scale, log);
            }
            ([phong_parameters; 4], [surface; 4])
        };
        // Ambient plus every light's term in light order, as `combine` sums them (a loop
        // here: through `combine_quad`'s closure it compiled to 3% more instructions).
        let mut total = Vec3x4::splat(Vec3::splat(AMBIENT));
        for (k, light) in self.lights.iter().enumerate() {
            let (mut diffuse, mut specular) = (f32x4::ZERO, [0.0f32; 4]);
            if listed[k] {
                blocks.lights[k] |= LightBlocks::DIFFUSE | LightBlocks::SPECULAR;
                if light.shadowed && self.shadow.is_some() {
                    blocks.lights[k] |= LightBlocks::SHADOW;
                }
                let shading = DirectionalQuad {
                    n_dot_l: f32x4::new(quad.n_dot_l[k]),
                    r_dot_l: f32x4::new(quad.r_dot_l[k]),
                    exponent: f32x4::new(phong_parameters.map(|p| p.0)),
                    strength: f32x4::new(phong_parameters.map(|p| p.1)),
                };
                diffuse = shading.lambert();
                // The power (a call per lane) only where a lane needs it.
                let powered = shading.specular_lanes(f32x4::new(scale[k]));
                for (l, specular) in specular.iter_mut().enumerate() {
                    if powered & 1 << l != 0 {
                        *specular = shading.lane(l).specular(true, || false);
                    }
                }
            }
            let weight = f32x4::new(scale[k]) * (diffuse + f32x4::new(specular));
            total = total + Vec3x4::splat(light.radiance).scale(weight);
        }
        blocks.take(Block::Compose);
        Some(compose_quad(&surfaces, total))
    }

    /// Lane `l`'s shadow visibility of each light of `shadowing` (shadowed lights, where the
    /// scene has a map), into `scale[k][l]`, in light order (its PCF footprints' reads).
    #[inline(always)]
    fn lane_visibilities(
        &self,
        quad: &QuadLighting,
        l: usize,
        shadowing: &[u32],
        scale: &mut [[f32; 4]; QUAD_LIGHTS],
        log: &mut AccessLog,
    ) {
        let Some(map) = self.shadow else { return };
        for &k in shadowing {
            let k = k as usize;
            if let Some(footprint) = quad.footprints[k][l] {
                scale[k][l] = map.filter(footprint, log);
            }
        }
    }

    /// Light `k`'s term at lane `l` of a quad: [`Self::light_term`] from the quad's arithmetic
    /// (`only_combined` as [`Self::directional_term`] takes it).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn lane_term(
        &self,
        quad: &QuadLighting,
        l: usize,
        k: usize,
        (exponent, strength): (f32, f32),
        only_combined: bool,
        term: &mut LightTerm,
        flags: &mut LightBlocks,
        log: &mut AccessLog,
    ) {
        let light = &self.lights[k];
        match light.kind {
            LightKind::Directional { .. } => {
                let shading = Directional {
                    n_dot_l: quad.n_dot_l[k][l],
                    r_dot_l: quad.r_dot_l[k][l],
                    exponent,
                    strength,
                };
                let footprint = |_: &ShadowMap| quad.footprints[k][l];
                self.directional_term(
                    light,
                    &shading,
                    footprint,
                    Effects::all(),
                    only_combined,
                    term,
                    flags,
                    log,
                )
            }
            LightKind::Point { .. } | LightKind::Spot { .. } => {
                let PointDirections { n, r } = quad.directions[l];
                let point = PointInputs {
                    position: quad.positions.lane(l),
                    n,
                    r,
                    exponent,
                    strength,
                };
                local_term(light, &point, Effects::all(), term, flags)
            }
        }
    }

    /// Evaluates the requested effects of every light at one point into `terms` (one per
    /// light), recording the blocks executed.
    pub fn light_terms(
        &self,
        inp: &LightingInputs,
        effects: Effects,
        terms: &mut [LightTerm],
        blocks: &mut BlockSet,
        log: &mut AccessLog,
    ) {
        self.light_terms_of(inp, effects, None, terms, blocks, log)
    }

    /// [`ShaderEnv::light_terms`] of the lights in `list` only (every light when None); the
    /// terms of the others are left untouched.
    #[inline(always)]
    fn light_terms_of(
        &self,
        inp: &LightingInputs,
        effects: Effects,
        list: Option<&[u32]>,
        terms: &mut [LightTerm],
        blocks: &mut BlockSet,
        log: &mut AccessLog,
    ) {
        blocks.take(Block::CoarseSetup);
        let material = &self.materials[inp.material as usize];
        let PointDirections { n, r } = self.directions(inp, material.double_sided, blocks, log);
        let (exponent, strength) = self.phong_parameters(inp.material, &inp.surface, blocks, log);
        let point = PointInputs {
            position: inp.position,
            n,
            r,
            exponent,
            strength,
        };
        match list {
            None => {
                for (k, (term, flags)) in terms.iter_mut().zip(blocks.lights.iter_mut()).enumerate() {
                    self.light_term(k, &point, effects, term, flags, log);
                }
            }
            Some(list) => {
                for &k in list {
                    let k = k as usize;
                    self.light_term(k, &point, effects, &mut terms[k], &mut blocks.lights[k], log);
                }
            }
        }
    }

    /// The Phong exponent and weight at a point: its material's, or from its
    /// metallic-roughness map.
    #[inline(always)]
    fn phong_parameters(
        &self,
        material: u32,
        at: &SurfacePoint,
        blocks: &mut BlockSet,
        log: &mut AccessLog,
    ) -> (f32, f32) {
        self.phong_parameters_of(material, blocks, log, |texture, log| self.sample_map(texture, at, log))
    }

    /// [`Self::phong_parameters`] with the map's texel from `texel` (a texture's sample at
    /// the point, its reads logged).
    #[inline(always)]
    fn phong_parameters_of(
        &self,
        material: u32,
        blocks: &mut BlockSet,
        log: &mut AccessLog,
        texel: impl FnOnce(u32, &mut AccessLog) -> Vec4,
    ) -> (f32, f32) {
        match self.maps.of(material).metallic_roughness {
            None => {
                let material = &self.materials[material as usize];
                (material.specular_exponent, material.specular_strength)
            }
            Some((texture, roughness, metallic)) => {
                blocks.take(Block::MetallicRoughnessMap);
                let texel = texel(texture, log);
                phong_from_metallic_roughness(roughness * texel.y, metallic * texel.z)
            }
        }
    }

    /// Light `k`'s term at one point.
    #[inline(always)]
    fn light_term(
        &self,
        k: usize,
        point: &PointInputs,
        effects: Effects,
        term: &mut LightTerm,
        flags: &mut LightBlocks,
        log: &mut AccessLog,
    ) {
        let light = &self.lights[k];
        match light.kind {
            LightKind::Directional { .. } => {
                let l = light.axis;
                let n_dot_l = point.n.dot(l);
                let shading = Directional {
                    n_dot_l,
                    r_dot_l: point.r.dot(l),
                    exponent: point.exponent,
                    strength: point.strength,
                };
                let footprint = |map: &ShadowMap| map.footprint(point.position, n_dot_l);
                self.directional_term(light, &shading, footprint, effects, false, term, flags, log)
            }
            LightKind::Point { .. } | LightKind::Spot { .. } => local_term(light, point, effects, term, flags),
        }
    }

    /// A directional light's term: `footprint` gives the point's PCF footprint in the shadow
    /// map, asked only where the light is shadowed. When the term only feeds
    /// [`Self::combine`] (`only_combined`; a multi-rate scheme's predicates also read its
    /// specular), a specular term a full shadow hides is not computed: with a power in
    /// `[0, 1]` and a finite strength, `0 * (diffuse + specular)` is zero either way, so the
    /// colour's bits are the same without the `powf`.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn directional_term(
        &self,
        light: &ShadingLight,
        shading: &Directional,
        footprint: impl FnOnce(&ShadowMap) -> Option<PcfFootprint>,
        effects: Effects,
        only_combined: bool,
        term: &mut LightTerm,
        flags: &mut LightBlocks,
        log: &mut AccessLog,
    ) {
        let lit = shading.lit();
        if effects.contains(Effects::DIFFUSE) {
            *flags |= LightBlocks::DIFFUSE;
            term.diffuse = shading.lambert();
            if !light.shadowed {
                term.scale = 1.0;
            }
        }
        // The specular and shadow effects run on every fragment, facing the light or not,
        // as in He et al.'s shaders (Fig. 9: no test of N·L), so a pixel costs the same on
        // either side; what they add stays zero on the unlit side.
        if effects.contains(Effects::SHADOW) && light.shadowed {
            term.scale = match self.shadow {
                Some(map) => {
                    *flags |= LightBlocks::SHADOW;
                    footprint(map).map_or(1.0, |footprint| map.filter(footprint, log))
                }
                None => 1.0,
            };
        }
        if effects.contains(Effects::SPECULAR) {
            *flags |= LightBlocks::SPECULAR;
            // Where the specular term could be infinite or NaN, it is computed: it decides
            // the bits (R·L can round past 1, which an infinite exponent takes to infinity).
            // Its sign does not matter: a ±0 term leaves the positive ambient sum alone.
            let hidden = || {
                only_combined
                    && effects.contains(Effects::SHADOW)
                    && light.shadowed
                    && shading.hidden_by_shadow(term.scale)
            };
            term.specular = shading.specular(lit, hidden);
        }
    }

    /// A point's directions ([`Self::quad_lighting`] computes the same for four points
    /// of a material without a normal map).
    fn directions(
        &self,
        inp: &LightingInputs,
        double_sided: bool,
        blocks: &mut BlockSet,
        log: &mut AccessLog,
    ) -> PointDirections {
        let v = (inp.eye - inp.position).normalize_or(Vec3::Z);
        let mut n = inp.normal.normalize_or(Vec3::Y);
        // The side is the interpolated normal's: a normal map bends the normal, it does not
        // turn a front face into a back face.
        let back = n.dot(v) < 0.0 && double_sided;
        if let Some((texture, scale)) = self.maps.of(inp.material).normal {
            blocks.take(Block::NormalMap);
            n = self.normal_mapped(n, &inp.surface, texture, scale, log);
        }
        if back {
            n = -n;
        }
        let r = (2.0 * n.dot(v) * n - v).normalize_or(n);
        PointDirections { n, r }
    }

    /// Ambient plus every light's term, always summed in light order (so that a scheme that
    /// recomputes every term per pixel reproduces `per-pixel` bit for bit).
    pub fn combine(&self, terms: &[LightTerm]) -> Vec3 {
        let mut total = Vec3::splat(AMBIENT);
        for (light, t) in self.lights.iter().zip(terms) {
            total += light.radiance * (t.scale * (t.diffuse + t.specular));
        }
        total
    }

    /// [`Self::combine`] of four lanes at once, from light `k`'s `term(k)`: its scale,
    /// diffuse and specular lanes. The same sum in light order, so each lane's bits.
    #[inline(always)]
    pub fn combine_quad(&self, mut term: impl FnMut(usize) -> [f32x4; 3]) -> Vec3x4 {
        let mut total = Vec3x4::splat(Vec3::splat(AMBIENT));
        for (k, light) in self.lights.iter().enumerate() {
            let [scale, diffuse, specular] = term(k);
            total = total + Vec3x4::splat(light.radiance).scale(scale * (diffuse + specular));
        }
        total
    }

    /// The tangent-space normal map's normal: the texel (in [0, 1], scaled in x and y by
    /// `scale`) in the frame of the tangent, the bitangent `cross(n, t) * w` and `n`. A
    /// point without a usable tangent keeps `n`.
    fn normal_mapped(&self, n: Vec3, at: &SurfacePoint, texture: u32, scale: f32, log: &mut AccessLog) -> Vec3 {
        let texel = self.sample_map(texture, at, log);
        let tangent = at.tangent.truncate();
        let Some(t) = (tangent - n * n.dot(tangent)).try_normalize() else {
            return n;
        };
        let b = n.cross(t) * if at.tangent.w < 0.0 { -1.0 } else { 1.0 };
        let m = Vec3::new(
            (2.0 * texel.x - 1.0) * scale,
            (2.0 * texel.y - 1.0) * scale,
            2.0 * texel.z - 1.0,
        );
        (t * m.x + b * m.y + n * m.z).normalize_or(n)
    }

    /// [`Self::normal_mapped`] of a quad's four lanes (`n` their normals), four lanes at a
    /// time with each lane's operations, from the lanes' normal-map `texels`.
    #[inline(never)]
    fn normal_mapped_quad(&self, n: Vec3x4, points: &[SurfacePoint; 4], texels: [Vec4; 4], scale: f32) -> Vec3x4 {
        let tangent = Vec3x4::from_lanes(&points.map(|at| at.tangent.truncate()));
        let (t, usable) = (tangent - n.scale(n.dot(tangent))).try_normalize();
        let handedness = f32x4::new(points.map(|at| if at.tangent.w < 0.0 { -1.0 } else { 1.0 }));
        let b = n.cross(t).scale(handedness);
        let (two, one) = (f32x4::splat(2.0), f32x4::ONE);
        let texel = |c: usize| f32x4::new(texels.map(|texel| texel[c]));
        let m = [
            (two * texel(0) - one) * f32x4::splat(scale),
            (two * texel(1) - one) * f32x4::splat(scale),
            two * texel(2) - one,
        ];
        let mapped = (t.scale(m[0]) + b.scale(m[1]) + n.scale(m[2])).normalize_or(n);
        Vec3x4::select(usable, mapped, n)
    }

    /// Fine albedo: base colour, times the texture when the material has one.
    #[inline(always)]
    pub fn albedo(
        &self,
        material: u32,
        uv: Vec2,
        duv_dx: Vec2,
        duv_dy: Vec2,
        blocks: &mut BlockSet,
        log: &mut AccessLog,
    ) -> Vec4 {
        let at = SurfacePoint {
            uv,
            duv_dx,
            duv_dy,
            ..SurfacePoint::default()
        };
        self.albedo_at(material, &at, blocks, log)
    }

    /// [`Self::albedo`] at a surface point.
    #[inline(always)]
    fn albedo_at(&self, material: u32, at: &SurfacePoint, blocks: &mut BlockSet, log: &mut AccessLog) -> Vec4 {
        self.albedo_of(material, blocks, log, &mut |texture, log| {
            self.sample_map(texture, at, log)
        })
    }

    /// [`Self::albedo`] with the texture's texel from `texel`.
    #[inline(always)]
    fn albedo_of(
        &self,
        material: u32,
        blocks: &mut BlockSet,
        log: &mut AccessLog,
        texel: &mut impl FnMut(u32, &mut AccessLog) -> Vec4,
    ) -> Vec4 {
        blocks.take(Block::FineSetup);
        let m = &self.materials[material as usize];
        let base = Vec4::from(m.base_color);
        match m.base_color_texture {
            Some(t) => {
                blocks.take(Block::AlbedoTextured);
                base * texel(t, log)
            }
            None => {
                blocks.take(Block::AlbedoConstant);
                base
            }
        }
    }

    /// A map's samples at a quad's four points, each lane's reads kept in `reads`: four
    /// lanes at a time where they share a level of detail (a quad's points do), else lane
    /// by lane.
    fn sample_quad_map(&self, texture: u32, points: &[SurfacePoint; 4], reads: &mut [TexelLines; 4]) -> [Vec4; 4] {
        let map = &self.textures[texture as usize];
        let lods: [Lod; 4] = std::array::from_fn(|l| self.map_lod(texture, &points[l]));
        match lods.iter().all(|&lod| lod == lods[0]) {
            true => map.sample_quad_recording(std::array::from_fn(|l| points[l].uv), lods[0], reads),
            false => std::array::from_fn(|l| map.sample_recording(points[l].uv, lods[l], &mut reads[l])),
        }
    }

    /// Samples every map a lane of `material` reads in [`Self::surface`], and in
    /// [`Self::phong_parameters`] where `phong`, at the quad's points into `texels` (each
    /// texture once: one already there, the normal map's, is not sampled again).
    pub fn sample_surface_maps(&self, material: u32, points: &[SurfacePoint; 4], phong: bool, texels: &mut QuadTexels) {
        let maps = self.maps.of(material);
        let emissive = !is_zero(Vec3::from_array(maps.emissive));
        let read = [
            self.materials[material as usize].base_color_texture,
            maps.metallic_roughness.filter(|_| phong).map(|(texture, ..)| texture),
            maps.occlusion.map(|(texture, _)| texture),
            maps.emissive_texture.filter(|_| emissive),
        ];
        for texture in read.into_iter().flatten() {
            self.sample_quad_texture(texture, points, texels);
        }
    }

    /// `texture`'s texels at the quad's points, sampled into `texels` unless already there.
    fn sample_quad_texture(&self, texture: u32, points: &[SurfacePoint; 4], texels: &mut QuadTexels) -> [Vec4; 4] {
        if let Some(i) = texels.textures[..texels.len].iter().position(|&t| t == texture) {
            return texels.values[i];
        }
        let i = texels.len;
        texels.textures[i] = texture;
        texels.values[i] = self.sample_quad_map(texture, points, &mut texels.reads[i]);
        texels.len += 1;
        texels.values[i]
    }

    /// A surface map's trilinear sample where `at` says.
    fn sample_map(&self, texture: u32, at: &SurfacePoint, log: &mut AccessLog) -> Vec4 {
        self.textures[texture as usize].sample_at(at.uv, self.map_lod(texture, at), log)
    }

    /// A surface map's level of detail at `at`: its quad's, or found from its derivatives.
    #[inline(always)]
    fn map_lod(&self, texture: u32, at: &SurfacePoint) -> Lod {
        match at.lods.and_then(|lods| lods.of(texture)) {
            Some(lod) => lod,
            None => self.textures[texture as usize].lod(at.duv_dx, at.duv_dy),
        }
    }

    /// Lane `l`'s normal-map block and reads (where the material has a normal map), in their
    /// turn among its others: [`Self::quad_lighting`] took the texels' values and kept the
    /// reads in `texels` earlier.
    #[inline(always)]
    fn log_normal_map(
        normal: Option<(u32, f32)>,
        texels: &QuadTexels,
        l: usize,
        blocks: &mut BlockSet,
        log: &mut AccessLog,
    ) {
        if let Some((texture, _)) = normal {
            blocks.take(Block::NormalMap);
            texels.lane(texture, l, log);
        }
    }

    /// The textures `material` may sample: base colour, metallic-roughness, occlusion,
    /// emissive and normal maps.
    fn material_textures(&self, material: u32) -> [Option<u32>; MATERIAL_TEXTURES] {
        let maps = self.maps.of(material);
        [
            self.materials[material as usize].base_color_texture,
            maps.metallic_roughness.map(|(texture, ..)| texture),
            maps.occlusion.map(|(texture, _)| texture),
            maps.emissive_texture,
            maps.normal.map(|(texture, _)| texture),
        ]
    }

    /// Whether `material` samples any texture: a material that does not reads nothing of
    /// its surface points.
    pub fn samples_textures(&self, material: u32) -> bool {
        self.material_textures(material).iter().any(Option::is_some)
    }

    /// The level of detail of every texture `material` samples at derivatives (`dx`, `dy`):
    /// what each of a quad's lanes, which share them, would find. None for a material
    /// without textures.
    pub fn texture_lods(&self, material: u32, dx: Vec2, dy: Vec2) -> Option<TextureLods> {
        let mut lods = TextureLods::default();
        for texture in self.material_textures(material).into_iter().flatten() {
            let map = &self.textures[texture as usize];
            // A texture shaped like an earlier one (often: the same texture, or a
            // material's maps of one size) has its level of detail.
            let earlier = lods.textures[..lods.len]
                .iter()
                .position(|&t| self.textures[t as usize].same_shape(map));
            lods.textures[lods.len] = texture;
            lods.lods[lods.len] = match earlier {
                Some(i) => lods.lods[i],
                None => map.lod(dx, dy),
            };
            lods.len += 1;
        }
        (lods.len > 0).then_some(lods)
    }

    /// The fine surface at `at`: [`ShaderEnv::albedo`], and the occlusion and emission of
    /// the material's maps (nothing more for a material without them).
    #[inline(always)]
    pub fn surface(&self, material: u32, at: &SurfacePoint, blocks: &mut BlockSet, log: &mut AccessLog) -> Surface {
        self.surface_of(material, blocks, log, |texture, log| self.sample_map(texture, at, log))
    }

    /// Lane `l`'s [`Self::surface`] from its quad's texels ([`Self::sample_surface_maps`]):
    /// the lane's blocks, and its reads logged in its turn.
    #[inline(always)]
    pub fn lane_surface(
        &self,
        material: u32,
        texels: &QuadTexels,
        l: usize,
        blocks: &mut BlockSet,
        log: &mut AccessLog,
    ) -> Surface {
        self.surface_of(material, blocks, log, |texture, log| texels.lane(texture, l, log))
    }

    /// [`Self::surface`] with each map's texel from `texel` (a texture's sample at the
    /// point, its reads logged).
    #[inline(always)]
    fn surface_of(
        &self,
        material: u32,
        blocks: &mut BlockSet,
        log: &mut AccessLog,
        mut texel: impl FnMut(u32, &mut AccessLog) -> Vec4,
    ) -> Surface {
        let mut surface = Surface::of_albedo(self.albedo_of(material, blocks, log, &mut texel));
        let maps = self.maps.of(material);
        if let Some((texture, strength)) = maps.occlusion {
            blocks.take(Block::OcclusionMap);
            let ao = texel(texture, log).x;
            surface.occlusion = 1.0 + strength * (ao - 1.0);
        }
        let emissive = Vec3::from_array(maps.emissive);
        if !is_zero(emissive) {
            surface.emission = match maps.emissive_texture {
                Some(texture) => {
                    blocks.take(Block::EmissiveTextured);
                    emissive * texel(texture, log).truncate()
                }
                None => {
                    blocks.take(Block::EmissiveConstant);
                    emissive
                }
            };
        }
        surface
    }
}

/// A point or spot light's term (distance window, cone, Lambert and Phong).
#[inline(always)]
fn local_term(
    light: &ShadingLight,
    point: &PointInputs,
    effects: Effects,
    term: &mut LightTerm,
    flags: &mut LightBlocks,
) {
    let (LightKind::Point { position, range } | LightKind::Spot { position, range, .. }) = light.kind else {
        return;
    };
    let PointInputs {
        n,
        r,
        exponent,
        strength,
        ..
    } = *point;
    if !effects.intersects(Effects::DIFFUSE | Effects::SPECULAR) {
        return;
    }
    *flags |= LightBlocks::TEST;
    let to_light = position - point.position;
    let d2 = to_light.length_squared();
    let window = match range {
        Some(r) if r > 0.0 => {
            let x = d2 / (r * r);
            ((1.0 - x * x).max(0.0)).powi(2)
        }
        _ => 1.0,
    };
    if window <= 0.0 {
        *term = LightTerm::default();
        return;
    }
    *flags |= LightBlocks::LOCAL;
    let l = to_light.normalize_or(Vec3::Y);
    let n_dot_l = n.dot(l).max(0.0);
    if effects.contains(Effects::DIFFUSE) {
        let cone = match light.kind {
            LightKind::Spot { .. } => {
                let cos = (-l).dot(light.axis);
                let (ci, co) = light.cone_cosines;
                ((cos - co) / (ci - co).max(1e-4)).clamp(0.0, 1.0)
            }
            _ => 1.0,
        };
        term.scale = window * cone / d2.max(1e-4);
        term.diffuse = n_dot_l;
    }
    if effects.contains(Effects::SPECULAR) {
        term.specular = if n_dot_l > 0.0 {
            strength * phong(r.dot(l), exponent)
        } else {
            0.0
        };
    }
}

/// `(R·L)^n` for the lit side, 0 behind.
fn phong(r_dot_l: f32, exponent: f32) -> f32 {
    if r_dot_l <= 0.0 || underflows(r_dot_l, exponent) {
        0.0
    } else {
        libm::powf(r_dot_l, exponent)
    }
}

/// Whether `powf(x, y)` is surely +0 for `x > 0`: `log2(x) <= (x - 1) / ln 2`, so where
/// `y (x - 1) / ln 2` (in f64, a relative error near 2^-52) is below -151 (the bound holds
/// only for `y > 0`, and is positive otherwise), the power lies below 2^-150.9, which rounds
/// to zero, and `powf` returns it (it flushes a logarithm at or below -150). A glossy
/// material's large exponents take most of its lanes' powers there: no call for them.
#[inline]
fn underflows(x: f32, y: f32) -> bool {
    f64::from(y) * (f64::from(x) - 1.0) / std::f64::consts::LN_2 < -151.0
}

/// Final colour: albedo times lighting (its ambient part darkened by occlusion), plus
/// emission, Reinhard tone-mapped to [0, 1), alpha kept. NaN (which only degenerate input
/// could produce) becomes black rather than reaching an image. Without occlusion and
/// emission this is exactly `tonemap(albedo * lighting)`.
#[inline]
pub fn compose(surface: &Surface, lighting: Vec3, blocks: &mut BlockSet) -> Vec4 {
    blocks.take(Block::Compose);
    let albedo = surface.albedo;
    // The colour's three channels as one SIMD register (its fourth lane unused): each lane
    // runs the scalar channel's IEEE operations, so the bits are the scalar ones.
    let rgb = |v: Vec3| f32x4::new([v.x, v.y, v.z, 0.0]);
    let base = rgb(albedo.truncate());
    let mut c = base * rgb(lighting);
    if surface.occlusion != 1.0 {
        c -= base * f32x4::splat(AMBIENT * (1.0 - surface.occlusion));
    }
    if !is_zero(surface.emission) {
        c += rgb(surface.emission);
    }
    let [r, g, b, _] = finite_or_zero_lanes(c / (f32x4::ONE + c)).to_array();
    Vec4::new(r, g, b, finite_or_zero(albedo.w))
}

/// [`compose`] of four lanes at once, each lane's surface with its lighting (one lane per
/// SIMD lane, by channel): the same operations lane by lane, the occlusion and emission
/// terms selected where each lane has them. The caller takes the Compose block.
#[inline(always)]
pub fn compose_quad(surfaces: &[Surface; 4], lighting: Vec3x4) -> [Vec4; 4] {
    // Lane by lane without array `map`s: shared by two callers, their closures were left
    // out of line.
    let [s0, s1, s2, s3] = surfaces;
    let albedo = Vec3x4::from_lanes(&[
        s0.albedo.truncate(),
        s1.albedo.truncate(),
        s2.albedo.truncate(),
        s3.albedo.truncate(),
    ])
    .components();
    let lighting = lighting.components();
    let occlusion = f32x4::new([s0.occlusion, s1.occlusion, s2.occlusion, s3.occlusion]);
    let occluded = occlusion.simd_ne(f32x4::ONE);
    let darkening = f32x4::splat(AMBIENT) * (f32x4::ONE - occlusion);
    let emits = |s: &Surface| if is_zero(s.emission) { 0.0 } else { 1.0 };
    let emits = f32x4::new([emits(s0), emits(s1), emits(s2), emits(s3)]).simd_ne(f32x4::ZERO);
    let emission = Vec3x4::from_lanes(&[s0.emission, s1.emission, s2.emission, s3.emission]).components();
    let channel = |ch: usize| {
        let mut c = albedo[ch] * lighting[ch];
        if occluded.to_bitmask() != 0 {
            c = occluded.bitselect(c - albedo[ch] * darkening, c);
        }
        if emits.to_bitmask() != 0 {
            c = emits.bitselect(c + emission[ch], c);
        }
        finite_or_zero_lanes(c / (f32x4::ONE + c)).to_array()
    };
    let (r, g, b) = (channel(0), channel(1), channel(2));
    let lane = |l: usize, s: &Surface| Vec4::new(r[l], g[l], b[l], finite_or_zero(s.albedo.w));
    [lane(0, s0), lane(1, s1), lane(2, s2), lane(3, s3)]
}

/// `v == Vec3::ZERO` (either sign of zero; NaN is not zero), on the bits: one test where
/// the float comparisons branch per component (it runs per lane, and is mostly true).
#[inline(always)]
fn is_zero(v: Vec3) -> bool {
    (v.x.to_bits() | v.y.to_bits() | v.z.to_bits()) << 1 == 0
}

fn finite_or_zero(x: f32) -> f32 {
    if x.is_finite() {
        x.clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// [`finite_or_zero`] of four lanes: the same comparisons as selects, so that `-0.0` stays
/// `-0.0` as `clamp` leaves it (a SIMD `max` with 0 would not).
#[inline(always)]
fn finite_or_zero_lanes(x: f32x4) -> f32x4 {
    let (zero, one) = (f32x4::ZERO, f32x4::ONE);
    let clamped = x.simd_lt(zero).bitselect(zero, x.simd_gt(one).bitselect(one, x));
    x.is_finite().bitselect(clamped, zero)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use shadetrace_formats::AlphaMode;

    fn vec3() -> impl Strategy<Value = Vec3> {
        let c = || prop_oneof![-10.0f32..10.0, Just(0.0f32), -1e-20f32..1e-20];
        (c(), c(), c()).prop_map(|(x, y, z)| Vec3::new(x, y, z))
    }

    proptest! {
        // A fully shadowed, lit lane with a NaN or infinite Phong parameter is rare among
        // the draws; 4096 cases (a fraction of a second) reach it every time.
        #![proptest_config(ProptestConfig::with_cases(4096))]

        /// A quad's lighting, its arithmetic four lanes at a time and the rest lane by lane,
        /// gives each lane the bits, the blocks and the shadow-map reads of the lane's own
        /// lighting: the two are written apart and must not drift. Every kind of light, with
        /// and without a light list, and Phong parameters out of range (the quad's skips a
        /// specular term a full shadow hides only where that keeps the bits). The same for
        /// each lane's terms, which keep that specular term.
        #[test]
        fn quad_lighting_is_each_lanes_own(
            eye in vec3(),
            positions in prop::array::uniform4(vec3()),
            normals in prop::array::uniform4(vec3()),
            double_sided in any::<bool>(),
            listed in any::<bool>(),
            specular_exponent in prop_oneof![0.0f32..200.0, Just(-3.0), Just(f32::INFINITY), Just(f32::NAN)],
            specular_strength in prop_oneof![0.0f32..2.0, Just(-1.0), Just(f32::INFINITY), Just(f32::NAN)],
            normal_map in prop_oneof![Just(None), Just(Some(1.0f32)), (-2.0f32..2.0).prop_map(Some)],
            uvs in prop::array::uniform4((-2.0f32..2.0, -2.0f32..2.0)),
            // Tangents of every handedness, some unusable (zero, too long to normalize) or
            // along the normal.
            tangents in prop::array::uniform4(prop_oneof![
                3 => prop::array::uniform4(-1.0f32..1.0),
                1 => Just([0.0f32; 4]),
                1 => Just([1e30f32, -1e30, 0.0, 1.0]),
                1 => Just([0.0f32, 0.0, 1.0, -1.0]),
            ]),
        ) {
            let material = Material {
                name: String::new(),
                base_color: [1.0; 4],
                base_color_texture: None,
                specular_exponent,
                specular_strength,
                alpha: AlphaMode::Opaque,
                double_sided,
            };
            // A normal map of noise (the texels' values bend each lane's normal its own way).
            let (normals_texture, _) = MipTexture::build(
                &shadetrace_formats::Texture {
                    name: String::new(),
                    width: 32,
                    height: 16,
                    wrap_u: shadetrace_formats::Wrap::Repeat,
                    wrap_v: shadetrace_formats::Wrap::ClampToEdge,
                    rgba8: (0..32 * 16 * 4).map(|i: u32| (i.wrapping_mul(29) % 251) as u8).collect(),
                },
                0,
                false,
            );
            let maps = SurfaceMaps {
                materials: vec![shadetrace_formats::MaterialMaps {
                    normal: normal_map.map(|scale| (0, scale)),
                    metallic_roughness: None,
                    occlusion: None,
                    emissive: [0.0; 3],
                    emissive_texture: None,
                }],
                tangents: Vec::new(),
                linear_textures: vec![0],
            };
            // The lanes' points: the quad's with its levels of detail, each lane's own without.
            let points: [SurfacePoint; 4] = std::array::from_fn(|l| SurfacePoint {
                uv: Vec2::from(uvs[l]),
                duv_dx: Vec2::new(0.05, 0.0),
                duv_dy: Vec2::new(0.0, 0.3),
                tangent: Vec4::from_array(tangents[l]),
                lods: None,
            });
            let lights = [
                ShadingLight::new(LightKind::Directional { direction: Vec3::new(0.3, -1.0, 0.2) }, Vec3::ONE, true),
                ShadingLight::new(LightKind::Directional { direction: Vec3::new(-0.5, -0.2, 0.7) }, Vec3::splat(0.5), false),
                ShadingLight::new(
                    LightKind::Point { position: Vec3::new(1.0, 2.0, 0.5), range: Some(8.0) },
                    Vec3::splat(3.0),
                    false,
                ),
                ShadingLight::new(
                    LightKind::Spot {
                        position: Vec3::new(-2.0, 3.0, 1.0),
                        direction: Vec3::new(0.2, -1.0, 0.1),
                        inner_cone: 0.3,
                        outer_cone: 0.6,
                        range: None,
                    },
                    Vec3::splat(2.0),
                    false,
                ),
            ];
            // The map covers the points' range, so footprints fall inside it and at its edges.
            let mut map = crate::shadow::test_map(64);
            map.view_projection = glam::Mat4::from_scale(Vec3::splat(0.1));
            let env = ShaderEnv {
                materials: std::slice::from_ref(&material),
                textures: std::slice::from_ref(&normals_texture),
                lights: &lights,
                shadow: Some(&map),
                receivers: None,
                maps: &maps,
            };
            let quad_points = points.map(|at| SurfacePoint {
                lods: env.texture_lods(0, at.duv_dx, at.duv_dy),
                ..at
            });
            let list = [0u32, 2];
            let list = listed.then_some(&list[..]);
            let mut quad = QuadLighting::default();
            let (p, n) = (Vec3x4::from_lanes(&positions), Vec3x4::from_lanes(&normals));
            prop_assert!(env.quad_lighting(0, eye, p, n, Some(&quad_points), &mut quad));
            let (mut quad_log, mut lane_log) = (AccessLog::new(), AccessLog::new());
            let bits = |v: Vec3| v.to_array().map(f32::to_bits);
            for l in 0..4 {
                let (mut quad_blocks, mut lane_blocks) = (BlockSet::new(lights.len()), BlockSet::new(lights.len()));
                let surface = quad_points[l];
                let got = env.lane_lighting(&quad, l, 0, &surface, list, &mut quad_blocks, &mut quad_log);
                let inputs = LightingInputs {
                    position: positions[l],
                    normal: normals[l],
                    eye,
                    material: 0,
                    surface: points[l],
                };
                let want = match list {
                    Some(list) => env.lighting_listed(&inputs, list, &mut lane_blocks, &mut lane_log),
                    None => env.lighting(&inputs, &mut lane_blocks, &mut lane_log),
                };
                prop_assert_eq!(bits(got), bits(want));
                prop_assert_eq!(&quad_blocks, &lane_blocks);
                // Every light's terms (a multi-rate block's corner): each effect's bits, the
                // blocks and the reads, after the lighting's in both logs.
                let (mut quad_terms, mut own_terms) = ([LightTerm::default(); 4], [LightTerm::default(); 4]);
                let (mut quad_blocks, mut lane_blocks) = (BlockSet::new(lights.len()), BlockSet::new(lights.len()));
                env.lane_terms(&quad, l, 0, &surface, &mut quad_terms, &mut quad_blocks, &mut quad_log);
                env.light_terms(&inputs, Effects::all(), &mut own_terms, &mut lane_blocks, &mut lane_log);
                let term_bits = |t: &[LightTerm; 4]| t.map(|t| [t.scale, t.diffuse, t.specular].map(f32::to_bits));
                prop_assert_eq!(term_bits(&quad_terms), term_bits(&own_terms));
                prop_assert_eq!(&quad_blocks, &lane_blocks);
            }
            let reads = |log: &AccessLog| log.expanded(0, crate::memory::Stream::Texture);
            prop_assert_eq!(reads(&quad_log), reads(&lane_log));
        }
    }

    /// An f32 of every kind a cosine or Phong parameter can be: ordinary, either zero, 1
    /// and the values beside it, infinite and NaN.
    fn any_kind_of_f32() -> impl Strategy<Value = f32> {
        prop_oneof![
            -2.0f32..2.0,
            0.0f32..300.0,
            prop::sample::select(vec![
                0.0,
                -0.0,
                1.0,
                f32::from_bits(1.0f32.to_bits() + 1),
                f32::from_bits(1.0f32.to_bits() - 1),
                -1.0,
                f32::INFINITY,
                f32::NEG_INFINITY,
                f32::NAN,
            ]),
        ]
    }

    proptest! {
        /// The four-wide directional tests are each lane's own: Lambert bits, and which
        /// lanes' specular is the power, for every kind of cosine, parameter and visibility.
        #[test]
        fn directional_quad_is_each_lanes_directional(
            n_dot_l in prop::array::uniform4(any_kind_of_f32()),
            r_dot_l in prop::array::uniform4(any_kind_of_f32()),
            exponent in prop::array::uniform4(any_kind_of_f32()),
            strength in prop::array::uniform4(any_kind_of_f32()),
            scale in prop::array::uniform4(prop_oneof![Just(0.0f32), Just(1.0), 0.0f32..1.0]),
        ) {
            let quad = DirectionalQuad {
                n_dot_l: f32x4::new(n_dot_l),
                r_dot_l: f32x4::new(r_dot_l),
                exponent: f32x4::new(exponent),
                strength: f32x4::new(strength),
            };
            let (lambert, powered) = (quad.lambert().to_array(), quad.specular_lanes(f32x4::new(scale)));
            for l in 0..4 {
                let lane = Directional { n_dot_l: n_dot_l[l], r_dot_l: r_dot_l[l], exponent: exponent[l], strength: strength[l] };
                prop_assert_eq!(lambert[l].to_bits(), lane.lambert().to_bits());
                prop_assert_eq!(powered & 1 << l != 0, lane.lit() && !lane.hidden_by_shadow(scale[l]));
                let alone = quad.lane(l);
                let fields = |d: &Directional| [d.n_dot_l, d.r_dot_l, d.exponent, d.strength].map(f32::to_bits);
                prop_assert_eq!(fields(&alone), fields(&lane));
            }
        }
    }

    proptest! {
        // As above: the rare draws need many cases (a fraction of a second).
        #![proptest_config(ProptestConfig::with_cases(4096))]

        /// A quad shaded together (`quad_colors`) gives each lane the colour bits, the blocks
        /// and the reads, in order, of the lane's own lighting, surface and compose: with and
        /// without a light list, a base colour texture and each map but the normal map or
        /// not, and Phong parameters out of range; the quad's textures' levels of detail
        /// found once for it, the lanes' each on their own. A quad lit by a point light is
        /// left to its lanes, with nothing read or taken.
        #[test]
        fn quad_colors_are_each_lanes_own(
            eye in vec3(),
            positions in prop::array::uniform4(vec3()),
            normals in prop::array::uniform4(vec3()),
            uvs in prop::array::uniform4((-2.0f32..2.0, -2.0f32..2.0)),
            derivatives in prop::array::uniform4(-0.5f32..0.5),
            // Base colour texture, metallic-roughness, occlusion and emissive maps.
            maps in prop::array::uniform4(any::<bool>()),
            emissive in prop_oneof![Just([0.0f32; 3]), Just([0.5, 0.2, 0.0])],
            list in prop_oneof![Just(None), Just(Some(vec![0u32])), Just(Some(vec![1u32])), Just(Some(vec![0u32, 1]))],
            point_light in any::<bool>(),
            shadow_map in any::<bool>(),
            base_color in prop::array::uniform4(prop_oneof![0.0f32..1.0, Just(0.0), Just(-0.0)]),
            specular_exponent in prop_oneof![0.0f32..200.0, Just(-3.0), Just(f32::INFINITY), Just(f32::NAN)],
            specular_strength in prop_oneof![0.0f32..2.0, Just(-1.0), Just(f32::INFINITY), Just(f32::NAN)],
            normal_map in any::<bool>(),
            tangents in prop::array::uniform4(prop::array::uniform4(-1.0f32..1.0)),
        ) {
            let [textured, phong_map, occlusion_map, emissive_map] = maps;
            let material = Material {
                name: String::new(),
                base_color,
                base_color_texture: textured.then_some(0),
                specular_exponent,
                specular_strength,
                alpha: AlphaMode::Opaque,
                double_sided: true,
            };
            // Of two sizes, so that their levels of detail differ.
            let noise = |seed: u32, left: u8, width: u32| shadetrace_formats::Texture {
                name: String::new(),
                width,
                height: 16,
                wrap_u: shadetrace_formats::Wrap::Repeat,
                wrap_v: shadetrace_formats::Wrap::ClampToEdge,
                // One value on the left half (black colour, white data), so that a quad's
                // lanes can emit or not, and be occluded or not.
                rgba8: (0..width * 16 * 4)
                    .map(|i: u32| if i / 4 % width < width / 2 { left } else { (i.wrapping_mul(seed) % 251) as u8 })
                    .collect(),
            };
            let (colour, end) = MipTexture::build(&noise(7, 0, 16), 0, true);
            let (data, _) = MipTexture::build(&noise(13, 255, 64), end, false);
            let maps = SurfaceMaps {
                materials: vec![shadetrace_formats::MaterialMaps {
                    normal: normal_map.then_some((1, 0.8)),
                    metallic_roughness: phong_map.then_some((1, 0.7, 0.3)),
                    occlusion: occlusion_map.then_some((1, 0.8)),
                    emissive,
                    emissive_texture: emissive_map.then_some(0),
                }],
                tangents: Vec::new(),
                linear_textures: vec![1],
            };
            let mut lights = vec![
                ShadingLight::new(LightKind::Directional { direction: Vec3::new(0.3, -1.0, 0.2) }, Vec3::ONE, true),
                ShadingLight::new(LightKind::Directional { direction: Vec3::new(-0.5, -0.2, 0.7) }, Vec3::splat(0.5), false),
            ];
            if point_light {
                let point = LightKind::Point { position: Vec3::new(1.0, 2.0, 0.5), range: Some(8.0) };
                lights.push(ShadingLight::new(point, Vec3::splat(3.0), false));
            }
            let mut map = crate::shadow::test_map(64);
            map.view_projection = glam::Mat4::from_scale(Vec3::splat(0.1));
            let env = ShaderEnv {
                materials: std::slice::from_ref(&material),
                textures: &[colour, data],
                lights: &lights,
                shadow: shadow_map.then_some(&map),
                receivers: None,
                maps: &maps,
            };
            let points = std::array::from_fn(|l| SurfacePoint {
                uv: Vec2::from(uvs[l]),
                duv_dx: Vec2::new(derivatives[0], derivatives[1]),
                duv_dy: Vec2::new(derivatives[2], derivatives[3]),
                tangent: Vec4::from_array(tangents[l]),
                lods: None,
            });
            // The quad's points with its textures' levels of detail found once (as
            // `per-pixel` shades them), the lanes' without: the same colours and reads.
            let quad_points = points.map(|at| SurfacePoint {
                lods: env.texture_lods(0, at.duv_dx, at.duv_dy),
                ..at
            });
            let mut quad = QuadLighting::default();
            let (p, n) = (Vec3x4::from_lanes(&positions), Vec3x4::from_lanes(&normals));
            prop_assert!(env.quad_lighting(0, eye, p, n, Some(&quad_points), &mut quad));
            let list = list.as_deref();
            let (mut quad_log, mut lane_log) = (AccessLog::new(), AccessLog::new());
            let mut quad_blocks = BlockSet::new(lights.len());
            let together = env.quad_colors(&mut quad, 0, &quad_points, list, &mut quad_blocks, &mut quad_log);
            let reads = |log: &AccessLog| log.expanded(0, crate::memory::Stream::Texture);
            let Some(together) = together else {
                prop_assert!(point_light);
                prop_assert_eq!(&quad_blocks, &BlockSet::new(lights.len()));
                prop_assert!(reads(&quad_log).is_empty());
                return Ok(());
            };
            prop_assert!(!point_light);
            for (l, at) in points.iter().enumerate() {
                let mut lane_blocks = BlockSet::new(lights.len());
                let lighting = env.lane_lighting(&quad, l, 0, at, list, &mut lane_blocks, &mut lane_log);
                let surface = env.surface(0, at, &mut lane_blocks, &mut lane_log);
                let own = compose(&surface, lighting, &mut lane_blocks);
                prop_assert_eq!(together[l].to_array().map(f32::to_bits), own.to_array().map(f32::to_bits), "lane {}", l);
                prop_assert_eq!(&quad_blocks, &lane_blocks, "lane {}", l);
            }
            prop_assert_eq!(reads(&quad_log), reads(&lane_log));
        }
    }

    fn channel() -> impl Strategy<Value = f32> {
        prop_oneof![
            -4.0f32..4.0,
            Just(0.0f32),
            Just(-0.0f32),
            Just(1.0f32),
            Just(f32::INFINITY),
            Just(f32::NEG_INFINITY),
            Just(f32::NAN),
            Just(f32::MAX),
            -1e-30f32..1e-30,
        ]
    }

    proptest! {
        /// `compose`, three channels in one SIMD register, gives the bits of the scalar
        /// channel-by-channel definition, at both zeros, NaN, infinities and overflow.
        #[test]
        fn compose_is_the_scalar_definition(
            albedo in prop::array::uniform4(channel()),
            lighting in prop::array::uniform3(channel()),
            emission in prop::array::uniform3(channel()),
            occlusion in prop_oneof![Just(1.0f32), channel()],
        ) {
            let surface = Surface {
                albedo: Vec4::from_array(albedo),
                emission: Vec3::from_array(emission),
                occlusion,
            };
            let lighting = Vec3::from_array(lighting);
            let mut c = surface.albedo.truncate() * lighting;
            if occlusion != 1.0 {
                c -= surface.albedo.truncate() * (AMBIENT * (1.0 - occlusion));
            }
            if surface.emission != Vec3::ZERO {
                c += surface.emission;
            }
            let mapped = c / (Vec3::ONE + c);
            let scalar = [mapped.x, mapped.y, mapped.z, surface.albedo.w].map(finite_or_zero);
            let composed = compose(&surface, lighting, &mut BlockSet::new(0)).to_array();
            prop_assert_eq!(composed.map(f32::to_bits), scalar.map(f32::to_bits));
        }
    }

    proptest! {
        /// Where the power is taken as underflowing, `powf` gives +0: bases from the
        /// smallest subnormal to just below 1, exponents up to infinity, and exponents that
        /// put the bound near the underflow (where, for bases near 1, it is the power's own
        /// logarithm: a bound of -150 or more would take subnormal powers for zero).
        #[test]
        fn underflowing_powers_are_zero(
            x in prop_oneof![f32::from_bits(1)..1.0f32, 0.99f32..1.0, Just(f32::from_bits(0x3f7f_ffff))],
            y in prop_oneof![0.0f32..1e3, 0.0f32..1e9, Just(f32::INFINITY)],
            bound in -153.0f64..-147.0,
        ) {
            let at_bound = (bound * std::f64::consts::LN_2 / (f64::from(x) - 1.0)) as f32;
            for y in [y, at_bound] {
                if underflows(x, y) {
                    prop_assert_eq!(libm::powf(x, y).to_bits(), 0, "{}^{}", x, y);
                }
            }
        }
    }

    /// `is_zero` is `== Vec3::ZERO`: at both zeros, the smallest subnormals, NaN of either
    /// sign, the infinities and ordinary values, in every combination of components.
    #[test]
    fn is_zero_is_comparison_with_zero() {
        let values = [
            0.0,
            -0.0,
            f32::from_bits(1),
            -f32::from_bits(1),
            1.0,
            f32::NAN,
            -f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
        ];
        for x in values {
            for y in values {
                for z in values {
                    let v = Vec3::new(x, y, z);
                    assert_eq!(is_zero(v), v == Vec3::ZERO, "{v:?}");
                }
            }
        }
    }
}
