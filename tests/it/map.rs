//! Workspace reliability maps: the inverse kinematics reaches every reached cell's target
//! (forward kinematics of the configuration within 1e-9 mm) for every preset, with the tool
//! pointing down and with free orientation; a map of the TX60 with only θ1 uncertain matches
//! the closed form `R_j(l) = 2Φ(2 asin(l / 2ρ) / σ) − 1` per cell and depends on the distance
//! ρ from the base axis alone; CPU and GPU (lavapipe) agree per cell; the command writes its
//! files and refuses bad input in one line.

use crate::common;

use common::{arg, check_svg_finite, fails_leaving_nothing, have_adapter, run, stdout, tmpdir};
use gpu_amcs::engine::{BackendChoice, CpuEvaluator, Evaluator, Problem, Reference};
use gpu_amcs::kinematics::{tx60, Params, RobotModel, Uncertainty};
use gpu_amcs::map::{
    default_reference_deg, evaluate, ik, round_trip_error, test_points, tool_down_rpy_deg,
    Evaluation, Grid, MapResult, MapSpec, Plane, Timings,
};
use gpu_amcs::points::WorkspaceBox;
use gpu_amcs::presets::{preset, PRESETS};

/// A plane map of `model` over `workspace` (the TX60 default box when `None`).
fn spec(model: &RobotModel, plane: Plane, at: f64, n: usize, free: bool) -> MapSpec {
    MapSpec {
        grid: Grid::Plane {
            plane,
            at,
            cells: [n, n],
        },
        workspace: WorkspaceBox::default(),
        orientation_rpy_deg: (!free).then_some(tool_down_rpy_deg(model)),
        reference_q_deg: default_reference_deg(model),
        ik_seeds: 8,
    }
}

#[test]
fn ik_round_trip_at_every_reached_cell_of_every_preset() {
    for name in PRESETS {
        let m = preset(name).unwrap();
        for free in [false, true] {
            let s = spec(&m, Plane::Xz, 100.0, 7, free);
            let sol = s.solve(&m).unwrap_or_else(|e| panic!("{name}: {e}"));
            let reached = sol.iter().flatten().count();
            // The default box lies within every preset's reach: a good part of the plane must
            // be reached (measured: 24–49 of 49 cells).
            assert!(
                reached >= 10,
                "{name} free {free}: only {reached} cells reached"
            );
            let rot = ik::rpy_rotation(tool_down_rpy_deg(&m));
            for (t, c) in s.targets().iter().zip(&sol) {
                let Some(c) = c else { continue };
                let q = c.q_deg.map(f64::to_radians);
                // World frame: the targets and the orientation are world-frame quantities (the
                // KR 6's base transform turns its base frame upside down).
                let p = m.world_position(&q);
                let d = ((p[0] - t.position[0]).powi(2)
                    + (p[1] - t.position[1]).powi(2)
                    + (p[2] - t.position[2]).powi(2))
                .sqrt();
                assert!(d <= 1e-9, "{name} cell {:?}: FK misses by {d} mm", t.index);
                assert!(
                    (d - c.position_residual_mm).abs() <= 1e-12,
                    "{name}: reported residual {} vs {d}",
                    c.position_residual_mm
                );
                m.check_limits(&c.q_deg).unwrap();
                match c.orientation_residual_rad {
                    Some(o) => {
                        assert!(!free);
                        let f = gpu_amcs::kinematics::transform(&m.params, &q);
                        let b = m.base.as_ref().map_or(nalgebra::Matrix3::identity(), |b| {
                            *b.isometry().rotation.to_rotation_matrix().matrix()
                        });
                        let r: [[f64; 3]; 3] = std::array::from_fn(|i| {
                            std::array::from_fn(|j| (0..3).map(|k| b[(i, k)] * f[k][j]).sum())
                        });
                        let a = ik::rotation_angle(&r, &rot);
                        assert!(
                            a <= 1e-10 && o <= 1e-10,
                            "{name}: orientation off by {a} rad"
                        );
                        // Tool down: the last frame's z axis is −z of the world, or +z where the
                        // flange lies on its negative side (the KR 6).
                        let down = if tool_down_rpy_deg(&m)[0] == 0.0 {
                            1.0
                        } else {
                            -1.0
                        };
                        assert!((r[2][2] - down).abs() < 1e-12, "{name}: {:?}", r[2][2]);
                    }
                    None => assert!(free),
                }
            }
        }
    }
}

