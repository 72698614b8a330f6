//! The model's joint errors (compliance, gear harmonics, payload; [`crate::kinematics::JointErrors`],
//! docs/METHOD.md §19) as a run draws them: per draw, the coefficients' offsets `δβ ~ N(0,
//! Σ_ββ)` and the payload's `δm ~ N(0, σ_m²)` from the draw's own normals, the geometric inputs
//! moved by `A δβ`, and at each test point the joint-angle offsets
//!
//! ```text
//! Δ_i = δk_i τ_links,i + ((k̄_i + δk_i)(m̄ + δm) − k̄_i m̄) τ_unit,i
//!       + δa_i1 sin q_i + δb_i1 cos q_i + δa_i2 sin 2q_i + δb_i2 cos 2q_i
//! ```
//!
//! on top of the mean deflections, which the problem's chain points hold already
//! ([`super::Problem::chain_points`]). The torques are those of the mean geometry at the
//! commanded angles: a draw's own geometry would change them by its relative size (~1e-3), a
//! change of ~1e-7 rad in a deflection of 1e-4 rad.
//!
//! # Normals
//!
//! Draw `k`'s normals are the Philox counters `(k mod 2³², k div 2³², b, JOINT_ERROR_STREAM)` for
//! blocks `b = 0, 1, …` (four normals each by Box–Muller, as the parameters'): normal `c` feeds
//! free coefficient `c`, the one after the last coefficient the payload. They are not slots of
//! the input space: a pick-freeze row takes the normals of each of the three groups —
//! compliance, gear harmonics, payload ([`TermGroup`]) — from its `b` draw when its mask has the
//! group's bit ([`TermGroup::mask`]), else from `a` (sensitivity's groups of these names).
//!
//! # Backlash
//!
//! A model with backlash ([`crate::kinematics::Backlash`]) turns joint `i` at test point `j` of
//! draw `k` further by `+h_i` or `−h_i`: bit `i` of the point's word `h(a ⊕ h(b + j))`
//! ([`super::discrepancy::point_word`]) with `(a, b)` the first two words of the Philox block
//! `(k mod 2³², k div 2³², 0, BACKLASH_STREAM)`. A pick-freeze row takes the words from its `b`
//! draw when its mask has [`BACKLASH_MASK`] (sensitivity's group `backlash`). The tail analysis
//! moves two more normals per state instead, the words `⌊Φ(z)·2³²⌋`
//! ([`JointErrorDraws::draw_from_normals`]).

use super::discrepancy::point_word;
use super::ProblemError;
use crate::kinematics::joint_errors::{
    JointErrors, PointTerms, COEFFICIENTS_PER_JOINT, MAX_COEFFICIENTS,
};
use crate::kinematics::{Block, Joints, RobotModel, MAX_JOINTS};
use crate::sampling::{box_muller, normals_block, philox4x32_10_lanes, Philox};

mod sides;
pub use sides::side;

/// The Philox stream of the joint errors' normals.
pub const JOINT_ERROR_STREAM: u32 = 0x10E7_0000;

/// The Philox stream of the backlash's sides (module docs).
pub const BACKLASH_STREAM: u32 = 0xBAC1_0000;

/// The pick-freeze mask bit that takes a row's backlash sides from its `b` draw (below the
/// joint errors' groups, above every normal of a draw).
pub const BACKLASH_MASK: u64 = 1 << 59;

/// The groups of the joint errors' normals a Sobol design tells apart.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TermGroup {
    /// The normals of the compliance coefficients.
    Compliance = 0,
    /// The normals of the harmonic coefficients.
    Harmonics = 1,
    /// The payload's normal.
    Payload = 2,
    /// The backlash's sides (no normals of their own: the words of a Philox block).
    Backlash = 3,
}

impl TermGroup {
    /// Every group, in order.
    pub const ALL: [TermGroup; 4] = [
        TermGroup::Compliance,
        TermGroup::Harmonics,
        TermGroup::Payload,
        TermGroup::Backlash,
    ];

