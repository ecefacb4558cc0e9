//! Load errors that name the file, the element and its line.

use std::fmt;
use std::path::{Path, PathBuf};

/// Why a scene file could not be loaded.
///
/// Displayed as `file:line: <element>: message`, with the parts that are
/// known; a user can jump straight to the offending element.
#[derive(Debug, Clone, PartialEq)]
pub struct LoadError {
    pub path: PathBuf,
    pub line: Option<u32>,
    pub element: Option<String>,
    pub message: String,
}

impl LoadError {
    /// An error about the file as a whole.
    pub fn file(path: &Path, message: impl Into<String>) -> LoadError {
        LoadError {
            path: path.to_path_buf(),
            line: None,
            element: None,
            message: message.into(),
        }
    }
}

impl fmt::Display for LoadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.path.display())?;
        if let Some(line) = self.line {
            write!(f, ":{line}")?;
        }
        if let Some(element) = &self.element {
            write!(f, ": <{element}>")?;
        }
        write!(f, ": {}", self.message)
    }
}

impl std::error::Error for LoadError {}

/// The file being parsed, for building located errors from XML nodes.
pub(crate) struct Source<'a, 'input> {
    pub path: &'a Path,
    pub doc: &'a roxmltree::Document<'input>,
}

impl Source<'_, '_> {
    /// An error located at `node`.
    pub fn error(&self, node: roxmltree::Node, message: impl Into<String>) -> LoadError {
        LoadError {
            path: self.path.to_path_buf(),
            line: Some(self.doc.text_pos_at(node.range().start).row),
            element: Some(node.tag_name().name().to_string()),
            message: message.into(),
        }
    }

    /// A one-line warning located at `node`.
    pub fn warning(&self, node: roxmltree::Node, message: impl AsRef<str>) -> String {
        format!(
            "{}:{}: {}",
            self.path.display(),
            self.doc.text_pos_at(node.range().start).row,
            message.as_ref()
        )
    }
}
