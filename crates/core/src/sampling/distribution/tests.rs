use super::*;
use crate::kinematics::{tx60, Layout, Uncertainty};

// The TX60's counts: six joints.
const N_PARAMS: usize = Layout::SIX.n_params();
const N_UNCERTAIN: usize = 33;

/// A tool spread adds draws without touching the parameters' bits (existing seeds keep
/// their results), and the tool's offsets have the stated σ: 4·10^4 draws, the relative
/// standard error of a σ estimate is 1/√(2n) ≈ 3.5e-3, bound 5 standard errors.
#[test]
fn tool_spread_keeps_parameter_draws_and_has_its_sigma() {
    let m = tx60();
    let mut mt = m.clone();
    mt.tool_sigma = [0.002, 0.0, 0.005];
    let (a, b) = (
        ParamSampler::new(&m, 11).unwrap(),
        ParamSampler::new(&mt, 11).unwrap(),
    );
    // tool x and y are the last normals of block 7, tool z the first of block 8
    assert_eq!(b.blocks()[b.blocks().len() - 2..], [7, 8]);
    assert!(!a.blocks().contains(&8));
    let n = 40_000u64;
    let mut ss = [0.0; 3];
    let (mut da, mut db) = ([0.0; N_UNCERTAIN], [0.0; N_UNCERTAIN]);
    for k in 0..n {
        a.deltas(k, &mut da);
        b.deltas(k, &mut db);
        assert_eq!(da[..N_PARAMS], db[..N_PARAMS], "draw {k}");
        assert_eq!(da[N_PARAMS..], [0.0; 3]);
        assert_eq!(b.tool_deltas(k), [db[30], db[31], db[32]]);
        for (s, d) in ss.iter_mut().zip(&db[N_PARAMS..]) {
            *s += d * d;
        }
    }
    assert_eq!(ss[1], 0.0);
    for (k, want) in [(0, 0.002), (2, 0.005)] {
        let got = (ss[k] / n as f64).sqrt();
        assert!((got / want - 1.0).abs() < 5.0 * 3.5e-3, "{k}: {got}");
    }
}

/// A 33 × 33 covariance correlates the tool with a parameter (ρ = −0.7; standard error of
/// the estimate (1−ρ²)/√n ≈ 2.5e-3 at n = 8·10^4, bound 5 standard errors), and a 30 × 30
/// covariance with `tool_sigma` draws the tool independently with that σ.
#[test]
fn full_covariance_correlates_the_tool() {
    let mut m = tx60();
    let s = m.param_sigmas();
    let n = N_UNCERTAIN;
    let mut c = vec![0.0; n * n];
    for i in 0..N_PARAMS {
        c[i * n + i] = s[i] * s[i];
    }
    let (t, st) = (N_PARAMS + 1, 0.004);
    c[t * n + t] = st * st;
    c[t * n + 2] = -0.7 * st * s[2];
    c[2 * n + t] = c[t * n + 2];
    m.uncertainty = Uncertainty::from_matrix(InputSpace::robot(6), c);
    m.tool_sigma = [0.0, st, 0.0];
    m.check().unwrap();
    let g = ParamSampler::new(&m, 5).unwrap();
    let draws = 80_000;
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    let mut d = [0.0; N_UNCERTAIN];
    for k in 0..draws {
        g.deltas(k, &mut d);
        sxy += d[t] * d[2];
        sxx += d[t] * d[t];
        syy += d[2] * d[2];
        assert_eq!((d[N_PARAMS], d[N_PARAMS + 2]), (0.0, 0.0));
    }
    let rho = sxy / (sxx * syy).sqrt();
    assert!((rho + 0.7).abs() < 5.0 * 2.5e-3, "rho {rho}");
    assert!(((sxx / draws as f64).sqrt() / st - 1.0).abs() < 0.02);
}

