//! The other targets of a fit with several targets measured at each pose (see the parent
//! module): their offsets in the flange frame.

/// Most targets measured at one pose that a fit takes (the model's target and seven others).
pub const MAX_TARGETS: usize = 8;

/// The offsets (flange frame, mm) of the targets after the first, when several targets were
/// measured at each pose (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct OtherTargets {
    count: u8,
    pub(super) offsets: [[f64; 3]; MAX_TARGETS - 1],
}

impl OtherTargets {
    /// No other target: one target per pose.
    pub const NONE: OtherTargets = OtherTargets {
        count: 0,
        offsets: [[0.0; 3]; MAX_TARGETS - 1],
    };

    /// `offsets` as the other targets (at most [`MAX_TARGETS`] − 1; more are dropped).
    pub fn new(offsets: &[[f64; 3]]) -> OtherTargets {
        let mut o = OtherTargets::NONE;
        for (k, x) in offsets.iter().take(MAX_TARGETS - 1).enumerate() {
            o.offsets[k] = *x;
            o.count += 1;
        }
        o
    }

    /// Number of other targets.
    pub fn len(&self) -> usize {
        self.count as usize
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// The offsets, in order.
    pub fn offsets(&self) -> &[[f64; 3]] {
        &self.offsets[..self.len()]
    }
}
