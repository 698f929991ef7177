//! [`FormatError`]: why a word array is not a scene.

use super::{HEADER_WORDS, MAX_DEPTH, VERSION};

/// Why a word array is not a scene. Each kind of corruption has its own variant.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FormatError {
    /// Fewer words than the header.
    TooShort,
    BadMagic,
    /// A top level of instances ("KDRI", `kdray_core::instance`), not a single-mesh scene: it is
    /// opened with `InstancedScene::from_words` beside the scenes it places.
    TopLevel,
    UnsupportedVersion(u32),
    /// CONTENTS has bits this version does not define, or disagrees with the counts/offsets.
    BadContents,
    /// CONTENTS has the bit of the cache-line blocks section (formats 7 to 11), retired in format
    /// 12 because the wide nodes walk single rays faster: rebuild the file with `kdray build`
    /// (`--layout wide`, the default).
    BlocksRetired,
    /// The scene stores triangle groups, and this build of the core was compiled without them
    /// (its `groups` feature): rebuild the tree with `kdray build --leaves list`.
    GroupsLeftOut,
    /// TOTAL_WORDS differs from the array's length (truncated or with trailing data).
    LengthMismatch {
        header: u32,
        actual: usize,
    },
    /// The stored checksum is not the words' [`checksum`](crate::format::checksum): the file was damaged after writing.
    Checksum,
    /// A reserved header word is not zero.
    ReservedNotZero,
    /// A count times its stride overflows `usize`, or the primitive total overflows `u32`.
    CountOverflow,
    /// A section starts inside the header, is misaligned or runs past the end.
    SectionOutOfBounds,
    /// Two sections share words.
    SectionsOverlap,
    /// The scene bounds are not finite or min > max.
    BadBounds,
    /// A triangle, sphere, normal or texture coordinate is NaN or infinite, a radius ≤ 0, a
    /// triangle's stored threshold is not the one its vertices give, or a triangle is too large
    /// for f32 ([`Triangle::is_too_large`](crate::Triangle::is_too_large)).
    NonFiniteGeometry,
    /// A hittable triangle (finite threshold) or a sphere reaches outside the header's bounds.
    OutsideBounds {
        prim: u32,
    },
    /// The tree has no node, or its depth exceeds [`MAX_DEPTH`] or disagrees with DEPTH.
    BadDepth,
    /// An interior node's split is not finite or lies outside the scene bounds.
    BadSplit {
        node: u32,
    },
    /// A child index is not greater than its parent's, is out of range, or the nodes are not one
    /// tree in depth-first order (a shared or skipped node).
    BadChild {
        node: u32,
    },
    /// An interior node's empty-child bits do not say exactly which children are empty leaves.
    BadEmptyFlag {
        node: u32,
    },
    /// A leaf references a primitive or an index-list range that does not exist.
    BadPrimitive {
        node: u32,
    },
    /// An entry of the primitive-index list is not below the primitive count.
    BadIndex {
        index: u32,
    },
    /// A leaf's index-list range does not start where the previous leaf's (in node order) ends:
    /// ranges shared, overlapping or out of order (see "Cost of validation" in
    /// [`crate::format`]).
    IndexOrder {
        node: u32,
    },
    /// The leaves' index-list ranges end before the list does (entries no leaf uses).
    UnusedIndices {
        from: u32,
    },
    /// A leaf's triangle group is not the one its ids' triangle records make
    /// ([`crate::group`]): different vertices or threshold, or bad padding.
    BadGroup {
        node: u32,
    },
    /// A wide node is entered out of turn, its count, orders or unused slots are not of the
    /// format's shape, or a leaf reference is not the node tree's next leaf
    /// ([`crate::format::wide::validate`]).
    BadWideNode {
        node: u32,
    },
    /// A wide node's box is not finite, lies outside its parent's box, or does not contain what
    /// its child holds.
    BadWideBox {
        node: u32,
    },
    /// A non-empty leaf of the node tree is the child of no wide node: the wide walk would never
    /// test its primitives.
    WideLeafLeftOut {
        leaf: u32,
    },
    /// An input id is not below the triangle count.
    BadInputId {
        triangle: u32,
    },
}

