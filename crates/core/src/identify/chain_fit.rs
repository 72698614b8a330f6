//! Whole-chain weighted least squares over every measured point: the measurement frame → robot
//! base placement, the MDH parameters and the target on the flange, from positions measured in
//! the tracker's own frame (docs/METHOD.md §2.4).
//!
//! The unknowns are the `5n + 9` *fit inputs* of an `n`-joint chain ([`ChainState::space`]: the
//! [`InputSpace::measured`]; 39 for six joints): the `5n` MDH parameters
//! joint-major, the target's x, y, z in the flange frame, then the placement's x, y, z (mm) and
//! roll, pitch, yaw (radians; `p_meas = Trans(xyz)·Rz(yaw)·Ry(pitch)·Rx(roll)·p_base`, the model's
//! `base` convention). Position data cannot separate all of them ([`default_free`] states what is
//! held at its nominal value and why); the identifiability analysis ([`super::identifiability`])
//! finds any further combination the data leave free.
//!
//! The fit minimises `Σ_k ‖W_k (B·P(θ, t, q_k) − p_k)‖² + Σ_i ((x_i − x̄_i)/σ_i)²` by
//! Levenberg–Marquardt, with `W_k` the whitening matrix of point k's measurement noise and the
//! optional second sum a prior towards the nominal geometry. A rigid alignment ([`initial_state`])
//! of the nominal chain to the data gives the start, so the placement may be anything.

use super::lm::levenberg_marquardt;
use crate::kinematics::{
    param_index, param_joint, position, position_with_trig, transform, twist_trig, Block,
    FixedParam, InputSpace, Joints, Layout, ParamKind, Params,
};
use nalgebra::{DMatrix, Matrix3, Matrix6, Rotation3, Vector3, Vector6};

/// The joint whose data move fit input `i` of `space` (1-based; the target counts as the last
/// joint's, J6's of a six-axis arm), `None` for the placement.
pub fn input_joint(space: InputSpace, i: usize) -> Option<usize> {
    match space.locate(i) {
        (Block::Joints, k) => Some(param_joint(k) + 1),
        (Block::Tool, _) => Some(space.joints()),
        (Block::Placement, _) => None,
    }
}

/// Values of all fit inputs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChainState {
    /// MDH parameters (`5n` of an `n`-joint chain), mm and radians.
    pub params: Params,
    /// Target in the flange frame, mm.
    pub tool: [f64; 3],
    /// Placement: x, y, z (mm), roll, pitch, yaw (radians).
    pub base: [f64; 6],
}

impl ChainState {
    /// The layout of the chain's inputs (its joint count is that of `params`).
    ///
    /// # Panics
    ///
    /// When `params` does not hold the parameters of 4 to 7 joints.
    pub fn layout(&self) -> Layout {
        Layout::new(self.params.len() / crate::kinematics::PARAMS_PER_JOINT)
    }

    /// The fit inputs: the parameters, the target, the placement ([`InputSpace::measured`]).
    pub fn space(&self) -> InputSpace {
        self.layout().measured()
    }

    /// Number of fit inputs (the length of [`Self::space`]).
    pub fn n_inputs(&self) -> usize {
        self.space().len()
    }

    /// Input `i`.
    pub fn get(&self, i: usize) -> f64 {
        match self.space().locate(i) {
            (Block::Joints, k) => self.params[k],
            (Block::Tool, k) => self.tool[k],
            (Block::Placement, k) => self.base[k],
        }
    }

    /// Sets input `i`.
    pub fn set(&mut self, i: usize, v: f64) {
        match self.space().locate(i) {
            (Block::Joints, k) => self.params[k] = v,
            (Block::Tool, k) => self.tool[k] = v,
            (Block::Placement, k) => self.base[k] = v,
        }
    }

    /// The placement's rotation `Rz(yaw)·Ry(pitch)·Rx(roll)`.
    pub fn rotation(&self) -> Matrix3<f64> {
        *Rotation3::from_euler_angles(self.base[3], self.base[4], self.base[5]).matrix()
    }

