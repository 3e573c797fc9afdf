//! Errors as the user sees them: where the problem is (a file, and in it a key path or a
//! line and column) and what was expected there.
//!
//! Inside the scene loader a problem is a [`KeyError`]: a [`Key`] path such as
//! `shapes[3].emission.scale` and a [`Detail`]; the loader adds the file when it hands
//! the error out as an [`Error`]. Every `Display` is the message `stokes` prints after
//! `error: `, on one line once [`one_line`] has escaped control characters.

use crate::accel::EmbreeError;
use std::fmt;
use std::path::PathBuf;

/// A path of keys into a scene file: `materials.white.reflectance`, `shapes[3].radius`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Key(String);

impl Key {
    /// A top-level key (`camera`, `shapes`, `render.spp`).
    pub fn root(name: &str) -> Key {
        Key(name.to_string())
    }

    /// The key `name` inside this one: `a.name`.
    pub fn field(&self, name: &str) -> Key {
        Key(format!("{}.{name}", self.0))
    }

    /// Item `i` of this array: `a[i]`.
    pub fn index(&self, i: usize) -> Key {
        Key(format!("{}[{i}]", self.0))
    }

    /// An error at this key.
    pub fn error(&self, detail: impl Into<Detail>) -> KeyError {
        KeyError {
            key: self.clone(),
            detail: detail.into(),
        }
    }

    /// `expected {expected}, found {found}` at this key.
    pub fn expected(&self, expected: impl Into<String>, found: impl fmt::Display) -> KeyError {
        self.error(Detail::expected(expected, found))
    }
}

impl fmt::Display for Key {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

/// What is wrong.
#[derive(Debug)]
pub enum Detail {
    /// `expected {expected}, found {found}`.
    Expected {
        /// What the value should have been.
        expected: String,
        /// What it was.
        found: String,
    },
    /// Any other explanation, already phrased.
    Text(String),
    /// The error of something the key names (a data file, Embree).
    Cause(Box<Error>),
}

impl Detail {
    /// `expected {expected}, found {found}`.
    pub fn expected(expected: impl Into<String>, found: impl fmt::Display) -> Detail {
        Detail::Expected {
            expected: expected.into(),
            found: found.to_string(),
        }
    }
}

impl fmt::Display for Detail {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Detail::Expected { expected, found } => write!(f, "expected {expected}, found {found}"),
            Detail::Text(t) => f.write_str(t),
            Detail::Cause(e) => e.fmt(f),
        }
    }
}

impl From<String> for Detail {
    fn from(text: String) -> Detail {
        Detail::Text(text)
    }
}

impl From<&str> for Detail {
    fn from(text: &str) -> Detail {
        Detail::Text(text.to_string())
    }
}

impl From<Error> for Detail {
    fn from(e: Error) -> Detail {
        Detail::Cause(Box::new(e))
    }
}

impl From<EmbreeError> for Detail {
    fn from(e: EmbreeError) -> Detail {
        Detail::Cause(Box::new(Error::Embree(e)))
    }
}

/// A problem at a key of the scene file being loaded: `{key}: {detail}`.
#[derive(Debug, thiserror::Error)]
#[error("{key}: {detail}")]
pub struct KeyError {
    /// Where.
    pub key: Key,
    /// What.
    pub detail: Detail,
}

impl KeyError {
    /// The same problem, reported at `key` (for example at the value that brought it in).
    pub fn at(self, key: &Key) -> KeyError {
        KeyError {
            key: key.clone(),
            ..self
        }
    }
}

