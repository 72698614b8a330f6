//! Test points: joint configurations at which the positioning error is evaluated.
//!
//! Generated sets are seeded: configurations uniform within the joint limits, kept when the tool
//! point lies in the workspace box (docs/METHOD.md §5). The default box is the robot's own
//! ([`WorkspaceBox::for_robot`]): the paper's 900 × 1200 × 800 mm box centred at (250, 0, 200) mm
//! for the TX60, scaled with the arm's reach for any other robot. The box, like every position
//! given or reported, is in the description's (world) frame, after a model's base transform.
//! Sets can also be read from and written to CSV (`q1..qn` in degrees for an `n`-joint model, one
//! configuration per row).

use crate::kinematics::{param_index, position_deg, Joints, ParamKind, RobotModel};
use rand::{Rng, SeedableRng};

/// An axis-aligned box in the description's (world) frame, mm: the frame `fk` reports in, after
/// the model's base transform ([`RobotModel::world_position`]).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct WorkspaceBox {
    /// Centre (x, y, z).
    pub center: [f64; 3],
    /// Edge lengths (x, y, z).
    pub size: [f64; 3],
}

impl Default for WorkspaceBox {
    fn default() -> Self {
        WorkspaceBox {
            center: [250.0, 0.0, 200.0],
            size: [900.0, 1200.0, 800.0],
        }
    }
}

/// Reach of the Stäubli TX60 by [`reach_mm`], mm: the links after joint 1 are 290 (a2),
/// 20 (d3), 310 (d4) and 70 (d6) mm long.
pub const TX60_REACH_MM: f64 = 690.0;
/// The paper's box for the TX60 (centre, then size, mm), scaled by [`WorkspaceBox::for_robot`].
const PAPER_BOX: ([f64; 3], [f64; 3]) = ([250.0, 0.0, 200.0], [900.0, 1200.0, 800.0]);
/// Height of the TX60's shoulder (d1), mm: the paper's box centre lies 175 mm below it.
const TX60_SHOULDER_MM: f64 = 375.0;
/// The default box is rounded to this grid, mm, so a calibrated model (parameters moved by
/// micrometres) gets the same box as its nominal robot.
const BOX_GRID_MM: f64 = 50.0;

/// The arm's reach beyond joint 1, mm: `Σ_{i=2..n} √(a_i² + d_i²)`, the sum of the link
/// translations after the first joint, which bounds the distance of the flange from the
/// shoulder (frame 1's origin) by the triangle inequality. The tracker target is left out: it
/// is small and differs between calibrations of one robot.
pub fn reach_mm(model: &RobotModel) -> f64 {
    (1..model.joints())
        .map(|j| {
            let a = model.params[param_index(j, ParamKind::A)];
            let d = model.params[param_index(j, ParamKind::D)];
            a.hypot(d)
        })
        .sum()
}

impl WorkspaceBox {
    /// The default box of `model`: the paper's TX60 box (900 × 1200 × 800 mm centred at
    /// (250, 0, 200) mm) scaled by the ratio of [`reach_mm`] to the TX60's 690 mm, its centre
    /// placed in x by the same ratio and in z at the same scaled depth below the shoulder
    /// (`d1`), rounded to 50 mm. For the TX60 it is the paper's box; for a larger arm it grows
    /// with the reach, so the generated points spread over the same share of the reachable
    /// shell. The box is in the world frame: for a model with a base transform the centre's
    /// offset is turned with the base and the depth is counted down the world's z.
    pub fn for_robot(model: &RobotModel) -> WorkspaceBox {
        let s = reach_mm(model) / TX60_REACH_MM;
        let round = |v: f64| (v / BOX_GRID_MM).round() * BOX_GRID_MM + 0.0;
        let shoulder = model.params[param_index(0, ParamKind::D)];
        let (c, size) = PAPER_BOX;
        let depth = (TX60_SHOULDER_MM - c[2]) * s;
        let size = size.map(|v| v * s);
        // In the world frame: the centre's horizontal offset is the arm's (base frame, at the
        // shoulder's height), then it goes `depth` down the world's z, so that a base turned
        // upside down (the KR 6's half turn about x) still gets its box below the shoulder; the
        // size is the world-aligned box around the turned one (the same for turns by multiples
        // of 90°).
        let (center, size) = match &model.base {
            None => ([c[0] * s, c[1] * s, shoulder - depth], size),
            Some(b) => {
                let mut center = b.apply([c[0] * s, c[1] * s, shoulder]);
                center[2] -= depth;
                let r = b.isometry().rotation.to_rotation_matrix();
                let size: [f64; 3] =
                    std::array::from_fn(|i| (0..3).map(|j| r[(i, j)].abs() * size[j]).sum::<f64>());
                (center, size)
            }
        };
        WorkspaceBox {
            center: center.map(round),
            size: size.map(round),
        }
    }

