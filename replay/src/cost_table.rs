//! The one cost table: ALU and texture instructions per shader block. Every scheme issues
//! the same blocks from this table, so relative costs compare like with like.
//!
//! The counts model the shader of ARCHITECTURE.md (Definitions) (Lambert + Phong + 5x5 PCF, times a per-pixel
//! albedo). With one shadowed light and a textured albedo, the coarse-able blocks are 104 of
//! 115 instructions (90%), close to the 91% He et al. report for their baseline shader.

use serde::Serialize;

/// Instructions of one block.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct BlockCost {
    pub alu: u32,
    pub tex: u32,
}

/// The blocks of the shader. Fine blocks run per pixel in every scheme; coarse-able blocks
/// run per pixel in `per-pixel` shading and per coarse fragment in multi-rate schemes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Block {
    /// Fine: interpolate uv.
    FineSetup,
    /// Fine: base colour without a texture.
    AlbedoConstant,
    /// Fine: base colour times a trilinear texture sample (LOD from quad derivatives).
    AlbedoTextured,
    /// Fine: albedo times lighting, tone map, output.
    Compose,
    /// Coarse-able: interpolate position and normal, normalize, view vector.
    CoarseSetup,
    /// Coarse-able: Lambert term of one directional light.
    Diffuse,
    /// Coarse-able: Phong `(R·L)^n` of one directional light (every fragment, as in He et al.'s
    /// shaders, which do not test N·L).
    Specular,
    /// Coarse-able: 5x5 PCF lookup of the shadow map (every fragment).
    Shadow,
    /// Coarse-able: one point or spot light in range (distance, falloff, diffuse, specular).
    LocalLight,
    /// Multi-rate fine: resampling the coarse outputs (diffuse RGB, specular RGB, visibility:
    /// 7 scalars, one interpolation instruction each, like triangle attributes) to the pixel.
    Resample,
    /// Multi-rate coarse predicate: screen-space variation of N·L, one `fwidth` (He et al.
    /// §4.1: "the overhead of this adaptivity check is minimal"). Predicate costs follow the
    /// paper's account of what each predicate adds to the lighting it already computes.
    PredicateDiffuse,
    /// Multi-rate coarse predicate: flatness and reflection-cone test: the average reflection
    /// direction and two dot products (He et al. §4.1).
    PredicateSpecular,
    /// Multi-rate coarse predicate: one edge-receiver lookup and the occlusion difference (§4.2).
    PredicateShadow,
    /// Tile-pair cache: hash the key `h(q, n, v)` and probe the on-chip cache (§5.1).
    CacheQuery,
    /// Tile-pair reuse shader on a local hit: position and normal differences (Algorithm 2).
    ReuseTest,
    /// Tile-pair reuse on a cross-view hit: projection, reflection and the `R · L` check.
    ReuseCrossView,
    /// Deferred G-buffer pass: interpolate and normalize the normal, octahedral encoding to
    /// 2x16 bits, pack albedo, ids and depth into the targets.
    GBufferWrite,
    /// Deferred lighting pass: four G-buffer fetches (depth, normal, albedo, ids), octahedral
    /// decode, position from depth.
    GBufferRead,
    /// Coarse-able: one point or spot light considered, in range or not: the vector to it,
    /// its squared length against the squared range, the branch. What a light list saves.
    LightTest,
    /// Light-list build, one lane per light and region: the light's sphere against the six
    /// planes of a tile's or cluster's frustum, and the append to the list.
    LightCull,
    /// Tiled shading: a pixel's samples into the tile's depth bounds (min, max, reduction).
    DepthBounds,
    /// Clustered shading: a pixel's cluster from its depth (view distance, log, slice) and
    /// the fetch of the cluster's list header.
    ClusterLookup,
    /// Visibility buffer, geometry pass: write the triangle and instance ids.
    VisibilityWrite,
    /// Visibility buffer, shading pass: read the ids, fetch the triangle's three vertices,
    /// barycentrics from its plane equations, interpolate position, normal and uv and their
    /// screen-space derivatives (deferred texturing, RTR4 §20.5).
    VisibilityInterpolate,
    /// DAIS fill pass, per fragment: hash the triangle id, probe the bucket's two entries
    /// (on a miss, the lock's atomic exchange and the slot allocation), write the visibility
    /// sample's reference and coverage.
    MemoLookup,
    /// DAIS fill pass, the fragment that won the lock: write the triangle's three vertices
    /// (1/w, normal, uv) into its slot; one divergent branch of its SIMD group.
    TriangleStore,
    /// DAIS derivative pass (Appendix A), per stored triangle: project the vertices, the
    /// barycentrics' screen derivatives, then the value at the screen centre and the x and
    /// y derivatives of 1/w and of normal and uv over w (18 dot products of three), and the
    /// record's write.
    TriangleDerivatives,
    /// DAIS shading pass: read the visibility sample and the triangle's record, Eq. 2 for
    /// 1/w, normal and uv at the pixel, uv's analytic derivatives for the texture LOD, the
    /// position from depth.
    DaisInterpolate,
    /// DAIS linked list, fill pass: allocate a node (atomic counter), write count, triangle
    /// and next pointer, swap the pixel's head.
    ListAppend,
    /// DAIS linked list, shading pass: read one node and follow its pointer.
    ListNode,
    /// DAIS multi-rate fill pass: agree within the 2x2 shading quad (one elected lane
    /// creates the sample) and write the sample's reference.
    ShadingSampleRef,
    /// DAIS multi-rate shading-sample pass: LogLuv-encode the result and store it.
    ShadingSampleWrite,
    /// DAIS multi-rate resolve: read the reference and the sample, LogLuv-decode it.
    ShadingSampleRead,
    /// Reprojection, per grid cell: the tessellation factor from its depth bounds (two
    /// linearizations, two arctangents of the binocular parallax, the threshold).
    TessFactor,
    /// Reprojection, per grid vertex (domain shader): fetch the left depth, the
    /// reprojection matrix (4x4), the perspective divide, the viewport transform.
    GridVertex,
    /// Reprojection, per grid fragment: the bilinear lookup of the left image, the depth
    /// test's output.
    WarpFragment,
    /// Ray-traced hole filling, per ray: origin and direction from the pixel (ray generation).
    RayGen,
    /// Per BVH node a ray visits: the slab tests of its two children, the stack.
    NodeVisit,
    /// Per triangle a ray tests: Möller-Trumbore.
    TriangleTest,
    /// Per hit: fetch the triangle's vertices and interpolate position, normal and uv from
    /// the hit's barycentrics.
    HitAttributes,
    /// Per hit: the ray cone's footprint and the texture LOD (Akenine-Möller et al. 2019).
    RayCone,
    /// BVH build, per triangle (PLOC: bounds, Morton code, radix sort, nearest-neighbour
    /// merging, over its passes).
    BvhBuild,
    /// Coarse-able: normal map: interpolate the tangent (4), the bitangent from the cross
    /// product and sign (4), one trilinear fetch, unpack and scale (3), into world space
    /// (9 multiply-adds), normalize (3).
    NormalMap,
    /// Coarse-able: metallic-roughness map: one fetch, times the two factors (2), then
    /// capture's roughness-to-Phong mapping (alpha, Blinn exponent, quarter and clamp, the
    /// Fresnel blend: 8).
    MetallicRoughnessMap,
    /// Fine: occlusion map: one fetch, its strength (2), the ambient part removed (3).
    OcclusionMap,
    /// Fine: a constant emissive colour added (3).
    EmissiveConstant,
    /// Fine: the emissive colour times one fetch of its texture (3), added (3).
    EmissiveTextured,
}