    /// The target's position in the measurement frame at joint angles `q` (radians).
    pub fn predict(&self, q: &[f64]) -> [f64; 3] {
        let r = self.rotation();
        let p = Vector3::from(position(&self.params, &self.tool, q));
        let v = r * p + Vector3::new(self.base[0], self.base[1], self.base[2]);
        [v.x, v.y, v.z]
    }

    /// [`Self::predict`] for many configurations: the placement's rotation and the twists'
    /// sines and cosines worked out once (the same arithmetic, so the same bits).
    pub fn predictor(&self) -> Predictor<'_> {
        Predictor {
            state: self,
            rotation: self.rotation(),
            trig: twist_trig(&self.params),
        }
    }
}

/// A [`ChainState`]'s predictions with what does not depend on the joint angles worked out once
/// ([`ChainState::predictor`]).
pub struct Predictor<'a> {
    state: &'a ChainState,
    rotation: Matrix3<f64>,
    trig: crate::kinematics::TwistTrig,
}

impl Predictor<'_> {
    /// [`ChainState::predict`] at joint angles `q` (radians).
    #[inline]
    pub fn predict(&self, q: &[f64]) -> [f64; 3] {
        let s = self.state;
        let p = Vector3::from(position_with_trig(&s.params, &self.trig, &s.tool, q));
        let v = self.rotation * p + Vector3::new(s.base[0], s.base[1], s.base[2]);
        [v.x, v.y, v.z]
    }
}

/// One measured point: commanded angles, measured position and its noise whitening.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Observation {
    /// Commanded joint angles, radians, one per joint.
    pub q: Joints,
    /// Measured position in the measurement frame, mm.
    pub p: [f64; 3],
    /// `W` with `Wᵀ W` the inverse of the point's noise covariance (mm⁻¹); the identity for
    /// unit weights.
    pub whiten: Matrix3<f64>,
    /// The payload during the measurement, kg (at the target; joint compliance bends under it).
    pub payload_kg: f64,
}

/// The inputs position data can identify by default: the placement (when `base_free`), then per
/// joint every parameter that is not its fixed `d`/`β`, except
///
/// * θ1 and d1 when the placement is free: a rotation about and a shift along J1's axis are the
///   placement's yaw and z (with the placement known, J1's axis is the base z axis and both stay
///   identifiable);
/// * all of the last joint's (J6's of a six-axis arm): the target is a point, so its three
///   coordinates already say everything the last joint's parameters could (its radius about that
///   axis, height along it and phase);
///
/// and the target's x, y, z. `fixed` has one entry per joint. A 6R chain with non-parallel J1/J2
/// then has 27 free inputs with the placement free (Everett's 4R + 2P + 6 minus the 3 of a
/// point's missing orientation) and 23 with it known; each further revolute joint adds four.
///
/// # Panics
///
/// When `fixed` does not have 4 to 7 entries.
pub fn default_free(fixed: &[FixedParam], base_free: bool) -> Vec<usize> {
    let lay = Layout::new(fixed.len());
    let mut free: Vec<usize> = Vec::new();
    for (j, f) in fixed.iter().enumerate().take(lay.joints() - 1) {
        for kind in ParamKind::ALL {
            if kind == f.kind() {
                continue;
            }
            if base_free && j == 0 && matches!(kind, ParamKind::Theta | ParamKind::D) {
                continue;
            }
            free.push(param_index(j, kind));
        }
    }
    let space = lay.measured();
    free.extend(space.range(Block::Tool).into_iter().flatten());
    if base_free {
        free.extend(space.range(Block::Placement).into_iter().flatten());
    }
    free
}

/// Finite-difference step of input `i` of a chain of layout `lay` for the Jacobian.
fn step(lay: Layout, i: usize) -> f64 {
    if lay.measured().is_angle(i) {
        1e-8
    } else {
        1e-5
    }
}

