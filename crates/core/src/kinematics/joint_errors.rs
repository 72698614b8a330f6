//! Joint errors beyond geometry (docs/METHOD.md §19): joint compliance under gravity and a
//! payload, and gear harmonics, as a robot model carries them.
//!
//! Commanded to `q`, joint `i` stands at `q_i + Δθ_i(q)` with
//!
//! ```text
//! Δθ_i(q) = k_i · τ_i(q, m) + a_i1 sin q_i + b_i1 cos q_i + a_i2 sin 2q_i + b_i2 cos 2q_i
//! τ_i(q, m) = τ_links,i(q) + m · τ_unit,i(q)
//! ```
//!
//! `τ_links,i` the gravity torque about joint i's axis of the links beyond it (the model's link
//! masses, [`super::gravity`]), `τ_unit,i` that of 1 kg at the payload's centre of mass, `m` the
//! payload (kg), all at the commanded angles and the model's mean geometry. The coefficients
//! `k_i` (rad/(N·m)) and `a, b` (rad) come from an identification (`identify` with the check
//! beyond geometry); the payload at the task can differ from the one during calibration, which is
//! what the "what if the payload changes" analyses ask.
//!
//! # Uncertainty
//!
//! The coefficients with spread (`free`) have the covariance `Σ_ββ` of the identification, and
//! the geometric inputs drawn with them are correlated with them: a draw takes
//! `δβ ~ N(0, Σ_ββ)` from its own stream and moves the geometric inputs by `A δβ` (`shift`, `A =
//! Σ_gβ Σ_ββ⁻¹`) on top of their own draw, whose covariance is then the geometry's given the
//! coefficients (what a fit with the coefficients held reports). Together that is the joint
//! distribution of the identification. The task payload has its own σ, independent of the rest.
//!
//! # Backlash
//!
//! A joint with backlash stands half its gap `b_j` from the commanded angle on the side it
//! arrived from (docs/METHOD.md §19.5). Which side that is at a task point is a property of the
//! robot program, not of the model, so the analyses draw it: at every test point of every draw
//! each joint's side is a fair coin, and the joint turns by `±h_j` with `h_j = ½ √(b̄_j² + σ_j²)`
//! ([`Backlash::half_spread`]). The mean deflection is unchanged (the sides cancel), and `h_j`
//! matches the second moment of `½ (b̄_j + δb_j) s_j` with `δb_j ~ N(0, σ_j²)` exactly: the sign
//! makes the offset uncorrelated with every other input whatever the gap's correlation with
//! them, so drawing the gap itself would only change the offset's fourth moment (by a relative
//! `σ⁴/b̄⁴`-sized amount).

use super::gravity::{gravity_torques, LinkMasses};
use super::{InputSpace, Joints, MAX_JOINTS};

/// Coefficients per joint: `k, a1, b1, a2, b2`.
pub const COEFFICIENTS_PER_JOINT: usize = 5;

/// Most coefficients of a model ([`MAX_JOINTS`] joints).
pub const MAX_COEFFICIENTS: usize = COEFFICIENTS_PER_JOINT * MAX_JOINTS;

/// A payload: its mass (kg) with a standard uncertainty, at a centre of mass in the flange frame
/// (mm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Payload {
    /// Mass, kg.
    pub mass_kg: f64,
    /// Standard uncertainty of the mass, kg.
    pub sigma_kg: f64,
    /// Centre of mass in the flange frame, mm.
    pub com_mm: [f64; 3],
}

impl Payload {
    /// No payload.
    pub const NONE: Payload = Payload {
        mass_kg: 0.0,
        sigma_kg: 0.0,
        com_mm: [0.0; 3],
    };
}

/// The per-point quantities the joint errors at a configuration are linear in: per joint
/// `[τ_links, τ_unit, sin q, cos q, sin 2q, cos 2q]` (N·m, N·m/kg, 1).
pub type PointTerms = [[f64; 6]; MAX_JOINTS];

/// Joint compliance and gear harmonics of a model, with their uncertainty (module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct JointErrors {
    /// Per joint `k, a1, b1, a2, b2` (rad/(N·m), rad), joint-major.
    pub coefficients: Vec<f64>,
    /// The link masses and centres of mass the gravity torques assume.
    pub links: LinkMasses,
    /// The payload during the calibration the coefficients come from.
    pub calibration_payload: Payload,
    /// The payload at the task (analyses): the calibration's unless changed.
    pub payload: Payload,
    /// Indices of the coefficients with spread.
    pub free: Vec<usize>,
    /// Covariance of the free coefficients, row-major, internal units.
    pub covariance: Vec<f64>,
    /// The geometric inputs the shift acts on (the model covariance's space).
    pub shift_space: InputSpace,
    /// `A`, row-major `shift_space.len() × free.len()`: the geometric inputs' mean shift per unit
    /// of each free coefficient (internal units); empty for none.
    pub shift: Vec<f64>,
    /// The joints' backlash, when the model carries it (module docs).
    pub backlash: Option<Backlash>,
}

