//! The registry of shading schemes: each entry names a scheme, says what it models and
//! reports, and builds it. Nothing outside this file matches on scheme names; adding a scheme
//! is one module plus one line in [`SCHEMES`].

use shadetrace_formats::{AlphaMode, Scene};

use super::multirate::{self, CacheSpace};
use super::{Dais, Deferred, ForwardPlus, HoleFill, Lists, PerPixel, Reprojection, ShadingScheme, Target, Variant};
use crate::options::ReplayOptions;
use crate::preset::Preset;

pub struct SchemeEntry {
    pub name: &'static str,
    /// What the scheme models, for `shadetrace presets`.
    pub models: &'static str,
    /// Results carry per-pixel refinement counts and heat maps (multi-rate schemes).
    pub reports_refinement: bool,
    /// Results carry shading-cache statistics.
    pub reports_cache: bool,
    /// The refinement thresholds and `--threshold-scale` apply (what `sweep` varies).
    pub has_thresholds: bool,
    pub build: fn(&Preset, &ReplayOptions) -> Box<dyn ShadingScheme>,
    /// Whether the scheme can run on a trace; the error names what is missing.
    pub supports: fn(&Scene) -> Result<(), String>,
}

fn any_scene(_: &Scene) -> Result<(), String> {
    Ok(())
}

pub const SCHEMES: [SchemeEntry; 15] = [
    SchemeEntry {
        name: "per-pixel",
        models: "every lane of every quad runs the whole shader (the reference)",
        reports_refinement: false,
        reports_cache: false,
        has_thresholds: false,
        build: |_, _| Box::new(PerPixel),
        supports: any_scene,
    },
    SchemeEntry {
        name: "forward-plus",
        models:
            "tiled forward (RTR4 20.3): z-prepass, light lists per 16x16 tile from its depth bounds, forward shading",
        reports_refinement: false,
        reports_cache: false,
        has_thresholds: false,
        build: |_, _| Box::new(ForwardPlus),
        supports: any_scene,
    },
    SchemeEntry {
        name: "multirate",
        models: "He, Gu and Fatahalian 2014: coarse blocks, refinement predicates, SIMD schedules",
        reports_refinement: true,
        reports_cache: false,
        has_thresholds: true,
        build: |p, o| multirate::build(p.mode, o, None),
        supports: any_scene,
    },
    SchemeEntry {
        name: "tile-pair-cache",
        models: "Yuan, Wang and Bao: multi-rate shading through a screen-space cache with cross-view reuse",
        reports_refinement: true,
        reports_cache: true,
        has_thresholds: true,
        build: |p, o| multirate::build(p.mode, o, Some(CacheSpace::Screen)),
        supports: any_scene,
    },
    SchemeEntry {
        name: "amfs",
        models: "AMFS-like patch-space shading cache, local and view-independent",
        reports_refinement: true,
        reports_cache: true,
        has_thresholds: true,
        build: |p, o| multirate::build(p.mode, o, Some(CacheSpace::Patch)),
        supports: any_scene,
    },
    SchemeEntry {
        name: "texel",
        models: "texel shading: a texture-space cache over a unique UV atlas",
        reports_refinement: true,
        reports_cache: true,
        has_thresholds: true,
        build: |p, o| multirate::build(p.mode, o, Some(CacheSpace::Texture)),
        supports: multirate::supports_texel,
    },
    SchemeEntry {
        name: "deferred",
        models:
            "deferred shading: G-buffer (20 bytes per sample, normals octahedral 2x16), lighting per pixel and triangle",
        reports_refinement: false,
        reports_cache: false,
        has_thresholds: false,
        build: |_, _| {
            Box::new(Deferred {
                target: Target::GBuffer,
                lists: Lists::None,
            })
        },
        supports: gbuffer_without_maps,
    },
    SchemeEntry {
        name: "tiled",
        models: "tiled deferred shading (RTR4 20.3): light lists per 16x16 tile from its depth bounds",
        reports_refinement: false,
        reports_cache: false,
        has_thresholds: false,
        build: |_, _| {
            Box::new(Deferred {
                target: Target::GBuffer,
                lists: Lists::Tiled,
            })
        },
        supports: gbuffer_without_maps,
    },
    SchemeEntry {
        name: "clustered",
        models: "clustered deferred shading (RTR4 20.4): light lists per 64x64 px x 16 exponential depth slices",
        reports_refinement: false,
        reports_cache: false,
        has_thresholds: false,
        build: |_, _| {
            Box::new(Deferred {
                target: Target::GBuffer,
                lists: Lists::Clustered,
            })
        },
        supports: gbuffer_without_maps,
    },
    SchemeEntry {
        name: "visbuffer",
        models: "visibility buffer (RTR4 20.5): triangle ids per sample, attributes and textures fetched when shading",
        reports_refinement: false,
        reports_cache: false,
        has_thresholds: false,
        build: |_, _| {
            Box::new(Deferred {
                target: Target::Visibility,
                lists: Lists::None,
            })
        },
        supports: opaque_only,
    },
    SchemeEntry {
        name: "dais",
        models: "Schied and Dachsbacher 2015: z-prepass, memoized triangle buffer (80 B), Eq. 2 interpolation",
        reports_refinement: false,
        reports_cache: false,
        has_thresholds: false,
        build: |_, _| {
            Box::new(Dais {
                variant: Variant::Samples,
            })
        },
        supports: dais_without_maps,
    },
    SchemeEntry {
        name: "dais-list",
        models: "DAIS with a per-pixel linked list of visibility samples (32-bit heads, 64-bit nodes)",
        reports_refinement: false,
        reports_cache: false,
        has_thresholds: false,
        build: |_, _| Box::new(Dais { variant: Variant::List }),
        supports: dais_without_maps,
    },
    SchemeEntry {
        name: "dais-multirate",
        models: "DAIS with lighting at shading rate 1/2 (2x2 shading quads, LogLuv shading samples)",
        reports_refinement: false,
        reports_cache: false,
        has_thresholds: false,
        build: |_, _| {
            Box::new(Dais {
                variant: Variant::Multirate,
            })
        },
        supports: dais_without_maps,
    },
    SchemeEntry {
        name: "repro-rt",
        models: "Wißmann et al. 2020 Repro RT: adaptive grid warp of the left view, holes ray traced through a BVH",
        reports_refinement: false,
        reports_cache: false,
        has_thresholds: false,
        build: |_, o| reprojection(HoleFill::RayTrace, o),
        supports: opaque_only,
    },
    SchemeEntry {
        name: "repro-reraster",
        models: "Wißmann et al. 2020 Repro ReRaster: adaptive grid warp, the right view drawn again, holes shaded",
        reports_refinement: false,
        reports_cache: false,
        has_thresholds: false,
        build: |_, o| reprojection(HoleFill::ReRaster, o),
        supports: opaque_only,
    },
];