    /// The group's pick-freeze mask bit: 60, 61, 62; the backlash's [`BACKLASH_MASK`] (59).
    pub const fn mask(self) -> u64 {
        match self {
            TermGroup::Backlash => BACKLASH_MASK,
            g => 1 << (60 + g as u64),
        }
    }

    /// How sensitivity reports name the group.
    pub const fn label(self) -> &'static str {
        match self {
            TermGroup::Compliance => "joint compliance",
            TermGroup::Harmonics => "gear harmonics",
            TermGroup::Payload => "payload",
            TermGroup::Backlash => "backlash",
        }
    }

    /// The group's input name in sensitivity reports.
    pub const fn input_name(self) -> &'static str {
        match self {
            TermGroup::Compliance => "joint_compliance",
            TermGroup::Harmonics => "gear_harmonics",
            TermGroup::Payload => "payload",
            TermGroup::Backlash => "backlash",
        }
    }
}

/// The pick-freeze mask bits of all the joint errors' groups ([`TermGroup::mask`] of each).
pub const JOINT_ERRORS_MASK: u64 = 0b1111 << 59;

/// Most normals of a draw: every coefficient and the payload.
const MAX_TERM_NORMALS: usize = MAX_COEFFICIENTS + 1;

/// One draw of the term: coefficient offsets (all coefficients, internal units), the payload's
/// offset (kg) and the free coefficients' offsets in order (for the shift).
#[derive(Clone, Copy, Debug)]
pub struct TermDraw {
    /// `δβ` of every coefficient (zero without spread).
    pub beta: [f64; MAX_COEFFICIENTS],
    /// `δβ` of the free coefficients, in order.
    pub free: [f64; MAX_COEFFICIENTS],
    /// `δm`, kg.
    pub mass: f64,
    /// The backlash's words `(a, b)`: the sides at point `j` are the bits of `h(a ⊕ h(b + j))`
    /// (module docs; unused without backlash).
    pub sides: [u32; 2],
}

/// The joint errors as a run draws them (module docs).
#[derive(Clone, Debug)]
pub struct JointErrorDraws {
    joints: usize,
    free: Vec<usize>,
    /// Lower Cholesky factor of the free coefficients' covariance, row-major (zero above the
    /// diagonal).
    chol: Vec<f64>,
    mass: f64,
    mass_sigma: f64,
    compliance: Joints,
    /// Per row of `shift_matrix`, the geometric input it shifts: input `k` of `block`; inputs
    /// whose row is all zero are left out.
    shift: Vec<(Block, usize)>,
    /// `A`: per input of `shift` its mean shift per unit of each free coefficient (row-major, a
    /// column per free coefficient).
    shift_matrix: Vec<f64>,
    gen: Philox,
    /// Per coefficient, its place among the free ones.
    position: [Option<usize>; MAX_COEFFICIENTS],
    /// Per test point, the quantities the offsets are linear in.
    pub terms: Vec<PointTerms>,
    /// Per joint the backlash's turn `h_j` (rad; [`crate::kinematics::Backlash::half_spread`]),
    /// all zero without backlash.
    pub half_gap: [f64; MAX_JOINTS],
    /// Whether the model draws backlash sides (some `h_j > 0`).
    pub backlash: bool,
    /// Per test point the sides known in advance ([`Self::set_known_sides`]): `[mask, bits]`,
    /// joint `i`'s side is bit `i` of `bits` where bit `i` of `mask` is set, drawn elsewhere;
    /// empty when none is known.
    pub known: Vec<[u32; 2]>,
    /// Per test point whether every joint stands at the centre of its gap there (no side
    /// drawn or known: the point is predicted as the model without its backlash predicts,
    /// [`Self::set_centre`]); empty when none is.
    pub centre: Vec<bool>,
}