/// Per joint a backlash gap with its standard uncertainty (module docs, docs/METHOD.md §19.5).
#[derive(Clone, Debug, PartialEq)]
pub struct Backlash {
    /// The gaps `b_j`, rad (a fit can give a small negative one: only its size acts).
    pub gap_rad: Vec<f64>,
    /// Their standard uncertainties, rad.
    pub sigma_rad: Vec<f64>,
    /// The discrepancy term of the prediction that does not know the sides (each joint at its
    /// commanded angle plus the mean deflections, no ±½ gap), fitted to that prediction's
    /// residuals on the calibration data, which hold the hysteresis: used instead of drawing
    /// the sides at test points whose sides are not all known (docs/METHOD.md §19.5); `None`
    /// for a model that draws them there.
    pub sides_unknown: Option<crate::discrepancy::Discrepancy>,
}

impl Backlash {
    /// Largest gap a model file may hold (1°: more is a broken gear, not a calibration's input).
    pub const LIMIT_RAD: f64 = std::f64::consts::PI / 180.0;

    /// `h_j = ½ √(b̄_j² + σ_j²)`, rad: the turn a drawn side gives joint `j`.
    pub fn half_spread(&self, j: usize) -> f64 {
        0.5 * self.gap_rad[j].hypot(self.sigma_rad[j])
    }

    /// Whether some joint turns by a drawn side.
    pub fn acts(&self) -> bool {
        (0..self.gap_rad.len()).any(|j| self.half_spread(j) > 0.0)
    }

    /// Checks: one gap and σ per joint, finite, |gap| and σ at most [`Self::LIMIT_RAD`], σ ≥ 0.
    ///
    /// # Errors
    ///
    /// `(field, message)` naming the model file's field.
    pub fn check(&self, joints: usize) -> Result<(), (String, String)> {
        for (field, v, signed) in [
            ("backlash_deg", &self.gap_rad, true),
            ("backlash_sigma_deg", &self.sigma_rad, false),
        ] {
            let bad = |m: String| Err((format!("joint_errors.{field}"), m));
            if v.len() != joints {
                return bad(format!(
                    "needs one value per joint ({joints}), found {}",
                    v.len()
                ));
            }
            if let Some(j) = v
                .iter()
                .position(|x| !x.is_finite() || x.abs() > Self::LIMIT_RAD || (!signed && *x < 0.0))
            {
                return bad(format!(
                    "joint {}: {} deg is not a {}size of at most 1 deg",
                    j + 1,
                    v[j].to_degrees(),
                    if signed { "" } else { "non-negative " }
                ));
            }
        }
        Ok(())
    }
}

impl JointErrors {
    /// Number of joints.
    pub fn joints(&self) -> usize {
        self.links.joints()
    }

    /// The name of coefficient `i` as files and reports write it: `k2`, `sin1_2`, `cos1_2`,
    /// `sin2_2`, `cos2_2` (1-based joint).
    pub fn coefficient_name(i: usize) -> String {
        let j = i / COEFFICIENTS_PER_JOINT + 1;
        match i % COEFFICIENTS_PER_JOINT {
            0 => format!("k{j}"),
            1 => format!("sin1_{j}"),
            2 => format!("cos1_{j}"),
            3 => format!("sin2_{j}"),
            _ => format!("cos2_{j}"),
        }
    }

    /// Whether coefficient `i` is a compliance (else a harmonic, an angle).
    pub fn is_compliance(i: usize) -> bool {
        i.is_multiple_of(COEFFICIENTS_PER_JOINT)
    }

    /// Factor from file units (µrad/(N·m), deg) to internal units (rad/(N·m), rad) of
    /// coefficient `i`.
    pub fn to_internal(i: usize) -> f64 {
        if Self::is_compliance(i) {
            1e-6
        } else {
            std::f64::consts::PI / 180.0
        }
    }

