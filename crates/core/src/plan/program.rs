//! A plan's design as a robot program: one joint move per pose, in visiting order, each followed
//! by a wait for the tracker's measurement.
//!
//! The syntax is each vendor's: URScript `movej(q, a, v)` with q in radians and `sleep(t)`
//! (Universal Robots, *The URScript Programming Language*); RAPID `MoveAbsJ` to a `jointtarget`
//! `[[robax (degrees)], [extax, 9E9 for none]]` and `WaitTime` (ABB, *Technical reference manual
//! – RAPID Instructions, Functions and Data types*); KRL `PTP {A1 …, A6 …}` (degrees) and
//! `WAIT SEC` (KUKA, *KUKA System Software 8 – Operating and Programming Instructions*).
//!
//! The angles are the model's joint angles. For a Universal Robots arm they are the
//! controller's: UR's published DH table, which the preset is built from, has every θ offset 0,
//! the controller's zero. For other robots the offset between the model's zero and the
//! controller's is not known here (a description's zero may differ from the controller's, as
//! ROS-Industrial's KUKA descriptions do); the program's header says so, and the angles must be
//! checked before the program is run.

use super::{setting, workcell::is_universal_robots, Plan, PlanError, PlanField};
use std::fmt::Write;

/// The language of a robot program.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProgramFormat {
    /// URScript (Universal Robots), `.script`.
    UrScript,
    /// RAPID (ABB), `.mod`.
    Rapid,
    /// KRL (KUKA), `.src`.
    Krl,
}

impl ProgramFormat {
    /// The format a file extension names (`script`, `mod`, `src`; any case).
    pub fn from_extension(ext: &str) -> Option<ProgramFormat> {
        match ext.to_ascii_lowercase().as_str() {
            "script" | "urscript" => Some(ProgramFormat::UrScript),
            "mod" | "rapid" => Some(ProgramFormat::Rapid),
            "src" | "krl" => Some(ProgramFormat::Krl),
            _ => None,
        }
    }

    /// The language's name.
    pub fn name(self) -> &'static str {
        match self {
            ProgramFormat::UrScript => "URScript",
            ProgramFormat::Rapid => "RAPID",
            ProgramFormat::Krl => "KRL",
        }
    }
}

/// Joints every format here writes: six-axis arms.
const PROGRAM_JOINTS: usize = 6;

/// A program or module name from `name`: letters, digits and `_`, starting with a letter, at
/// most 24 characters (KRL's limit; a KRL `DEF` must match the file's name).
pub fn program_name(name: &str) -> String {
    let mut s: String = name
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .take(24)
        .collect();
    if !s.starts_with(|c: char| c.is_ascii_alphabetic()) {
        s.insert(0, 'p');
        s.truncate(24);
    }
    s
}

