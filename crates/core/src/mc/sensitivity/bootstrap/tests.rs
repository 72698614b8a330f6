//! Unit tests of the bootstrap: the Poisson weights, the register-blocked sums, the integer
//! pass over the indicators against the f64 pass, and independence of the thread count.

use super::*;

#[test]
fn poisson_table_is_the_distribution_function() {
    let mut p = (-1.0f64).exp();
    let mut cdf = p;
    for (j, &t) in POISSON_CDF.iter().enumerate() {
        assert!((f64::from(t) - cdf * 2f64.powi(32)).abs() < 2.0, "{j}");
        p /= (j + 1) as f64;
        cdf += p;
    }
    assert_eq!(poisson(0), 0);
    assert_eq!(poisson(POISSON_CDF[0] - 1), 0);
    assert_eq!(poisson(POISSON_CDF[0]), 1);
    assert_eq!(poisson(u32::MAX), 12);
}

#[test]
fn weights_are_poisson_seeded_and_blockwise() {
    let n = 1 << 12;
    let all = |seed| {
        let b = Bootstrap::new(seed, 50);
        let mut w = vec![0u8; 50 * n];
        for (r, w) in w.chunks_exact_mut(n).enumerate() {
            b.weights(r, 0, w);
        }
        w
    };
    let w = all(9);
    assert_eq!(w, all(9));
    assert_ne!(w, all(10));
    // Any block of base samples gets the weights of the whole range (lanes or single
    // Philox blocks alike).
    let b = Bootstrap::new(9, 50);
    let mut part = vec![0u8; 68];
    b.weights(3, 1004, &mut part);
    assert_eq!(part, w[3 * n + 1004..3 * n + 1072]);
    // 204 800 weights: mean 1 and variance 1 within 6 standard errors, P(0) = 1/e.
    let m = w.len() as f64;
    let mean = w.iter().map(|&c| f64::from(c)).sum::<f64>() / m;
    let var = w
        .iter()
        .map(|&c| (f64::from(c) - mean).powi(2))
        .sum::<f64>()
        / m;
    let zeros = w.iter().filter(|&&c| c == 0).count() as f64 / m;
    assert!((mean - 1.0).abs() < 6.0 / m.sqrt(), "{mean}");
    assert!((var - 1.0).abs() < 6.0 * 3f64.sqrt() / m.sqrt(), "{var}");
    assert!(
        (zeros - (-1.0f64).exp()).abs() < 6.0 * 0.49 / m.sqrt(),
        "{zeros}"
    );
}

/// The register-blocked sums (portable and AVX2) are the bits of the plain loop.
#[test]
fn accumulate_keeps_the_bits_of_the_plain_loop() {
    let f = 2 + 3 * 7;
    let feat: Vec<f64> = (0..BLOCK * f)
        .map(|i| ((i * 7919 % 1013) as f64 - 506.0) / 37.0)
        .collect();
    let (count, mut nz, mut nnz) = (3, vec![(0u32, 0.0); 3 * BLOCK], vec![0; 3]);
    for g in 0..count {
        for k in (g..BLOCK).step_by(g + 2) {
            nz[g * BLOCK + nnz[g]] = (k as u32, (k % 5 + 1) as f64);
            nnz[g] += 1;
        }
    }
    let start: Vec<f64> = (0..count * f).map(|i| i as f64 / 3.0).collect();
    let mut plain = start.clone();
    for g in 0..count {
        for &(k, c) in &nz[g * BLOCK..g * BLOCK + nnz[g]] {
            for j in 0..f {
                plain[g * f + j] += c * feat[k as usize * f + j];
            }
        }
    }
    let (mut fast, mut portable) = (start.clone(), start);
    accumulate(&mut fast, &feat, f, &nz, &nnz);
    accumulate_impl(&mut portable, &feat, f, &nz, &nnz);
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&fast), bits(&plain));
    assert_eq!(bits(&portable), bits(&plain));
}

/// Outputs of y = x1 + x2 + x1·x3 on the pick-freeze design of three uniform inputs.
fn outputs(n: usize) -> Outputs {
    let gen = Philox::new(17);
    let x = |k: u64| {
        gen.block(k, 0, 0)
            .map(|w| f64::from(w) / 2f64.powi(32) - 0.5)
    };
    let f = |x: [f64; 3]| x[0] + x[1] + 2.0 * x[0] * x[2];
    let mut y = Outputs {
        sets: vec![Vec::new(); 3],
        ..Outputs::default()
    };
    for k in 0..n as u64 {
        let (a, b) = (x(k), x(k + (1 << 40)));
        y.a.push(f([a[0], a[1], a[2]]));
        y.b.push(f([b[0], b[1], b[2]]));
        for (i, s) in y.sets.iter_mut().enumerate() {
            let mut m = [a[0], a[1], a[2]];
            m[i] = b[i];
            s.push(f(m));
        }
    }
    y
}

/// The integer pass over the ranks gives, at every threshold, the indices the f64 pass
/// gives on the indicator's own outputs, point estimates and replicates alike.
#[test]
fn indicator_pass_matches_the_value_pass_on_indicators() {
    let y = outputs(512);
    let boot = Bootstrap::new(4, 40);
    let levels = [-0.6, -0.2, 0.0, 0.05, 0.5, 0.9];
    let (point, reps) = indicators(&Ranks::new(&y, &levels), &boot);
    assert_eq!(reps.len(), boot.count);
    for (j, &l) in levels.iter().enumerate() {
        let ind =
            |v: &Vec<f64>| -> Vec<f64> { v.iter().map(|&x| f64::from(u8::from(x >= l))).collect() };
        let yi = Outputs {
            a: ind(&y.a),
            b: ind(&y.b),
            sets: y.sets.iter().map(ind).collect(),
        };
        let m0 = yi.a.iter().chain(&yi.b).sum::<f64>() / 1024.0;
        let (pv, rv) = value(&yi, m0, &boot);
        let hits = Ranks::new(&y, &levels).hits()[j];
        assert_eq!(hits as f64, m0 * 1024.0, "threshold {l}");
        for (x, v) in std::iter::once((&point, &pv)).chain(reps.iter().zip(&rv)) {
            let (x, v) = (x.level(j, 3), v.level(0, 3));
            assert_eq!(x.is_some(), v.is_some(), "threshold {l}");
            if let (Some(x), Some(v)) = (x, v) {
                for (p, q) in x.0.iter().chain(x.1).zip(v.0.iter().chain(v.1)) {
                    assert!((p - q).abs() < 1e-12, "threshold {l}: {p} vs {q}");
                }
            }
        }
    }
}

/// The replicates are the same bits with 1 thread and with 3.
#[test]
fn replicates_do_not_depend_on_the_thread_count() {
    let y = outputs(1024);
    let boot = Bootstrap::new(8, 100);
    let levels = [-0.3, 0.1, 0.4];
    let run = |threads| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let (_, v) = value(&y, 0.01, &boot);
            let (_, i) = indicators(&Ranks::new(&y, &levels), &boot);
            v.iter()
                .chain(&i)
                .flat_map(|r| r.values.iter().map(|x| x.to_bits()))
                .collect::<Vec<u64>>()
        })
    };
    assert_eq!(run(1), run(3));
}