/// Whitened residuals `W_k (B·P(q_k) − p_k)`, x, y, z per point.
pub fn residuals(obs: &[Observation], s: &ChainState) -> Vec<f64> {
    let r = s.rotation();
    let t = Vector3::new(s.base[0], s.base[1], s.base[2]);
    let trig = twist_trig(&s.params);
    let mut out = Vec::with_capacity(3 * obs.len());
    for o in obs {
        let p = Vector3::from(position_with_trig(&s.params, &trig, &s.tool, &o.q));
        let e = o.whiten * (r * p + t - Vector3::from(o.p));
        out.extend_from_slice(&[e.x, e.y, e.z]);
    }
    out
}

/// Plain (unwhitened) position residuals `B·P(q_k) − p_k`, mm.
pub fn position_residuals(obs: &[Observation], s: &ChainState) -> Vec<[f64; 3]> {
    obs.iter()
        .map(|o| {
            let p = s.predict(&o.q);
            [p[0] - o.p[0], p[1] - o.p[1], p[2] - o.p[2]]
        })
        .collect()
}

/// Jacobian of the whitened residuals by central differences, one column per input of `free`.
pub fn jacobian(obs: &[Observation], s: &ChainState, free: &[usize]) -> DMatrix<f64> {
    let m = 3 * obs.len();
    let lay = s.layout();
    let cols: Vec<Vec<f64>> = {
        use rayon::prelude::*;
        free.par_iter()
            .map(|&i| {
                let h = step(lay, i);
                let mut a = *s;
                a.set(i, s.get(i) + h);
                let mut b = *s;
                b.set(i, s.get(i) - h);
                let (ra, rb) = (residuals(obs, &a), residuals(obs, &b));
                ra.iter()
                    .zip(&rb)
                    .map(|(x, y)| (x - y) / (2.0 * h))
                    .collect()
            })
            .collect()
    };
    DMatrix::from_fn(m, free.len(), |r, c| cols[c][r])
}

/// Whether the placement's three rotation inputs are all among `free`: the fit's
/// identifiability analysis then takes them as small rotations about the measurement frame's
/// axes at the estimate ([`local_jacobian`]).
pub fn rotation_free(space: InputSpace, free: &[usize]) -> bool {
    space
        .range(Block::Placement)
        .is_some_and(|r| (r.start + 3..r.end).all(|i| free.contains(&i)))
}

/// [`jacobian`] with the placement's roll, pitch and yaw columns replaced, when all three are
/// free ([`rotation_free`]), by the derivatives with respect to small rotations `ω` about the
/// measurement frame's x, y and z axes at the estimate, `W (e_k × R p)`: a parameterisation
/// that turns with the tracker frame, so that the condition number and the correlations of the
/// same data do not depend on how the tracker stood (roll-pitch-yaw degenerates at ±90° pitch,
/// where roll and yaw turn about one axis). `δω = M δ(roll, pitch, yaw)` ([`rpy_to_local`]).
pub fn local_jacobian(obs: &[Observation], s: &ChainState, free: &[usize]) -> DMatrix<f64> {
    let mut j = jacobian(obs, s, free);
    let space = s.space();
    if !rotation_free(space, free) {
        return j;
    }
    let r = s.rotation();
    for (c, &i) in free.iter().enumerate() {
        let (Block::Placement, k @ 3..=5) = space.locate(i) else {
            continue;
        };
        let axis = Vector3::ith(k - 3, 1.0);
        for (n, o) in obs.iter().enumerate() {
            let rp = r * Vector3::from(position(&s.params, &s.tool, &o.q));
            let d = o.whiten * axis.cross(&rp);
            for a in 0..3 {
                j[(3 * n + a, c)] = d[a];
            }
        }
    }
    j
}

/// `M` with `δω = M δ(roll, pitch, yaw)`: the small rotation about the measurement frame's axes
/// that increments of the placement's roll, pitch and yaw make at `s` (columns `Rz Ry e_x`,
/// `Rz e_y`, `e_z`; singular at ±90° pitch).
pub fn rpy_to_local(s: &ChainState) -> Matrix3<f64> {
    let rz = Rotation3::from_euler_angles(0.0, 0.0, s.base[5]);
    let ry = Rotation3::from_euler_angles(0.0, s.base[4], 0.0);
    Matrix3::from_columns(&[rz * (ry * Vector3::x()), rz * Vector3::y(), Vector3::z()])
}