impl JointErrorDraws {
    /// The term of `model` at the commanded angles `points` (rad) for a run keyed by `seed`;
    /// `None` when the model has no joint errors or nothing of them is uncertain.
    ///
    /// # Errors
    ///
    /// [`ProblemError::Model`] when the coefficients' covariance has no Cholesky factor.
    pub fn new(
        model: &RobotModel,
        points: &[Joints],
        seed: u64,
    ) -> Result<Option<JointErrorDraws>, ProblemError> {
        let Some(e) = model.joint_errors.as_ref().filter(|e| e.drawn()) else {
            return Ok(None);
        };
        let p = e.free.len();
        let chol = if p == 0 {
            Vec::new()
        } else {
            let c = nalgebra::DMatrix::from_row_slice(p, p, &e.covariance);
            let l = nalgebra::linalg::Cholesky::new(c)
                .ok_or_else(|| ProblemError::Model {
                    model: model.name.clone(),
                    field: "joint_errors.covariance".into(),
                    message: "is not positive definite".into(),
                })?
                .l();
            (0..p * p).map(|i| l[(i / p, i % p)]).collect()
        };
        let (shift, shift_matrix) = shift_rows(e);
        let n = model.joints();
        let backlash = e.backlash.as_ref().filter(|b| b.acts());
        Ok(Some(JointErrorDraws {
            half_gap: std::array::from_fn(|j| {
                backlash.filter(|_| j < n).map_or(0.0, |b| b.half_spread(j))
            }),
            backlash: backlash.is_some(),
            known: Vec::new(),
            centre: Vec::new(),
            joints: n,
            free: e.free.clone(),
            chol,
            mass: e.payload.mass_kg,
            mass_sigma: e.payload.sigma_kg,
            compliance: Joints::from_fn(n, |i| e.coefficients[COEFFICIENTS_PER_JOINT * i]),
            shift,
            shift_matrix,
            gen: Philox::new(seed),
            position: std::array::from_fn(|i| e.free.iter().position(|&f| f == i)),
            terms: points
                .iter()
                .map(|q| e.point_terms(&model.params, q))
                .collect(),
        }))
    }

    /// Whether the payload's lane factor `(k̄ + δk)(m̄ + δm) − k̄ m̄` can be nonzero: with no
    /// payload (`m̄ = 0`) and no spread of it (`σ_m = 0`) it is `±0` in every draw, and the
    /// lanes leave its term out of the offsets (the same bits).
    pub fn payload_term(&self) -> bool {
        self.mass != 0.0 || self.mass_sigma != 0.0
    }

    /// Number of normals a draw uses: one per free coefficient, then the payload's.
    pub fn normals(&self) -> usize {
        self.free.len() + 1
    }

    /// The group of normal `c` (free coefficient `c`, or the payload after them).
    fn group_of(&self, c: usize) -> TermGroup {
        match self.free.get(c) {
            Some(&i) if JointErrors::is_compliance(i) => TermGroup::Compliance,
            Some(_) => TermGroup::Harmonics,
            None => TermGroup::Payload,
        }
    }

    /// The groups whose normals move something: compliance and harmonics with a free
    /// coefficient, the payload with a σ.
    pub fn groups(&self) -> Vec<TermGroup> {
        TermGroup::ALL
            .into_iter()
            .filter(|&g| match g {
                TermGroup::Payload => self.mass_sigma > 0.0,
                TermGroup::Backlash => self.backlash,
                g => (0..self.free.len()).any(|c| self.group_of(c) == g),
            })
            .collect()
    }

    /// The term's draw from the normals of counter draw `k`.
    pub fn draw(&self, k: u64) -> TermDraw {
        self.draw_mixed([k; 4])
    }

    /// The term's draw of a pick-freeze row: the normals of each [`TermGroup`] `g` from draw
    /// `draws[g]`, the backlash's sides from draw `draws[3]`.
    pub fn draw_mixed(&self, draws: [u64; 4]) -> TermDraw {
        let mut z = [0.0; MAX_TERM_NORMALS];
        for blk in 0..self.normals().div_ceil(4) {
            let mut by_draw: [Option<(u64, [f64; 4])>; 3] = [None; 3];
            for (c, slot) in z.iter_mut().enumerate().skip(4 * blk).take(4) {
                let k = draws[self.group_of(c) as usize];
                let v = match by_draw.iter().flatten().find(|(d, _)| *d == k) {
                    Some((_, v)) => *v,
                    None => {
                        let v = normals_block(&self.gen, k, blk as u32, JOINT_ERROR_STREAM);
                        if let Some(free) = by_draw.iter_mut().find(|x| x.is_none()) {
                            *free = Some((k, v));
                        }
                        v
                    }
                };
                *slot = v[c - 4 * blk];
            }
        }
        let mut d = self.draw_from_normals(&z[..self.normals()]);
        d.sides = self.side_words(draws[3]);
        d
    }

