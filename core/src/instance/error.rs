//! [`InstanceError`]: why a word array is not a top level over the given bottom scenes.

use super::{HEADER_WORDS, MAX_DEPTH, VERSION};

/// Why a word array is not a top level ([`super::InstancedScene::from_words`]). Each kind of
/// damage has its own variant; `instance` and `node` name the first record or node at fault.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InstanceError {
    /// Fewer words than the header.
    TooShort,
    /// Neither a top level's magic nor a single-mesh scene's.
    BadMagic,
    /// A single-mesh scene ("KDRY"): open it with [`crate::Scene::from_words`], or pass it as a
    /// bottom scene.
    SingleMesh,
    /// Another version of the top level's format: rebuild it with this build's host.
    UnsupportedVersion(u32),
    /// TOTAL_WORDS differs from the array's length (truncated or with trailing data).
    LengthMismatch { header: u32, actual: usize },
    /// The stored checksum is not the words' ([`crate::format::checksum`]): damaged after writing.
    Checksum,
    /// A reserved header word is not zero.
    ReservedNotZero,
    /// No instance or no node, or the counts' words overflow, or TOTAL_WORDS is not the header
    /// plus the two sections.
    BadCounts,
    /// BOTTOM_COUNT is not the number of bottom scenes passed in.
    BottomCount { header: u32, actual: usize },
    /// The header's bounds are not finite or min > max.
    BadBounds,
    /// A record's bottom-scene index is out of range.
    BadBottom { instance: u32 },
    /// A record's transform or inverse has a NaN or infinite entry.
    NonFiniteTransform { instance: u32 },
    /// A record's transform is singular or nearly so ([`super::affine::MIN_DET_RATIO`]).
    Singular { instance: u32 },
    /// A record's inverse is not its transform's ([`super::affine::Affine::inverts`]).
    InverseMismatch { instance: u32 },
    /// A record's box is not finite, misses part of its bottom scene's image, or lies outside
    /// the header's bounds or its slot's box.
    BadInstanceBox { instance: u32 },
    /// The tree is deeper than [`MAX_DEPTH`], or than DEPTH says, or shallower.
    BadDepth,
    /// A node's reference to another node is not the next node the depth-first walk meets (so
    /// backwards, out of range, shared or missing), or the node's count is not 1..=8, a slot past
    /// it is not empty, or a reserved word is set.
    BadChild { node: u32 },
    /// A slot's box in this node is not finite or lies outside the box of the parent's slot that
    /// names the node (or the header's bounds, for the root).
    BadNodeBox { node: u32 },
    /// A slot of this node names a record other than the next one the depth-first walk should
    /// meet, or the slots do not name every record.
    RecordOrder { node: u32 },
}

impl core::fmt::Display for InstanceError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::TooShort => write!(f, "shorter than the {HEADER_WORDS}-word header"),
            Self::BadMagic => write!(f, "not a kdray top level (bad magic)"),
            Self::SingleMesh => write!(
                f,
                "a single-mesh scene, not a top level of instances (open it as a scene)"
            ),
            Self::UnsupportedVersion(v) => write!(
                f,
                "top-level format version {v}, this build reads {VERSION} (rebuild the top level)"
            ),
            Self::LengthMismatch { header, actual } => write!(
                f,
                "header says {header} words, the data has {actual} (truncated or padded)"
            ),
            Self::Checksum => write!(
                f,
                "checksum mismatch: the top level was damaged after it was written"
            ),
            Self::ReservedNotZero => write!(f, "reserved header words are not zero"),
            Self::BadCounts => write!(
                f,
                "instance or node counts are zero or disagree with the length"
            ),
            Self::BottomCount { header, actual } => write!(
                f,
                "the top level indexes {header} bottom scenes, {actual} were given"
            ),
            Self::BadBounds => write!(f, "world bounds are not finite"),
            Self::BadBottom { instance } => {
                write!(f, "instance {instance}: bottom-scene index out of range")
            }
            Self::NonFiniteTransform { instance } => {
                write!(f, "instance {instance}: transform or inverse is not finite")
            }
            Self::Singular { instance } => {
                write!(f, "instance {instance}: transform is singular or nearly so")
            }
            Self::InverseMismatch { instance } => write!(
                f,
                "instance {instance}: stored inverse is not the transform's inverse"
            ),
            Self::BadInstanceBox { instance } => write!(
                f,
                "instance {instance}: world box is not finite or does not contain the instance"
            ),
            Self::BadDepth => write!(f, "tree depth is above {MAX_DEPTH} or wrong"),
            Self::BadChild { node } => write!(
                f,
                "node {node}: a child reference or the slot count breaks the tree's rules"
            ),
            Self::BadNodeBox { node } => write!(
                f,
                "node {node}: a slot's box is not finite or lies outside its parent's"
            ),
            Self::RecordOrder { node } => write!(
                f,
                "node {node}: an instance record out of turn (the slots must name the records in turn)"
            ),
        }
    }
}
