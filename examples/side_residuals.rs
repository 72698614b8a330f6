//! Where a model with backlash misses when the approach sides are drawn (docs/METHOD.md §19.5).
//!
//! ```text
//! cargo run --release --example side_residuals -- MODEL.toml HELD_OUT.csv [TRAINING.csv]
//! ```
//!
//! `MODEL.toml` is identified with `--beyond-geometry` from poses with recorded sides (`s1..sn`),
//! `HELD_OUT.csv` holds measured poses with their recorded sides (as `scripts/real-data/
//! coverage.sh` with `SIDES_FROM_ORDER=1` writes them). It prints, for the held-out poses,
//!
//! 1. the share inside the predicted 95 % bound with the sides drawn (the model without its term
//!    for unknown sides) and with the recorded sides (4000 draws each, the discrepancy term drawn
//!    as `validate` draws it), and which poses each misses; for a model with that term also the
//!    share at the centre of the gaps with it;
//! 2. for every missed pose the residual left after the recorded sides (`r`), the side
//!    displacement (`b`) and the part of each of J1–J3's side displacement along `r`;
//! 3. for each file, the residual after the recorded sides split into its component along J1's
//!    tangent (the direction a turn of J1 moves the target) and the rest, by quartile of the
//!    target's distance from J1's axis: an error that grows with that distance along the tangent
//!    is a J1 angle that varies from visit to visit, which no constant gap and no isotropic
//!    noise describes.

use gpu_amcs::discrepancy::DiscrepancyUse;
use gpu_amcs::engine::{CpuEvaluator, Evaluator, Frame, Problem, Reference};
use gpu_amcs::identify::chain::Placement;
use gpu_amcs::identify::validate::{parse_measurements, point_errors_in, Measurement};
use gpu_amcs::kinematics::{Joints, RobotModel};

const DRAWS: usize = 4000;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [model, held, rest @ ..] = args.as_slice() else {
        return Err("usage: side_residuals MODEL.toml HELD_OUT.csv [TRAINING.csv]".into());
    };
    let model = RobotModel::from_toml(&std::fs::read_to_string(model)?, model)?;
    let test = parse_measurements(std::fs::File::open(held)?, held)?;
    if test.iter().any(|m| m.sides.is_none()) || model.side_turns(&[1.0; 6]).is_none() {
        return Err("needs a model with backlash and held-out poses with s1..sn".into());
    }
    let n = test.len();
    let bare: Vec<Measurement> = (test.iter().cloned())
        .map(|mut m| {
            m.sides = None;
            m
        })
        .collect();
    // The sides drawn: the model without its term for unknown sides (with it, a pose without
    // sides is predicted at the centre of the gaps and that term drawn).
    let mut drawing = model.clone();
    let centre_term = (drawing.joint_errors.as_mut())
        .and_then(|e| e.backlash.as_mut())
        .and_then(|b| b.sides_unknown.take())
        .is_some();
    let (obs, obs_sided) = (
        point_errors_in(&drawing, &bare, Placement::Identify),
        point_errors_in(&model, &test, Placement::Identify),
    );
    let sides: Vec<Joints> = test.iter().map(|m| m.sides.unwrap()).collect();
    let q: Vec<Joints> = test.iter().map(|m| m.q_deg).collect();
    let bound_of =
        |model: &RobotModel, known: bool| -> Result<Vec<f64>, Box<dyn std::error::Error>> {
            let mut p = Problem::new(model.clone(), &q, &Reference::Calibrated, 7)?;
            if known {
                p.predict_known_sides(&sides)?;
            }
            let p = (p.in_frame(Frame::Measurement)).with_discrepancy_use(DiscrepancyUse::Measured);
            let (mut w, mut e) = (vec![0.0; DRAWS], vec![0.0; DRAWS * n]);
            CpuEvaluator::new(p).evaluate(0, &mut w, Some(&mut e))?;
            Ok((0..n)
                .map(|j| {
                    let mut c: Vec<f64> = (0..DRAWS).map(|k| e[k * n + j]).collect();
                    c.sort_by(f64::total_cmp);
                    c[(0.95 * DRAWS as f64).ceil() as usize - 1]
                })
                .collect())
        };
    let (drawn, known) = (bound_of(&drawing, false)?, bound_of(&model, true)?);
    let inside = |o: &[f64], b: &[f64]| o.iter().zip(b).filter(|(o, b)| o <= b).count();
    println!(
        "95 % bound covers {}/{n} held-out poses with the sides drawn, {}/{n} with the recorded sides",
        inside(&obs, &drawn),
        inside(&obs_sided, &known)
    );
    if centre_term {
        let obs_centre = point_errors_in(&model, &bare, Placement::Identify);
        let centre = bound_of(&model, false)?;
        println!(
            "  and {}/{n} at the centre of the gaps with the model's term for unknown sides",
            inside(&obs_centre, &centre)
        );
    }
    println!("poses missed (r: residual after the recorded sides; b: their displacement; along r: each joint's part of b along r):");
    for j in (0..n).filter(|&j| obs[j] > drawn[j] || obs_sided[j] > known[j]) {
        let m = &test[j];
        let qr = m.q_deg.map(f64::to_radians);
        let turns = model.side_turns(&sides[j]).unwrap();
        let at = |t: Option<&Joints>| model.predicted_position(&qr, t, true, true);
        let (sided, centre) = (at(Some(&turns)), at(None));
        let r: Vec<f64> = (0..3).map(|k| m.position_mm[k] - sided[k]).collect();
        let nr = r.iter().map(|v| v * v).sum::<f64>().sqrt();
        let nb = (0..3)
            .map(|k| (sided[k] - centre[k]).powi(2))
            .sum::<f64>()
            .sqrt();
        let along: Vec<String> = (0..3)
            .map(|i| {
                let ti = Joints::from_fn(6, |k| if k == i { turns[k] } else { 0.0 });
                let pi = at(Some(&ti));
                let d: f64 = (0..3).map(|k| r[k] * (pi[k] - centre[k])).sum();
                format!("J{} {:+.3}", i + 1, d / nr)
            })
            .collect();
        println!(
            "  line {:4}: drawn {} ({:.3} > {:.3})  recorded {} ({:.3} > {:.3})  |r| {nr:.3}  |b| {nb:.3}  along r: {}",
            m.line,
            if obs[j] > drawn[j] { "missed" } else { "inside" },
            obs[j],
            drawn[j],
            if obs_sided[j] > known[j] { "missed" } else { "inside" },
            obs_sided[j],
            known[j],
            along.join(", ")
        );
    }
    println!("residual after the recorded sides, by distance from J1's axis (rho):");
    print_tangential(&model, &test, "held out");
    if let Some(train) = rest.first() {
        let train = parse_measurements(std::fs::File::open(train)?, train)?;
        print_tangential(&model, &train, "training");
    }
    Ok(())
}