#[test]
fn neighbouring_cells_share_a_branch() {
    // On a fine plane the configurations of neighbouring reached cells differ by little: the
    // branch does not flip from cell to cell. 45 × 40 mm cells move a joint by well under 30°
    // except near the edge of the reach (the elbow almost stretched: measured up to 37° in q3),
    // over the base axis (q1 turns fast) and where the nearest-reference choice switches the
    // wrist; allow 1 pair in 20 (measured: 5 of 203, one of them a wrist flip).
    let m = tx60();
    let s = spec(&m, Plane::Xz, 0.0, 20, false);
    let sol = s.solve(&m).unwrap();
    let n = 20;
    let (mut pairs, mut jumps) = (0, 0);
    for j in 0..n {
        for i in 0..n - 1 {
            if let (Some(a), Some(b)) = (&sol[j * n + i], &sol[j * n + i + 1]) {
                pairs += 1;
                let d = (0..6)
                    .map(|k| (a.q_deg[k] - b.q_deg[k]).abs())
                    .fold(0.0, f64::max);
                jumps += usize::from(d > 30.0);
            }
        }
    }
    assert!(pairs > 50, "{pairs}");
    assert!(
        jumps * 20 <= pairs,
        "{jumps} branch jumps in {pairs} neighbouring pairs"
    );
}

/// `Φ(x)` for x ≥ 0 from `erf(x/√2)` by its series of positive terms
/// `erf(z) = 2/√π · e^{−z²} · Σ 2^n z^{2n+1} / (1·3·…·(2n+1))` (Abramowitz & Stegun 7.1.6),
/// summed until the terms fall below 1e-17 (no cancellation, so the error is rounding only).
fn phi(x: f64) -> f64 {
    let z = x / std::f64::consts::SQRT_2;
    let (mut term, mut sum, mut n) = (z, z, 0.0);
    while term > 1e-17 * sum {
        n += 1.0;
        term *= 2.0 * z * z / (2.0 * n + 1.0);
        sum += term;
    }
    0.5 + (-z * z).exp() * sum / std::f64::consts::PI.sqrt()
}

/// σ of θ1 in the θ1-only model, radians.
const SIGMA: f64 = 0.005 * std::f64::consts::PI / 180.0;

fn theta1_model() -> RobotModel {
    let mut m = tx60();
    let mut s = Params::filled(m.layout().n_params(), 0.0);
    s[0] = SIGMA;
    m.uncertainty = Uncertainty::Independent(s);
    m
}

/// A map of `m` on evaluator `ev` for the reached configurations of `s`.
fn map_on(
    m: &RobotModel,
    s: &MapSpec,
    draws: u64,
    thresholds: &[f64],
    backend: BackendChoice,
) -> MapResult {
    let sol = s.solve(m).unwrap();
    let pb = Problem::new(m.clone(), &test_points(&sol), &Reference::Calibrated, 7).unwrap();
    let (mut ev, _) = gpu_amcs::backends()
        .make_evaluator(pb, backend, None)
        .unwrap();
    let e: Evaluation = evaluate(ev.as_mut(), draws, 5000, thresholds, None).unwrap();
    MapResult::new(&m.name, s, 7, sol, e, ev.info(), Timings::default())
}

