// Maximum point error of MDH parameter vectors (docs/METHOD.md §3, paper eqs. 12 and 17).
// Composed after philox.wgsl and the input space's constants, written by the host from its
// InputSpace (gpu crate, `input_constants`): N_JOINTS (4 to 7; one module per count met),
// N_PARAMS (the joints block), TOOL_AT (first tool input), N_INPUTS (a row without the
// placement), PLACEMENT_AT (first placement input) and N_PLACED (a row with it). The counts
// below are for six joints, the paper's TX60: 30 parameters, 33 inputs, 39 with the placement.
// After this file the host appends `struct Chain`, `chain_offsets` and `chain_step`, the chain
// written out joint by joint (gpu crate, `unrolled_chain`).
// One invocation per parameter vector, three entry points that share
// the kinematics (point_errors):
//   max_point_error: counter draws first + i,
//     1. normals of the draw (Philox blocks 0–8 the free inputs use, Box–Muller; input i uses
//        normal i: parameters 0 … 5n−1, tool x, y, z 5n … 5n+2),
//     2. offsets δ of the 5n + 3 inputs: independent δ_i = σ_i z_i, or correlated
//        δ_free[a] = Σ_{b<=a} L[a][b] z[free[b]];
//   max_point_error_offsets: δ read from row i of the offset matrix (N_INPUTS f32 per row, N_PLACED
//   in mode 2);
//   max_point_error_pick_freeze: row r of matrix s of a Sobol pick-freeze design: normal n from
//     draw b_first + r where bit n of masks[s] is set, from draw first + r elsewhere, then the
//     offsets of step 2 (so the rows of A, B and A_B are generated here, never uploaded);
// then at every test point the deviation Δ of the end position from the mean-parameter chain,
// propagated from the tool to the base, starting from the tool point's own offset
// Δ_{n+1} = δ_tool = (δ_5n, δ_5n+1, δ_5n+2) (see src/engine/deviation.rs for the formulation and its
// error budget), e_j = |Δ_1 + o_j|, w = max_j e_j. Counter draws and pick-freeze rows (from
// draw b where the matrix's mask has bit 63, else a; not offset rows) of a model with a
// discrepancy term (what the geometric model does not explain; cfg.disc_count radii
// in disc_radii, 0: none) then take e_j ← √(e_j² + r² + 2 e_j r c), radius r and cosine c from
// the word h(a ⊕ h(b + j)), (a, b, c, _) the draw's Philox block (draw, 0, DISCREPANCY_STREAM),
// r times the draw's size factor from c's top 8 bits
// (crates/core/src/discrepancy/mod.rs, size.rs, crates/core/src/engine/discrepancy.rs).
// A model with uncertain joint errors (cfg.term_on; compliance, gear harmonics, payload,
// docs/METHOD.md §19.2) draws them per counter draw and pick-freeze row (term_draw, from draw b
// where the mask has bit 60, 61, 62 for compliance, harmonics, payload): the geometric offsets moved by A δβ, and each joint turned
// further at each point by its offset (chain_step_turned); offset rows keep the mean.
// Only small quantities (offsets, rotation differences, deviations) are formed in f32; the
// ~1000 mm nominal positions enter only multiplied by small rotation differences.

struct Config {
    key: vec2<u32>,
    m: u32,
    // 0: independent (spread = σ[N_INPUTS]); 1: correlated (spread = L, nfree × nfree
    // row-major); 2: correlated over the N_PLACED inputs with the base placement (spread = L, then 15 constants:
    // a_y, a_p, the rows of R̂ᵀ; docs/METHOD.md §2.8)
    mode: u32,
    nfree: u32,
    // bit b set: Philox block b feeds some free parameter
    block_mask: u32,
    // radii of the discrepancy term in disc_radii (0: no term)
    disc_count: u32,
    // 1: m per-point factors of the radii follow them in disc_radii (a compensated model)
    disc_scaled: u32,
    // 1: counter draws and pick-freeze rows draw the model's joint errors (term)
    term_on: u32,
    // free coefficients of the joint errors, rows of their shift, start of the point words
    term_free: u32,
    term_rows: u32,
    term_pts: u32,
    // where a second term's radii start in disc_radii (0: none; engine::SecondTerm): its
    // disc_second_count radii, its SIZE_DRAWS factors, then per point 1.0 where the point draws
    // it (the per-point factors after the first term's then hold each point's own)
    disc_second: u32,
    disc_second_count: u32,
    pad0: u32,
    pad1: u32,
}

