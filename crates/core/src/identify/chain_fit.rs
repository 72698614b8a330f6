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
//! Several targets measured at each pose (reflectors on one tool) share the chain and the
//! placement; each has its own offset in the flange frame. The first is the model's tool
//! ([`Block::Tool`]); the others ([`OtherTargets`]) are fit inputs after the space's, at
//! positions `space.len() + 3(t − 1) + k` for target `t` (`t` = 1, 2, … counting the first as 0)
//! and coordinate `k`: nuisance inputs of the fit that the model file does not keep.
//!
//! The fit minimises `Σ_k ‖W_k (B·P(θ, t, q_k) − p_k)‖² + Σ_i ((x_i − x̄_i)/σ_i)²` by
//! Levenberg–Marquardt, with `W_k` the whitening matrix of point k's measurement noise and the
//! optional second sum a prior towards the nominal geometry. A rigid alignment ([`initial_state`])
//! of the nominal chain to the data gives the start, so the placement may be anything.

mod targets;

pub use targets::{OtherTargets, MAX_TARGETS};

use super::lm::levenberg_marquardt;
use crate::kinematics::{
    param_index, param_joint, position, position_with_trig, transform, twist_trig, Block,
    FixedParam, InputSpace, Joints, Layout, ParamKind, Params,
};
use nalgebra::{DMatrix, Matrix3, Matrix6, Rotation3, Vector3, Vector6};

/// The joint whose data move fit input `i` of `space` (1-based; the target counts as the last
/// joint's, J6's of a six-axis arm), `None` for the placement.
pub fn input_joint(space: InputSpace, i: usize) -> Option<usize> {
    if i >= space.len() {
        // another target's offset: seen through the last joint, as the tool
        return Some(space.joints());
    }
    match space.locate(i) {
        (Block::Joints, k) => Some(param_joint(k) + 1),
        (Block::Tool, _) => Some(space.joints()),
        (Block::Placement, _) => None,
    }
}

