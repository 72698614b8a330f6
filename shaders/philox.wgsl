// Philox4x32-10 (Salmon, Moraes, Dror, Shaw, SC'11; Random123) and the Box–Muller normal
// transform, in WGSL. Mirrors src/sampling/philox.rs and src/sampling/normal.rs word for word:
// counter [draw lo, draw hi, block, stream], key = the seed's two words, uniform
// u = (x + 1/2)·2^-32, phi = pi·(s + 1/2)·2^-31 with s the second word read as i32,
// z1 = r cos(phi), z2 = r sin(phi), r = sqrt(-2 ln u).
//
// WGSL has no 64-bit integers: the 32×32→64-bit product of a Philox round is formed from
// 16-bit halves with an explicit carry. ln, sin and cos are evaluated here by argument
// reduction and short series rather than the builtins, whose required accuracy on Vulkan is
// only 2^-11 absolute for sin/cos.

const PHILOX_M0: u32 = 0xD2511F53u;
const PHILOX_M1: u32 = 0xCD9E8D57u;
const PHILOX_W0: u32 = 0x9E3779B9u;
const PHILOX_W1: u32 = 0xBB67AE85u;

// (hi, lo) words of the 64-bit product a·b.
fn mulhilo(a: u32, b: u32) -> vec2<u32> {
    let a0 = a & 0xFFFFu;
    let a1 = a >> 16u;
    let b0 = b & 0xFFFFu;
    let b1 = b >> 16u;
    let p00 = a0 * b0;
    let p01 = a0 * b1;
    let p10 = a1 * b0;
    let p11 = a1 * b1;
    // Bits 16..47: at most 3·(2^16 − 1) + 2^16, no overflow.
    let mid = (p00 >> 16u) + (p01 & 0xFFFFu) + (p10 & 0xFFFFu);
    let hi = p11 + (p01 >> 16u) + (p10 >> 16u) + (mid >> 16u);
    return vec2<u32>(hi, a * b);
}

fn philox4x32_10(counter: vec4<u32>, key: vec2<u32>) -> vec4<u32> {
    var c = counter;
    var k = key;
    for (var round = 0u; round < 10u; round++) {
        if (round > 0u) {
            k = k + vec2<u32>(PHILOX_W0, PHILOX_W1);
        }
        let r0 = mulhilo(PHILOX_M0, c.x);
        let r1 = mulhilo(PHILOX_M1, c.z);
        c = vec4<u32>(r1.x ^ c.y ^ k.x, r1.y, r0.x ^ c.w ^ k.y, r0.y);
    }
    return c;
}

const TWO_POW_M32: f32 = 2.3283064365386963e-10;
const HALF_PI: f32 = 1.5707963267948966;
const LN2_HI: f32 = 0.693145751953125;
const LN2_LO: f32 = 1.4286068203094172e-06;

// (sin x, cos x) for |x| <= pi/4 by Taylor series (truncation below 2e-9).
fn sincos_reduced(x: f32) -> vec2<f32> {
    let x2 = x * x;
    let s = x * (1.0 - x2 / 6.0 * (1.0 - x2 / 20.0 * (1.0 - x2 / 42.0 * (1.0 - x2 / 72.0))));
    let c = 1.0 - x2 / 2.0 * (1.0 - x2 / 12.0 * (1.0 - x2 / 30.0 * (1.0 - x2 / 56.0 * (1.0 - x2 / 90.0))));
    return vec2<f32>(s, c);
}

// (sin x, cos x) of a small angle (a parameter offset): series when |x| <= pi/4, else builtins.
fn sincos_small(x: f32) -> vec2<f32> {
    if (abs(x) <= 0.7853981633974483) {
        return sincos_reduced(x);
    }
    return vec2<f32>(sin(x), cos(x));
}

// Natural log of u in (0, 1) (normal f32): u = m·2^e with m in [sqrt(1/2), sqrt(2)),
// ln m = 2 atanh((m − 1)/(m + 1)) by series (|s| <= 0.172, truncation below 1e-10).
fn ln_unit(u: f32) -> f32 {
    let bits = bitcast<u32>(u);
    var e = i32((bits >> 23u) & 0xFFu) - 127;
    var m = bitcast<f32>((bits & 0x007FFFFFu) | 0x3F800000u);
    if (m > 1.4142135623730951) {
        m = m * 0.5;
        e = e + 1;
    }
    let s = (m - 1.0) / (m + 1.0);
    let s2 = s * s;
    let series = 2.0 * s * (1.0 + s2 * (1.0 / 3.0 + s2 * (1.0 / 5.0 + s2 * (1.0 / 7.0 + s2 * (1.0 / 9.0 + s2 / 11.0)))));
    let ef = f32(e);
    return ef * LN2_HI + (ef * LN2_LO + series);
}

// −ln u for u = (x + 1/2)·2^-32. Near u = 1 it uses v = 1 − u = (~x + 1/2)·2^-32, which f32
// holds exactly enough, and −ln(1 − v) = Σ v^k / k.
fn neg_ln_uniform(x: u32) -> f32 {
    let v = (f32(~x) + 0.5) * TWO_POW_M32;
    if (v < 0.25) {
        var acc = 1.0 / 13.0;
        for (var k = 12; k >= 1; k--) {
            acc = 1.0 / f32(k) + v * acc;
        }
        return v * acc;
    }
    let u = (f32(x) + 0.5) * TWO_POW_M32;
    return -ln_unit(u);
}

// Two standard normals from two words (see the header).
fn box_muller(x0: u32, x1: u32) -> vec2<f32> {
    let r = sqrt(2.0 * neg_ln_uniform(x0));
    // phi = (pi/2)·(s + 1/2)/2^30 = k·pi/2 + (pi/2)(t + 1/2)/2^30, exact integer split.
    let s = bitcast<i32>(x1);
    var k = s >> 30u;
    var t = s - (k << 30u);
    if (t >= (1 << 29u)) {
        t = t - (1 << 30u);
        k = k + 1;
    }
    let sc = sincos_reduced((f32(t) + 0.5) * (HALF_PI * 9.313225746154785e-10));
    var sn = sc.x;
    var cs = sc.y;
    switch (k & 3) {
        case 1: {
            sn = sc.y;
            cs = -sc.x;
        }
        case 2: {
            sn = -sc.x;
            cs = -sc.y;
        }
        case 3: {
            sn = -sc.y;
            cs = sc.x;
        }
        default: {}
    }
    return vec2<f32>(r * cs, r * sn);
}

// The four normals of block `block` of draw (lo, hi) in stream `stream`.
fn normals_block(draw: vec2<u32>, block: u32, stream: u32, key: vec2<u32>) -> vec4<f32> {
    let w = philox4x32_10(vec4<u32>(draw.x, draw.y, block, stream), key);
    return vec4<f32>(box_muller(w.x, w.y), box_muller(w.z, w.w));
}