struct Chunk {
    // first draw of the chunk, (lo, hi) words (pick-freeze: the draw of row 0 of matrix A)
    first: vec2<u32>,
    count: u32,
    // 1: write per-point errors
    want_e: u32,
    // pick-freeze only: draw of row 0 of matrix B, rows per matrix, and the request's row of
    // this chunk's invocation 0
    b_first: vec2<u32>,
    per_matrix: u32,
    row0: u32,
}

@group(0) @binding(0) var<uniform> cfg: Config;
@group(0) @binding(1) var<uniform> chunk: Chunk;
// per joint: (cos α, sin α, cos β, sin β) of the mean parameters
@group(0) @binding(2) var<storage, read> joint_trig: array<vec4<f32>, N_JOINTS>;
@group(0) @binding(3) var<storage, read> spread: array<f32>;
@group(0) @binding(4) var<storage, read> free_idx: array<u32>;
// per point WORDS_PER_POINT = 2n + 1 vec4: joint i (0-based) at 2i: (u0_i, cos φ_i), 2i+1:
// (p0_{i+1}, sin φ_i); 2n: (o_j, 0) with o_j = P(mean, q_j) − P_ref,j
@group(0) @binding(5) var<storage, read> pts: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read_write> w_out: array<f32>;
@group(0) @binding(7) var<storage, read_write> e_out: array<f32>;
// offset path: row i = δ of parameter vector i, N_INPUTS entries (mm, rad; tool last), then in
// mode 2 the placement's six (x, y, z mm; roll, pitch, yaw rad)
@group(0) @binding(8) var<storage, read> offsets_in: array<f32>;
// pick-freeze path: per matrix, the mask of normals (one bit per normal) taken from the B draw, (lo, hi) words
@group(0) @binding(9) var<storage, read> masks: array<vec2<u32>>;
// the discrepancy term's radii, mm (cfg.disc_count of them; one unused entry without a term)
@group(0) @binding(10) var<storage, read> disc_radii: array<f32>;
// The joint errors' per-point quantities (crates/core/src/engine/joint_errors.rs, TermPacking's
// points), two vec4 per point and joint: (τ_links, τ_unit, sin q, cos q), (sin 2q, cos 2q, k, s)
// with k = 1 where the backlash's side s (±1) is known at the point.
// (Their L, A and factors are constants of the host-written term_draw; one unused vec4 without
// joint errors.)
@group(0) @binding(11) var<storage, read> term: array<vec4<f32>>;

const WORDS_PER_POINT: u32 = 2u * N_JOINTS + 1u;
// N_PARAMS, TOOL_AT, N_INPUTS, PLACEMENT_AT and N_PLACED come from the host (see the top).
// Philox blocks of 4 normals per draw covering the inputs with the placement (10 for six
// joints, 11 for seven)
const N_BLOCKS: u32 = (N_PLACED + 3u) / 4u;
const N_NORMALS: u32 = 4u * N_BLOCKS;
const WORKGROUP_SIZE: u32 = 64u;
// The Philox stream of the discrepancy term (engine::DISCREPANCY_STREAM).
const DISCREPANCY_STREAM: u32 = 0xD15C0000u;
// The backlash's Philox stream (engine::BACKLASH_STREAM): per draw the words (a, b) of block
// (draw, 0, BACKLASH_STREAM); joint j's side at point pj is bit j of h(a ⊕ h(b + pj)).
const BACKLASH_STREAM: u32 = 0xBAC10000u;
// The joint errors' Philox stream (engine::JOINT_ERROR_STREAM).
const JOINT_ERROR_STREAM: u32 = 0x10E70000u;
// The discrepancy term's per-draw size factors (discrepancy::size::SIZE_DRAWS), indexed by 8 bits.
const SIZE_DRAWS: u32 = 256u;