    /// Whether `p` lies inside.
    pub fn contains(&self, p: &[f64; 3]) -> bool {
        (0..3).all(|k| (p[k] - self.center[k]).abs() <= 0.5 * self.size[k])
    }
}

/// Most test points a set may have (generated or read): far more than an analysis needs (the
/// paper uses tens to hundreds), and a bound on the memory a mistyped count can claim.
pub const MAX_POINTS: usize = 1_000_000;

/// Errors about test points.
#[derive(Debug, thiserror::Error)]
pub enum PointsError {
    /// Zero points asked for.
    #[error("the number of test points must be at least 1")]
    Zero,
    /// More test points than [`MAX_POINTS`] asked for.
    #[error("the number of test points must be at most {MAX_POINTS}, got {0}")]
    TooMany(usize),
    /// The box is empty or not finite.
    #[error("workspace box: {0}")]
    BadBox(String),
    /// The box is (almost) out of reach.
    #[error("found only {found} of {wanted} configurations with the tool point in the workspace box after {tries} tries: is the box within reach?")]
    Unreachable {
        /// Found so far.
        found: usize,
        /// Asked for.
        wanted: usize,
        /// Tries made.
        tries: u64,
    },
    /// A CSV file could not be read: missing, too large or not UTF-8.
    #[error(transparent)]
    Read(#[from] crate::input::ReadError),
    /// A CSV file's contents are wrong (the message names the line).
    #[error("{path}: {message}")]
    Csv {
        /// File.
        path: String,
        /// What went wrong, with the line.
        message: String,
    },
}

/// `n` seeded configurations (degrees) uniform within the model's joint limits whose tool point
/// (world frame, after the model's base transform) lies in `bx`.
///
/// # Errors
///
/// [`PointsError::Zero`] for `n = 0`, [`PointsError::TooMany`] above [`MAX_POINTS`],
/// [`PointsError::BadBox`] for a box that is not finite or has a non-positive size, and
/// [`PointsError::Unreachable`] when too few configurations put the tool point in the box.
///
/// # Examples
///
/// Five configurations of the TX60 in its own box: seeded, within the joint limits, with the
/// tool point in the box:
///
/// ```
/// use gpu_amcs_core::kinematics::{position_deg, tx60};
/// use gpu_amcs_core::points::{generate, PointsError, WorkspaceBox};
///
/// let model = tx60();
/// let bx = WorkspaceBox::for_robot(&model);
/// let points = generate(&model, 5, &bx, 1)?;
/// assert_eq!(points.len(), 5);
/// for q in &points {
///     assert_eq!(q.len(), model.joints());
///     assert!(model.check_limits(q).is_ok());
///     assert!(bx.contains(&position_deg(&model.params, &model.tool, q)));
/// }
/// // Same seed, same points; another seed, other points.
/// assert_eq!(generate(&model, 5, &bx, 1)?, points);
/// assert_ne!(generate(&model, 5, &bx, 2)?, points);
/// // No points asked for is an error.
/// assert!(matches!(generate(&model, 0, &bx, 1), Err(PointsError::Zero)));
/// # Ok::<(), PointsError>(())
/// ```
pub fn generate(
    model: &RobotModel,
    n: usize,
    bx: &WorkspaceBox,
    seed: u64,
) -> Result<Vec<Joints>, PointsError> {
    if n == 0 {
        return Err(PointsError::Zero);
    }
    if n > MAX_POINTS {
        return Err(PointsError::TooMany(n));
    }
    if !(bx.size.iter().all(|s| s.is_finite() && *s > 0.0)
        && bx.center.iter().all(|c| c.is_finite()))
    {
        return Err(PointsError::BadBox(format!(
            "size {:?} must be positive and centre {:?} finite",
            bx.size, bx.center
        )));
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    // The box is in the world frame: the tool point goes through the base transform.
    let base = model.base.as_ref().map(|b| b.isometry());
    let max_tries = 2_000_000u64.max(20_000 * n as u64);
    let mut out = Vec::with_capacity(n);
    let mut tries = 0;
    while out.len() < n {
        if tries == max_tries {
            return Err(PointsError::Unreachable {
                found: out.len(),
                wanted: n,
                tries,
            });
        }
        tries += 1;
        let q = Joints::from_fn(model.joints(), |j| {
            let (lo, hi) = model.limits_deg[j];
            rng.random_range(lo..=hi)
        });
        let p = position_deg(&model.params, &model.tool, &q);
        let p = match &base {
            None => p,
            Some(t) => {
                let v = t * nalgebra::Point3::from(p);
                [v.x, v.y, v.z]
            }
        };
        if bx.contains(&p) {
            out.push(q);
        }
    }
    Ok(out)
}

/// Reads configurations of a `joints`-joint model from a CSV with header `q1..qn` (degrees), at
/// most [`crate::input::CSV_FILE_LIMIT`] bytes.
///
/// # Errors
///
/// [`PointsError::Read`] when the file cannot be read, is too large or is not UTF-8, and
/// [`PointsError::Csv`] (naming the line as an editor counts it, also for CRLF files) for a missing
/// header, a column for a joint the model does not have (`q7` for six joints), a malformed row,
/// a value that is not a finite number, or no rows.
pub fn read_csv(path: &std::path::Path, joints: usize) -> Result<Vec<Joints>, PointsError> {
    let p = path.display().to_string();
    let err = |message: String| PointsError::Csv {
        path: p.clone(),
        message,
    };
    let text = crate::input::read_csv_text(path)?;
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    let headers = rdr.headers().map_err(|e| err(e.to_string()))?.clone();
    let expected = (1..=joints)
        .map(|j| format!("q{j}"))
        .collect::<Vec<_>>()
        .join(",");
    let cols: Vec<usize> = (1..=joints)
        .map(|j| {
            let name = format!("q{j}");
            headers
                .iter()
                .position(|h| h.eq_ignore_ascii_case(&name))
                .ok_or_else(|| {
                    err(format!(
                        "header has no column '{name}' (expected {expected} for a {joints}-joint model)"
                    ))
                })
        })
        .collect::<Result<_, _>>()?;
    let extra = format!("q{}", joints + 1);
    if headers.iter().any(|h| h.eq_ignore_ascii_case(&extra)) {
        return Err(err(format!(
            "header has a column '{extra}', but the model has {joints} joints (expected {expected})"
        )));
    }
    let mut out = Vec::new();
    for rec in rdr.records() {
        let rec = rec.map_err(|e| {
            err(format!(
                "line {}: {e}",
                e.position().map_or(0, |p| p.line())
            ))
        })?;
        let line = rec.position().map_or(0, |p| p.line());
        if out.len() == MAX_POINTS {
            return Err(err(format!(
                "line {line}: more than {MAX_POINTS} configurations (the most a set may have)"
            )));
        }
        let mut q = Joints::filled(joints, 0.0);
        for (j, &c) in cols.iter().enumerate() {
            let s = rec.get(c).unwrap_or("");
            q[j] = s
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    err(format!(
                        "line {line}: q{} = '{s}' is not a finite number",
                        j + 1
                    ))
                })?;
        }
        out.push(q);
    }
    if out.is_empty() {
        return Err(err("no configurations (rows) in the file".into()));
    }
    Ok(out)
}