/// The plan's design as a program in `format`, named `name` ([`program_name`]), waiting
/// `settle_s` seconds at each pose for the tracker; for a plan with an approach side
/// ([`Plan::approach`]), each pose reached from its approach pose ([`Plan::approach_poses`]) so
/// that every joint arrives from that side.
///
/// # Errors
///
/// [`PlanError::Setting`] ([`PlanField::Program`]) for a model without six joints or a wait
/// that is not a finite number of seconds ≥ 0; [`PlanField::Approach`] for an approach pose
/// outside the limits or the workcell.
pub fn robot_program(
    plan: &Plan,
    format: ProgramFormat,
    name: &str,
    settle_s: f64,
) -> Result<String, PlanError> {
    let approach = plan.approach;
    let joints = plan.nominal.joints();
    if joints != PROGRAM_JOINTS {
        return Err(setting(
            PlanField::Program,
            format!(
                "{} programs are written for six-axis arms, {} has {joints} joints",
                format.name(),
                plan.model_name
            ),
        ));
    }
    if !(settle_s.is_finite() && settle_s >= 0.0) {
        return Err(setting(
            PlanField::Program,
            format!("the wait at each pose must be ≥ 0 s, got {settle_s}"),
        ));
    }
    let name = program_name(name);
    let angles = if is_universal_robots(&plan.nominal) {
        "joint angles: the model's, which are the controller's (UR's DH table has every theta offset 0)"
            .to_string()
    } else {
        "joint angles: the model's; the offset between the model's zero and the controller's is not known to gpu-amcs: check the first pose before running".to_string()
    };
    let header = [
        format!(
            "calibration poses planned by gpu-amcs for {}",
            plan.model_name
        ),
        format!(
            "{} poses in visiting order, joint travel {:.0} deg; measure the target at each wait",
            plan.design_deg.len(),
            plan.travel_deg
        ),
        angles,
        match approach {
            Some(a) => format!(
                "every joint arrives at each pose moving {} (from {}° short of it), as the pose file's s1..s6 record",
                a.name(),
                super::APPROACH_STEP_DEG
            ),
            None => "each joint arrives at a pose from the previous one".to_string(),
        },
    ];
    let pre = approach.map(|a| plan.approach_poses(a)).transpose()?;
    let before = |k: usize| pre.as_ref().map(|p| p[k]);
    let n = plan.design_deg.len();
    let mut s = String::new();
    match format {
        ProgramFormat::UrScript => {
            for h in &header {
                let _ = writeln!(s, "# {h}");
            }
            let _ = writeln!(s, "def {name}():");
            for (k, q) in plan.design_deg.iter().enumerate() {
                let movej = |s: &mut String, q: &crate::kinematics::Joints| {
                    let r: Vec<String> =
                        q.iter().map(|v| format!("{:.8}", v.to_radians())).collect();
                    let _ = writeln!(s, "  movej([{}], a=0.5, v=0.25)", r.join(", "));
                };
                if let Some(p) = before(k) {
                    movej(&mut s, &p);
                }
                movej(&mut s, q);
                let _ = writeln!(s, "  textmsg(\"measure pose {} of {n}\")", k + 1);
                let _ = writeln!(s, "  sleep({settle_s})");
            }
            let _ = writeln!(s, "end");
            let _ = writeln!(s, "{name}()");
        }
        ProgramFormat::Rapid => {
            for h in &header {
                let _ = writeln!(s, "! {h}");
            }
            let _ = writeln!(s, "MODULE {name}");
            let _ = writeln!(s, "  PROC main()");
            for (k, q) in plan.design_deg.iter().enumerate() {
                let move_abs = |s: &mut String, q: &crate::kinematics::Joints| {
                    let r: Vec<String> = q.iter().map(|v| format!("{v:.6}")).collect();
                    let _ = writeln!(
                        s,
                        "    MoveAbsJ [[{}],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, tool0;",
                        r.join(",")
                    );
                };
                if let Some(p) = before(k) {
                    move_abs(&mut s, &p);
                }
                move_abs(&mut s, q);
                let _ = writeln!(s, "    ! measure pose {} of {n}", k + 1);
                let _ = writeln!(s, "    WaitTime {settle_s};");
            }
            let _ = writeln!(s, "  ENDPROC");
            let _ = writeln!(s, "ENDMODULE");
        }
        ProgramFormat::Krl => {
            let _ = writeln!(s, "DEF {name}( )");
            for h in &header {
                let _ = writeln!(s, "; {h}");
            }
            for a in 1..=PROGRAM_JOINTS {
                let _ = writeln!(s, "$VEL_AXIS[{a}] = 10");
                let _ = writeln!(s, "$ACC_AXIS[{a}] = 10");
            }
            for (k, q) in plan.design_deg.iter().enumerate() {
                let ptp = |s: &mut String, q: &crate::kinematics::Joints| {
                    let r: Vec<String> = (q.iter().enumerate())
                        .map(|(j, v)| format!("A{} {v:.6}", j + 1))
                        .collect();
                    let _ = writeln!(s, "PTP {{{}}}", r.join(", "));
                };
                if let Some(p) = before(k) {
                    ptp(&mut s, &p);
                }
                ptp(&mut s, q);
                let _ = writeln!(s, "; measure pose {} of {n}", k + 1);
                let _ = writeln!(s, "WAIT SEC {settle_s}");
            }
            let _ = writeln!(s, "END");
        }
    }
    Ok(s)
}