// The integer hash "lowbias32" of engine::discrepancy::hash32 (wrapping u32 arithmetic).
fn hash32(v: u32) -> u32 {
    var x = v;
    x = x ^ (x >> 16u);
    x = x * 0x7feb352du;
    x = x ^ (x >> 15u);
    x = x * 0x846ca68bu;
    return x ^ (x >> 16u);
}

// Offsets of one joint's rotations for a draw: α' and β' as (cos', sin', cos' − cos,
// sin' − sin), θ as (sin h, cos h, δa, δd) with h = δθ/2.
struct JointOffsets {
    ra: vec4<f32>,
    rb: vec4<f32>,
    rt: vec4<f32>,
}

fn joint_offsets(j: u32, dth: f32, dd: f32, da: f32, dal: f32, dbe: f32) -> JointOffsets {
    let tr = joint_trig[j];
    // cos(x+δ) − cos x = −2 sin(δ/2) sin(x+δ/2); sin(x+δ) − sin x = 2 sin(δ/2) cos(x+δ/2)
    let ha = sincos_small(0.5 * dal);
    let sma = tr.y * ha.y + tr.x * ha.x;
    let cma = tr.x * ha.y - tr.y * ha.x;
    let dca = -2.0 * ha.x * sma;
    let dsa = 2.0 * ha.x * cma;
    let hb = sincos_small(0.5 * dbe);
    let smb = tr.w * hb.y + tr.z * hb.x;
    let cmb = tr.z * hb.y - tr.w * hb.x;
    let dcb = -2.0 * hb.x * smb;
    let dsb = 2.0 * hb.x * cmb;
    let ht = sincos_small(0.5 * dth);
    return JointOffsets(
        vec4<f32>(tr.x + dca, tr.y + dsa, dca, dsa),
        vec4<f32>(tr.z + dcb, tr.w + dsb, dcb, dsb),
        vec4<f32>(ht.x, ht.y, da, dd),
    );
}

// Deviation after joint i: A = (u0_i, cos φ), B = (p0_{i+1}, sin φ), tr = mean (cα, sα, cβ, sβ).
fn joint_step(dv: vec3<f32>, A: vec4<f32>, B: vec4<f32>, tr: vec4<f32>, o: JointOffsets) -> vec3<f32> {
    let p0 = B.xyz;
    let a = o.ra;
    let bt = o.rb;
    let t = o.rt;
    // v = Ry(β')Δ + (Ry(β') − Ry(β)) p0
    let vx = bt.x * dv.x + bt.y * dv.z + bt.z * p0.x + bt.w * p0.z;
    let vy = dv.y;
    let vz = -bt.y * dv.x + bt.x * dv.z - bt.w * p0.x + bt.z * p0.z;
    // r = Ry(β) p0 (mean); Δu = Rx(α') v + (Rx(α') − Rx(α)) r + (δa, 0, δd)
    let ry = p0.y;
    let rz = -tr.w * p0.x + tr.z * p0.z;
    let ux = vx + t.z;
    let uy = a.x * vy - a.y * vz + a.z * ry - a.w * rz;
    let uz = a.y * vy + a.x * vz + a.w * ry + a.z * rz + t.w;
    // Δ = Rz(φ') Δu + (Rz(φ') − Rz(φ)) u0, φ' = φ + 2h
    let cphi = A.w;
    let sphi = B.w;
    let sm = sphi * t.y + cphi * t.x;
    let cm = cphi * t.y - sphi * t.x;
    let dcz = -2.0 * t.x * sm;
    let dsz = 2.0 * t.x * cm;
    let cz = cphi + dcz;
    let sz = sphi + dsz;
    return vec3<f32>(
        cz * ux - sz * uy + dcz * A.x - dsz * A.y,
        sz * ux + cz * uy + dsz * A.x + dcz * A.y,
        uz,
    );
}