/// The name of fit input `i` of a chain whose space is `space`: the space's
/// ([`InputSpace::name`]), `target2_x`, `target2_y`, … for the other targets' inputs past it
/// (numbered from 2, the model's tool being target 1).
pub fn fit_input_name(space: InputSpace, i: usize) -> String {
    let n = space.len();
    if i < n {
        return space.name(i);
    }
    format!("target{}_{}", (i - n) / 3 + 2, ["x", "y", "z"][(i - n) % 3])
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
    /// The other targets measured at each pose, if any.
    pub others: OtherTargets,
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

    /// Number of fit inputs: the length of [`Self::space`] and three per other target.
    pub fn n_inputs(&self) -> usize {
        self.space().len() + 3 * self.others.len()
    }

    /// Number of targets measured at each pose (1 without others).
    pub fn targets(&self) -> usize {
        1 + self.others.len()
    }

    /// Target `t`'s offset in the flange frame, mm (0: the model's tool).
    ///
    /// # Panics
    ///
    /// When `t >= self.targets()`.
    pub fn target(&self, t: usize) -> [f64; 3] {
        if t == 0 {
            self.tool
        } else {
            self.others.offsets()[t - 1]
        }
    }

    /// The other target and coordinate of fit input `i`, `None` for an input of the space.
    fn other(&self, i: usize) -> Option<(usize, usize)> {
        let n = self.space().len();
        (i >= n).then(|| ((i - n) / 3, (i - n) % 3))
    }

    /// Input `i`.
    pub fn get(&self, i: usize) -> f64 {
        if let Some((t, k)) = self.other(i) {
            return self.others.offsets()[t][k];
        }
        match self.space().locate(i) {
            (Block::Joints, k) => self.params[k],
            (Block::Tool, k) => self.tool[k],
            (Block::Placement, k) => self.base[k],
        }
    }

    /// Sets input `i`.
    pub fn set(&mut self, i: usize, v: f64) {
        if let Some((t, k)) = self.other(i) {
            assert!(
                t < self.others.len(),
                "fit input {i} is past the last target"
            );
            self.others.offsets[t][k] = v;
            return;
        }
        match self.space().locate(i) {
            (Block::Joints, k) => self.params[k] = v,
            (Block::Tool, k) => self.tool[k] = v,
            (Block::Placement, k) => self.base[k] = v,
        }
    }

    /// The name of fit input `i` ([`fit_input_name`]).
    pub fn input_name(&self, i: usize) -> String {
        fit_input_name(self.space(), i)
    }

    /// Whether fit input `i` is an angle.
    pub fn is_angle(&self, i: usize) -> bool {
        self.other(i).is_none() && self.space().is_angle(i)
    }

    /// The fit inputs of the other targets' offsets.
    pub fn other_inputs(&self) -> std::ops::Range<usize> {
        let n = self.space().len();
        n..n + 3 * self.others.len()
    }

    /// The placement's rotation `Rz(yaw)·Ry(pitch)·Rx(roll)`.
    pub fn rotation(&self) -> Matrix3<f64> {
        *Rotation3::from_euler_angles(self.base[3], self.base[4], self.base[5]).matrix()
    }

    /// The target's position in the measurement frame at joint angles `q` (radians).
    pub fn predict(&self, q: &[f64]) -> [f64; 3] {
        self.predict_target(q, 0)
    }

    /// Target `t`'s position in the measurement frame at joint angles `q` (radians).
    pub fn predict_target(&self, q: &[f64], t: usize) -> [f64; 3] {
        let r = self.rotation();
        let p = Vector3::from(position(&self.params, &self.target(t), q));
        let v = r * p + Vector3::new(self.base[0], self.base[1], self.base[2]);
        [v.x, v.y, v.z]
    }

    /// Where observation `o`'s target is predicted (its angles, its target).
    pub fn predict_observation(&self, o: &Observation) -> [f64; 3] {
        self.predict_target(&o.q, o.target as usize)
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
        self.predict_target(q, 0)
    }

    /// [`ChainState::predict_target`] at joint angles `q` (radians).
    #[inline]
    pub fn predict_target(&self, q: &[f64], t: usize) -> [f64; 3] {
        let s = self.state;
        let p = Vector3::from(position_with_trig(&s.params, &self.trig, &s.target(t), q));
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
    /// Which target was measured: 0 the model's tool, `t` the state's other target `t`
    /// ([`ChainState::target`]).
    pub target: u8,
    /// The side each joint arrived from, when the data say ([`super::chain::MeasuredPoint::sides`]).
    pub sides: Option<Joints>,
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

/// Finite-difference step of fit input `i` of `s` for the Jacobian.
fn step(s: &ChainState, i: usize) -> f64 {
    if s.is_angle(i) {
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
        let p = Vector3::from(position_with_trig(
            &s.params,
            &trig,
            &s.target(o.target as usize),
            &o.q,
        ));
        let e = o.whiten * (r * p + t - Vector3::from(o.p));
        out.extend_from_slice(&[e.x, e.y, e.z]);
    }
    out
}

/// Plain (unwhitened) position residuals `B·P(q_k) − p_k`, mm.
pub fn position_residuals(obs: &[Observation], s: &ChainState) -> Vec<[f64; 3]> {
    obs.iter()
        .map(|o| {
            let p = s.predict_observation(o);
            [p[0] - o.p[0], p[1] - o.p[1], p[2] - o.p[2]]
        })
        .collect()
}

/// Jacobian of the whitened residuals by central differences, one column per input of `free`.
pub fn jacobian(obs: &[Observation], s: &ChainState, free: &[usize]) -> DMatrix<f64> {
    let m = 3 * obs.len();
    let cols: Vec<Vec<f64>> = {
        use rayon::prelude::*;
        free.par_iter()
            .map(|&i| {
                let h = step(s, i);
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
    for (c, &i) in free.iter().enumerate().filter(|(_, &i)| i < space.len()) {
        let (Block::Placement, k @ 3..=5) = space.locate(i) else {
            continue;
        };
        let axis = Vector3::ith(k - 3, 1.0);
        for (n, o) in obs.iter().enumerate() {
            let rp = r * Vector3::from(position(&s.params, &s.target(o.target as usize), &o.q));
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
    /// σ per input of the space (the other targets' have none), internal units; 0 = none.
    pub sigma: Vec<f64>,
}

impl Prior {
    /// σ of fit input `i` (0: no prior; the other targets' inputs never have one).
    pub fn sigma_of(&self, i: usize) -> f64 {
        self.sigma.get(i).copied().unwrap_or(0.0)
    }
}

/// Minimises the whitened residuals (plus the prior's rows) over the inputs `free`, from `start`.
pub fn fit(
    obs: &[Observation],
    start: &ChainState,
    free: &[usize],
    prior: Option<&Prior>,
) -> ChainState {
    let steps: Vec<f64> = free.iter().map(|&i| step(start, i)).collect();
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
                let sd = p.sigma_of(i);
                if sd > 0.0 {
                    r.push((s.get(i) - p.centre.get(i)) / sd);
                }
            }
        }
        r
    };
    levenberg_marquardt(*start, &steps, apply, res)
}

/// Kabsch: the rotation and translation that best map `from` onto `to` (least squares).
pub(crate) fn kabsch(from: &[Vector3<f64>], to: &[Vector3<f64>]) -> (Matrix3<f64>, Vector3<f64>) {
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
/// and `tool`, on the observations of the first target; then each other target's offset
/// ([`with_other_targets`]).
pub fn initial_state(obs: &[Observation], params: &[f64], tool: &[f64; 3]) -> ChainState {
    let frames: Vec<([[f64; 4]; 4], Vector3<f64>)> = obs
        .iter()
        .filter(|o| o.target == 0)
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
    let s = ChainState {
        params: Params::from_slice(params),
        tool: [tool.x, tool.y, tool.z],
        base: [trans.x, trans.y, trans.z, roll, pitch, yaw],
        others: OtherTargets::NONE,
    };
    with_other_targets(s, obs)
}

/// `s` with one other target per target index above 0 that `obs` holds (up to the largest),
/// each offset the linear least-squares solution given `s`'s parameters and placement
/// (`B·(R_f(q) t + o_f(q)) = p`); an offset the data do not determine (one flange orientation)
/// starts at the model's tool.
pub fn with_other_targets(s: ChainState, obs: &[Observation]) -> ChainState {
    let count = obs.iter().map(|o| o.target as usize).max().unwrap_or(0);
    if count == 0 {
        return ChainState {
            others: OtherTargets::NONE,
            ..s
        };
    }
    let r = s.rotation();
    let b = Vector3::new(s.base[0], s.base[1], s.base[2]);
    let offsets: Vec<[f64; 3]> = (1..=count)
        .map(|t| {
            let mut ata = Matrix3::<f64>::zeros();
            let mut atb = Vector3::<f64>::zeros();
            for o in obs.iter().filter(|o| o.target as usize == t) {
                let f = transform(&s.params, &o.q);
                let a = r * flange_rotation(&f);
                ata += a.transpose() * a;
                atb += a.transpose() * (Vector3::from(o.p) - b - r * flange_origin(&f));
            }
            ata.cholesky()
                .map(|c| c.solve(&atb))
                .filter(|x| x.iter().all(|v| v.is_finite()))
                .map_or(s.tool, |x| [x.x, x.y, x.z])
        })
        .collect();
    ChainState {
        others: OtherTargets::new(&offsets),
        ..s
    }
}

/// The target (flange frame) that best fits base-frame data with the placement known and the
/// parameters `params`: positions are linear in it (`R_f(q)·t + o_f(q) = p`). `None` when the
/// data do not determine it (all points at one flange orientation). Only the first target's
/// observations count.
pub fn initial_tool(obs: &[Observation], params: &[f64]) -> Option<[f64; 3]> {
    let mut ata = Matrix3::<f64>::zeros();
    let mut atb = Vector3::<f64>::zeros();
    for o in obs.iter().filter(|o| o.target == 0) {
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
mod tests;