/// The backlash sides a configurations file gives (docs/METHOD.md §19.5): optional columns
/// `s1..sn`, per row the side each joint arrives from at that configuration, `1` (moving
/// positive), `-1` or `0` (not known: the analyses draw it); a column left out is unknown at
/// every row. `None` when the file has no such column. (The rows are those of [`read_csv`].)
///
/// # Errors
///
/// As [`read_csv`] for the file; [`PointsError::Csv`] naming the column and line for a value
/// that is not −1, 0 or 1, and for a column `s{n+1}` the model has no joint for.
pub fn read_sides(
    path: &std::path::Path,
    joints: usize,
) -> Result<Option<Vec<Joints>>, PointsError> {
    let p = path.display().to_string();
    let err = |message: String| PointsError::Csv {
        path: p.clone(),
        message,
    };
    let text = crate::input::read_csv_text(path)?;
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    let headers = rdr.headers().map_err(|e| err(e.to_string()))?.clone();
    let Some(cols) = side_columns(&headers, joints).map_err(err)? else {
        return Ok(None);
    };
    let mut out = Vec::new();
    for rec in rdr.records() {
        let rec = rec.map_err(|e| err(e.to_string()))?;
        let line = rec.position().map_or(0, |p| p.line());
        out.push(row_sides(&rec, &cols).map_err(|m| err(format!("line {line}: {m}")))?);
    }
    Ok(Some(out))
}

