//! The input space: every uncertain input of a draw, in typed blocks, and the one place that
//! knows their order, names, units, normal slots and where each acts on the chain.
//!
//! A draw perturbs the forward kinematics through [`Block`]s: the `5n` MDH parameters
//! ([`Block::Joints`]), the tool point in the flange frame ([`Block::Tool`]) and the robot's
//! placement in the measurement frame ([`Block::Placement`]). An [`InputSpace`] is an ordered
//! set of them for an `n`-joint model — the inputs a covariance covers, a sampler draws, an
//! identification estimates — and answers every index question: where a block's inputs lie
//! ([`InputSpace::range`]), what input `i` is called and in which unit the files write it
//! ([`InputSpace::name`], [`InputSpace::quantity`]), and which standard normal of a draw feeds it
//! ([`InputSpace::slot`]).
//!
//! # Normal slots are append-only
//!
//! Input `k` of block `B` always uses normal number `offset(B) + k`, where `offset(B)` is the
//! summed length of the blocks before `B` in [`Block::ALL`] (the canonical order), whatever
//! subset a space holds. A block added to the end of [`Block::ALL`] therefore never moves the
//! normal of an older one: a six-joint model draws its parameters from normals 0–29, its tool
//! from 30–32 and its placement from 33–38, as before blocks existed (docs/METHOD.md §6, §14).
//!
//! # Adding an error source
//!
//! A new block kind is one variant here (its length, names, quantities, [`Action`]), one
//! application per [`Action`] in each of the three kernels (the f64 point form
//! `engine::placement`, the f64 lanes `engine::cpu`, the WGSL shader) and its lines in the model
//! file; docs/ARCHITECTURE.md, "Adding an error source", walks one through.
//!
//! # Examples
//!
//! ```
//! use gpu_amcs_core::kinematics::{Block, InputSpace, Quantity};
//!
//! // A six-joint model identified in a tracker's frame: 30 parameters, tool, placement.
//! let space = InputSpace::measured(6);
//! assert_eq!(space.len(), 39);
//! assert_eq!(space.range(Block::Tool), Some(30..33));
//! assert_eq!(space.name(31), "tool_y");
//! assert_eq!(space.quantity(36), Quantity::Angle); // base_roll
//! assert_eq!(space.find("base_yaw"), Some(38));
//!
//! // Without the tool block the placement keeps its normals (33–38), not its positions.
//! let no_tool = InputSpace::new(6, &[Block::Joints, Block::Placement]).unwrap();
//! assert_eq!(no_tool.range(Block::Placement), Some(30..36));
//! assert_eq!(no_tool.slot(30), 33);
//! ```

use std::ops::Range;

use super::index::{param_joint, param_kind, MAX_JOINTS, MIN_JOINTS, PARAMS_PER_JOINT};

/// One kind of uncertain input of a draw. [`Block::ALL`] is the canonical order: the order of the
/// blocks in every [`InputSpace`] and of their normal slots.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Block {
    /// The `5n` MDH parameters, joint-major `[θ, d, a, α, β]` (mm, angles in rad inside, deg
    /// in files).
    Joints,
    /// The tool point's x, y, z in the flange frame (mm).
    Tool,
    /// The placement of the robot's base in the measurement frame: x, y, z (mm), roll, pitch,
    /// yaw (rad inside, deg in files), the model file's `base` convention.
    Placement,
}

/// Where a block's inputs act on the chain `B · T_1(q_1) ⋯ T_n(q_n) · p_tool`. Each kernel (the
/// f64 point form, the f64 lanes, the WGSL shader) applies each action once.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Action {
    /// The link transforms `T_i` (MDH parameters).
    LinkTransform,
    /// The point carried by the flange (`p_tool`).
    FlangeOffset,
    /// The transform `B` from the base frame to the measurement frame.
    BaseTransform,
}

/// What an input measures, so its unit: lengths in mm, angles in radians inside the crate and
/// degrees in files and reports.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quantity {
    /// A length, mm.
    Length,
    /// An angle: radians inside, degrees in files.
    Angle,
}