    /// The term's draw from its standard normals `z` (the free coefficients', then the
    /// payload's; then, when `z` holds [`Self::state_normals`] and the model has backlash, two
    /// whose `⌊Φ(z)·2³²⌋` are the backlash's words): `δβ = L z`, `δm = σ_m z_p`. Counter draws
    /// take `z` from their Philox blocks ([`Self::draw`]); the tail analysis moves them as
    /// coordinates of its standard-normal space.
    ///
    /// # Panics
    ///
    /// When `z` holds fewer than [`Self::normals`] entries.
    pub fn draw_from_normals(&self, z: &[f64]) -> TermDraw {
        let p = self.free.len();
        let word =
            |v: f64| (crate::normal::normal_cdf(v) * 4_294_967_296.0).min(4_294_967_295.0) as u32;
        let mut d = TermDraw {
            beta: [0.0; MAX_COEFFICIENTS],
            free: [0.0; MAX_COEFFICIENTS],
            mass: self.mass_sigma * z[p],
            sides: match z.get(p + 1..p + 3) {
                Some(&[a, b]) if self.backlash => [word(a), word(b)],
                _ => [0, 0],
            },
        };
        for r in 0..p {
            let v: f64 = (0..=r).map(|c| self.chol[r * p + c] * z[c]).sum();
            d.free[r] = v;
            d.beta[self.free[r]] = v;
        }
        d
    }

    /// The draws of `L` lanes at once, the normals of group `g` ([`TermGroup`]) of lane `l`
    /// from draw `draws[g][l]` (lane `l` equal to [`Self::draw_mixed`] to rounding: the same
    /// normals, the sums in the same order): the free coefficients' offsets `free[c][l]` and
    /// the payload's `mass[l]`.
    #[inline(always)]
    pub fn draw_lanes<const L: usize>(
        &self,
        draws: &[[u64; L]; 3],
        free: &mut [[f64; L]; MAX_COEFFICIENTS],
        mass: &mut [f64; L],
    ) {
        let p = self.free.len();
        let mut z = [[0.0; L]; MAX_TERM_NORMALS];
        // Counter draws (all groups from one draw) compute each block once.
        let same = draws[1] == draws[0] && draws[2] == draws[0];
        for blk in 0..self.normals().div_ceil(4) {
            for (g, d) in draws.iter().enumerate() {
                if same && g > 0 {
                    break;
                }
                let lo: [u32; L] = std::array::from_fn(|l| d[l] as u32);
                let hi: [u32; L] = std::array::from_fn(|l| (d[l] >> 32) as u32);
                let w = philox4x32_10_lanes(
                    [lo, hi, [blk as u32; L], [JOINT_ERROR_STREAM; L]],
                    self.gen.key,
                );
                // Which of the block's four normals this draw feeds (decided once, outside the
                // lanes, so that the lane loop vectorises).
                let take: [bool; 4] = std::array::from_fn(|t| {
                    let n = 4 * blk + t;
                    n < MAX_TERM_NORMALS && (same || self.group_of(n) as usize == g)
                });
                let mut v = [[0.0; L]; 4];
                for l in 0..L {
                    (v[0][l], v[1][l]) = box_muller(w[0][l], w[1][l]);
                    (v[2][l], v[3][l]) = box_muller(w[2][l], w[3][l]);
                }
                for (t, vt) in v.iter().enumerate() {
                    if take[t] {
                        z[4 * blk + t] = *vt;
                    }
                }
            }
        }
        crate::sampling::rows_times_lanes(&self.chol, p, true, &z[..p], |r, acc| free[r] = *acc);
        for l in 0..L {
            mass[l] = self.mass_sigma * z[p][l];
        }
    }