/// An error of the renderer's inputs or outputs.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A value in a file is wrong: `{file}: {key}: {detail}`.
    #[error("{}: {error}", file.display())]
    Value {
        /// The file.
        file: PathBuf,
        /// The key and what is wrong with its value.
        error: KeyError,
    },
    /// A file cannot be parsed at a place: `{file}:{line}:{column}: {message} (in `{text}`)`.
    #[error("{}:{line}:{column}: {message} (in `{text}`)", file.display())]
    Syntax {
        /// The file.
        file: PathBuf,
        /// Line, from 1.
        line: usize,
        /// Column, from 1.
        column: usize,
        /// What the parser expected.
        message: String,
        /// The line's text.
        text: String,
    },
    /// Something in a file, or the file itself, is wrong: `{file}: {detail}` or, at a
    /// line, `{file}:{line}: {detail}`.
    #[error("{}{}: {detail}", file.display(), line.map(|l| format!(":{l}")).unwrap_or_default())]
    File {
        /// The file.
        file: PathBuf,
        /// The line, where one is to blame.
        line: Option<usize>,
        /// What is wrong.
        detail: Detail,
    },
    /// A sentence about a file that starts with its name, after the option that gave it
    /// if one did: `b.exr is 4x4 but a.exr is 8x8: …`, `--reference r.exr holds …`.
    /// For what relates a file to another file or to the run, where no key or line is to
    /// blame.
    #[error("{}{} {rest}", option.as_ref().map(|o| format!("{o} ")).unwrap_or_default(), file.display())]
    About {
        /// The option that named the file (`--reference`), if any.
        option: Option<String>,
        /// The file.
        file: PathBuf,
        /// The rest of the sentence.
        rest: String,
    },
    /// A command-line option's value does not fit: `{option}: {detail}`.
    #[error("{option}: {detail}")]
    Option {
        /// The option, `--spp`.
        option: String,
        /// What is wrong.
        detail: Detail,
    },
    /// Embree refused.
    #[error(transparent)]
    Embree(#[from] EmbreeError),
    /// Anything else, already phrased.
    #[error("{0}")]
    Other(String),
}

impl Error {
    /// An error in `file` as a whole (or at `line`).
    pub fn file(file: impl Into<PathBuf>, line: Option<usize>, detail: impl Into<Detail>) -> Error {
        Error::File {
            file: file.into(),
            line,
            detail: detail.into(),
        }
    }

    /// A sentence about `file`: `{file} {rest}`.
    pub fn about(file: impl Into<PathBuf>, rest: impl Into<String>) -> Error {
        Error::About {
            option: None,
            file: file.into(),
            rest: rest.into(),
        }
    }

    /// A sentence about `file`, named by command-line option `option`:
    /// `{option} {file} {rest}`.
    pub fn about_option(option: &str, file: impl Into<PathBuf>, rest: impl Into<String>) -> Error {
        Error::About {
            option: Some(option.to_string()),
            file: file.into(),
            rest: rest.into(),
        }
    }

    /// An error in the value of command-line option `option`.
    pub fn option(option: &str, detail: impl Into<Detail>) -> Error {
        Error::Option {
            option: option.to_string(),
            detail: detail.into(),
        }
    }
}

/// Errors phrased in full elsewhere keep their text.
impl From<String> for Error {
    fn from(text: String) -> Error {
        Error::Other(text)
    }
}

impl From<&str> for Error {
    fn from(text: &str) -> Error {
        Error::Other(text.to_string())
    }
}

/// The message with control characters escaped, so that an error is always one line (a
/// file name in a scene may hold a newline escape).
pub fn one_line(msg: &str) -> String {
    msg.chars()
        .flat_map(|c| {
            if c.is_control() {
                c.escape_default().collect::<Vec<_>>()
            } else {
                vec![c]
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_name_the_place_and_what_was_expected() {
        let key = Key::root("shapes").index(3).field("radius");
        assert_eq!(key.to_string(), "shapes[3].radius");
        let e = Error::Value {
            file: "s.toml".into(),
            error: key.expected("a positive number", -1.0),
        };
        assert_eq!(
            e.to_string(),
            "s.toml: shapes[3].radius: expected a positive number, found -1"
        );
        let data = Error::file("m.obj", Some(12), "expected 3 numbers");
        let e = Error::Value {
            file: "s.toml".into(),
            error: Key::root("shapes").index(0).field("file").error(data),
        };
        assert_eq!(
            e.to_string(),
            "s.toml: shapes[0].file: m.obj:12: expected 3 numbers"
        );
        assert_eq!(
            Error::option("--spp", "expected at least 1").to_string(),
            "--spp: expected at least 1"
        );
        assert_eq!(
            Error::about_option("--reference", "r.exr", "holds samples up to 9").to_string(),
            "--reference r.exr holds samples up to 9"
        );
        assert_eq!(one_line("a\nb"), "a\\nb");
    }
}