impl Quantity {
    /// Factor from file units (mm, deg) to internal units (mm, rad).
    pub fn to_internal(self) -> f64 {
        match self {
            Quantity::Length => 1.0,
            Quantity::Angle => std::f64::consts::PI / 180.0,
        }
    }

    /// Factor from internal units to file units (rad → deg for angles).
    pub fn from_internal(self) -> f64 {
        match self {
            Quantity::Length => 1.0,
            Quantity::Angle => 180.0 / std::f64::consts::PI,
        }
    }

    /// The unit files and reports write: `mm` or `deg`.
    pub fn file_unit(self) -> &'static str {
        match self {
            Quantity::Length => "mm",
            Quantity::Angle => "deg",
        }
    }
}

const PLACEMENT_NAMES: [&str; 6] = ["x", "y", "z", "roll", "pitch", "yaw"];
const TOOL_NAMES: [&str; 3] = ["x", "y", "z"];

impl Block {
    /// Every block kind, in canonical order.
    pub const ALL: [Block; 3] = [Block::Joints, Block::Tool, Block::Placement];

    /// The name the model file's `covariance.blocks` and reports use.
    pub const fn name(self) -> &'static str {
        match self {
            Block::Joints => "joints",
            Block::Tool => "tool",
            Block::Placement => "placement",
        }
    }

    /// The block called `name` ([`Block::name`]), if any.
    pub fn from_name(name: &str) -> Option<Block> {
        Block::ALL.into_iter().find(|b| b.name() == name)
    }

    /// The names of every block kind, comma-separated, for messages.
    pub fn known_names() -> String {
        Block::ALL.map(Block::name).join(", ")
    }

    /// Number of inputs of the block for an `joints`-joint model.
    pub const fn len(self, joints: usize) -> usize {
        match self {
            Block::Joints => PARAMS_PER_JOINT * joints,
            Block::Tool => TOOL_NAMES.len(),
            Block::Placement => PLACEMENT_NAMES.len(),
        }
    }

    /// Where the block acts on the chain.
    pub const fn action(self) -> Action {
        match self {
            Block::Joints => Action::LinkTransform,
            Block::Tool => Action::FlangeOffset,
            Block::Placement => Action::BaseTransform,
        }
    }

    /// What input `k` of the block measures.
    pub fn quantity(self, k: usize) -> Quantity {
        match self {
            Block::Joints if param_kind(k).is_angle() => Quantity::Angle,
            Block::Placement if k >= 3 => Quantity::Angle,
            _ => Quantity::Length,
        }
    }

    /// The name of input `k` of the block as reports spell it: `theta2`, `d1` (1-based joint),
    /// `tool_x`, `base_roll`.
    pub fn input_name(self, k: usize) -> String {
        match self {
            Block::Joints => format!("{}{}", param_kind(k).name(), param_joint(k) + 1),
            Block::Tool => format!("tool_{}", TOOL_NAMES[k]),
            Block::Placement => format!("base_{}", PLACEMENT_NAMES[k]),
        }
    }

    /// How reports name the block as a group of inputs (sensitivity groups, notes).
    pub const fn label(self) -> &'static str {
        match self {
            Block::Joints => "MDH parameters",
            Block::Tool => "tool",
            Block::Placement => "base placement",
        }
    }

    /// What the block holds, in words, for file comments and messages.
    pub const fn description(self) -> &'static str {
        match self {
            Block::Joints => "the MDH parameters, joint-major [theta, d, a, alpha, beta]",
            Block::Tool => "the tool's x, y, z",
            Block::Placement => {
                "the base placement's x, y, z and roll, pitch, yaw (the `base` field's convention)"
            }
        }
    }

    /// Position of the block in [`Block::ALL`].
    const fn rank(self) -> usize {
        match self {
            Block::Joints => 0,
            Block::Tool => 1,
            Block::Placement => 2,
        }
    }

    /// First normal slot of the block for an `joints`-joint model: the summed length of the
    /// blocks before it in [`Block::ALL`].
    const fn slot_offset(self, joints: usize) -> usize {
        let mut s = 0;
        let mut r = 0;
        while r < self.rank() {
            s += Block::ALL[r].len(joints);
            r += 1;
        }
        s
    }
}