fn reprojection(fill: HoleFill, o: &ReplayOptions) -> Box<dyn ShadingScheme> {
    Box::new(Reprojection {
        fill,
        cell: o.grid_cell,
        threshold_arcmin: o.parallax_threshold,
        specular_error: o.specular_error,
    })
}

/// Deferred shading lights opaque surfaces only; blended and alpha-tested ones would need
/// the forward pass after lighting that real renderers add (not modelled).
fn opaque_only(scene: &Scene) -> Result<(), String> {
    match scene.materials.iter().find(|m| m.alpha != AlphaMode::Opaque) {
        Some(m) => Err(format!(
            "deferred shading lights opaque surfaces only, and material `{}` is {:?}",
            m.name, m.alpha
        )),
        None => Ok(()),
    }
}

/// [`opaque_only`], and no surface maps: what a scheme needs whose stored shading inputs
/// (`what`) have no channels for normal, metallic-roughness, occlusion or emissive maps.
fn opaque_without_maps(scene: &Scene, what: &str) -> Result<(), String> {
    opaque_only(scene)?;
    match scene.surface_maps.materials.iter().position(|m| !m.is_empty()) {
        Some(i) => Err(format!(
            "material `{}` has surface maps (normal, metallic-roughness, occlusion or emissive), which {what} \
             has no channels for yet",
            scene.materials[i].name
        )),
        None => Ok(()),
    }
}

fn gbuffer_without_maps(scene: &Scene) -> Result<(), String> {
    opaque_without_maps(scene, "the 20-byte G-buffer")
}

fn dais_without_maps(scene: &Scene) -> Result<(), String> {
    opaque_without_maps(scene, "the DAIS triangle record")
}

/// The registry entry of scheme `name`.
pub fn scheme(name: &str) -> Option<&'static SchemeEntry> {
    SCHEMES.iter().find(|s| s.name == name)
}
