//! The terrain material's textures, generated: one layer per material of tiling
//! value-noise albedo and the normal map of the same height, with every mip
//! level (box-filtered), so nothing ships in `assets/` and the far horizon does
//! not shimmer.

use bevy::asset::RenderAssetUsages;
use bevy::image::{
    ImageAddressMode, ImageFilterMode, ImageSampler, ImageSamplerDescriptor, TextureFormatPixelInfo,
};
use bevy::prelude::*;
use bevy::render::render_resource::{
    Extent3d, TextureDataOrder, TextureDimension, TextureFormat, TextureViewDescriptor,
    TextureViewDimension,
};

use super::LAYERS;

/// How a generated layer looks: two colours mixed by the layer's height noise,
/// and how rough that height is.
struct LayerLook {
    /// Colour where the height is low (sRGB, 0-255).
    low: [u8; 3],
    /// Colour where the height is high.
    high: [u8; 3],
    /// Lattice period of the first octave, in lattice steps across the tile.
    period: u32,
    /// Octaves of noise.
    octaves: u32,
    /// Stretch along v (strata, ripples): the noise's v period divides by it.
    stretch: u32,
    /// Normal-map slope scale.
    bump: f32,
}

/// The six generated layers, in the order of the core's terrain materials
/// (grass, rock, dirt, snow), then sand and a plain light grain for tinted
/// materials (CSG parts).
const LOOKS: [LayerLook; LAYERS] = [
    // grass
    LayerLook {
        low: [52, 92, 30],
        high: [104, 142, 52],
        period: 16,
        octaves: 5,
        stretch: 1,
        bump: 2.0,
    },
    // rock: strata
    LayerLook {
        low: [88, 84, 80],
        high: [150, 142, 132],
        period: 4,
        octaves: 6,
        stretch: 4,
        bump: 5.0,
    },
    // dirt
    LayerLook {
        low: [78, 54, 34],
        high: [128, 94, 62],
        period: 8,
        octaves: 5,
        stretch: 1,
        bump: 3.0,
    },
    // snow
    LayerLook {
        low: [206, 214, 226],
        high: [246, 248, 252],
        period: 8,
        octaves: 4,
        stretch: 1,
        bump: 1.0,
    },
    // sand: ripples
    LayerLook {
        low: [176, 150, 104],
        high: [216, 194, 146],
        period: 8,
        octaves: 4,
        stretch: 3,
        bump: 1.5,
    },
    // plain grain (to be tinted)
    LayerLook {
        low: [200, 200, 200],
        high: [240, 240, 240],
        period: 16,
        octaves: 3,
        stretch: 1,
        bump: 0.6,
    },
];

/// A hash of a lattice point to `[0, 1)`.
fn lattice(x: u32, y: u32, seed: u32) -> f32 {
    let mut h =
        x.wrapping_mul(0x8da6_b343) ^ y.wrapping_mul(0xd816_3841) ^ seed.wrapping_mul(0xcb1a_b31f);
    h ^= h >> 15;
    h = h.wrapping_mul(0x2c1b_3c6d);
    h ^= h >> 12;
    h = h.wrapping_mul(0x297a_2d39);
    h ^= h >> 15;
    (h >> 8) as f32 / (1u32 << 24) as f32
}

/// Value noise at `(u, v)` in `[0, 1)²` on a lattice of `px` by `py` steps that
/// wraps at the tile's edges (so the texture tiles), smoothly interpolated.
fn value_noise(u: f32, v: f32, px: u32, py: u32, seed: u32) -> f32 {
    let (x, y) = (u * px as f32, v * py as f32);
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (sx, sy) = (fx * fx * (3.0 - 2.0 * fx), fy * fy * (3.0 - 2.0 * fy));
    let (ix, iy) = ((x0 as u32) % px, (y0 as u32) % py);
    let (jx, jy) = ((ix + 1) % px, (iy + 1) % py);
    let a = lattice(ix, iy, seed);
    let b = lattice(jx, iy, seed);
    let c = lattice(ix, jy, seed);
    let d = lattice(jx, jy, seed);
    let top = a + (b - a) * sx;
    let bottom = c + (d - c) * sx;
    top + (bottom - top) * sy
}