// Standard normals of draw `draw` from the Philox blocks whose bit is set in `blocks` (zero
// elsewhere; the CPU sampler's definition, in f32).
fn draw_normals(draw: vec2<u32>, blocks: u32) -> array<f32, N_NORMALS> {
    var z: array<f32, N_NORMALS>;
    for (var b = 0u; b < N_BLOCKS; b++) {
        if ((blocks & (1u << b)) != 0u) {
            let v = normals_block(draw, b, 0u, cfg.key);
            z[4u * b] = v.x;
            z[4u * b + 1u] = v.y;
            z[4u * b + 2u] = v.z;
            z[4u * b + 3u] = v.w;
        } else {
            z[4u * b] = 0.0;
            z[4u * b + 1u] = 0.0;
            z[4u * b + 2u] = 0.0;
            z[4u * b + 3u] = 0.0;
        }
    }
    return z;
}

// Offsets δ of the N_INPUTS inputs (N_PLACED with the placement; 0 beyond) from standard
// normals: independent δ_i = σ_i z_i, or correlated δ_free[a] = Σ_{b<=a} L[a][b] z[free[b]].
fn spread_offsets(z: array<f32, N_NORMALS>) -> array<f32, N_PLACED> {
    var d: array<f32, N_PLACED>;
    for (var p = 0u; p < N_PLACED; p++) {
        d[p] = 0.0;
    }
    if (cfg.mode == 0u) {
        for (var p = 0u; p < N_INPUTS; p++) {
            d[p] = spread[p] * z[p];
        }
    } else {
        let n = cfg.nfree;
        for (var a = 0u; a < n; a++) {
            var acc = 0.0;
            for (var b = 0u; b <= a; b++) {
                acc = acc + spread[a * n + b] * z[free_idx[b]];
            }
            d[free_idx[a]] = acc;
        }
    }
    return d;
}

// Offsets δ of counter draw `draw`.
fn draw_offsets(draw: vec2<u32>) -> array<f32, N_PLACED> {
    return spread_offsets(draw_normals(draw, cfg.block_mask));
}

// 64-bit draw index `base + r`, with carry.
fn draw_plus(base: vec2<u32>, r: u32) -> vec2<u32> {
    let lo = base.x + r;
    return vec2<u32>(lo, base.y + select(0u, 1u, lo < base.x));
}

// Standard normals of a pick-freeze row: per Philox block, the four normals of draw `a`, with
// those whose bit is set in `mask` (N_NORMALS bits, (lo, hi) words) taken from draw `b`. A block is
// computed for a draw only when some of its normals come from that draw; a row with mask 0
// does exactly what draw_normals(a, cfg.block_mask) does.
fn pick_freeze_normals(a: vec2<u32>, b: vec2<u32>, mask: vec2<u32>) -> array<f32, N_NORMALS> {
    var z: array<f32, N_NORMALS>;
    for (var blk = 0u; blk < N_BLOCKS; blk++) {
        var v = vec4<f32>(0.0);
        if ((cfg.block_mask & (1u << blk)) != 0u) {
            var nib: u32;
            if (blk < 8u) {
                nib = (mask.x >> (4u * blk)) & 15u;
            } else {
                nib = (mask.y >> (4u * (blk - 8u))) & 15u;
            }
            if (nib != 15u) {
                v = normals_block(a, blk, 0u, cfg.key);
            }
            if (nib != 0u) {
                let take = vec4<bool>(
                    (nib & 1u) != 0u,
                    (nib & 2u) != 0u,
                    (nib & 4u) != 0u,
                    (nib & 8u) != 0u,
                );
                v = select(v, normals_block(b, blk, 0u, cfg.key), take);
            }
        }
        z[4u * blk] = v.x;
        z[4u * blk + 1u] = v.y;
        z[4u * blk + 2u] = v.z;
        z[4u * blk + 3u] = v.w;
    }
    return z;
}

// Increment of v under a small rotation δ about the unit axis a:
// Rot(a, δ) v − v = sin δ (a × v) + (1 − cos δ) a × (a × v), with 1 − cos δ = 2 sin²(δ/2).
fn rot_inc(a: vec3<f32>, delta: f32, v: vec3<f32>) -> vec3<f32> {
    let h = sincos_small(0.5 * delta);
    let s = 2.0 * h.x * h.y;
    let omc = 2.0 * h.x * h.x;
    let av = cross(a, v);
    return s * av + omc * cross(a, av);
}