/// The residual after the recorded sides along J1's tangent and per other direction, by
/// quartile of the distance from J1's axis.
fn print_tangential(model: &RobotModel, ms: &[Measurement], label: &str) {
    let mut rows: Vec<(f64, f64, f64)> = ms
        .iter()
        .map(|m| {
            let qr = m.q_deg.map(f64::to_radians);
            let t = m.sides.and_then(|s| model.side_turns(&s));
            let mut t1 = t.unwrap_or_else(|| Joints::filled(qr.len(), 0.0));
            let p = model.predicted_position(&qr, Some(&t1), true, true);
            t1[0] += 1e-6;
            let p1 = model.predicted_position(&qr, Some(&t1), true, true);
            let tangent: Vec<f64> = (0..3).map(|k| (p1[k] - p[k]) / 1e-6).collect();
            let rho = tangent.iter().map(|v| v * v).sum::<f64>().sqrt();
            let r: Vec<f64> = (0..3).map(|k| m.position_mm[k] - p[k]).collect();
            let along: f64 = (0..3).map(|k| r[k] * tangent[k] / rho).sum();
            let rest = (r.iter().map(|v| v * v).sum::<f64>() - along * along).max(0.0);
            (rho, along * along, rest / 2.0)
        })
        .collect();
    rows.sort_by(|a, b| a.0.total_cmp(&b.0));
    let per = rows.len().div_ceil(4);
    for (i, c) in rows.chunks(per).enumerate() {
        let k = c.len() as f64;
        let rho = c.iter().map(|r| r.0).sum::<f64>() / k;
        let t = (c.iter().map(|r| r.1).sum::<f64>() / k).sqrt();
        let o = (c.iter().map(|r| r.2).sum::<f64>() / k).sqrt();
        println!(
            "  {label}, quartile {}: rho {rho:4.0} mm  rms along J1's tangent {t:.3} mm ({:.4} deg of J1)  rms per other direction {o:.3} mm",
            i + 1,
            (t / rho).to_degrees()
        );
    }
}