#[test]
fn theta1_only_map_matches_closed_form_and_depends_on_rho_alone() {
    let m = theta1_model();
    // A horizontal plane at z = 300 mm, symmetric about y = 0 (the default box): cells j and
    // n − 1 − j are mirror images with equal ρ.
    let n = 8;
    let s = spec(&m, Plane::Xy, 300.0, n, false);
    let thresholds = [0.01, 0.03, 0.06];
    let draws = 100_000u64;
    let r = map_on(&m, &s, draws, &thresholds, BackendChoice::Cpu);
    assert!(r.reached >= 20, "{}", r.reached);
    for c in &r.cells {
        let Some(st) = &c.stats else { continue };
        assert!(round_trip_error(&m, c).unwrap() <= 1e-9);
        let [x, y, _] = c.target.position;
        let rho = x.hypot(y);
        for rel in &st.reliability {
            let l = rel.threshold;
            let exact = if l >= 2.0 * rho {
                1.0
            } else {
                2.0 * phi(2.0 * (l / (2.0 * rho)).asin() / SIGMA) - 1.0
            };
            // Error analysis: the count is binomial(N, R); 3·(#cells·#thresholds ≈ 150) checks
            // at 4.4σ have a joint false-alarm rate below 0.2 %, and 3/N covers the Poisson
            // tails where R is within a few 1/N of 0 or 1.
            let sd = (exact * (1.0 - exact) / draws as f64).sqrt();
            assert!(
                (rel.r - exact).abs() <= 4.4 * sd + 3.0 / draws as f64,
                "cell {:?} ρ = {rho:.1} l = {l}: {} vs exact {exact}",
                c.target.index,
                rel.r
            );
            // The reported Wilson interval is tight at this N: its width is at most
            // 2·1.96·√(1/4N) ≈ 0.0062 (the binomial standard deviation is largest at R = ½).
            assert!(rel.ci_high - rel.ci_low <= 1.96 / (draws as f64).sqrt() * 1.001);
            assert!(exact >= rel.ci_low - 2.0 * sd - 3.0 / draws as f64);
            assert!(exact <= rel.ci_high + 2.0 * sd + 3.0 / draws as f64);
        }
        // Mean and 95 % quantile of e = 2ρ|sin(δ/2)| ≈ ρ|δ|, |δ| half-normal: mean σ√(2/π),
        // 95 % quantile 1.95996σ. Sampling error of the mean ≈ 0.6σρ/√N ≈ 0.2 %; allow 1 %.
        let mean = rho * SIGMA * (2.0 / std::f64::consts::PI).sqrt();
        assert!(
            (st.mean_mm / mean - 1.0).abs() < 0.01,
            "{} vs {mean}",
            st.mean_mm
        );
        let q95 = rho * SIGMA * 1.959_963_984_540_054;
        assert!(
            (st.q95_mm / q95 - 1.0).abs() < 0.01,
            "{} vs {q95}",
            st.q95_mm
        );
    }
    // ρ alone: mirrored cells (same ρ, same draws) have the same counts.
    let mut mirrored = 0;
    for c in &r.cells {
        let [i, j, _] = c.target.index;
        let twin = &r.cells[(n - 1 - j) * n + i];
        if let (Some(a), Some(b)) = (&c.stats, &twin.stats) {
            mirrored += 1;
            for (ra, rb) in a.reliability.iter().zip(&b.reliability) {
                assert_eq!(
                    ra.r, rb.r,
                    "cells {:?} and {:?}",
                    c.target.index, twin.target.index
                );
            }
            // Equal up to the rounding of the positions (~1e-13 mm at 500 mm).
            assert!((a.q95_mm - b.q95_mm).abs() <= 1e-9);
        }
    }
    assert!(mirrored >= 10, "{mirrored}");
    // Multi-point: w = 2ρ_max|sin(δ/2)| over the reached cells.
    let rho_max = r
        .cells
        .iter()
        .filter(|c| c.stats.is_some())
        .map(|c| c.target.position[0].hypot(c.target.position[1]))
        .fold(0.0, f64::max);
    for rel in &r.multi_point {
        let exact = 2.0 * phi(2.0 * (rel.threshold / (2.0 * rho_max)).asin() / SIGMA) - 1.0;
        let sd = (exact * (1.0 - exact) / draws as f64).sqrt();
        assert!(
            (rel.r - exact).abs() <= 4.4 * sd + 3.0 / draws as f64,
            "{rel:?} vs {exact}"
        );
    }
}