// The deviation in the mean placement's base frame with the placement drawn (mode 2):
// Δ_0 = ΔR (x0 + Δ_1) − x0 + R̂ᵀ δt, ΔR = Rot(a_y, δyaw) Rot(a_p, δpitch) Rot(x, δroll), applied
// as increments so that the ~1000 mm x0 enters only multiplied by small sines.
fn placement_step(dv: vec3<f32>, x0: vec3<f32>, d: array<f32, N_PLACED>) -> vec3<f32> {
    let c = cfg.nfree * cfg.nfree;
    let a_y = vec3<f32>(spread[c], spread[c + 1u], spread[c + 2u]);
    let a_p = vec3<f32>(spread[c + 3u], spread[c + 4u], spread[c + 5u]);
    let i1 = rot_inc(vec3<f32>(1.0, 0.0, 0.0), d[PLACEMENT_AT + 3u], x0 + dv);
    let i2 = rot_inc(a_p, d[PLACEMENT_AT + 4u], x0 + dv + i1);
    let i3 = rot_inc(a_y, d[PLACEMENT_AT + 5u], x0 + dv + i1 + i2);
    let t = vec3<f32>(d[PLACEMENT_AT], d[PLACEMENT_AT + 1u], d[PLACEMENT_AT + 2u]);
    let rt = vec3<f32>(
        spread[c + 6u] * t.x + spread[c + 7u] * t.y + spread[c + 8u] * t.z,
        spread[c + 9u] * t.x + spread[c + 10u] * t.y + spread[c + 11u] * t.z,
        spread[c + 12u] * t.x + spread[c + 13u] * t.y + spread[c + 14u] * t.z,
    );
    return dv + i1 + i2 + i3 + rt;
}

// The error of point pj whose kinematic error is e with the discrepancy word wd and the draw's
// size factor g: radius r = disc_radii[⌊(wd ≫ 16)·K / 2¹⁶⌋] (exact in u32: K ≤ 2¹⁶; times
// disc_radii[K + SIZE_DRAWS + pj] for a compensated model) times g, cosine
// c = ((wd mod 2¹⁶) + ½)·2⁻¹⁵ − 1, and √(e² + r² + 2erc) formed as √((e − r)² + 2er(1 + c)):
// both terms are non-negative and 1 + c is exact in f32, so no cancellation.
fn with_discrepancy(e: f32, wd: u32, k: u32, pj: u32, g: f32, g2: f32) -> f32 {
    // The term point pj draws: the first (radii from 0, k of them, factor g) or, where the
    // model has a second term and marks the point, the second (factor g2).
    var at = 0u;
    var count = k;
    var size = g;
    if (cfg.disc_second != 0u) {
        let k2 = cfg.disc_second_count;
        if (disc_radii[cfg.disc_second + k2 + SIZE_DRAWS + pj] != 0.0) {
            at = cfg.disc_second;
            count = k2;
            size = g2;
        }
    }
    var r = disc_radii[at + (((wd >> 16u) * count) >> 16u)];
    if (cfg.disc_scaled != 0u) {
        // a compensated model: the point's predictive σ over the term's reference
        r = r * disc_radii[k + SIZE_DRAWS + pj];
    }
    r = r * size;
    let one_plus_c = (f32(wd & 0xFFFFu) + 0.5) * (1.0 / 32768.0);
    let dr = e - r;
    return sqrt(dr * dr + 2.0 * e * r * one_plus_c);
}

// The joint errors of a draw (docs/METHOD.md §19.2), `fn term_draw(draws, d)`, are written by
// the host for each model (gpu-amcs-gpu term_code): δβ = L z from the normals of Philox blocks
// (draws[g], b, JOINT_ERROR_STREAM) of each normal's group g (compliance, harmonics, payload),
// the payload's δm = σ_m z_p, the geometric offsets d moved by A δβ, and per joint the factors
// (δk, (k̄ + δk)(m̄ + δm) − k̄ m̄, δa1, δb1) and (δa2, δb2, 0, 0) of its per-point angle offsets,
// with L and A as constants.