/// Most inputs of any space: every block of a [`MAX_JOINTS`]-joint model (44), so also the
/// number of normal slots a draw has.
pub const MAX_INPUTS: usize = {
    let mut s = 0;
    let mut r = 0;
    while r < Block::ALL.len() {
        s += Block::ALL[r].len(MAX_JOINTS);
        r += 1;
    }
    s
};

/// Most inputs of a draw in the robot's base frame ([`InputSpace::robot`] of a [`MAX_JOINTS`]-joint
/// model: 38): the width of the evaluators' fixed-size offset arrays.
pub const MAX_ROBOT_INPUTS: usize = Block::Joints.len(MAX_JOINTS) + Block::Tool.len(MAX_JOINTS);

/// Errors naming an input space.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum InputSpaceError {
    /// A block name no block kind has.
    #[error("unknown block '{name}' (known: {known})", known = Block::known_names())]
    UnknownBlock {
        /// The name given.
        name: String,
    },
    /// The blocks are not in canonical order, repeat one, or leave out the joints.
    #[error("the blocks must start with \"joints\" and follow the order {order} without repeats, found [{found}]",
        order = Block::known_names())]
    Order {
        /// The names given, comma-separated.
        found: String,
    },
}

/// An ordered set of [`Block`]s for an `n`-joint model: the inputs of a covariance, a draw or a
/// fit (see the module docs). Always starts with [`Block::Joints`]; the blocks follow
/// [`Block::ALL`]'s order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct InputSpace {
    joints: u8,
    /// Bit `Block::rank` set for each block held.
    mask: u8,
}

impl InputSpace {
    /// The space of `blocks` for an `joints`-joint model.
    ///
    /// # Errors
    ///
    /// [`InputSpaceError::Order`] when `blocks` does not start with [`Block::Joints`], repeats a
    /// block or breaks [`Block::ALL`]'s order.
    ///
    /// # Panics
    ///
    /// When `joints` is not within 4..=7 (checked where a model is read).
    pub fn new(joints: usize, blocks: &[Block]) -> Result<InputSpace, InputSpaceError> {
        assert!(
            (MIN_JOINTS..=MAX_JOINTS).contains(&joints),
            "{joints} joints: a model has {MIN_JOINTS} to {MAX_JOINTS}"
        );
        let ordered = blocks.first() == Some(&Block::Joints)
            && blocks.windows(2).all(|w| w[0].rank() < w[1].rank());
        if !ordered {
            return Err(InputSpaceError::Order {
                found: blocks
                    .iter()
                    .map(|b| format!("\"{}\"", b.name()))
                    .collect::<Vec<_>>()
                    .join(", "),
            });
        }
        Ok(InputSpace {
            joints: joints as u8,
            mask: blocks.iter().fold(0, |m, b| m | 1 << b.rank()),
        })
    }

