//! Scene and mesh errors: they name the file, the line where known, and the field.

/// Why a scene or mesh cannot be used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SceneError {
    /// A mesh's data is unusable.
    #[error("{origin}{}: {message}", line.map(|l| format!(":{l}")).unwrap_or_default())]
    Mesh {
        /// The mesh file (or generated mesh) the error is about.
        origin: String,
        /// 1-based line of the file, when known.
        line: Option<usize>,
        /// Vertex index the message is about, if any (used to find the OBJ line).
        vertex: Option<usize>,
        /// What is wrong.
        message: String,
    },
    /// A scene field is unusable (`field` is a dotted path, e.g. `objects[3].mesh`).
    #[error("field `{field}`: {message}")]
    Field {
        /// Dotted path of the field.
        field: String,
        /// What is wrong.
        message: String,
    },
}

impl SceneError {
    /// An error about mesh `origin`, at vertex `vertex` when known (the OBJ
    /// line is found from it later).
    pub fn mesh(origin: &str, vertex: Option<usize>, message: impl Into<String>) -> Self {
        SceneError::Mesh {
            origin: origin.to_string(),
            line: None,
            vertex,
            message: message.into(),
        }
    }

    /// An error at line `line` (1-based) of mesh file `origin`.
    pub fn mesh_at(origin: &str, line: usize, message: impl Into<String>) -> Self {
        SceneError::Mesh {
            origin: origin.to_string(),
            line: Some(line),
            vertex: None,
            message: message.into(),
        }
    }

    /// An error about scene field `field` (a dotted path).
    pub fn field(field: impl Into<String>, message: impl Into<String>) -> Self {
        SceneError::Field {
            field: field.into(),
            message: message.into(),
        }
    }

    /// For an error about vertex `k` of an OBJ file: the line of its `v` statement.
    pub(crate) fn with_obj_line(self, text: &str) -> Self {
        match self {
            SceneError::Mesh {
                origin,
                line: None,
                vertex: Some(k),
                message,
            } => {
                let line = text
                    .lines()
                    .enumerate()
                    .filter(|(_, l)| l.split_whitespace().next() == Some("v"))
                    .nth(k)
                    .map(|(i, _)| i + 1);
                SceneError::Mesh {
                    origin,
                    line,
                    vertex: Some(k),
                    message,
                }
            }
            other => other,
        }
    }
}