impl core::fmt::Display for FormatError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::TooShort => write!(f, "shorter than the {HEADER_WORDS}-word header"),
            Self::BadMagic => write!(f, "not a kdray scene (bad magic)"),
            Self::TopLevel => write!(
                f,
                "a top level of instances, not a single-mesh scene (open it with \
                 `InstancedScene::from_words` and the scenes it places)"
            ),
            Self::UnsupportedVersion(v) => {
                write!(
                    f,
                    "format version {v}, this build reads {VERSION} (rebuild the file with `kdray build`)"
                )
            }
            Self::BadContents => write!(f, "contents bits disagree with the sections"),
            Self::BlocksRetired => write!(
                f,
                "the tree carries a cache-line blocks section (`--layout blocked`), retired in \
                 format 12: rebuild it with `kdray build` (`--layout wide`, the default)"
            ),
            Self::GroupsLeftOut => write!(
                f,
                "the tree stores triangle groups, which this build leaves out (kdray-core's \
                 `groups` feature): rebuild it with `kdray build --leaves list`"
            ),
            Self::LengthMismatch { header, actual } => {
                write!(
                    f,
                    "header says {header} words, the data has {actual} (truncated or padded)"
                )
            }
            Self::Checksum => write!(
                f,
                "checksum mismatch: the file was damaged after it was written (rebuild it with `kdray build`)"
            ),
            Self::ReservedNotZero => write!(f, "reserved header words are not zero"),
            Self::CountOverflow => write!(f, "a count overflows"),
            Self::SectionOutOfBounds => {
                write!(f, "a section lies outside the data or is misaligned")
            }
            Self::SectionsOverlap => write!(f, "two sections overlap"),
            Self::BadBounds => write!(f, "scene bounds are not finite"),
            Self::NonFiniteGeometry => {
                write!(
                    f,
                    "geometry has NaN/infinite values, a radius <= 0, a triangle too large for \
                     f32 or a wrong stored threshold"
                )
            }
            Self::BadDepth => write!(f, "tree depth is zero-sized, above {MAX_DEPTH} or wrong"),
            Self::OutsideBounds { prim } => {
                write!(f, "primitive {prim} lies outside the scene bounds")
            }
            Self::BadSplit { node } => {
                write!(
                    f,
                    "node {node}: split plane is not finite or outside the bounds"
                )
            }
            Self::BadChild { node } => write!(f, "node {node}: child index breaks the tree order"),
            Self::BadEmptyFlag { node } => {
                write!(
                    f,
                    "node {node}: empty-child flags disagree with its children"
                )
            }
            Self::BadPrimitive { node } => {
                write!(f, "node {node}: primitive reference out of range")
            }
            Self::BadIndex { index } => {
                write!(f, "primitive-index entry {index} is out of range")
            }
            Self::IndexOrder { node } => write!(
                f,
                "node {node}: index-list range is shared or out of order (leaves must use the list in turn)"
            ),
            Self::BadWideNode { node } => write!(
                f,
                "wide node {node}: entered out of turn, a malformed order or unused slot, or not the node tree's next leaf"
            ),
            Self::BadWideBox { node } => write!(
                f,
                "wide node {node}: a box is not finite, lies outside its parent's or misses what its child holds"
            ),
            Self::WideLeafLeftOut { leaf } => {
                write!(f, "node {leaf}: a leaf that no wide node references")
            }
            Self::BadGroup { node } => write!(
                f,
                "node {node}: a triangle group differs from the triangles it names"
            ),
            Self::UnusedIndices { from } => {
                write!(
                    f,
                    "primitive-index entries from {from} on are used by no leaf"
                )
            }
            Self::BadInputId { triangle } => {
                write!(f, "triangle {triangle}: input id out of range")
            }
        }
    }
}
