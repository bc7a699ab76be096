//! The terrain material: [`TerrainMaterial`], an `ExtendedMaterial` over
//! `StandardMaterial` that shows the materials the field gives each vertex
//! (grass, rock, dirt, snow, ... or a CSG part's colour), blended by their
//! weights and textured by triplanar projection from a texture array, so cliffs
//! are not stretched and nothing needs UVs.
//!
//! How it fits together:
//! - The core gives every vertex up to four material ids with weights
//!   ([`kdcontour::material::MaterialBlend`]) when the field has materials.
//! - A volume made [`crate::KdVolume::with_terrain_material`] turns them into
//!   per-layer weights on the task thread: layers 0-3 in the vertex colour and
//!   4-5 in the UV set (`ATTRIBUTE_UV_0`; [`layer_weights`]), which Bevy's own vertex shader
//!   interpolates, so shadows and the depth prepass work unchanged.
//! - The fragment shader (`terrain.wgsl`, embedded) samples each layer with a
//!   weight from the albedo and normal arrays along the three axes and blends
//!   by the surface normal, then lights the result with Bevy's PBR.
//!
//! Material ids 0 to [`LAYERS`]` - 1` are the texture array's layers; higher
//! ids wrap around (`id % LAYERS`). The generated textures
//! ([`TerrainTextures::generate`]) follow the core's terrain ids: 0 grass,
//! 1 rock, 2 dirt, 3 snow, then 4 sand and 5 a plain grain to tint. Users can
//! supply their own arrays (any square size, `LAYERS` layers, with mips), and a
//! volume keeps [`crate::KdVolume::with_material`] for a plain
//! `StandardMaterial`.

mod textures;

use bevy::asset::embedded_asset;
use bevy::pbr::{ExtendedMaterial, MaterialExtension};
use bevy::prelude::*;
use bevy::render::render_resource::{AsBindGroup, ShaderType};
use bevy::shader::ShaderRef;
use kdcontour::material::MaterialBlend;

/// Layers of the texture arrays: the materials one terrain material can show.
pub const LAYERS: usize = 6;

/// Where [`TerrainMaterialPlugin`] embeds the shader.
const SHADER_PATH: &str = "embedded://bevy_kdcontour/material/terrain.wgsl";

/// The terrain material: Bevy's `StandardMaterial` (roughness, metallic,
/// reflectance; its base colour is replaced) extended by [`TerrainExtension`].
pub type TerrainMaterial = ExtendedMaterial<StandardMaterial, TerrainExtension>;

/// Registers [`TerrainMaterial`] and embeds its shader. Not in
/// [`crate::KdContourPlugins`]: add it in apps that render.
pub struct TerrainMaterialPlugin;

impl Plugin for TerrainMaterialPlugin {
    fn build(&self, app: &mut App) {
        embedded_asset!(app, "terrain.wgsl");
        app.add_plugins(MaterialPlugin::<TerrainMaterial>::default());
    }
}

/// The terrain part of [`TerrainMaterial`]: the texture arrays, each layer's
/// tint, and how the projection blends.
#[derive(Asset, AsBindGroup, Reflect, Debug, Clone)]
#[uniform(104, TerrainUniform)]
pub struct TerrainExtension {
    /// Albedo array (sRGB), [`LAYERS`] layers.
    #[texture(100, dimension = "2d_array")]
    #[sampler(101)]
    pub albedo: Handle<Image>,
    /// Tangent-space normal maps (linear, z out of the surface), [`LAYERS`] layers.
    #[texture(102, dimension = "2d_array")]
    #[sampler(103)]
    pub normal: Handle<Image>,
    /// Each layer's colour, multiplied with its texture.
    pub tints: [LinearRgba; LAYERS],
    /// Texture repeats per world unit.
    pub texture_scale: f32,
    /// Triplanar blend sharpness (the power of the normal's components; 4 is
    /// crisp, 1 soft).
    pub blend_sharpness: f32,
    /// Normal-map strength (0 turns the maps off).
    pub normal_strength: f32,
    /// How much of the texture shows over the tint: 1 the full texture, 0 the
    /// tint alone (flat colours for CSG parts).
    pub texture_mix: f32,
}