    /// The mean shift `A δβ` of `L` lanes of free-coefficient offsets `free`: `f(block, k, v)`
    /// with `v[l]` the shift of input `k` of `block` in lane `l`.
    #[inline(always)]
    pub fn shift_lanes<const L: usize>(
        &self,
        free: &[[f64; L]; MAX_COEFFICIENTS],
        mut f: impl FnMut(Block, usize, &[f64; L]),
    ) {
        let p = self.free.len();
        crate::sampling::rows_times_lanes(&self.shift_matrix, p, false, &free[..p], |r, acc| {
            let (block, k) = self.shift[r];
            f(block, k, acc);
        });
    }

    /// The lane factors of joint `i` (`[f0, f1, δa1, δb1, δa2, δb2]`, [`Self::factors`]) from
    /// `L` lanes of free-coefficient offsets and payload offsets.
    #[inline(always)]
    pub fn factor_lanes<const L: usize>(
        &self,
        i: usize,
        free: &[[f64; L]; MAX_COEFFICIENTS],
        mass: &[f64; L],
        out: &mut [[f64; L]; 6],
    ) {
        let of = |c: usize| -> [f64; L] {
            match self.position[COEFFICIENTS_PER_JOINT * i + c] {
                Some(r) => free[r],
                None => [0.0; L],
            }
        };
        let dk = of(0);
        let k = self.compliance[i];
        for l in 0..L {
            out[0][l] = dk[l];
            out[1][l] = (k + dk[l]) * (self.mass + mass[l]) - k * self.mass;
        }
        for c in 1..COEFFICIENTS_PER_JOINT {
            out[c + 1] = of(c);
        }
    }

    /// The geometric inputs' mean shift `A δβ` of draw `d`: `f(block, k, v)` for input `k` of
    /// `block` moved by `v` (placement rows included; the caller drops those it does not draw).
    #[inline]
    pub fn shift_each(&self, d: &TermDraw, mut f: impl FnMut(Block, usize, f64)) {
        let p = self.free.len();
        for (&(block, k), row) in self
            .shift
            .iter()
            .zip(self.shift_matrix.chunks_exact(p.max(1)))
        {
            let v: f64 = (0..p).map(|c| row[c] * d.free[c]).sum();
            f(block, k, v);
        }
    }

    /// Per joint the two lane factors of a draw: `δk_i` and `(k̄_i + δk_i)(m̄ + δm) − k̄_i m̄`.
    pub fn factors(&self, d: &TermDraw) -> [[f64; 2]; MAX_JOINTS] {
        let mut f = [[0.0; 2]; MAX_JOINTS];
        for (i, fi) in f.iter_mut().enumerate().take(self.joints) {
            let dk = d.beta[COEFFICIENTS_PER_JOINT * i];
            let k = self.compliance[i];
            *fi = [dk, (k + dk) * (self.mass + d.mass) - k * self.mass];
        }
        f
    }

    /// The joint-angle offsets (rad) of draw `d` at test point `point`, on top of the mean
    /// deflections: the coefficients' part, then the backlash's `±h_i` of the point's sides.
    pub fn offsets(&self, d: &TermDraw, point: usize) -> Joints {
        let f = self.factors(d);
        let t = &self.terms[point];
        let w = self.with_known(point_word(d.sides[0], d.sides[1], point as u32), point);
        Joints::from_fn(self.joints, |i| {
            let b = &d.beta[COEFFICIENTS_PER_JOINT * i..COEFFICIENTS_PER_JOINT * (i + 1)];
            let [tl, tu, s1, c1, s2, c2] = t[i];
            let o = f[i][0] * tl + f[i][1] * tu + b[1] * s1 + b[2] * c1 + b[3] * s2 + b[4] * c2;
            if self.backlash && !self.at_centre(point) {
                o + side(w, i, self.half_gap[i])
            } else {
                o
            }
        })
    }
}

