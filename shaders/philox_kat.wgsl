// Test kernel (composed after philox.wgsl): for each case, 6 input words
// (counter[4], key[2]) → 4 Philox words and the 4 Box–Muller normals of that block (as f32 bits).

@group(0) @binding(0) var<storage, read> kat_in: array<u32>;
@group(0) @binding(1) var<storage, read_write> kat_out: array<u32>;

@compute @workgroup_size(1)
fn philox_kat(@builtin(global_invocation_id) gid: vec3<u32>) {
    let c = gid.x;
    let base = 6u * c;
    let counter = vec4<u32>(kat_in[base], kat_in[base + 1u], kat_in[base + 2u], kat_in[base + 3u]);
    let key = vec2<u32>(kat_in[base + 4u], kat_in[base + 5u]);
    let w = philox4x32_10(counter, key);
    let z = vec4<f32>(box_muller(w.x, w.y), box_muller(w.z, w.w));
    kat_out[8u * c] = w.x;
    kat_out[8u * c + 1u] = w.y;
    kat_out[8u * c + 2u] = w.z;
    kat_out[8u * c + 3u] = w.w;
    kat_out[8u * c + 4u] = bitcast<u32>(z.x);
    kat_out[8u * c + 5u] = bitcast<u32>(z.y);
    kat_out[8u * c + 6u] = bitcast<u32>(z.z);
    kat_out[8u * c + 7u] = bitcast<u32>(z.w);
}
