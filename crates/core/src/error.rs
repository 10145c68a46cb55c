//! The core's two shared small errors, the bottom layer of the crate:
//! [`ParseError`], text that does not name a value (an integrator, a
//! sampler, a filter, an accelerator…), and [`RangeError`], a setting out
//! of its range (a material's, a texture's, the flood-fill cache's). Both
//! are one concept across modules, so they live here once; errors that
//! belong to one module (`SceneError`, `InputError`, `DiffError`,
//! `AccelError`, `RenderError`…) live with it.
//!
//! Messages are whole (they name the value given and what was expected),
//! since the command line prints them as they are.

/// Text that does not name a value of some kind: what kind, what was
/// given and what would have been accepted.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ParseError {
    /// A name that is none of the kind's.
    #[error("unknown {what} `{given}` (expected {expected})")]
    Unknown {
        /// The kind of value ("integrator", "sampler", "filter"…).
        what: &'static str,
        /// The text given.
        given: String,
        /// The forms accepted.
        expected: String,
    },
    /// A known form with a value out of range or not a number.
    #[error("{what} must be {expected}, got `{given}`")]
    Value {
        /// The value ("path bounce count", "floodfill `res`"…).
        what: String,
        /// Its range ("an integer in 1..=64").
        expected: String,
        /// The text given.
        given: String,
    },
    /// A name that starts right but is malformed.
    #[error("bad {what} `{given}`: {problem}; expected {expected}")]
    Malformed {
        /// The kind of name ("BVH name").
        what: &'static str,
        /// The text given.
        given: String,
        /// What is wrong with it.
        problem: String,
        /// The grammar accepted.
        expected: &'static str,
    },
    /// More parts than the form takes.
    #[error("{what} takes at most {expected}, got extra `{extra}`")]
    Extra {
        /// The form ("adaptive").
        what: &'static str,
        /// What it takes.
        expected: &'static str,
        /// The first part too many.
        extra: String,
    },
    /// An item of a `key=value` list that is not `key=value`.
    #[error("{what} `{item}` is not `key=value` (keys: {keys})")]
    NotKeyValue {
        /// The list's items ("floodfill option").
        what: &'static str,
        /// The item given.
        item: String,
        /// The keys accepted.
        keys: &'static str,
    },
    /// A key of a `key=value` list that is none of the list's.
    #[error("unknown {what} `{key}` (keys: {keys})")]
    UnknownKey {
        /// The list's items ("floodfill option").
        what: &'static str,
        /// The key given.
        key: String,
        /// The keys accepted.
        keys: &'static str,
    },
    /// A name of something this build leaves out (a cargo feature off).
    #[error(
        "{what} `{given}` needs {needs}, but this raylab was built without the `{feature}` feature"
    )]
    NotBuilt {
        /// The kind of value ("accelerator").
        what: &'static str,
        /// The text given.
        given: String,
        /// What it needs ("Embree").
        needs: &'static str,
        /// The cargo feature.
        feature: &'static str,
    },
    /// Settings that parse one by one but are out of range together.
    #[error("{what}: {error}")]
    Settings {
        /// The form ("floodfill").
        what: &'static str,
        /// The setting out of range.
        error: RangeError,
    },
}

/// A setting out of its range: the field, what it must be and its value.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("`{field}` must be {expected}, got {got}")]
pub struct RangeError {
    /// The field, as a file or command names it (`alpha`, `texture`:
    /// `size`).
    pub field: String,
    /// Its range ("positive and finite").
    pub expected: &'static str,
    /// The value, written out.
    pub got: String,
}

impl RangeError {
    /// `field` must be `expected`, and is `got`.
    pub fn new(field: impl Into<String>, expected: &'static str, got: impl ToString) -> Self {
        Self {
            field: field.into(),
            expected,
            got: got.to_string(),
        }
    }

    /// The same error inside `outer` (`` `texture`: `size` ``).
    pub fn within(mut self, outer: &str) -> Self {
        self.field = format!("{outer}`: `{}", self.field);
        self
    }
}