    /// Standard uncertainty of coefficient `i`, internal units (0 when it has no spread).
    pub fn sigma(&self, i: usize) -> f64 {
        let p = self.free.len();
        self.free
            .iter()
            .position(|&f| f == i)
            .map_or(0.0, |k| self.covariance[k * p + k].max(0.0).sqrt())
    }

    /// One line for an analysis's notes: how many coefficients are drawn, of which joints'
    /// compliance and gear harmonics, and the payload at the task against the calibration's,
    /// e.g. `joint errors drawn: 9 uncertain coefficients (compliance of J2, J3; gear harmonics
    /// of J1), payload at the task 5 ± 1 kg (during calibration 0 kg)`.
    pub fn describe(&self) -> String {
        let joints_of = |compliance: bool| -> Vec<String> {
            let mut j: Vec<usize> = (self.free.iter())
                .filter(|&&i| Self::is_compliance(i) == compliance)
                .map(|&i| i / COEFFICIENTS_PER_JOINT + 1)
                .collect();
            j.dedup();
            j.iter().map(|j| format!("J{j}")).collect()
        };
        let mut kinds = Vec::new();
        for (compliance, label) in [(true, "compliance"), (false, "gear harmonics")] {
            let j = joints_of(compliance);
            if !j.is_empty() {
                kinds.push(format!("{label} of {}", j.join(", ")));
            }
        }
        let which = if kinds.is_empty() {
            String::new()
        } else {
            format!(" ({})", kinds.join("; "))
        };
        let p = &self.payload;
        let sigma = if p.sigma_kg > 0.0 {
            format!(" ± {}", p.sigma_kg)
        } else {
            String::new()
        };
        let backlash = match &self.backlash {
            Some(b) if b.acts() => format!(
                ", backlash of J{} (half gaps {} deg)",
                (0..b.gap_rad.len())
                    .filter(|&j| b.half_spread(j) > 0.0)
                    .map(|j| (j + 1).to_string())
                    .collect::<Vec<_>>()
                    .join(", J"),
                (0..b.gap_rad.len())
                    .map(|j| format!("{:.4}", b.half_spread(j).to_degrees()))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
            _ => String::new(),
        };
        format!(
            "joint errors drawn: {} uncertain coefficients{which}, payload at the task {}{sigma} kg (during calibration {} kg){backlash}",
            self.free.len(),
            p.mass_kg,
            self.calibration_payload.mass_kg
        )
    }

    /// Whether a draw moves anything: some coefficient or the task payload has spread.
    pub fn drawn(&self) -> bool {
        !self.free.is_empty()
            || self.payload.sigma_kg > 0.0
            || self.backlash.as_ref().is_some_and(Backlash::acts)
    }

    /// The quantities the joint errors at the commanded angles `q` (rad) are linear in, for the
    /// chain `params` of the model's mean and the task payload's centre of mass
    /// ([`PointTerms`]).
    pub fn point_terms(&self, params: &[f64], q: &[f64]) -> PointTerms {
        self.point_terms_for(params, q, &self.payload)
    }

    /// [`Self::point_terms`] with `payload`'s centre of mass.
    fn point_terms_for(&self, params: &[f64], q: &[f64], payload: &Payload) -> PointTerms {
        let n = q.len();
        let tau_links = gravity_torques(params, &[0.0; 3], &self.links, 0.0, q);
        let zero = LinkMasses::at_midpoints(Joints::filled(n, 0.0));
        let tau_unit = gravity_torques(params, &payload.com_mm, &zero, 1.0, q);
        let mut t = [[0.0; 6]; MAX_JOINTS];
        for i in 0..n {
            let (s1, c1) = q[i].sin_cos();
            let (s2, c2) = (2.0 * q[i]).sin_cos();
            t[i] = [tau_links[i], tau_unit[i], s1, c1, s2, c2];
        }
        t
    }

    /// The deflections `Δθ` (rad) at the commanded angles `q` of coefficients `beta` (all of
    /// them, internal units) with a payload of `mass_kg`, from the point's [`PointTerms`].
    pub fn deflections_with(beta: &[f64], mass_kg: f64, t: &PointTerms, n: usize) -> Joints {
        Joints::from_fn(n, |i| {
            let b = &beta[COEFFICIENTS_PER_JOINT * i..COEFFICIENTS_PER_JOINT * (i + 1)];
            let [tl, tu, s1, c1, s2, c2] = t[i];
            b[0] * (tl + mass_kg * tu) + b[1] * s1 + b[2] * c1 + b[3] * s2 + b[4] * c2
        })
    }

    /// The mean deflections (rad) at the commanded angles `q` (rad) of the chain `params` with
    /// the task payload.
    pub fn deflections(&self, params: &[f64], q: &[f64]) -> Joints {
        let t = self.point_terms(params, q);
        Self::deflections_with(&self.coefficients, self.payload.mass_kg, &t, q.len())
    }

    /// The joint angles (rad) the mean model stands at when commanded to `q` (rad), with the
    /// task payload.
    pub fn actual_angles(&self, params: &[f64], q: &[f64]) -> Joints {
        self.angles_with(params, q, &self.payload)
    }

    /// The joint angles (rad) the mean model stands at when commanded to `q` (rad) carrying
    /// `payload`.
    pub fn angles_with(&self, params: &[f64], q: &[f64], payload: &Payload) -> Joints {
        let t = self.point_terms_for(params, q, payload);
        let d = Self::deflections_with(&self.coefficients, payload.mass_kg, &t, q.len());
        Joints::from_fn(q.len(), |i| q[i] + d[i])
    }

    /// Checks the values: finite, one set per joint, a positive semi-definite-looking covariance
    /// (non-negative diagonal) of the right size, a shift of the right size.
    ///
    /// # Errors
    ///
    /// `(field, message)` naming the first bad field, as the model file spells it.
    pub fn check(&self, joints: usize) -> Result<(), (String, String)> {
        let bad = |f: &str, m: String| Err((format!("joint_errors.{f}"), m));
        if self.coefficients.len() != COEFFICIENTS_PER_JOINT * joints {
            return bad(
                "compliance_urad_per_nm",
                format!("needs one value per joint ({joints})"),
            );
        }
        if let Err((field, m)) = self.links.check(joints) {
            return bad(
                if field == "mass_kg" {
                    "link_mass_kg"
                } else {
                    "link_com_mm"
                },
                m,
            );
        }
        if let Some(i) = self.coefficients.iter().position(|v| !v.is_finite()) {
            return bad(
                if Self::is_compliance(i) {
                    "compliance_urad_per_nm"
                } else {
                    "harmonics_deg"
                },
                format!("{} is not a finite number", Self::coefficient_name(i)),
            );
        }
        // Deflections beyond 1° are not a compliance or a gear error of a calibrated robot.
        let limit = 1f64.to_radians();
        for j in 0..joints {
            let h: f64 = (1..5)
                .map(|k| self.coefficients[COEFFICIENTS_PER_JOINT * j + k].abs())
                .sum();
            if h > limit {
                return bad(
                    "harmonics_deg",
                    format!(
                        "joint {}: harmonic amplitudes summing to {:.3} deg (at most 1 deg)",
                        j + 1,
                        h.to_degrees()
                    ),
                );
            }
        }
        for (name, p) in [
            ("calibration_payload_kg", &self.calibration_payload),
            ("payload_kg", &self.payload),
        ] {
            if !(0.0..=1e4).contains(&p.mass_kg) || !(0.0..=1e4).contains(&p.sigma_kg) {
                return bad(
                    name,
                    format!("{} kg with σ {} kg (0 to 10000 kg)", p.mass_kg, p.sigma_kg),
                );
            }
            if p.com_mm.iter().any(|v| !v.is_finite() || v.abs() > 1e5) {
                return bad(
                    name,
                    format!(
                        "centre of mass {:?} mm is not a finite length within 100 m",
                        p.com_mm
                    ),
                );
            }
        }
        let p = self.free.len();
        if self.free.iter().any(|&i| i >= self.coefficients.len())
            || self.free.windows(2).any(|w| w[0] >= w[1])
        {
            return bad(
                "free",
                "names unknown, repeated or unordered coefficients".into(),
            );
        }
        if self.covariance.len() != p * p {
            return bad(
                "covariance",
                format!("needs {p} × {p} entries, one row per free coefficient"),
            );
        }
        if self.covariance.iter().any(|v| !v.is_finite())
            || (0..p).any(|k| self.covariance[k * p + k] < 0.0)
        {
            return bad(
                "covariance",
                "entries must be finite, the diagonal non-negative".into(),
            );
        }
        if !self.shift.is_empty()
            && (self.shift.len() != self.shift_space.len() * p
                || self.shift.iter().any(|v| !v.is_finite()))
        {
            return bad(
                "geometry_shift",
                format!(
                    "needs {} rows (the covariance's inputs) of {p} finite numbers",
                    self.shift_space.len()
                ),
            );
        }
        if let Some(b) = &self.backlash {
            b.check(joints)?;
        }
        Ok(())
    }
}