    /// The space of the blocks named `names` ([`Block::name`]).
    ///
    /// # Errors
    ///
    /// [`InputSpaceError::UnknownBlock`] naming the first unknown name, else as
    /// [`InputSpace::new`].
    pub fn from_names<S: AsRef<str>>(
        joints: usize,
        names: &[S],
    ) -> Result<InputSpace, InputSpaceError> {
        let blocks = names
            .iter()
            .map(|n| {
                Block::from_name(n.as_ref()).ok_or_else(|| InputSpaceError::UnknownBlock {
                    name: n.as_ref().to_string(),
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        InputSpace::new(joints, &blocks)
    }

    fn of_ranks(joints: usize, mask: u8) -> InputSpace {
        assert!((MIN_JOINTS..=MAX_JOINTS).contains(&joints));
        InputSpace {
            joints: joints as u8,
            mask,
        }
    }

    /// The MDH parameters alone.
    pub fn parameters(joints: usize) -> InputSpace {
        InputSpace::of_ranks(joints, 0b001)
    }

    /// The inputs of the robot in its own base frame: the parameters and the tool point (33 for
    /// six joints). Offset rows and drawn models without a placement have this width.
    pub fn robot(joints: usize) -> InputSpace {
        InputSpace::of_ranks(joints, 0b011)
    }

    /// The inputs in a measurement frame: the parameters, the tool point and the placement (39
    /// for six joints), as a whole-chain identification from tracker data estimates them.
    pub fn measured(joints: usize) -> InputSpace {
        InputSpace::of_ranks(joints, 0b111)
    }

    /// Number of joints of the model.
    pub const fn joints(self) -> usize {
        self.joints as usize
    }

    /// Whether the space holds `block`.
    pub const fn has(self, block: Block) -> bool {
        self.mask & (1 << block.rank()) != 0
    }

    /// The blocks held, in order.
    pub fn blocks(self) -> impl Iterator<Item = Block> + Clone {
        Block::ALL.into_iter().filter(move |b| self.has(*b))
    }

    /// The names of the blocks held ([`Block::name`]), in order.
    pub fn block_names(self) -> Vec<&'static str> {
        self.blocks().map(Block::name).collect()
    }

    /// The space with `block` added (or kept).
    pub fn with(self, block: Block) -> InputSpace {
        InputSpace {
            mask: self.mask | 1 << block.rank(),
            ..self
        }
    }

    /// The space with `block` removed; the joints stay.
    pub fn without(self, block: Block) -> InputSpace {
        if block == Block::Joints {
            return self;
        }
        InputSpace {
            mask: self.mask & !(1 << block.rank()),
            ..self
        }
    }

    /// Number of inputs.
    pub fn len(self) -> usize {
        self.blocks().map(|b| b.len(self.joints())).sum()
    }

    /// Whether the space has no inputs (never: it always holds the joints).
    pub fn is_empty(self) -> bool {
        self.len() == 0
    }

    /// Positions of `block`'s inputs in this space, or `None` when the space lacks it.
    pub fn range(self, block: Block) -> Option<Range<usize>> {
        let mut start = 0;
        for b in self.blocks() {
            let len = b.len(self.joints());
            if b == block {
                return Some(start..start + len);
            }
            start += len;
        }
        None
    }

    /// Position of input `k` of `block`, or `None` when the space lacks the block.
    pub fn index(self, block: Block, k: usize) -> Option<usize> {
        debug_assert!(k < block.len(self.joints()));
        self.range(block).map(|r| r.start + k)
    }

    /// The block of input `i` and its place `k` within it.
    ///
    /// # Panics
    ///
    /// When `i >= self.len()`.
    pub fn locate(self, i: usize) -> (Block, usize) {
        let mut start = 0;
        for b in self.blocks() {
            let len = b.len(self.joints());
            if i < start + len {
                return (b, i - start);
            }
            start += len;
        }
        panic!("input {i} of a space of {} inputs", self.len())
    }

    /// The name of input `i` ([`Block::input_name`]).
    pub fn name(self, i: usize) -> String {
        let (b, k) = self.locate(i);
        b.input_name(k)
    }

    /// Every input's name, in order.
    pub fn names(self) -> Vec<String> {
        (0..self.len()).map(|i| self.name(i)).collect()
    }

    /// Position of the input called `name` ([`InputSpace::name`]).
    pub fn find(self, name: &str) -> Option<usize> {
        (0..self.len()).find(|&i| self.name(i) == name)
    }

    /// What input `i` measures.
    pub fn quantity(self, i: usize) -> Quantity {
        let (b, k) = self.locate(i);
        b.quantity(k)
    }

    /// Whether input `i` is an angle.
    pub fn is_angle(self, i: usize) -> bool {
        self.quantity(i) == Quantity::Angle
    }

    /// Factor from file units to internal units of input `i` (deg → rad for angles).
    pub fn to_internal(self, i: usize) -> f64 {
        self.quantity(i).to_internal()
    }

    /// Factor from internal units to file units of input `i` (rad → deg for angles).
    pub fn from_internal(self, i: usize) -> f64 {
        self.quantity(i).from_internal()
    }

    /// The joint input `i` belongs to (0-based) for the parameters; `None` for the other blocks.
    pub fn joint_of(self, i: usize) -> Option<usize> {
        match self.locate(i) {
            (Block::Joints, k) => Some(param_joint(k)),
            _ => None,
        }
    }

    /// The standard normal (slot) of a draw that feeds input `i` (see the module docs).
    pub fn slot(self, i: usize) -> usize {
        let (b, k) = self.locate(i);
        b.slot_offset(self.joints()) + k
    }

    /// The normal slots of `block` for this model's joint count (whether or not the space
    /// holds it).
    pub fn slot_range(self, block: Block) -> Range<usize> {
        let s = block.slot_offset(self.joints());
        s..s + block.len(self.joints())
    }

    /// Position in this space of the input that sits at position `i` of `other` (a space of the
    /// same joint count), or `None` when this space lacks its block.
    pub fn position_of(self, other: InputSpace, i: usize) -> Option<usize> {
        let (b, k) = other.locate(i);
        self.index(b, k)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The canonical spaces have today's sizes and names, and every input's slot equals its
    /// position in the full space (the normals drawn before blocks existed).
    #[test]
    fn canonical_spaces_keep_the_historic_layout() {
        for n in MIN_JOINTS..=MAX_JOINTS {
            let (p, r, m) = (
                InputSpace::parameters(n),
                InputSpace::robot(n),
                InputSpace::measured(n),
            );
            assert_eq!((p.len(), r.len(), m.len()), (5 * n, 5 * n + 3, 5 * n + 9));
            for i in 0..m.len() {
                assert_eq!(m.slot(i), i);
                assert_eq!(m.find(&m.name(i)), Some(i));
                if i < r.len() {
                    assert_eq!(r.name(i), m.name(i));
                    assert_eq!(r.slot(i), i);
                }
            }
            assert_eq!(m.range(Block::Placement), Some(5 * n + 3..5 * n + 9));
            assert_eq!(r.range(Block::Placement), None);
            assert_eq!(m.joint_of(5 * n), None);
            assert_eq!(m.joint_of(5 * n - 1), Some(n - 1));
        }
        assert_eq!(MAX_INPUTS, 44);
        let six = InputSpace::measured(6);
        assert_eq!(six.name(0), "theta1");
        assert_eq!(six.name(31), "tool_y");
        assert_eq!(six.name(38), "base_yaw");
        assert!(six.is_angle(0) && !six.is_angle(1) && six.is_angle(36) && !six.is_angle(35));
    }

    #[test]
    fn names_order_and_unknown_blocks_are_checked() {
        let s = InputSpace::from_names(6, &["joints", "tool", "placement"]).unwrap();
        assert_eq!(s, InputSpace::measured(6));
        assert_eq!(s.block_names(), ["joints", "tool", "placement"]);
        let e = InputSpace::from_names(6, &["joints", "compliance"]).unwrap_err();
        assert_eq!(
            e.to_string(),
            "unknown block 'compliance' (known: joints, tool, placement)"
        );
        for bad in [
            &["tool", "joints"][..],
            &["joints", "joints"],
            &["joints", "placement", "tool"],
            &[],
        ] {
            let e = InputSpace::from_names(6, bad).unwrap_err();
            assert!(matches!(e, InputSpaceError::Order { .. }), "{bad:?}: {e}");
        }
    }

    #[test]
    fn a_space_without_a_block_keeps_the_slots_of_the_others() {
        let s = InputSpace::new(7, &[Block::Joints, Block::Placement]).unwrap();
        assert_eq!(s.len(), 41);
        assert_eq!(s.locate(35), (Block::Placement, 0));
        assert_eq!(s.slot(35), 38);
        assert_eq!(s.slot_range(Block::Tool), 35..38);
        assert_eq!(s.position_of(InputSpace::measured(7), 40), Some(37));
        assert_eq!(s.position_of(InputSpace::measured(7), 36), None);
        assert_eq!(InputSpace::measured(7).without(Block::Tool), s);
        assert_eq!(s.with(Block::Tool), InputSpace::measured(7));
    }
}