impl Block {
    pub const fn cost(self) -> BlockCost {
        let (alu, tex) = match self {
            Block::FineSetup => (4, 0),
            Block::AlbedoConstant => (1, 0),
            Block::AlbedoTextured => (2, 1),
            Block::Compose => (4, 0),
            Block::CoarseSetup => (8, 0),
            Block::Diffuse => (6, 0),
            Block::Specular => (12, 0),
            Block::Shadow => (53, 25),
            Block::LocalLight => (22, 0),
            Block::LightTest => (5, 0),
            Block::LightCull => (26, 0),
            Block::DepthBounds => (4, 0),
            Block::ClusterLookup => (8, 0),
            Block::VisibilityWrite => (2, 0),
            Block::VisibilityInterpolate => (36, 0),
            Block::MemoLookup => (6, 0),
            Block::TriangleStore => (12, 0),
            Block::TriangleDerivatives => (96, 0),
            Block::DaisInterpolate => (30, 0),
            Block::ListAppend => (4, 0),
            Block::ListNode => (3, 0),
            Block::ShadingSampleRef => (4, 0),
            Block::ShadingSampleWrite => (6, 0),
            Block::ShadingSampleRead => (6, 0),
            Block::TessFactor => (14, 0),
            Block::GridVertex => (24, 1),
            Block::WarpFragment => (8, 1),
            Block::RayGen => (10, 0),
            Block::NodeVisit => (16, 0),
            Block::TriangleTest => (24, 0),
            Block::HitAttributes => (18, 0),
            Block::RayCone => (10, 0),
            Block::BvhBuild => (60, 0),
            Block::NormalMap => (23, 1),
            Block::MetallicRoughnessMap => (10, 1),
            Block::OcclusionMap => (5, 1),
            Block::EmissiveConstant => (3, 0),
            Block::EmissiveTextured => (6, 1),
            Block::Resample => (7, 0),
            Block::PredicateDiffuse => (2, 0),
            Block::PredicateSpecular => (6, 0),
            Block::PredicateShadow => (4, 1),
            Block::CacheQuery => (4, 0),
            Block::ReuseTest => (8, 0),
            Block::ReuseCrossView => (16, 0),
            Block::GBufferWrite => (12, 0),
            Block::GBufferRead => (10, 4),
        };
        BlockCost { alu, tex }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coarse_share_of_the_baseline_shader() {
        let sum = |blocks: &[Block]| blocks.iter().map(|b| b.cost().alu + b.cost().tex).sum::<u32>();
        let fine = sum(&[Block::FineSetup, Block::AlbedoTextured, Block::Compose]);
        let coarse = sum(&[Block::CoarseSetup, Block::Diffuse, Block::Specular, Block::Shadow]);
        assert_eq!((fine, coarse), (11, 104));
    }
}