/// Where the side columns `s1..s{joints}` of a CSV header are (any case; `None` per column left
/// out), or `None` when it has none (docs/METHOD.md §19.5: the side each joint arrives from).
/// Shared by the points, pose and measurement files.
///
/// # Errors
///
/// A message naming a column `s{joints+1}`, which the model has no joint for.
pub fn side_columns(
    headers: &csv::StringRecord,
    joints: usize,
) -> Result<Option<Vec<Option<usize>>>, String> {
    let cols: Vec<Option<usize>> = (1..=joints)
        .map(|j| {
            let name = format!("s{j}");
            headers
                .iter()
                .position(|h| h.trim().eq_ignore_ascii_case(&name))
        })
        .collect();
    let extra = format!("s{}", joints + 1);
    if headers
        .iter()
        .any(|h| h.trim().eq_ignore_ascii_case(&extra))
    {
        return Err(format!(
            "header has a column '{extra}', but the model has {joints} joints (sides s1..s{joints})"
        ));
    }
    Ok(cols.iter().any(Option::is_some).then_some(cols))
}

/// The sides of one CSV row in the columns `cols` of [`side_columns`]: per joint `1` (it
/// arrives moving positive), `-1`, or `0` (not known; also for a column left out).
///
/// # Errors
///
/// A message naming the column and value that is not −1, 0 or 1 (without the line, which the
/// caller adds).
pub fn row_sides(rec: &csv::StringRecord, cols: &[Option<usize>]) -> Result<Joints, String> {
    let mut s = Joints::filled(cols.len(), 0.0);
    for (j, c) in cols.iter().enumerate() {
        let Some(c) = *c else { continue };
        let v = rec.get(c).unwrap_or("").trim();
        s[j] = match v.parse::<f64>() {
            Ok(x) if x == 1.0 || x == -1.0 || x == 0.0 => x,
            _ => {
                return Err(format!(
                    "s{} = '{v}' is not a side (1: the joint arrives moving positive, -1: negative, 0: not known)",
                    j + 1
                ))
            }
        };
    }
    Ok(s)
}

/// Writes configurations as CSV with header `q1..qn` (`n` = the configurations' length, 6 when
/// there are none).
pub fn to_csv<P: AsRef<[f64]>>(points: &[P]) -> String {
    to_csv_within(points, &[])
}

/// [`to_csv`] for configurations within joint limits `limits_deg` (degrees, one pair per
/// joint): a value whose six decimals would round past its limit (an inverse-kinematics
/// solution on the limit, −176.00117550828628° written −176.001176°) is written rounded towards
/// the inside instead, so that every configuration reads back within the limits.
pub fn to_csv_within<P: AsRef<[f64]>>(points: &[P], limits_deg: &[(f64, f64)]) -> String {
    let n = points.first().map_or(6, |q| q.as_ref().len());
    let mut s = (1..=n)
        .map(|j| format!("q{j}"))
        .collect::<Vec<_>>()
        .join(",");
    s.push('\n');
    for q in points {
        let row: Vec<String> = q
            .as_ref()
            .iter()
            .enumerate()
            .map(|(j, &v)| match limits_deg.get(j) {
                Some(&(lo, hi)) => six_decimals_within(v, lo, hi),
                None => format!("{v:.6}"),
            })
            .collect();
        s.push_str(&row.join(","));
        s.push('\n');
    }
    s
}

