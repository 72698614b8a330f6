//! When the whole-chain identification fits joint errors beyond the geometry (docs/METHOD.md §19).

use serde::Serialize;

/// When the identification fits joint errors beyond the geometry (compliance under gravity and
/// gear harmonics, [`super::BeyondGeometry`]); [`JointErrorFit::Auto`] and [`JointErrorFit::On`]
/// keep them in the model only when the cross-validated check says they predict held-out poses
/// better, [`JointErrorFit::Keep`] always, [`JointErrorFit::Check`] and [`JointErrorFit::Off`]
/// never.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum JointErrorFit {
    /// Geometry alone; no check.
    Off,
    /// The check runs when the geometric fit shows a lack of fit: a stated noise rejected by
    /// the χ² test, or a noise that is not stated (the residuals then cannot tell, and the
    /// cross-validation decides).
    #[default]
    Auto,
    /// The check always runs.
    On,
    /// The check always runs and the model keeps the joint errors whatever it finds (for a
    /// payload what-if on data that do not show the compliance: an undetermined compliance
    /// keeps its prior σ).
    Keep,
    /// The check always runs and is reported, and the model keeps the geometry alone (what
    /// several runs get when asked for the check: their mean model holds no joint errors).
    Check,
}

impl JointErrorFit {
    /// The name in reports and on the command line.
    pub fn as_str(self) -> &'static str {
        match self {
            JointErrorFit::Off => "off",
            JointErrorFit::Auto => "auto",
            JointErrorFit::On => "on",
            JointErrorFit::Keep => "keep",
            JointErrorFit::Check => "check",
        }
    }

    /// Whether the model keeps the joint errors whose check found that they `predict_better`.
    pub fn keeps(self, predict_better: bool) -> bool {
        match self {
            JointErrorFit::Off | JointErrorFit::Check => false,
            JointErrorFit::Auto | JointErrorFit::On => predict_better,
            JointErrorFit::Keep => true,
        }
    }

    /// Whether it was asked for explicitly (the check then also fits a backlash per joint).
    pub fn explicit(self) -> bool {
        matches!(
            self,
            JointErrorFit::On | JointErrorFit::Keep | JointErrorFit::Check
        )
    }

    /// Checks harmonic orders per joint ([`super::ChainOptions::harmonic_orders`]) set with this
    /// mode for a model of `joints` joints ([`check_harmonic_orders`]; with [`JointErrorFit::Off`]
    /// they have no effect, which is an error too).
    ///
    /// # Errors
    ///
    /// What is wrong with them, in a sentence that does not name the setting.
    pub fn check_orders(self, orders: &[u8], joints: usize) -> Result<(), String> {
        if self == JointErrorFit::Off {
            return Err("has no effect when no joint errors are fitted beyond geometry".into());
        }
        check_harmonic_orders(orders, joints)
    }

    /// Whether the check runs for a geometric fit whose lack of fit test gave `found` (`None`:
    /// the noise is not stated).
    pub fn checks(self, found: Option<bool>) -> bool {
        match self {
            JointErrorFit::Off => false,
            JointErrorFit::Auto => found != Some(false),
            JointErrorFit::On | JointErrorFit::Keep | JointErrorFit::Check => true,
        }
    }
}

/// The highest order of the gear harmonics a model holds (`sin kq, cos kq`, k = 1, 2).
pub const MAX_HARMONIC_ORDER: u8 = 2;

/// Checks harmonic orders per joint ([`super::ChainOptions::harmonic_orders`]) for a model of
/// `joints` joints: one per joint, each at most [`MAX_HARMONIC_ORDER`]; the error says what is
/// wrong.
///
/// # Errors
///
/// Another count than `joints`, or an order above [`MAX_HARMONIC_ORDER`]: the message says
/// which, without naming the setting.
pub fn check_harmonic_orders(orders: &[u8], joints: usize) -> Result<(), String> {
    if orders.len() != joints {
        return Err(format!(
            "needs one order per joint ({joints}), found {}",
            orders.len()
        ));
    }
    match orders.iter().position(|&o| o > MAX_HARMONIC_ORDER) {
        Some(j) => Err(format!(
            "J{}: order {} (the model holds the harmonics of orders 1 to {MAX_HARMONIC_ORDER}; 0 for none)",
            j + 1,
            orders[j]
        )),
        None => Ok(()),
    }
}