#[test]
fn cpu_and_gpu_agree_per_cell() {
    if !have_adapter("cpu_and_gpu_agree_per_cell") {
        return;
    }
    let m = tx60();
    let s = spec(&m, Plane::Xz, 0.0, 6, false);
    let draws = 4000u64;
    let thresholds = [0.05, 0.1];
    let cpu = map_on(&m, &s, draws, &thresholds, BackendChoice::Cpu);
    let gpu = map_on(&m, &s, draws, &thresholds, BackendChoice::Gpu);
    assert_eq!(gpu.backend.backend, "gpu");
    // Per draw and point the f32 deviation form stays within 1e-5 mm of the f64 CPU (the bound
    // tests/gpu.rs uses); a count can differ only by draws whose CPU error lies within 1e-5 mm
    // of a threshold, which are counted here from the CPU's own errors.
    let sol = s.solve(&m).unwrap();
    let pb = Problem::new(m.clone(), &test_points(&sol), &Reference::Calibrated, 7).unwrap();
    let mut ev = CpuEvaluator::new(pb);
    let k = ev.n_points();
    let mut w = vec![0.0; draws as usize];
    let mut e = vec![0.0; draws as usize * k];
    ev.evaluate(0, &mut w, Some(&mut e)).unwrap();
    let reached: Vec<_> = cpu.cells.iter().filter_map(|c| c.stats.as_ref()).collect();
    let reached_gpu: Vec<_> = gpu.cells.iter().filter_map(|c| c.stats.as_ref()).collect();
    assert_eq!(reached.len(), k);
    for (j, (a, b)) in reached.iter().zip(&reached_gpu).enumerate() {
        assert!((a.mean_mm - b.mean_mm).abs() <= 1e-5, "cell {j} mean");
        assert!((a.q95_mm - b.q95_mm).abs() <= 1e-5, "cell {j} q95");
        for (t, (ra, rb)) in a.reliability.iter().zip(&b.reliability).enumerate() {
            let near = (0..draws as usize)
                .filter(|&i| (e[i * k + j] - thresholds[t]).abs() <= 1e-5)
                .count();
            assert!(
                ((ra.r - rb.r) * draws as f64).abs() <= near as f64 + 1e-9,
                "cell {j} l = {}: {} vs {} ({near} draws near the threshold)",
                thresholds[t],
                ra.r,
                rb.r
            );
        }
    }
}

#[test]
fn command_writes_the_map() {
    let d = tmpdir("map-files");
    let (json, csv, svg) = (arg(&d, "m.json"), arg(&d, "csv"), arg(&d, "svg"));
    let o = run(&[
        "map",
        "--plane",
        "xz",
        "--at",
        "0",
        "--cells",
        "12,10",
        "--draws",
        "500",
        "--backend",
        "cpu",
        "--thresholds",
        "0.05,0.1",
        "--json",
        &json,
        "--csv",
        &csv,
        "--svg",
        &svg,
    ]);
    assert!(o.status.success(), "{}", common::stderr(&o));
    let out = stdout(&o);
    assert!(
        out.contains("multi-point reliability") && out.contains("of 120 cells"),
        "{out}"
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let cells = v["map"]["cells"].as_array().unwrap();
    assert_eq!(cells.len(), 120);
    let unreachable = cells.iter().filter(|c| c["ik"].is_null()).count();
    assert!(unreachable > 0 && unreachable < 120, "{unreachable}");
    let text = std::fs::read_to_string(d.join("csv/map.csv")).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 121);
    let cols = lines[0].split(',').count();
    assert!(lines.iter().all(|l| l.split(',').count() == cols));
    assert!(
        lines[0].ends_with("R_0.1,R_0.1_low,R_0.1_high"),
        "{}",
        lines[0]
    );
    for name in ["map_e95.svg", "map_r.svg"] {
        let s = std::fs::read_to_string(d.join("svg").join(name)).unwrap();
        check_svg_finite(&s, name);
        for part in [
            "<title",
            "<desc",
            "url(#hatch)",
            "x (mm)",
            "z (mm)",
            "base",
            "unreachable",
        ] {
            assert!(s.contains(part), "{name} lacks {part}");
        }
    }
    // The HTML report: one self-contained page with both heat maps inline, each titled and
    // described, tables with headers, and links to the files beside it.
    let html = arg(&d, "html");
    let o = run(&[
        "map",
        "--plane",
        "xy",
        "--at",
        "300",
        "--cells",
        "8,8",
        "--draws",
        "300",
        "--backend",
        "cpu",
        "-q",
        "--html",
        &html,
    ]);
    assert!(o.status.success(), "{}", common::stderr(&o));
    let page = std::fs::read_to_string(d.join("html/index.html")).unwrap();
    for bad in ["<script", "http://", "https://", "NaN"] {
        assert!(!page.contains(bad), "page contains {bad}");
    }
    assert_eq!(page.matches("<figure ").count(), 2);
    assert_eq!(page.matches("<desc id=\"fig").count(), 2);
    assert_eq!(
        page.matches("<desc").count(),
        2,
        "one text alternative per figure"
    );
    assert_eq!(
        page.matches("<table").count(),
        page.matches("<thead><tr><th scope=\"col\">").count()
    );
    for f in ["map.json", "map.csv", "map_e95.svg", "map_r.svg"] {
        assert!(d.join("html").join(f).is_file(), "{f}");
        assert!(page.contains(&format!("href=\"./{f}\"")), "{f} not linked");
    }
    // A 3-D grid writes the heat maps per z layer.
    let d3 = tmpdir("map-volume");
    let svg3 = arg(&d3, "svg");
    let o = run(&[
        "map",
        "--cells",
        "4,4,3",
        "--draws",
        "200",
        "--backend",
        "cpu",
        "--free-orientation",
        "--svg",
        &svg3,
        "-q",
    ]);
    assert!(o.status.success(), "{}", common::stderr(&o));
    let names: Vec<String> = common::tree(&d3)
        .into_iter()
        .filter(|n| n.ends_with(".svg"))
        .collect();
    assert_eq!(names.len(), 6, "{names:?}");
    assert!(
        names.iter().any(|n| n.ends_with("map_r_z2.svg")),
        "{names:?}"
    );
}