/// The joint errors as an f32 kernel uploads them (the WGSL shader's `term` and `term_pts`
/// buffers, docs/METHOD.md §19.2).
#[derive(Clone, Debug, PartialEq)]
pub struct TermPacking {
    /// Free coefficients `p`.
    pub free: u32,
    /// Rows of the shift.
    pub rows: u32,
    /// `L` (`p × p`, row-major); then per shift row its input's position in a row with the
    /// placement ([`crate::kinematics::InputSpace::measured`]) and its `p` entries of `A`; then
    /// per joint `k̄` and the free positions of `k, a1, b1, a2, b2` (−1: no spread); then the
    /// payload's mean and σ (kg); then the [`TermGroup`] of each of the `p + 1` normals.
    pub words: Vec<f32>,
    /// Per test point and joint two vec4: `(τ_links, τ_unit, sin q, cos q)`, `(sin 2q, cos 2q,
    /// k, s)` with `k = 1` where the joint's backlash side is known there, `s` that side (±1),
    /// or 0 at a point at the centre of the gaps ([`JointErrorDraws::set_centre`]).
    pub points: Vec<[f32; 4]>,
    /// Per joint the backlash's turn `h_j` (rad); empty without backlash.
    pub half_gap: Vec<f32>,
}

impl JointErrorDraws {
    /// The f32 words of [`TermPacking`].
    pub fn packing(&self) -> TermPacking {
        let p = self.free.len();
        let measured = crate::kinematics::InputSpace::measured(self.joints);
        let mut words: Vec<f32> = self.chol.iter().map(|&v| v as f32).collect();
        let mut rows = 0;
        for (&(block, k), row) in self
            .shift
            .iter()
            .zip(self.shift_matrix.chunks_exact(p.max(1)))
        {
            if let Some(i) = measured.index(block, k) {
                words.push(i as f32);
                words.extend(row.iter().map(|&v| v as f32));
                rows += 1;
            }
        }
        for j in 0..self.joints {
            words.push(self.compliance[j] as f32);
            for c in 0..COEFFICIENTS_PER_JOINT {
                words
                    .push(self.position[COEFFICIENTS_PER_JOINT * j + c].map_or(-1.0, |r| r as f32));
            }
        }
        words.push(self.mass as f32);
        words.push(self.mass_sigma as f32);
        // The group of each normal (TermGroup), the coefficients' then the payload's.
        words.extend((0..=p).map(|c| self.group_of(c) as u8 as f32));
        debug_assert!(p <= MAX_COEFFICIENTS);
        let points = (self.terms.iter().enumerate())
            .flat_map(|(pj, t)| {
                let [mask, bits] = self.known.get(pj).copied().unwrap_or([0, 0]);
                // A point at the centre: every side "known" as 0, so no joint turns.
                let centre = self.at_centre(pj);
                (0..self.joints).flat_map(move |j| {
                    let [tl, tu, s1, c1, s2, c2] = t[j];
                    let known = if centre { 1 } else { (mask >> j) & 1 };
                    let side = match (centre, (bits >> j) & 1 == 1) {
                        (true, _) => 0.0,
                        (false, true) => 1.0,
                        (false, false) => -1.0,
                    };
                    [
                        [tl as f32, tu as f32, s1 as f32, c1 as f32],
                        [s2 as f32, c2 as f32, known as f32, side],
                    ]
                })
            })
            .collect();
        TermPacking {
            free: p as u32,
            rows,
            words,
            points,
            half_gap: if self.backlash {
                self.half_gap[..self.joints]
                    .iter()
                    .map(|&h| h as f32)
                    .collect()
            } else {
                Vec::new()
            },
        }
    }
}

/// The nonzero rows of `e`'s shift, by block and place.
fn shift_rows(e: &JointErrors) -> (Vec<(Block, usize)>, Vec<f64>) {
    let p = e.free.len();
    let (mut inputs, mut matrix) = (Vec::new(), Vec::new());
    if e.shift.is_empty() || p == 0 {
        return (inputs, matrix);
    }
    for r in 0..e.shift_space.len() {
        let row = &e.shift[r * p..(r + 1) * p];
        if row.iter().any(|&v| v != 0.0) {
            inputs.push(e.shift_space.locate(r));
            matrix.extend_from_slice(row);
        }
    }
    (inputs, matrix)
}