/// The layer's height at pixel `(x, y)` of a `size`-pixel tile, in `[0, 1]`.
fn height(look: &LayerLook, layer: u32, size: u32, x: u32, y: u32) -> f32 {
    let (u, v) = (x as f32 / size as f32, y as f32 / size as f32);
    let (mut sum, mut amp, mut norm) = (0.0, 1.0, 0.0);
    for o in 0..look.octaves {
        let p = look.period << o;
        let py = (p / look.stretch).max(1);
        sum += amp * value_noise(u, v, p, py, layer * 31 + o);
        norm += amp;
        amp *= 0.5;
    }
    sum / norm
}

/// One mip level of every layer: albedo (sRGB RGBA8) and normal (RGBA8).
struct Level {
    size: u32,
    albedo: Vec<[u8; 4]>,
    normal: Vec<[f32; 3]>,
}

/// The full-size level: heights, their colours, and the normals of the heights
/// (central differences that wrap, like the noise).
fn base_level(layer: u32, size: u32) -> Level {
    let look = &LOOKS[layer as usize];
    let h: Vec<f32> = (0..size * size)
        .map(|i| height(look, layer, size, i % size, i / size))
        .collect();
    let at = |x: i64, y: i64| {
        let s = size as i64;
        h[(y.rem_euclid(s) * s + x.rem_euclid(s)) as usize]
    };
    let mut albedo = Vec::with_capacity(h.len());
    let mut normal = Vec::with_capacity(h.len());
    for y in 0..size as i64 {
        for x in 0..size as i64 {
            let t = at(x, y);
            let c = |i: usize| {
                (look.low[i] as f32 + (look.high[i] as f32 - look.low[i] as f32) * t) as u8
            };
            albedo.push([c(0), c(1), c(2), 255]);
            let dx = (at(x + 1, y) - at(x - 1, y)) * 0.5 * look.bump * size as f32 / 64.0;
            let dy = (at(x, y + 1) - at(x, y - 1)) * 0.5 * look.bump * size as f32 / 64.0;
            normal.push(Vec3::new(-dx, -dy, 1.0).normalize().to_array());
        }
    }
    Level {
        size,
        albedo,
        normal,
    }
}

/// The next mip level: each pixel the mean of four (albedo averaged in linear
/// light, normals renormalised).
fn half(level: &Level) -> Level {
    let s = (level.size / 2).max(1);
    let mut albedo = Vec::with_capacity((s * s) as usize);
    let mut normal = Vec::with_capacity((s * s) as usize);
    let to_linear = |c: u8| (c as f32 / 255.0).powf(2.2);
    let to_srgb = |c: f32| (c.powf(1.0 / 2.2) * 255.0).round().clamp(0.0, 255.0) as u8;
    for y in 0..s {
        for x in 0..s {
            let idx = |dx: u32, dy: u32| {
                (((2 * y + dy) % level.size) * level.size + (2 * x + dx) % level.size) as usize
            };
            let quad = [idx(0, 0), idx(1, 0), idx(0, 1), idx(1, 1)];
            let mut a = [0.0f32; 3];
            let mut n = Vec3::ZERO;
            for &i in &quad {
                for (k, ak) in a.iter_mut().enumerate() {
                    *ak += to_linear(level.albedo[i][k]) * 0.25;
                }
                n += Vec3::from_array(level.normal[i]);
            }
            albedo.push([to_srgb(a[0]), to_srgb(a[1]), to_srgb(a[2]), 255]);
            normal.push(n.normalize_or(Vec3::Z).to_array());
        }
    }
    Level {
        size: s,
        albedo,
        normal,
    }
}

/// Every mip level of one layer, largest first.
fn mip_chain(layer: u32, size: u32) -> Vec<Level> {
    let mut levels = vec![base_level(layer, size)];
    while levels.last().expect("one level").size > 1 {
        let next = half(levels.last().expect("one level"));
        levels.push(next);
    }
    levels
}