// Joint j's angle offset at point pj from the draw's factors f: (f0, f1, δa1, δb1)·(τ_links,
// τ_unit, sin q, cos q) + (δa2, δb2)·(sin 2q, cos 2q); with backlash (BACKLASH_ON, host-written)
// plus the joint's half gap f[2j + 1].z on the side known at the point (the second vec4's z, w)
// or, where none is, on the side bit j of the point's word wb gives.
fn term_offset(f: array<vec4<f32>, 2u * N_JOINTS>, pj: u32, j: u32, wb: u32) -> f32 {
    let at = 2u * (pj * N_JOINTS + j);
    let t0 = term[at];
    let t1 = term[at + 1u];
    let o = dot(f[2u * j], t0) + dot(f[2u * j + 1u].xy, t1.xy);
    if (BACKLASH_ON) {
        // The side known at this point (t1.z = 1: t1.w = ±1), else drawn.
        let h = f[2u * j + 1u].z;
        let drawn = select(-h, h, ((wb >> j) & 1u) != 0u);
        return o + select(drawn, t1.w * h, t1.z != 0.0);
    }
    return o;
}

// The joint offsets o of a draw with joint j turned further by `extra` (θ offset dth + extra).
fn turned(o: JointOffsets, dth: f32, extra: f32) -> JointOffsets {
    let ht = sincos_small(0.5 * (dth + extra));
    return JointOffsets(o.ra, o.rb, vec4<f32>(ht.x, ht.y, o.rt.z, o.rt.w));
}

// Errors of the parameter vector mean + d at every test point: e_out row i (if asked for) and
// w_out[i] = max_j e_j. With disc_count > 0 (counter draws and pick-freeze rows) the
// discrepancy term of draw `draw` is applied at every point.
fn point_errors(i: u32, d0: array<f32, N_PLACED>, draw: vec2<u32>, disc_count: u32, term_draws: array<vec2<u32>, 4>, with_term: bool) {
    // The joint errors move the geometric offsets and give the factors of each point's angle
    // offsets (counter draws and pick-freeze rows of a model that draws them).
    // TERM_ON (host-written) removes this code from the kernels of models without them.
    var d = d0;
    var f: array<vec4<f32>, 2u * N_JOINTS>;
    // The backlash's words of the draw (term_draws[3]: the draw its sides come from).
    var sab = vec2<u32>(0u);
    if (TERM_ON && with_term) {
        f = term_draw(term_draws, &d);
        if (BACKLASH_ON) {
            sab = philox4x32_10(vec4<u32>(term_draws[3].x, term_draws[3].y, 0u, BACKLASH_STREAM), cfg.key).xy;
        }
    }
    // Per joint: α' and β' as (cos', sin', cos' − cos, sin' − sin); θ as (sin h, cos h) with
    // h = δθ/2; and (δa, δd); and the mean (cos α, sin α, cos β, sin β). The host writes
    // chain_offsets and chain_step out joint by joint with constant indices, so that they stay
    // in registers (loops over arrays of them ran 3.1× slower on an H100).
    let chain = chain_offsets(d);

    let m = cfg.m;
    var w = 0.0;
    // The draw's discrepancy words (a, b): point pj takes h(a ⊕ h(b + pj)); the draw's size
    // factor is disc_radii[K + (c ≫ 24)] (after the K radii, SIZE_DRAWS of them).
    var dab = vec2<u32>(0u);
    var g = 0.0;
    var g2 = 0.0;
    if (disc_count != 0u) {
        let words = philox4x32_10(vec4<u32>(draw.x, draw.y, 0u, DISCREPANCY_STREAM), cfg.key);
        dab = words.xy;
        g = disc_radii[disc_count + (words.z >> 24u)];
        if (cfg.disc_second != 0u) {
            g2 = disc_radii[cfg.disc_second + cfg.disc_second_count + (words.z >> 24u)];
        }
    }
    for (var pj = 0u; pj < m; pj++) {
        let base = pj * WORDS_PER_POINT;
        // Δ_{n+1}: the tool point's offset in the flange frame
        var dv = vec3<f32>(d[TOOL_AT], d[TOOL_AT + 1u], d[TOOL_AT + 2u]);
        if (TERM_ON && with_term) {
            var wb = 0u;
            if (BACKLASH_ON) {
                wb = hash32(sab.x ^ hash32(sab.y + pj));
            }
            dv = chain_step_turned(dv, base, chain, f, pj, wb);
        } else {
            dv = chain_step(dv, base, chain);
        }
        if (cfg.mode == 2u) {
            // x0 = Rz(φ_0) u0_0, the mean chain's position (f32 is enough: it only multiplies
            // small sines)
            let u = pts[base];
            let sp = pts[base + 1u].w;
            let x0 = vec3<f32>(u.w * u.x - sp * u.y, sp * u.x + u.w * u.y, u.z);
            dv = placement_step(dv, x0, d);
        }
        let o = pts[base + 2u * N_JOINTS];
        let ex = dv.x + o.x;
        let ey = dv.y + o.y;
        let ez = dv.z + o.z;
        var e = sqrt(ex * ex + ey * ey + ez * ez);
        if (disc_count != 0u) {
            e = with_discrepancy(e, hash32(dab.x ^ hash32(dab.y + pj)), disc_count, pj, g, g2);
        }
        if (chunk.want_e != 0u) {
            e_out[i * m + pj] = e;
        }
        w = max(w, e);
    }
    w_out[i] = w;
}