/// A prior on some inputs: pseudo-observations `(x_i − centre_i)/σ_i` in the whitened units of
/// the data (σ = 0: no prior on that input).
#[derive(Clone, Debug, PartialEq)]
pub struct Prior {
    /// The values the prior pulls towards (the nominal geometry).
    pub centre: ChainState,
    /// σ per fit input ([`ChainState::n_inputs`] of them), internal units; 0 = none.
    pub sigma: Vec<f64>,
}

/// Minimises the whitened residuals (plus the prior's rows) over the inputs `free`, from `start`.
pub fn fit(
    obs: &[Observation],
    start: &ChainState,
    free: &[usize],
    prior: Option<&Prior>,
) -> ChainState {
    let lay = start.layout();
    let steps: Vec<f64> = free.iter().map(|&i| step(lay, i)).collect();
    let apply = |s: &ChainState, d: &[f64]| -> ChainState {
        let mut n = *s;
        for (k, &i) in free.iter().enumerate() {
            n.set(i, s.get(i) + d[k]);
        }
        n
    };
    let res = |s: &ChainState| -> Vec<f64> {
        let mut r = residuals(obs, s);
        if let Some(p) = prior {
            for &i in free {
                if p.sigma[i] > 0.0 {
                    r.push((s.get(i) - p.centre.get(i)) / p.sigma[i]);
                }
            }
        }
        r
    };
    levenberg_marquardt(*start, &steps, apply, res)
}

/// Kabsch: the rotation and translation that best map `from` onto `to` (least squares).
fn kabsch(from: &[Vector3<f64>], to: &[Vector3<f64>]) -> (Matrix3<f64>, Vector3<f64>) {
    let n = from.len().max(1) as f64;
    let ca = from.iter().sum::<Vector3<f64>>() / n;
    let cb = to.iter().sum::<Vector3<f64>>() / n;
    let mut h = Matrix3::zeros();
    for (a, b) in from.iter().zip(to) {
        h += (a - ca) * (b - cb).transpose();
    }
    let svd = h.svd(true, true);
    let (Some(u), Some(vt)) = (svd.u, svd.v_t) else {
        return (Matrix3::identity(), cb - ca);
    };
    let mut d = Matrix3::identity();
    if (vt.transpose() * u.transpose()).determinant() < 0.0 {
        d[(2, 2)] = -1.0;
    }
    let r = vt.transpose() * d * u.transpose();
    (r, cb - r * ca)
}

/// A start for the fit when the placement is unknown: alternately a rigid alignment (Kabsch) of
/// the chain's predicted points onto the measured ones and a linear least-squares solve for the
/// target and the placement's translation given its rotation (the positions are linear in both),
/// ten rounds from the nominal parameters (`5n`, one joint angle per joint in every observation)
/// and `tool`.
pub fn initial_state(obs: &[Observation], params: &[f64], tool: &[f64; 3]) -> ChainState {
    let frames: Vec<([[f64; 4]; 4], Vector3<f64>)> = obs
        .iter()
        .map(|o| (transform(params, &o.q), Vector3::from(o.p)))
        .collect();
    let mut tool = Vector3::from(*tool);
    let mut rot = Matrix3::identity();
    let mut trans = Vector3::zeros();
    for _ in 0..10 {
        let chain: Vec<Vector3<f64>> = frames
            .iter()
            .map(|(t, _)| flange_rotation(t) * tool + flange_origin(t))
            .collect();
        let measured: Vec<Vector3<f64>> = frames.iter().map(|(_, p)| *p).collect();
        (rot, trans) = kabsch(&chain, &measured);
        // rot·(R_f t + o_f) + b = p  ⇒  [rot·R_f  I] [t; b] = p − rot·o_f
        let mut ata = Matrix6::<f64>::zeros();
        let mut atb = Vector6::<f64>::zeros();
        for (t, p) in &frames {
            let a_tool = rot * flange_rotation(t);
            let rhs = p - rot * flange_origin(t);
            for row in 0..3 {
                let mut a = Vector6::zeros();
                for c in 0..3 {
                    a[c] = a_tool[(row, c)];
                }
                a[3 + row] = 1.0;
                ata += a * a.transpose();
                atb += a * rhs[row];
            }
        }
        match ata.cholesky() {
            Some(ch) => {
                let x = ch.solve(&atb);
                tool = Vector3::new(x[0], x[1], x[2]);
                trans = Vector3::new(x[3], x[4], x[5]);
            }
            None => break,
        }
    }
    let (roll, pitch, yaw) = Rotation3::from_matrix_unchecked(rot).euler_angles();
    ChainState {
        params: Params::from_slice(params),
        tool: [tool.x, tool.y, tool.z],
        base: [trans.x, trans.y, trans.z, roll, pitch, yaw],
    }
}