#[test]
fn bad_input_is_one_line() {
    let d = tmpdir("map-bad");
    let json = arg(&d, "m.json");
    let base = [
        "map",
        "--backend",
        "cpu",
        "--draws",
        "100",
        "--json",
        json.as_str(),
    ];
    let with = |extra: &[&str]| -> Vec<String> {
        base.iter().chain(extra).map(|s| s.to_string()).collect()
    };
    let cases: &[(&[&str], &str)] = &[
        (
            &["--plane", "xy", "--at", "900"],
            "outside the workspace box",
        ),
        (&["--plane", "xy", "--at", "900"], "--at"),
        (
            &[
                "--plane",
                "xy",
                "--at",
                "3000",
                "--box-size",
                "9000,9000,9000",
            ],
            "beyond the reach",
        ),
        (
            &["--plane", "xy", "--at", "300", "--cells", "0,5"],
            "--cells",
        ),
        (&["--plane", "xy", "--at", "300", "--cells", "5"], "--cells"),
        (
            &["--plane", "xy", "--at", "300", "--cells", "1000,1000"],
            "at most",
        ),
        (
            &["--plane", "xy", "--at", "300", "--orientation", "180,0"],
            "--orientation",
        ),
        (
            &["--plane", "xy", "--at", "300", "--orientation", "1e9,0,0"],
            "--orientation",
        ),
        (&["--plane", "xy"], "--at"),
        (&["--at", "300"], "--plane"),
        (
            &[
                "--plane",
                "xy",
                "--at",
                "0",
                "--box-center",
                "5000,5000,0",
                "--box-size",
                "100,100,100",
            ],
            "none of the",
        ),
        (
            &["--plane", "xy", "--at", "300", "--reference-q", "0,0,0"],
            "--reference-q",
        ),
        (
            &[
                "--plane",
                "xy",
                "--at",
                "300",
                "--reference-q",
                "999,0,0,0,0,0",
            ],
            "--reference-q",
        ),
        (
            &["--plane", "xy", "--at", "300", "--thresholds", "-1"],
            "--thresholds",
        ),
        (
            &["--plane", "xy", "--at", "300", "--memory-limit", "1M"],
            "memory",
        ),
    ];
    for (extra, what) in cases {
        let args = with(extra);
        let refs: Vec<&str> = args.iter().map(String::as_str).collect();
        fails_leaving_nothing(&d, &refs, what);
    }
    // Zero draws: the library names the field, the binary the flag.
    fails_leaving_nothing(
        &d,
        &[
            "map", "--plane", "xy", "--at", "300", "--draws", "0", "--json", &json,
        ],
        "--draws",
    );
}

