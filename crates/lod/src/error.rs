//! The one error type of the crate: bad input meshes, bad views, bad modes,
//! and fold/unfold requests the cut cannot honour. Every message says what
//! was wrong and where.

/// Everything that can go wrong in this crate.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum LodError {
    /// `VertexTree::build` was given no vertices.
    #[error("the mesh has no vertices; a vertex tree needs at least one")]
    EmptyMesh,

    /// A per-vertex array does not have one entry per vertex.
    #[error("{what} has {got} entries but there are {expected} vertices (one entry per vertex)")]
    LengthMismatch {
        what: &'static str,
        expected: usize,
        got: usize,
    },

    /// A triangle refers to a vertex that does not exist.
    #[error("triangle {triangle} has index {index} ≥ {vertex_count} vertices (corner {corner})")]
    IndexOutOfRange {
        triangle: usize,
        corner: usize,
        index: u32,
        vertex_count: usize,
    },

    /// A coordinate or attribute is NaN or infinite.
    #[error("{what} {index} is not finite ({value}); fix or drop that vertex")]
    NonFinite {
        what: &'static str,
        index: usize,
        value: String,
    },

    /// Luminance is in cd/m² and cannot be negative.
    #[error("luminance {index} is {value} cd/m²; luminance must be ≥ 0")]
    NegativeLuminance { index: usize, value: f32 },

    /// The input exceeds the size cap of `BuildOptions` (checked before
    /// anything is allocated).
    #[error("{what}: {count} exceeds the limit of {max}; raise BuildOptions::{field} if the memory is there")]
    TooLarge {
        what: &'static str,
        field: &'static str,
        count: usize,
        max: usize,
    },

    /// A `View` field makes no sense (NaN, infinite, out of range).
    #[error("view: {field} is {value}: {reason}")]
    InvalidView {
        field: &'static str,
        value: String,
        reason: &'static str,
    },

    /// A `Mode` parameter makes no sense.
    #[error("mode: {field} is {value}: {reason}")]
    InvalidMode {
        field: &'static str,
        value: String,
        reason: &'static str,
    },

    /// A node id that the tree does not have.
    #[error("node {node} does not exist (the tree has {node_count} nodes)")]
    NoSuchNode { node: u32, node_count: usize },

    /// `fold`/`unfold` asked for something the cut's current state forbids.
    #[error("cannot {op} node {node}: {reason}")]
    InvalidOperation {
        op: &'static str,
        node: u32,
        reason: &'static str,
    },
}