// Counter draws first + i.
@compute @workgroup_size(WORKGROUP_SIZE)
fn max_point_error(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if (i >= chunk.count) {
        return;
    }
    let draw = draw_plus(chunk.first, i);
    point_errors(i, draw_offsets(draw), draw, cfg.disc_count, array<vec2<u32>, 4>(draw, draw, draw, draw), cfg.term_on != 0u);
}

// Explicit offsets: row i of offsets_in (chunk.first is unused).
@compute @workgroup_size(WORKGROUP_SIZE)
fn max_point_error_offsets(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if (i >= chunk.count) {
        return;
    }
    var d: array<f32, N_PLACED>;
    for (var p = 0u; p < N_PLACED; p++) {
        d[p] = 0.0;
    }
    // Rows carry the placement's six offsets too when it is drawn (mode 2).
    let width = select(N_INPUTS, N_PLACED, cfg.mode == 2u);
    for (var p = 0u; p < width; p++) {
        d[p] = offsets_in[i * width + p];
    }
    // No draw, no discrepancy term, no joint errors' spread.
    point_errors(i, d, vec2<u32>(0u), 0u, array<vec2<u32>, 4>(), false);
}

// Pick-freeze rows: invocation i is row row0 + i of the request, row r of matrix s.
@compute @workgroup_size(WORKGROUP_SIZE)
fn max_point_error_pick_freeze(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if (i >= chunk.count) {
        return;
    }
    let row = chunk.row0 + i;
    let s = row / chunk.per_matrix;
    let r = row - s * chunk.per_matrix;
    let a = draw_plus(chunk.first, r);
    let b = draw_plus(chunk.b_first, r);
    let z = pick_freeze_normals(a, b, masks[s]);
    // The discrepancy term is one more Sobol input: from draw b where the mask has bit 63
    // (DISCREPANCY_MASK), else from a.
    let disc_draw = select(a, b, (masks[s].y & 0x80000000u) != 0u);
    // So are the groups of the joint errors (compliance, harmonics, payload, backlash): from b
    // where the mask has bit 60, 61, 62, 59 (TermGroup::mask).
    let my = masks[s].y;
    let term_of = array<vec2<u32>, 4>(
        select(a, b, (my & 0x10000000u) != 0u),
        select(a, b, (my & 0x20000000u) != 0u),
        select(a, b, (my & 0x40000000u) != 0u),
        select(a, b, (my & 0x08000000u) != 0u),
    );
    point_errors(i, spread_offsets(z), disc_draw, cfg.disc_count, term_of, cfg.term_on != 0u);
}