/// Reach and branch do not depend on the extra seeds: on a 20 × 20 plane of every preset (tool
/// down), the built-in seeds alone reach exactly the cells 500 extra seeds reach, with the same
/// configurations; and every cell left unreachable is either outside the reach ball (a proof)
/// or missed by all 564 seeds.
#[test]
fn reach_and_branch_match_a_dense_seed_reference() {
    for name in ["tx60", "ur5e", "kr6r700sixx"] {
        let m = preset(name).unwrap();
        let base = spec(&m, Plane::Xz, 0.0, 20, false);
        let solve = |extra: usize| {
            MapSpec {
                ik_seeds: extra,
                ..base.clone()
            }
            .solve(&m)
            .unwrap()
        };
        let plain = solve(0);
        let dense = solve(500);
        let reached = |s: &[Option<gpu_amcs::map::CellIk>]| s.iter().flatten().count();
        eprintln!(
            "{name}: {} cells reached with 0 and {} with 500 extra seeds",
            reached(&plain),
            reached(&dense)
        );
        assert_eq!(reached(&plain), reached(&dense), "{name}");
        for (c, (a, b)) in plain.iter().zip(&dense).enumerate() {
            match (a, b) {
                (Some(a), Some(b)) => {
                    let d = (0..6)
                        .map(|k| (a.q_deg[k] - b.q_deg[k]).abs())
                        .fold(0.0, f64::max);
                    assert!(d < 1e-6, "{name}: cell {c} on another branch ({d} deg)");
                }
                (None, None) => {}
                _ => panic!("{name}: cell {c} reached by one seed set only"),
            }
        }
    }
}

/// The KUKA KR 6 R700 sixx written with A1 about +z: the same arm as the preset (whose A1 turns
/// about −z, held by the base transform Rx(180°) that mirrors its MDH chain) with no base
/// transform, the joint-1 sense reversed (its limits are symmetric, so it reaches the same).
fn kr6_unturned() -> RobotModel {
    let joints = [
        ("0 0 0.4", "0 0 1"),
        ("0.025 0 0", "0 1 0"),
        ("0.315 0 0", "0 1 0"),
        ("0 0 0.035", "-1 0 0"),
        ("0.365 0 0", "0 1 0"),
        ("0.080 0 0", "-1 0 0"),
    ];
    let limits = [
        (-170.0_f64, 170.0_f64),
        (-190.0, 45.0),
        (-120.0, 156.0),
        (-185.0, 185.0),
        (-120.0, 120.0),
        (-350.0, 350.0),
    ];
    let mut s = String::from("<robot name=\"kr6up\">\n  <link name=\"l0\"/>\n");
    for (k, ((xyz, axis), (lo, hi))) in joints.iter().zip(limits).enumerate() {
        s.push_str(&format!(
            "  <link name=\"l{}\"/>\n  <joint name=\"a{}\" type=\"revolute\"><origin xyz=\"{xyz}\"/><parent link=\"l{k}\"/><child link=\"l{}\"/><axis xyz=\"{axis}\"/><limit lower=\"{}\" upper=\"{}\"/></joint>\n",
            k + 1,
            k + 1,
            k + 1,
            lo.to_radians(),
            hi.to_radians()
        ));
    }
    s.push_str("</robot>\n");
    let d = tmpdir("kr6up");
    let p = d.join("kr6up.urdf");
    std::fs::write(&p, s).unwrap();
    let m = gpu_amcs::import::import_file(&p, &Default::default())
        .unwrap()
        .model;
    assert!(m.base.is_none());
    m
}

