// The terrain material's fragment shader (`TerrainExtension`): up to six
// materials per vertex, blended by the weights the core gives each vertex
// (carried in the vertex colour, layers 0-3, and the UV set, layers 4-5; the
// meshes have no texture coordinates of their own, triplanar needs none),
// each textured by triplanar projection from a texture array (albedo and
// tangent-space normal maps, one layer per material), then lit by Bevy's PBR.

#import bevy_pbr::{
    pbr_fragment::pbr_input_from_standard_material,
    pbr_functions::alpha_discard,
    forward_io::{VertexOutput, FragmentOutput},
    pbr_functions::{apply_pbr_lighting, main_pass_post_lighting_processing},
}

struct TerrainParams {
    // Linear RGB tint of each layer (alpha unused).
    tints: array<vec4<f32>, 6>,
    // x: texture repeats per world unit, y: triplanar blend sharpness,
    // z: normal-map strength, w: how much of the texture shows (0 = tint only).
    settings: vec4<f32>,
}

@group(#{MATERIAL_BIND_GROUP}) @binding(100) var albedo_array: texture_2d_array<f32>;
@group(#{MATERIAL_BIND_GROUP}) @binding(101) var albedo_sampler: sampler;
@group(#{MATERIAL_BIND_GROUP}) @binding(102) var normal_array: texture_2d_array<f32>;
@group(#{MATERIAL_BIND_GROUP}) @binding(103) var normal_sampler: sampler;
@group(#{MATERIAL_BIND_GROUP}) @binding(104) var<uniform> terrain: TerrainParams;

// The six layer weights at this fragment, normalised (layer 0 alone when the
// mesh carries no weights).
fn layer_weights(in: VertexOutput) -> array<f32, 6> {
    var w = array<f32, 6>(1.0, 0.0, 0.0, 0.0, 0.0, 0.0);
#ifdef VERTEX_COLORS
    w[0] = max(in.color.r, 0.0);
    w[1] = max(in.color.g, 0.0);
    w[2] = max(in.color.b, 0.0);
    w[3] = max(in.color.a, 0.0);
#endif
#ifdef VERTEX_UVS_A
    w[4] = max(in.uv.x, 0.0);
    w[5] = max(in.uv.y, 0.0);
#endif
    var sum = 0.0;
    for (var i = 0; i < 6; i++) {
        sum += w[i];
    }
    if sum <= 0.0 {
        return array<f32, 6>(1.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    }
    for (var i = 0; i < 6; i++) {
        w[i] = w[i] / sum;
    }
    return w;
}

@fragment
fn fragment(
    in: VertexOutput,
    @builtin(front_facing) is_front: bool,
) -> FragmentOutput {
    var pbr_input = pbr_input_from_standard_material(in, is_front);

    let n = normalize(pbr_input.world_normal);
    let p = in.world_position.xyz * terrain.settings.x;
    // Triplanar blend: the projection along each axis, weighted by how much the
    // surface faces that axis.
    var blend = pow(abs(n), vec3<f32>(terrain.settings.y));
    blend = blend / max(blend.x + blend.y + blend.z, 1e-6);

    // The three projections' coordinates and their screen derivatives, taken in
    // uniform control flow so the per-layer branches below may sample.
    let uv_x = p.zy;
    let uv_y = p.xz;
    let uv_z = p.xy;
    let dx_x = dpdx(uv_x);
    let dy_x = dpdy(uv_x);
    let dx_y = dpdx(uv_y);
    let dy_y = dpdy(uv_y);
    let dx_z = dpdx(uv_z);
    let dy_z = dpdy(uv_z);

    let w = layer_weights(in);
    var albedo = vec3<f32>(0.0);
    var normal = vec3<f32>(0.0);
    let strength = terrain.settings.z;
    let show = terrain.settings.w;
    for (var layer = 0; layer < 6; layer++) {
        let wl = w[layer];
        if wl < 0.004 {
            continue;
        }
        var a = vec3<f32>(0.0);
        var tn_x = vec3<f32>(0.0, 0.0, 1.0);
        var tn_y = vec3<f32>(0.0, 0.0, 1.0);
        var tn_z = vec3<f32>(0.0, 0.0, 1.0);
        if blend.x > 0.002 {
            a += blend.x * textureSampleGrad(albedo_array, albedo_sampler, uv_x, layer, dx_x, dy_x).rgb;
            tn_x = textureSampleGrad(normal_array, normal_sampler, uv_x, layer, dx_x, dy_x).xyz * 2.0 - 1.0;
        }
        if blend.y > 0.002 {
            a += blend.y * textureSampleGrad(albedo_array, albedo_sampler, uv_y, layer, dx_y, dy_y).rgb;
            tn_y = textureSampleGrad(normal_array, normal_sampler, uv_y, layer, dx_y, dy_y).xyz * 2.0 - 1.0;
        }
        if blend.z > 0.002 {
            a += blend.z * textureSampleGrad(albedo_array, albedo_sampler, uv_z, layer, dx_z, dy_z).rgb;
            tn_z = textureSampleGrad(normal_array, normal_sampler, uv_z, layer, dx_z, dy_z).xyz * 2.0 - 1.0;
        }
        let tint = terrain.tints[layer].rgb;
        albedo += wl * tint * mix(vec3<f32>(1.0), a, show);

        // Whiteout blend of the three tangent-space normals onto the surface
        // normal (each projection's tangent axes are the world axes of its uv).
        tn_x = vec3<f32>(tn_x.xy * strength + n.zy, abs(tn_x.z) * n.x);
        tn_y = vec3<f32>(tn_y.xy * strength + n.xz, abs(tn_y.z) * n.y);
        tn_z = vec3<f32>(tn_z.xy * strength + n.xy, abs(tn_z.z) * n.z);
        let nl = tn_x.zyx * blend.x + tn_y.xzy * blend.y + tn_z.xyz * blend.z;
        normal += wl * nl;
    }

    // The base material's colour is replaced (the standard path multiplied it by
    // the vertex colour, which here holds weights); its roughness, metallic and
    // reflectance still apply.
    pbr_input.material.base_color = vec4<f32>(albedo, 1.0);
    if show > 0.0 && strength > 0.0 {
        pbr_input.N = normalize(mix(n, normalize(normal), show));
    }
    pbr_input.material.base_color = alpha_discard(pbr_input.material, pbr_input.material.base_color);

    var out: FragmentOutput;
    out.color = apply_pbr_lighting(pbr_input);
    out.color = main_pass_post_lighting_processing(pbr_input, out.color);
    return out;
}