/// `v` with six decimals, rounded towards the inside of `lo … hi` when `v` lies within them
/// and the nearest six decimals do not (full precision if even that would not read back
/// inside).
fn six_decimals_within(v: f64, lo: f64, hi: f64) -> String {
    let text = format!("{v:.6}");
    let back: f64 = text.parse().unwrap_or(v);
    let inward = if back < lo && v >= lo {
        (v * 1e6).ceil() / 1e6
    } else if back > hi && v <= hi {
        (v * 1e6).floor() / 1e6
    } else {
        return text;
    };
    let text = format!("{inward:.6}");
    match text.parse::<f64>() {
        Ok(x) if (lo..=hi).contains(&x) => text,
        _ => format!("{v}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::tx60;

    #[test]
    fn configurations_on_a_limit_are_written_within_it() {
        let lo = -176.00117550828628;
        let hi = 89.99999999;
        let csv = to_csv_within(
            &[[lo, hi, 12.3456789]],
            &[(lo, 0.0), (0.0, hi), (-90.0, 90.0)],
        );
        let row: Vec<f64> = csv
            .lines()
            .nth(1)
            .unwrap()
            .split(',')
            .map(|x| x.parse().unwrap())
            .collect();
        assert_eq!(
            csv.lines().nth(1).unwrap(),
            "-176.001175,89.999999,12.345679"
        );
        assert!(row[0] >= lo && row[1] <= hi);
        // Plain to_csv rounds past the limit.
        assert!(to_csv(&[[lo]]).contains("-176.001176"));
    }

    #[test]
    fn generated_points_are_in_box_and_limits_and_seeded() {
        let m = tx60();
        let bx = WorkspaceBox::default();
        let a = generate(&m, 50, &bx, 1).unwrap();
        assert_eq!(a, generate(&m, 50, &bx, 1).unwrap());
        assert_ne!(a, generate(&m, 50, &bx, 2).unwrap());
        for q in &a {
            assert!(m.check_limits(q).is_ok());
            assert!(bx.contains(&position_deg(&m.params, &m.tool, q)));
        }
    }

    /// The TX60's own box is the paper's; a calibrated TX60 gets the same; every preset's box
    /// holds generated points (a box mostly out of reach would fail), and the box grows with
    /// the reach.
    #[test]
    fn default_box_follows_the_robot() {
        let m = tx60();
        assert_eq!(reach_mm(&m), TX60_REACH_MM);
        assert_eq!(WorkspaceBox::for_robot(&m), WorkspaceBox::default());
        let mut cal = m.clone();
        cal.params[7] += 0.3;
        cal.params[16] -= 0.2;
        assert_eq!(WorkspaceBox::for_robot(&cal), WorkspaceBox::default());
        for name in crate::presets::PRESETS {
            let r = crate::presets::preset(name).unwrap();
            let bx = WorkspaceBox::for_robot(&r);
            eprintln!("{name}: reach {:.1} mm, box {bx:?}", reach_mm(&r));
            let pts = generate(&r, 200, &bx, 3).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert_eq!(pts.len(), 200);
            let ratio = bx.size[0] / reach_mm(&r);
            assert!((ratio - 900.0 / 690.0).abs() < 0.1, "{name}: {bx:?}");
        }
    }

    #[test]
    fn absurd_counts_are_errors_not_allocations() {
        for n in [MAX_POINTS + 1, usize::MAX] {
            assert!(matches!(
                generate(&tx60(), n, &WorkspaceBox::default(), 1),
                Err(PointsError::TooMany(k)) if k == n
            ));
        }
    }

    #[test]
    fn unreachable_box_is_an_error() {
        let bx = WorkspaceBox {
            center: [5000.0, 0.0, 0.0],
            size: [10.0, 10.0, 10.0],
        };
        assert!(matches!(
            generate(&tx60(), 3, &bx, 1),
            Err(PointsError::Unreachable { .. })
        ));
    }
}