/// Every position of a map is in the world frame (the frame `fk` reports in), also for a robot
/// whose base transform turns its MDH chain upside down: the KR 6's default box and its xz
/// plane at y = 0 are the same as those of the same arm written without the turn, and it reaches
/// about as many cells (measured: 240 of 400 for both, 20 × 20 cells, tool down; with the box
/// in the MDH frame the turned KR 6 reached 19).
#[test]
fn base_turned_robot_maps_in_the_world_frame() {
    let turned = preset("kr6r700sixx").unwrap();
    assert!(turned.base.is_some());
    let plain = kr6_unturned();
    // Same arm in the world frame.
    for k in 0..50 {
        let q = [
            0.3 * k as f64,
            -1.0,
            0.5,
            0.2 * k as f64,
            0.7,
            0.1 * k as f64,
        ]
        .map(|v: f64| v.sin());
        let mut qp = q;
        qp[0] = -q[0];
        let (a, b) = (turned.world_position(&q), plain.world_position(&qp));
        let d = ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
        assert!(d < 1e-9, "{a:?} vs {b:?}");
    }
    let bx = WorkspaceBox::for_robot(&turned);
    assert_eq!(bx, WorkspaceBox::for_robot(&plain));
    assert!(bx.center[2] > 0.0, "the box is above the floor: {bx:?}");
    let reached = |m: &RobotModel| {
        let s = MapSpec {
            grid: Grid::Plane {
                plane: Plane::Xz,
                at: 0.0,
                cells: [20, 20],
            },
            workspace: WorkspaceBox::for_robot(m),
            orientation_rpy_deg: Some(tool_down_rpy_deg(m)),
            reference_q_deg: default_reference_deg(m),
            ik_seeds: 8,
        };
        let sol = s.solve(m).unwrap();
        for (t, c) in s.targets().iter().zip(&sol) {
            assert!(t.position[2] >= bx.center[2] - 0.5 * bx.size[2]);
            if let Some(c) = c {
                let cell = gpu_amcs::map::MapCell {
                    target: *t,
                    ik: Some(*c),
                    stats: None,
                };
                assert!(round_trip_error(m, &cell).unwrap() < 1e-9);
            }
        }
        sol.iter().flatten().count()
    };
    let (nt, np) = (reached(&turned), reached(&plain));
    eprintln!(
        "KR 6 xz plane at y = 0, 20 × 20: turned {nt}, unturned {np} of 400 cells; box {bx:?}"
    );
    assert!(nt >= 100 && np >= 100, "{nt} {np}");
    assert!(
        (nt as f64) >= 0.6 * np as f64 && (np as f64) >= 0.6 * nt as f64,
        "{nt} {np}"
    );
    // The command: the same plane.
    let o = run(&[
        "map",
        "--preset",
        "kr6r700sixx",
        "--plane",
        "xz",
        "--at",
        "0",
        "--cells",
        "20,20",
        "--draws",
        "100",
        "--backend",
        "cpu",
    ]);
    assert!(o.status.success(), "{}", common::stderr(&o));
    let out = stdout(&o);
    let line = out.lines().find(|l| l.starts_with("reached")).unwrap();
    let n: usize = line.split_whitespace().nth(1).unwrap().parse().unwrap();
    assert!(n >= 100, "{line}");
}

/// The heat map marks the base frame's origin where the model's `[base]` puts it: the TX60
/// moved to (500, 300, 200) mm and mapped on the plane y = 300 gives the same picture, marker
/// included, as the TX60 at the origin mapped on y = 0 (the default grid follows the base), and
/// the JSON records the origin.
#[test]
fn heat_map_marks_an_offset_base_where_it_stands() {
    let d = tmpdir("map-base");
    let plain = arg(&d, "tx.toml");
    let text = stdout(&run(&["model"]));
    std::fs::write(&plain, &text).unwrap();
    let shifted = arg(&d, "shifted.toml");
    std::fs::write(
        &shifted,
        format!("{text}\n[base]\nxyz = [500.0, 300.0, 200.0]\nrpy = [0.0, 0.0, 0.0]\n"),
    )
    .unwrap();
    let marker = |model: &str, at: &str, name: &str| {
        let (svg, json) = (arg(&d, name), arg(&d, &format!("{name}.json")));
        let o = run(&[
            "map",
            "--model",
            model,
            "--plane",
            "xz",
            "--at",
            at,
            "--cells",
            "8,8",
            "--backend",
            "cpu",
            "-q",
            "--svg",
            &svg,
            "--json",
            &json,
        ]);
        assert!(o.status.success(), "{}", common::stderr(&o));
        let page = std::fs::read_to_string(d.join(name).join("map_e95.svg")).unwrap();
        let m = page
            .split("<circle ")
            .nth(1)
            .and_then(|s| s.split(" r=\"8\"").next())
            .unwrap_or_else(|| panic!("no base marker in {page}"))
            .to_string();
        let j: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        (m, j["map"]["base_origin_mm"].clone())
    };
    let (a, ja) = marker(&plain, "0", "plain");
    let (b, jb) = marker(&shifted, "300", "shifted");
    assert_eq!(a, b);
    assert_eq!(ja, serde_json::json!([0.0, 0.0, 0.0]));
    assert_eq!(jb, serde_json::json!([500.0, 300.0, 200.0]));
    let _ = std::fs::remove_dir_all(&d);
}
