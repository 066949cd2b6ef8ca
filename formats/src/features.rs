//! What a scene requires, as flags in the `Meta` chunk. Replay builds only what these ask
//! for (no shadow pass without a shadowed light, no texture traffic without textures).

use serde::{Deserialize, Serialize};

/// A set of [`Feature`]s, stored as a bit mask.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Features(u32);

/// One requirement a scene may have.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Feature {
    /// The scene has textures (base colour or surface maps).
    Textures,
    /// A directional light casts shadows (replay runs a shadow-map pass).
    ShadowedLight,
    /// Lights besides the shadowed one.
    ExtraLights,
    /// Alpha-masked materials (discard below cutoff).
    AlphaMask,
    /// Alpha-blended materials.
    AlphaBlend,
    /// Rigid node animation.
    Animation,
    /// Skinned meshes.
    Skinning,
    /// Per-triangle surface patch ids.
    PatchIds,
    /// Every textured mesh has a non-overlapping UV atlas.
    UniqueUvAtlas,
    /// Materials with texture maps beyond base colour (the `SurfaceMaps` chunk).
    SurfaceMaps,
}

impl Feature {
    pub const ALL: [Feature; 10] = [
        Feature::Textures,
        Feature::ShadowedLight,
        Feature::ExtraLights,
        Feature::AlphaMask,
        Feature::AlphaBlend,
        Feature::Animation,
        Feature::Skinning,
        Feature::PatchIds,
        Feature::UniqueUvAtlas,
        Feature::SurfaceMaps,
    ];

    fn bit(self) -> u32 {
        1 << self as u32
    }

    pub fn name(self) -> &'static str {
        match self {
            Feature::Textures => "textures",
            Feature::ShadowedLight => "shadowed-light",
            Feature::ExtraLights => "extra-lights",
            Feature::AlphaMask => "alpha-mask",
            Feature::AlphaBlend => "alpha-blend",
            Feature::Animation => "animation",
            Feature::Skinning => "skinning",
            Feature::PatchIds => "patch-ids",
            Feature::UniqueUvAtlas => "unique-uv-atlas",
            Feature::SurfaceMaps => "surface-maps",
        }
    }
}

impl Features {
    pub const NONE: Features = Features(0);

    pub fn contains(self, f: Feature) -> bool {
        self.0 & f.bit() != 0
    }

    pub fn insert(&mut self, f: Feature) {
        self.0 |= f.bit();
    }

    pub fn with(mut self, f: Feature) -> Features {
        self.insert(f);
        self
    }

    /// Flags present, in declaration order.
    pub fn iter(self) -> impl Iterator<Item = Feature> {
        Feature::ALL.into_iter().filter(move |f| self.contains(*f))
    }

    /// Bits this version does not know (set by a newer minor version).
    pub fn unknown_bits(self) -> u32 {
        let known = Feature::ALL.iter().fold(0, |acc, f| acc | f.bit());
        self.0 & !known
    }
}

impl std::fmt::Display for Features {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let names: Vec<&str> = self.iter().map(Feature::name).collect();
        if names.is_empty() {
            write!(f, "(none)")
        } else {
            write!(f, "{}", names.join(", "))
        }
    }
}
