//! Scene and mesh errors: they name the file, the line where known, and the field.

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SceneError {
    /// A mesh's data is unusable.
    #[error("{origin}{}: {message}", line.map(|l| format!(":{l}")).unwrap_or_default())]
    Mesh {
        origin: String,
        line: Option<usize>,
        /// Vertex index the message is about, if any (used to find the OBJ line).
        vertex: Option<usize>,
        message: String,
    },
    /// A scene field is unusable (`field` is a dotted path, e.g. `objects[3].mesh`).
    #[error("field `{field}`: {message}")]
    Field { field: String, message: String },
}

impl SceneError {
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