/// Pick-freeze rows: mask 0 is draw `a` and a full mask draw `b`, to the bit; a mask
/// takes exactly its normals from `b` (independent: δ_i = σ_i z_i of the draw it names;
/// correlated: `L` times the mixed normals, recomputed here from the Philox blocks).
#[test]
fn pick_freeze_rows_mix_two_draws_by_mask() {
    let mut mc = tx60();
    let s = mc.param_sigmas();
    let mut c = vec![0.0; N_PARAMS * N_PARAMS];
    for i in 0..N_PARAMS {
        c[i * N_PARAMS + i] = s[i] * s[i];
    }
    c[N_PARAMS + 7] = 0.5 * s[1] * s[7];
    c[7 * N_PARAMS + 1] = c[N_PARAMS + 7];
    mc.uncertainty = Uncertainty::from_matrix(InputSpace::parameters(6), c);
    mc.tool_sigma = [0.002, 0.0, 0.003];
    let mut mi = tx60();
    mi.tool_sigma = [0.002, 0.0, 0.003];
    let (a, b) = (12_345u64, (1u64 << 63) + 12_345);
    for model in [mi, mc] {
        let g = ParamSampler::new(&model, 9).unwrap();
        let (mut da, mut db, mut d) = ([0.0; N_UNCERTAIN], [0.0; N_UNCERTAIN], [0.0; 33]);
        g.deltas(a, &mut da);
        g.deltas(b, &mut db);
        g.pick_freeze_deltas(a, b, 0, &mut d);
        assert_eq!(d, da);
        g.pick_freeze_deltas(a, b, ALL_NORMALS, &mut d);
        assert_eq!(d, db);
        let normals = |k: u64| -> Vec<f64> {
            (0..(MAX_NORMALS / 4) as u32)
                .flat_map(|blk| crate::sampling::normals_block(&g.gen, k, blk, PARAM_STREAM))
                .collect()
        };
        let (za, zb) = (normals(a), normals(b));
        for mask in [1u64 << 7, (1 << 1) | (1 << 31) | (1 << 32), 0x5_5555_5555] {
            g.pick_freeze_deltas(a, b, mask, &mut d);
            let z: Vec<f64> = (0..MAX_NORMALS)
                .map(|i| if mask >> i & 1 == 1 { zb[i] } else { za[i] })
                .collect();
            let want: Vec<f64> = match g.cholesky() {
                None => (0..N_UNCERTAIN)
                    .map(|i| g.sigmas().unwrap()[i] * z[i])
                    .collect(),
                Some((free, l)) => {
                    let n = free.len();
                    let mut out = vec![0.0; N_UNCERTAIN];
                    for r in 0..n {
                        out[free[r]] = (0..=r).map(|q| l[r * n + q] * z[free[q]]).sum();
                    }
                    out
                }
            };
            for i in 0..N_UNCERTAIN {
                assert!(
                    (d[i] - want[i]).abs() <= 1e-15 * want[i].abs().max(1e-3),
                    "{i}"
                );
            }
            if g.cholesky().is_none() {
                // one normal, one input: its offset is the B draw's, the others A's
                for i in 0..N_UNCERTAIN {
                    let from = if mask >> i & 1 == 1 { db[i] } else { da[i] };
                    assert_eq!(d[i], from, "input {i}, mask {mask:#x}");
                }
            }
        }
    }
}

#[test]
fn diagonal_covariance_equals_sigma_list() {
    let m = tx60();
    let s = m.param_sigmas();
    let mut mc = m.clone();
    let mut c = vec![0.0; N_PARAMS * N_PARAMS];
    for i in 0..N_PARAMS {
        c[i * N_PARAMS + i] = s[i] * s[i];
    }
    mc.uncertainty = Uncertainty::from_matrix(InputSpace::parameters(6), c);
    let (a, b) = (
        ParamSampler::new(&m, 7).unwrap(),
        ParamSampler::new(&mc, 7).unwrap(),
    );
    for k in [0u64, 1, 99, 1 << 40] {
        let (da, db) = (a.draw(k), b.draw(k));
        for i in 0..N_PARAMS {
            assert!((da[i] - db[i]).abs() <= 1e-15 * da[i].abs().max(1.0));
        }
    }
}

#[test]
fn correlated_draws_reproduce_covariance() {
    // Two correlated parameters, ρ = 0.8; 2·10^5 draws: the correlation estimate's standard
    // error is (1−ρ²)/√n ≈ 8e-4, bound 5 standard errors.
    let mut m = tx60();
    let s = m.param_sigmas();
    let mut c = vec![0.0; N_PARAMS * N_PARAMS];
    for i in 0..N_PARAMS {
        c[i * N_PARAMS + i] = s[i] * s[i];
    }
    c[N_PARAMS + 2] = 0.8 * s[1] * s[2];
    c[2 * N_PARAMS + 1] = c[N_PARAMS + 2];
    m.uncertainty = Uncertainty::from_matrix(InputSpace::parameters(6), c);
    let g = ParamSampler::new(&m, 3).unwrap();
    let n = 200_000;
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    let mut d = [0.0; N_UNCERTAIN];
    for k in 0..n {
        g.deltas(k, &mut d);
        sxy += d[1] * d[2];
        sxx += d[1] * d[1];
        syy += d[2] * d[2];
    }
    let rho = sxy / (sxx * syy).sqrt();
    assert!((rho - 0.8).abs() < 5.0 * 8e-4, "rho {rho}");
    assert!(((sxx / n as f64).sqrt() / s[1] - 1.0).abs() < 0.01);
}

#[test]
fn indefinite_covariance_is_an_error() {
    let mut m = tx60();
    let mut c = vec![0.0; N_PARAMS * N_PARAMS];
    c[0] = 1e-8;
    c[2 * N_PARAMS + 2] = 1e-8;
    c[2] = 2e-8;
    c[2 * N_PARAMS] = 2e-8;
    m.uncertainty = Uncertainty::from_matrix(InputSpace::parameters(6), c);
    assert!(ParamSampler::new(&m, 1).is_err());
}
