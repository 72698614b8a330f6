//! The joint errors a model keeps of an extended fit ([`ExtendedFit::joint_errors`]): the
//! coefficients, their marginal covariance and the shift of the geometric inputs per unit of
//! each.

use super::{ExtendedFit, PER_JOINT};
use crate::identify::chain::MeasuredPoint;
use crate::kinematics::{InputSpace, JointErrors, Joints, Payload};

impl ExtendedFit {
    /// How many inputs beyond the geometry this fit took from the data: the coefficients of
    /// the terms it kept ([`super::BeyondGeometry::parameters`]) and, when kept, its gaps. A
    /// geometry fitted again to the angles they correct sees its residuals shrunk by these too
    /// (docs/METHOD.md §19.1); the candidates a selection dropped stay at 0 and shrink nothing.
    pub fn fitted_beyond_geometry(&self) -> usize {
        self.report.parameters + self.backlash.as_ref().map_or(0, |b| b.gap_rad.len())
    }

    /// The joint errors a model keeps of this fit: the coefficients, their marginal covariance
    /// times `scale` (the noise of the data the geometry is finally fitted to, over the one
    /// this fit was whitened with), and the shift `A = Σ_gβ Σ_ββ⁻¹` of the inputs of `space`
    /// (the model covariance's) per unit of each coefficient; `fit` is the space of the
    /// geometric indices.
    ///
    /// A compliance the data did not determine (its joint's torque hardly varied over the
    /// poses) is kept at 0 with the prior σ `prior_k` (rad/(N·m),
    /// [`crate::kinematics::gravity::compliance_prior`]) and no correlation: a payload at the
    /// task bends such a joint by an amount the calibration never saw.
    pub fn joint_errors(
        &self,
        fit: InputSpace,
        space: InputSpace,
        scale: f64,
        prior_k: f64,
    ) -> JointErrors {
        let geo = self.geo;
        let fitted = self.free.len() - geo;
        // The fitted coefficients, then the undetermined compliances, in coefficient order.
        let mut coeffs: Vec<(usize, Option<usize>)> = self.free[geo..]
            .iter()
            .enumerate()
            .map(|(k, &i)| (i, Some(k)))
            .collect();
        for i in (0..self.model.beta.len()).step_by(PER_JOINT) {
            if !self.free[geo..].contains(&i) {
                coeffs.push((i, None));
            }
        }
        coeffs.sort_by_key(|c| c.0);
        let p = coeffs.len();
        let sbb = self
            .covariance
            .view((geo, geo), (fitted, fitted))
            .into_owned();
        let sgb = self.covariance.view((0, geo), (geo, fitted)).into_owned();
        // A = Σ_gβ Σ_ββ⁻¹ = (Σ_ββ⁻¹ Σ_βg)ᵀ (Σ_ββ symmetric); a singular block leaves no shift.
        let a = sbb
            .clone()
            .cholesky()
            .map(|c| c.solve(&sgb.transpose()).transpose());
        let mut shift = vec![0.0; space.len() * p];
        if let Some(a) = &a {
            // the other targets' offsets (past the fit's space) shift nothing the model keeps
            for (k, &i) in self.free[..geo]
                .iter()
                .enumerate()
                .filter(|(_, &i)| i < fit.len())
            {
                let (block, place) = fit.locate(i);
                if let Some(r) = space.index(block, place) {
                    for (c, &(_, f)) in coeffs.iter().enumerate() {
                        if let Some(f) = f {
                            shift[r * p + c] = a[(k, f)];
                        }
                    }
                }
            }
        }
        let covariance = (0..p * p)
            .map(|e| match (coeffs[e / p].1, coeffs[e % p].1) {
                (Some(a), Some(b)) => scale * sbb[(a, b)],
                (None, None) if e / p == e % p => prior_k * prior_k,
                _ => 0.0,
            })
            .collect();
        JointErrors {
            coefficients: self.model.beta.clone(),
            links: self.model.links,
            calibration_payload: Payload::NONE,
            payload: Payload::NONE,
            free: coeffs.iter().map(|c| c.0).collect(),
            covariance,
            shift_space: space,
            shift: if a.is_some() { shift } else { Vec::new() },
            backlash: None,
        }
    }
}

impl ExtendedFit {
    /// `points` at the angles the joints stood at: commanded plus the fitted deflections, and
    /// half the gap on the side each joint arrived from (the points' sides, else their order)
    /// when the fit keeps the backlash and `sides` (without: the prediction that does not know
    /// them, each joint at the centre of its gap).
    pub fn corrected(&self, points: &[MeasuredPoint], sides: bool) -> Vec<MeasuredPoint> {
        let sides = self.backlash.as_ref().filter(|_| sides).map(|_| {
            let q: Vec<Joints> = points.iter().map(|p| p.q_deg).collect();
            let given: Vec<Option<Joints>> = points.iter().map(|p| p.sides).collect();
            super::approach_directions(&q, &given)
        });
        (points.iter().enumerate())
            .map(|(k, p)| {
                let q = p.q_deg.map(f64::to_radians);
                let mut d = self.model.deflections_at(&q, p.payload_kg);
                if let (Some(b), Some(s)) = (&self.backlash, &sides) {
                    for j in 0..q.len() {
                        d[j] += 0.5 * b.gap_rad[j] * s[k][j];
                    }
                }
                MeasuredPoint {
                    q_deg: Joints::from_fn(q.len(), |i| (q[i] + d[i]).to_degrees()),
                    ..*p
                }
            })
            .collect()
    }
}

/// The payload (kg) most of `points` were measured with (the smallest of those tied).
pub(crate) fn most_common_payload(points: &[MeasuredPoint]) -> f64 {
    let mut counts: Vec<(f64, usize)> = Vec::new();
    for p in points {
        match counts.iter_mut().find(|(m, _)| *m == p.payload_kg) {
            Some((_, c)) => *c += 1,
            None => counts.push((p.payload_kg, 1)),
        }
    }
    counts
        .into_iter()
        .max_by(|a, b| a.1.cmp(&b.1).then(b.0.total_cmp(&a.0)))
        .map_or(0.0, |(m, _)| m)
}
