//! Forward kinematics of the MDH chain in f64 (docs/METHOD.md §1, paper eq. 2).
//!
//! [`position`] applies the joint transforms to the tool point from the flange back to the base,
//! `p ← Rz(θ_i+q_i)·(Rx(α_i)·Ry(β_i)·p + (a_i, 0, d_i))` for i = n…1, which is the same product as
//! `T_1 ⋯ T_n · p_tool` without forming 4×4 matrices. [`transform`] forms the full homogeneous
//! transforms for callers that need frames (identification, tests).

use super::index::Joints;

/// Row-major homogeneous 4×4 transform.
pub type Mat4 = [[f64; 4]; 4];

/// The homogeneous transform of joint `i` for parameters `(θ, d, a, α, β)` (radians, mm) at
/// joint angle `q` (radians): `Rz(θ+q)·Tz(d)·Tx(a)·Rx(α)·Ry(β)`.
pub fn joint_transform(theta: f64, d: f64, a: f64, alpha: f64, beta: f64, q: f64) -> Mat4 {
    let (sz, cz) = (theta + q).sin_cos();
    let (sa, ca) = alpha.sin_cos();
    let (sb, cb) = beta.sin_cos();
    // Rx(α)·Ry(β)
    let rxy = [
        [cb, 0.0, sb],
        [sa * sb, ca, -sa * cb],
        [-ca * sb, sa, ca * cb],
    ];
    let mut m = [[0.0; 4]; 4];
    for c in 0..3 {
        m[0][c] = cz * rxy[0][c] - sz * rxy[1][c];
        m[1][c] = sz * rxy[0][c] + cz * rxy[1][c];
        m[2][c] = rxy[2][c];
    }
    m[0][3] = cz * a;
    m[1][3] = sz * a;
    m[2][3] = d;
    m[3][3] = 1.0;
    m
}

fn mul(a: &Mat4, b: &Mat4) -> Mat4 {
    let mut r = [[0.0; 4]; 4];
    for (i, row) in r.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = (0..4).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    r
}

/// Flange transform `T_1(q_1)⋯T_n(q_n)` for the `5n` parameters (radians, mm) and `n` joint
/// angles (radians). The tool point is not applied.
pub fn transform(params: &[f64], q: &[f64]) -> Mat4 {
    debug_assert_eq!(params.len(), 5 * q.len());
    let mut t = [[0.0; 4]; 4];
    for (i, row) in t.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    for (i, qi) in q.iter().enumerate() {
        let p = &params[5 * i..5 * i + 5];
        t = mul(&t, &joint_transform(p[0], p[1], p[2], p[3], p[4], *qi));
    }
    t
}

/// End position `P(q) = T(q)·p_tool` in mm, for parameters in radians/mm and `q` in radians.
#[inline(always)]
pub fn position(params: &[f64], tool: &[f64; 3], q: &[f64]) -> [f64; 3] {
    position_with_trig(params, &twist_trig(params), tool, q)
}

/// `[(sin α_i, cos α_i), (sin β_i, cos β_i)]` per joint: the part of [`position`]'s trigonometry
/// that does not depend on the joint angles, for callers that evaluate many configurations of
/// one parameter vector.
pub type TwistTrig = super::Capped<[(f64, f64); 2], { super::MAX_JOINTS }>;

/// [`TwistTrig`] of a parameter vector.
#[inline(always)]
pub fn twist_trig(params: &[f64]) -> TwistTrig {
    TwistTrig::from_fn(params.len() / 5, |i| {
        [params[5 * i + 3].sin_cos(), params[5 * i + 4].sin_cos()]
    })
}

/// [`position`] with the twists' sines and cosines given ([`twist_trig`]): the same arithmetic,
/// so the same bits.
#[inline(always)]
pub fn position_with_trig(
    params: &[f64],
    trig: &TwistTrig,
    tool: &[f64; 3],
    q: &[f64],
) -> [f64; 3] {
    let [mut x, mut y, mut z] = *tool;
    for i in (0..q.len()).rev() {
        let p = &params[5 * i..5 * i + 5];
        let [(sa, ca), (sb, cb)] = trig[i];
        let (sz, cz) = (p[0] + q[i]).sin_cos();
        // Ry(β)
        let x1 = cb * x + sb * z;
        let z1 = -sb * x + cb * z;
        // Rx(α), then Tx(a)·Tz(d)
        let y2 = ca * y - sa * z1;
        let z2 = sa * y + ca * z1 + p[1];
        let x2 = x1 + p[2];
        // Rz(θ+q)
        x = cz * x2 - sz * y2;
        y = sz * x2 + cz * y2;
        z = z2;
    }
    [x, y, z]
}

/// [`position`] with joint angles in degrees.
pub fn position_deg(params: &[f64], tool: &[f64; 3], q_deg: &[f64]) -> [f64; 3] {
    position(
        params,
        tool,
        &Joints::from_fn(q_deg.len(), |i| q_deg[i].to_radians()),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::tx60;

    #[test]
    fn tx60_flange_at_zero() {
        let m = tx60();
        let p = position(&m.params, &[0.0; 3], &[0.0; 6]);
        for (got, want) in p.iter().zip([0.0, 20.0, 1045.0]) {
            assert!((got - want).abs() < 1e-9, "{p:?}");
        }
    }

    #[test]
    fn point_form_matches_matrix_form() {
        let mut m = tx60();
        m.params[4 + 5] = 0.001; // β2
        m.params[3] += 0.002;
        let tool = [12.0, -7.0, 55.0];
        let q = [0.3, -0.7, 1.1, 2.0, -0.4, 0.9];
        let t = transform(&m.params, &q);
        let p = position(&m.params, &tool, &q);
        for r in 0..3 {
            let v = t[r][0] * tool[0] + t[r][1] * tool[1] + t[r][2] * tool[2] + t[r][3];
            assert!((v - p[r]).abs() < 1e-9);
        }
    }
}