/// A repeating, trilinear-filtered sampler (no anisotropic filtering: software
/// renderers slow to a crawl with it).
fn repeating() -> ImageSampler {
    ImageSampler::Descriptor(ImageSamplerDescriptor {
        address_mode_u: ImageAddressMode::Repeat,
        address_mode_v: ImageAddressMode::Repeat,
        mag_filter: ImageFilterMode::Linear,
        min_filter: ImageFilterMode::Linear,
        mipmap_filter: ImageFilterMode::Linear,
        ..default()
    })
}

/// An array image of `LAYERS` layers with all mips (layer-major data).
fn array_image(size: u32, mips: u32, format: TextureFormat, data: Vec<u8>) -> Image {
    let mut image = Image::new_uninit(
        Extent3d {
            width: size,
            height: size,
            depth_or_array_layers: LAYERS as u32,
        },
        TextureDimension::D2,
        format,
        RenderAssetUsages::RENDER_WORLD,
    );
    debug_assert_eq!(
        data.len(),
        (0..mips)
            .map(|m| ((size >> m).max(1) as usize).pow(2) * format.pixel_size().unwrap_or(4))
            .sum::<usize>()
            * LAYERS
    );
    image.data = Some(data);
    image.data_order = TextureDataOrder::LayerMajor;
    image.texture_descriptor.mip_level_count = mips;
    image.texture_view_descriptor = Some(TextureViewDescriptor {
        dimension: Some(TextureViewDimension::D2Array),
        ..default()
    });
    image.sampler = repeating();
    image
}

/// The generated texture arrays: `(albedo, normal)`, `size` pixels square (a
/// power of two), one layer per material, with every mip level.
pub fn generate(size: u32) -> (Image, Image) {
    let size = size.clamp(4, 2048).next_power_of_two();
    let chains: Vec<Vec<Level>> = (0..LAYERS as u32).map(|l| mip_chain(l, size)).collect();
    let mips = chains[0].len() as u32;
    let mut albedo = Vec::new();
    let mut normal = Vec::new();
    for chain in &chains {
        for level in chain {
            albedo.extend(level.albedo.iter().flatten());
            normal.extend(level.normal.iter().flat_map(|n| {
                let b = |c: f32| ((c * 0.5 + 0.5) * 255.0).round().clamp(0.0, 255.0) as u8;
                [b(n[0]), b(n[1]), b(n[2]), 255]
            }));
        }
    }
    (
        array_image(size, mips, TextureFormat::Rgba8UnormSrgb, albedo),
        array_image(size, mips, TextureFormat::Rgba8Unorm, normal),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layers_tile_and_differ() {
        let size = 32;
        for layer in 0..LAYERS as u32 {
            let look = &LOOKS[layer as usize];
            // The height wraps: the column past the last equals the first.
            for y in 0..size {
                let u_end = height(look, layer, size, size, y);
                let u_start = height(look, layer, size, 0, y);
                assert!((u_end - u_start).abs() < 1e-5, "layer {layer} row {y}");
            }
        }
        let (albedo, normal) = generate(32);
        // 32, 16, 8, 4, 2, 1: six mips of six layers.
        let per_layer: usize = [32, 16, 8, 4, 2, 1].iter().map(|s| s * s * 4).sum();
        assert_eq!(albedo.data.as_ref().map(Vec::len), Some(per_layer * LAYERS));
        assert_eq!(normal.texture_descriptor.mip_level_count, 6);
        // Grass is green, snow is bright: the layers are what they say.
        let data = albedo.data.expect("data");
        let mean = |layer: usize, c: usize| {
            let base = layer * per_layer;
            (0..32 * 32)
                .map(|i| data[base + 4 * i + c] as f32)
                .sum::<f32>()
                / 1024.0
        };
        assert!(
            mean(0, 1) > mean(0, 0) && mean(0, 1) > mean(0, 2),
            "grass is green"
        );
        assert!(mean(3, 0) > 190.0 && mean(3, 2) > 200.0, "snow is bright");
        // Normals are unit and face out of the tile.
        let n = normal.data.expect("data");
        for px in n.chunks(4).take(32 * 32) {
            let v = Vec3::new(px[0] as f32, px[1] as f32, px[2] as f32) / 127.5 - 1.0;
            assert!((v.length() - 1.0).abs() < 0.03 && v.z > 0.2, "{v}");
        }
    }
}
