//! Scene and mesh errors: they name the file, the line where known, and the field.

use std::path::Path;

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

    pub fn field(field: impl Into<String>, message: impl Into<String>) -> Self {
        SceneError::Field {
            field: field.into(),
            message: message.into(),
        }
    }

    /// For an error about vertex `k` of an OBJ file: the line of its `v` statement.
    pub(crate) fn with_obj_line(self, path: &Path) -> Self {
        match self {
            SceneError::Mesh {
                origin,
                line: None,
                vertex: Some(k),
                message,
            } => {
                let line = std::fs::read_to_string(path).ok().and_then(|text| {
                    text.lines()
                        .enumerate()
                        .filter(|(_, l)| l.trim_start().starts_with("v "))
                        .nth(k)
                        .map(|(i, _)| i + 1)
                });
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
