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
        /// Which array (`normals`, `luminance`).
        what: &'static str,
        /// Its expected length: the vertex count.
        expected: usize,
        /// Its length.
        got: usize,
    },

    /// A triangle refers to a vertex that does not exist.
    #[error("triangle {triangle} has index {index} ≥ {vertex_count} vertices (corner {corner})")]
    IndexOutOfRange {
        /// The triangle's index.
        triangle: usize,
        /// Which corner (0, 1 or 2).
        corner: usize,
        /// The vertex index it holds.
        index: u32,
        /// Vertices in the mesh.
        vertex_count: usize,
    },

    /// A coordinate or attribute is NaN or infinite.
    #[error("{what} {index} is not finite ({value}); fix or drop that vertex")]
    NonFinite {
        /// What is not finite (`position`, `normal`, `luminance`).
        what: &'static str,
        /// The vertex.
        index: usize,
        /// The value as given, formatted.
        value: String,
    },

    /// Luminance is in cd/m² and cannot be negative.
    #[error("luminance {index} is {value} cd/m²; luminance must be ≥ 0")]
    NegativeLuminance {
        /// The vertex.
        index: usize,
        /// Its luminance, cd/m².
        value: f32,
    },

    /// The input exceeds the size cap of `BuildOptions` (checked before
    /// anything is allocated).
    #[error("{what}: {count} exceeds the limit of {max}; raise BuildOptions::{field} if the memory is there")]
    TooLarge {
        /// What is too large, as the message names it.
        what: &'static str,
        /// The `BuildOptions` field that sets the limit.
        field: &'static str,
        /// How many the input has.
        count: usize,
        /// The limit.
        max: usize,
    },

    /// A `View` field makes no sense (NaN, infinite, out of range).
    #[error("view: {field} is {value}: {reason}")]
    InvalidView {
        /// The `View` field.
        field: &'static str,
        /// The value as given, formatted.
        value: String,
        /// What would be accepted.
        reason: &'static str,
    },

    /// A `Mode` parameter makes no sense.
    #[error("mode: {field} is {value}: {reason}")]
    InvalidMode {
        /// The `Mode` parameter.
        field: &'static str,
        /// The value as given, formatted.
        value: String,
        /// What would be accepted.
        reason: &'static str,
    },

    /// A node id that the tree does not have.
    #[error("node {node} does not exist (the tree has {node_count} nodes)")]
    NoSuchNode {
        /// The id asked for.
        node: u32,
        /// Nodes in the tree (ids are `0..node_count`).
        node_count: usize,
    },

    /// `fold`/`unfold` asked for something the cut's current state forbids.
    #[error("cannot {op} node {node}: {reason}")]
    InvalidOperation {
        /// The operation refused (`fold`, `unfold`).
        op: &'static str,
        /// The node it was asked for.
        node: u32,
        /// Why the cut's current state forbids it.
        reason: &'static str,
    },
}