/// The target (flange frame) that best fits base-frame data with the placement known and the
/// parameters `params`: positions are linear in it (`R_f(q)·t + o_f(q) = p`). `None` when the
/// data do not determine it (all points at one flange orientation).
pub fn initial_tool(obs: &[Observation], params: &[f64]) -> Option<[f64; 3]> {
    let mut ata = Matrix3::<f64>::zeros();
    let mut atb = Vector3::<f64>::zeros();
    for o in obs {
        let t = transform(params, &o.q);
        let r = flange_rotation(&t);
        ata += r.transpose() * r;
        atb += r.transpose() * (Vector3::from(o.p) - flange_origin(&t));
    }
    let x = ata.cholesky()?.solve(&atb);
    x.iter().all(|v| v.is_finite()).then(|| [x.x, x.y, x.z])
}

fn flange_rotation(t: &[[f64; 4]; 4]) -> Matrix3<f64> {
    Matrix3::from_fn(|r, c| t[r][c])
}

fn flange_origin(t: &[[f64; 4]; 4]) -> Vector3<f64> {
    Vector3::new(t[0][3], t[1][3], t[2][3])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::tx60;
    use rand::{Rng, SeedableRng};

    fn observations(truth: &ChainState, n: usize, seed: u64) -> Vec<Observation> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        (0..n)
            .map(|_| {
                let q = Joints::from_fn(6, |_| rng.random_range(-2.0..2.0));
                Observation {
                    q,
                    p: truth.predict(&q),
                    whiten: Matrix3::identity(),
                    payload_kg: 0.0,
                }
            })
            .collect()
    }

    #[test]
    fn input_joints() {
        for n in 4..=7 {
            let space = Layout::new(n).measured();
            let tool = space.index(Block::Tool, 0).unwrap();
            assert_eq!(input_joint(space, tool), Some(n));
            assert_eq!(input_joint(space, 5 * n - 1), Some(n));
            assert_eq!(input_joint(space, tool + 3), None);
        }
    }

    #[test]
    fn free_counts_follow_everett() {
        let m = tx60();
        assert_eq!(default_free(&m.fixed, true).len(), 27);
        assert_eq!(default_free(&m.fixed, false).len(), 23);
    }

    /// Noise-free data in a placement 2.5 m away, turned 140° and tilted: the alignment start and
    /// the fit recover every identifiable input.
    #[test]
    fn recovers_a_far_placement() {
        let nominal = tx60();
        let mut truth = ChainState {
            params: nominal.params,
            tool: [30.0, -20.0, 80.0],
            base: [2500.0, -400.0, 300.0, 0.05, -0.08, 140f64.to_radians()],
        };
        let free = default_free(&nominal.fixed, true);
        for (k, &i) in free.iter().enumerate() {
            if i < Layout::SIX.n_params() {
                let size = if Layout::SIX.measured().is_angle(i) {
                    5e-4
                } else {
                    0.3
                };
                truth.set(i, truth.get(i) + size * if k % 2 == 0 { 1.0 } else { -0.7 });
            }
        }
        let obs = observations(&truth, 40, 3);
        let start = initial_state(&obs, &nominal.params, &[0.0; 3]);
        let got = fit(&obs, &start, &free, None);
        for &i in &free {
            assert!(
                (got.get(i) - truth.get(i)).abs() < 1e-6,
                "{}: {} vs {}",
                Layout::SIX.measured().name(i),
                got.get(i),
                truth.get(i)
            );
        }
    }
}
