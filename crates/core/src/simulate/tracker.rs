//! Laser-tracker noise model built on the Leica AT960 specification (paper §3.1, docs/METHOD.md §2).
//!
//! The AT960's accuracy is stated as a maximum permissible error (MPE, ISO 10360-10) of the
//! measured point, `U_xyz = ±(15 µm + 6 µm/m · L)` with `L` the distance from the tracker; its
//! absolute distance meter (ADM, the radial direction) is specified at ±10 µm over the whole
//! range. A tracker measures a point in its own spherical frame: a distance (radial, from the
//! ADM/interferometer) and two angles (transverse, from the angle encoders). The radial error does
//! not grow with distance; the transverse error is an angle error times the distance, which is
//! why the transverse direction is the weaker one.
//!
//! **MPE → σ.** Leica writes that typical errors are half the MPE; we read the MPE as a 2σ bound
//! ([`MPE_SIGMAS`] = 2), so
//!
//! * radial σ_r = 10 µm / 2 = 5 µm, independent of `L`;
//! * transverse σ_t = (15 µm + 6 µm/m · L) / 2 per transverse direction (two of them).
//!
//! A point at 2 m then has σ_t = 13.5 µm and σ_r = 5 µm. Noise is drawn in the tracker's
//! spherical frame (along the line of sight and in the two directions perpendicular to it) and
//! added to the true position.
//!
//! **Placement.** By default the tracker stands at [`DEFAULT_TRACKER_POSITION_MM`]
//! = (2000, −600, 400) mm in the robot base frame: about 2 m in front of and beside the TX60, at
//! a height where it sees the target on all six sweeps (measuring ranges of docs/METHOD.md §1).

use super::standard_normal;
use rand::Rng;

/// Number of standard deviations a maximum permissible error stands for (Leica: typical = MPE/2).
pub const MPE_SIGMAS: f64 = 2.0;
/// Default tracker position in the robot base frame, mm.
pub const DEFAULT_TRACKER_POSITION_MM: [f64; 3] = [2000.0, -600.0, 400.0];

/// A laser tracker's position and accuracy.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct TrackerModel {
    /// Tracker position in the robot base frame, mm.
    pub position_mm: [f64; 3],
    /// Constant part of the point MPE (angle encoders), µm.
    pub mpe_constant_um: f64,
    /// Distance-proportional part of the point MPE, µm per metre.
    pub mpe_per_metre_um: f64,
    /// MPE of the distance meter (radial), µm.
    pub radial_mpe_um: f64,
    /// How many σ an MPE stands for.
    pub mpe_sigmas: f64,
}

impl Default for TrackerModel {
    /// The Leica AT960 at [`DEFAULT_TRACKER_POSITION_MM`], MPE = 2σ.
    fn default() -> Self {
        TrackerModel {
            position_mm: DEFAULT_TRACKER_POSITION_MM,
            mpe_constant_um: 15.0,
            mpe_per_metre_um: 6.0,
            radial_mpe_um: 10.0,
            mpe_sigmas: MPE_SIGMAS,
        }
    }
}

impl TrackerModel {
    /// A noise-free tracker (for tests).
    pub fn perfect() -> Self {
        TrackerModel {
            mpe_constant_um: 0.0,
            mpe_per_metre_um: 0.0,
            radial_mpe_um: 0.0,
            ..Self::default()
        }
    }

    /// `(σ_radial, σ_transverse)` in mm for a point `p` (mm, base frame).
    pub fn sigmas_mm(&self, p: &[f64; 3]) -> (f64, f64) {
        let l_m = self.distance_mm(p) / 1000.0;
        let radial = self.radial_mpe_um / self.mpe_sigmas * 1e-3;
        let transverse =
            (self.mpe_constant_um + self.mpe_per_metre_um * l_m) / self.mpe_sigmas * 1e-3;
        (radial, transverse)
    }

    /// Distance of `p` from the tracker, mm.
    pub fn distance_mm(&self, p: &[f64; 3]) -> f64 {
        (0..3)
            .map(|k| (p[k] - self.position_mm[k]).powi(2))
            .sum::<f64>()
            .sqrt()
    }

    /// The measured position of the true point `p`: radial and two transverse Gaussian errors in
    /// the tracker's spherical frame.
    pub fn measure(&self, p: [f64; 3], rng: &mut impl Rng) -> [f64; 3] {
        let (sr, st) = self.sigmas_mm(&p);
        let v = [
            p[0] - self.position_mm[0],
            p[1] - self.position_mm[1],
            p[2] - self.position_mm[2],
        ];
        let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if l == 0.0 {
            return p;
        }
        let r = v.map(|x| x / l);
        // Transverse basis: horizontal (azimuth) direction and the elevation direction.
        let mut h = [-r[1], r[0], 0.0];
        let hn = (h[0] * h[0] + h[1] * h[1]).sqrt();
        if hn < 1e-12 {
            h = [1.0, 0.0, 0.0];
        } else {
            h = h.map(|x| x / hn);
        }
        let e = [
            r[1] * h[2] - r[2] * h[1],
            r[2] * h[0] - r[0] * h[2],
            r[0] * h[1] - r[1] * h[0],
        ];
        let (zr, zh, ze) = (
            standard_normal(rng),
            standard_normal(rng),
            standard_normal(rng),
        );
        std::array::from_fn(|k| p[k] + sr * zr * r[k] + st * (zh * h[k] + ze * e[k]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn transverse_is_worse_and_grows_with_distance() {
        let t = TrackerModel::default();
        let near = [1500.0, -600.0, 400.0]; // 0.5 m
        let far = [-1000.0, -600.0, 400.0]; // 3 m
        let (r1, t1) = t.sigmas_mm(&near);
        let (r2, t2) = t.sigmas_mm(&far);
        assert!((r1 - 0.005).abs() < 1e-12 && r1 == r2);
        assert!((t1 - 0.009).abs() < 1e-12 && (t2 - 0.0165).abs() < 1e-12);
        // Empirical spread along the line of sight vs across it.
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let (mut sx, mut sy) = (0.0, 0.0);
        let n = 20000;
        for _ in 0..n {
            let m = t.measure(far, &mut rng);
            sx += (m[0] - far[0]).powi(2); // radial (line of sight is along x)
            sy += (m[1] - far[1]).powi(2); // transverse
        }
        let (sx, sy) = ((sx / n as f64).sqrt(), (sy / n as f64).sqrt());
        assert!((sx / 0.005 - 1.0).abs() < 0.05, "{sx}");
        assert!((sy / 0.0165 - 1.0).abs() < 0.05, "{sy}");
        assert_eq!(TrackerModel::perfect().measure(far, &mut rng), far);
    }
}