/// [`TerrainExtension`] as the shader reads it.
#[derive(Clone, Copy, Debug, ShaderType)]
pub struct TerrainUniform {
    /// Each layer's tint (linear RGB).
    pub tints: [Vec4; LAYERS],
    /// Texture scale, blend sharpness, normal strength, texture mix.
    pub settings: Vec4,
}

impl From<&TerrainExtension> for TerrainUniform {
    fn from(e: &TerrainExtension) -> Self {
        TerrainUniform {
            tints: e.tints.map(|c| c.to_vec4()),
            settings: Vec4::new(
                e.texture_scale,
                e.blend_sharpness.max(0.0),
                e.normal_strength.max(0.0),
                e.texture_mix.clamp(0.0, 1.0),
            ),
        }
    }
}

impl MaterialExtension for TerrainExtension {
    fn fragment_shader() -> ShaderRef {
        SHADER_PATH.into()
    }
}

/// A pair of texture arrays for [`TerrainExtension`].
#[derive(Clone, Debug)]
pub struct TerrainTextures {
    /// Albedo array.
    pub albedo: Handle<Image>,
    /// Normal-map array.
    pub normal: Handle<Image>,
}

impl TerrainTextures {
    /// Generated textures (`size` pixels square, rounded up to a power of two;
    /// 256 takes a fraction of a second): noise-based grass, rock, dirt, snow,
    /// sand and a plain grain, with their normal maps and mips.
    pub fn generate(images: &mut Assets<Image>, size: u32) -> Self {
        let (albedo, normal) = textures::generate(size);
        TerrainTextures {
            albedo: images.add(albedo),
            normal: images.add(normal),
        }
    }

    /// A terrain material over these textures: full textures, untinted, one
    /// repeat every 6 world units.
    pub fn terrain(&self) -> TerrainMaterial {
        self.material([LinearRgba::WHITE; LAYERS], 1.0 / 6.0, 1.0)
    }

    /// A material that shows each layer as a flat `tints` colour with a light
    /// grain (for CSG parts).
    pub fn tinted(&self, tints: [Color; LAYERS]) -> TerrainMaterial {
        self.material(tints.map(|c| c.to_linear()), 1.0 / 2.0, 0.25)
    }

    fn material(
        &self,
        tints: [LinearRgba; LAYERS],
        texture_scale: f32,
        texture_mix: f32,
    ) -> TerrainMaterial {
        ExtendedMaterial {
            base: StandardMaterial {
                perceptual_roughness: 0.92,
                reflectance: 0.3,
                ..default()
            },
            extension: TerrainExtension {
                albedo: self.albedo.clone(),
                normal: self.normal.clone(),
                tints,
                texture_scale,
                blend_sharpness: 4.0,
                normal_strength: 1.0,
                texture_mix,
            },
        }
    }
}

/// Per-vertex layer weights from the core's material blends: layers 0-3 (as
/// vertex colours) and 4-5 (as the UV set). Ids past the last layer wrap.
pub fn layer_weights(blends: &[MaterialBlend]) -> (Vec<[f32; 4]>, Vec<[f32; 2]>) {
    let mut lo = Vec::with_capacity(blends.len());
    let mut hi = Vec::with_capacity(blends.len());
    for b in blends {
        let mut w = [0.0f32; LAYERS];
        for (id, weight) in b.ids.iter().zip(b.weights) {
            w[*id as usize % LAYERS] += weight.max(0.0);
        }
        lo.push([w[0], w[1], w[2], w[3]]);
        hi.push([w[4], w[5]]);
    }
    (lo, hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_land_on_their_layers_and_keep_their_sum() {
        let blends = [
            MaterialBlend {
                ids: [1, 3, 0, 0],
                weights: [0.75, 0.25, 0.0, 0.0],
            },
            MaterialBlend {
                ids: [5, 4, 7, 0],
                weights: [0.5, 0.25, 0.25, 0.0],
            },
        ];
        let (lo, hi) = layer_weights(&blends);
        assert_eq!(lo[0], [0.0, 0.75, 0.0, 0.25]);
        assert_eq!(hi[0], [0.0, 0.0]);
        // Id 7 wraps to layer 1.
        assert_eq!(lo[1], [0.0, 0.25, 0.0, 0.0]);
        assert_eq!(hi[1], [0.25, 0.5]);
        for (l, h) in lo.iter().zip(&hi) {
            let sum: f32 = l.iter().chain(h).sum();
            assert!((sum - 1.0).abs() < 1e-6);
        }
    }
}
