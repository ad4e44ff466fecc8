//! The description of scene keys: name, type, default, allowed values and
//! meaning, written once. It drives the reader (parsing, checking, the
//! defaults), the known-key lists of unknown-key errors, and the key tables
//! of `docs/SCENE.md` (a test checks the page against [`KeySpec::doc_row`]).
//!
//! A table's settings are declared with the `settings!` macro: one entry
//! per key makes the struct field, its default, its reading and checking,
//! and its documentation row, so adding a key touches one place.

/// What values a key takes.
#[derive(Debug, Clone, PartialEq)]
pub enum Kind {
    /// An integer from `lo` to `hi`, both included.
    Int {
        /// Smallest value.
        lo: u32,
        /// Largest value.
        hi: u32,
    },
    /// A finite number in a range.
    Num(Range),
    /// `true` or `false`.
    Bool,
    /// One of these names.
    Choice(Vec<&'static str>),
    /// A colour: three numbers ≥ 0 (linear RGB).
    Colour,
    /// A point or direction: three finite numbers.
    Vector,
}

/// A range of finite numbers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Range {
    /// Lower end.
    pub lo: f64,
    /// Whether `lo` itself is allowed.
    pub lo_included: bool,
    /// Upper end (may be +∞).
    pub hi: f64,
    /// Whether `hi` itself is allowed.
    pub hi_included: bool,
    /// The allowed values as the docs write them (`> 0`, `0 < s ≤ 2`).
    pub doc: &'static str,
    /// What an error says was expected (`a positive number`).
    pub expected: &'static str,
}

impl Range {
    /// Numbers > 0.
    pub const POSITIVE: Range = Range {
        lo: 0.0,
        lo_included: false,
        hi: f64::INFINITY,
        hi_included: false,
        doc: "> 0",
        expected: "a positive number",
    };
    /// Numbers ≥ 0.
    pub const NON_NEGATIVE: Range = Range {
        lo: 0.0,
        lo_included: true,
        hi: f64::INFINITY,
        hi_included: false,
        doc: "≥ 0",
        expected: "a number ≥ 0",
    };

    /// True when `x` is finite and in the range.
    pub fn contains(&self, x: f64) -> bool {
        x.is_finite()
            && (x > self.lo || (self.lo_included && x == self.lo))
            && (x < self.hi || (self.hi_included && x == self.hi))
    }
}

/// One key of a table.
#[derive(Debug, Clone, PartialEq)]
pub struct KeySpec {
    /// The key.
    pub name: &'static str,
    /// What it takes.
    pub kind: Kind,
    /// The default as the file would write it.
    pub default: String,
    /// What it does (one line, Markdown).
    pub doc: &'static str,
}

impl KeySpec {
    /// The type column of the docs.
    pub fn type_name(&self) -> &'static str {
        match self.kind {
            Kind::Int { .. } => "integer",
            Kind::Num(_) => "number",
            Kind::Bool => "boolean",
            Kind::Choice(_) => "string",
            Kind::Colour => "colour",
            Kind::Vector => "vector",
        }
    }

    /// The allowed-values column of the docs.
    pub fn allowed(&self) -> String {
        match self.kind {
            Kind::Int { lo, hi } => format!("{lo} … {hi}"),
            Kind::Num(ref r) => r.doc.to_string(),
            Kind::Bool => String::new(),
            Kind::Choice(ref names) => names
                .iter()
                .map(|n| format!("`\"{n}\"`"))
                .collect::<Vec<_>>()
                .join(", "),
            Kind::Colour => "components ≥ 0".to_string(),
            Kind::Vector => String::new(),
        }
    }

    /// The row of the key table in `docs/SCENE.md`:
    /// `| key | type | default | allowed | meaning |`.
    pub fn doc_row(&self) -> String {
        let allowed = self.allowed();
        let allowed = if allowed.is_empty() {
            String::new()
        } else {
            format!("{allowed} ")
        };
        format!(
            "| `{}` | {} | `{}` | {}| {} |",
            self.name,
            self.type_name(),
            self.default,
            allowed,
            self.doc
        )
    }
}

/// The names of a table's keys.
pub fn names(keys: &[KeySpec]) -> Vec<&'static str> {
    keys.iter().map(|k| k.name).collect()
}

/// Declares a settings table: the struct, its `Default`, its key
/// descriptions and a reader. Each entry is
/// `/// doc` `name: Type = default, kind, "meaning in the docs";`
/// with `kind` one of [`int`], [`num`], [`boolean`], [`choice`], [`colour`].
macro_rules! settings {
    (
        $(#[$meta:meta])*
        pub struct $name:ident, keys $keys:ident {
            $(
                $(#[doc = $fdoc:literal])*
                $field:ident : $ty:ty = $default:expr, $kind:expr, $doc:literal;
            )*
        }
    ) => {
        $(#[$meta])*
        #[derive(Debug, Clone, PartialEq)]
        pub struct $name {
            $(
                $(#[doc = $fdoc])*
                pub $field: $ty,
            )*
        }

        impl Default for $name {
            fn default() -> Self {
                $name {
                    $($field: $default,)*
                }
            }
        }

        /// The keys of this table, in the order the docs list them.
        pub fn $keys() -> Vec<$crate::schema::KeySpec> {
            let d = $name::default();
            vec![
                $(
                    $crate::schema::KeySpec {
                        name: stringify!($field),
                        kind: $kind,
                        default: $crate::schema::DocValue::doc_text(&d.$field),
                        doc: $doc,
                    },
                )*
            ]
        }

        impl $name {
            /// Reads the table's keys (absent keys take their defaults),
            /// checking each against its description.
            pub(crate) fn read(r: &mut $crate::load::Reader) -> Result<Self, $crate::SceneError> {
                let d = $name::default();
                let keys = $keys();
                let mut keys = keys.iter();
                $(
                    let $field: $ty = $crate::schema::FromKey::from_key(r, keys.next().expect("one spec per field"), d.$field)?;
                )*
                Ok($name { $($field,)* })
            }
        }
    };
}
pub(crate) use settings;

/// An integer from `lo` to `hi`.
pub fn int(lo: u32, hi: u32) -> Kind {
    Kind::Int { lo, hi }
}
/// A number in `range`.
pub fn num(range: Range) -> Kind {
    Kind::Num(range)
}
/// A number in a range written out: (lo, hi], [lo, hi) and so on.
pub const fn range(
    lo: f64,
    lo_included: bool,
    hi: f64,
    hi_included: bool,
    doc: &'static str,
    expected: &'static str,
) -> Range {
    Range {
        lo,
        lo_included,
        hi,
        hi_included,
        doc,
        expected,
    }
}
/// `true` or `false`.
pub fn boolean() -> Kind {
    Kind::Bool
}
/// One of the names of `T`.
pub fn choice<T: Named>() -> Kind {
    Kind::Choice(T::NAMES.iter().map(|(n, _)| *n).collect())
}
/// A colour of components ≥ 0.
pub fn colour() -> Kind {
    Kind::Colour
}
/// A point or direction.
pub fn vector() -> Kind {
    Kind::Vector
}

/// A default as the file would write it.
pub trait DocValue {
    /// The text.
    fn doc_text(&self) -> String;
}

impl DocValue for u32 {
    fn doc_text(&self) -> String {
        self.to_string()
    }
}
impl DocValue for f64 {
    fn doc_text(&self) -> String {
        format!("{self:?}")
    }
}
impl DocValue for bool {
    fn doc_text(&self) -> String {
        self.to_string()
    }
}
impl DocValue for [f64; 3] {
    fn doc_text(&self) -> String {
        format!("[{:?}, {:?}, {:?}]", self[0], self[1], self[2])
    }
}
impl<T: Named> DocValue for T {
    fn doc_text(&self) -> String {
        let name = T::NAMES.iter().find(|(_, v)| v == self).map(|(n, _)| *n).unwrap_or("?");
        format!("\"{name}\"")
    }
}

/// Values a key can be read into.
pub(crate) trait FromKey: Sized {
    fn from_key(r: &mut crate::load::Reader, spec: &KeySpec, default: Self) -> Result<Self, crate::SceneError>;
}

impl FromKey for u32 {
    fn from_key(r: &mut crate::load::Reader, spec: &KeySpec, default: Self) -> Result<Self, crate::SceneError> {
        let Kind::Int { lo, hi } = spec.kind else {
            unreachable!("an integer key")
        };
        r.int(spec.name, default, lo, hi)
    }
}

impl FromKey for f64 {
    fn from_key(r: &mut crate::load::Reader, spec: &KeySpec, default: Self) -> Result<Self, crate::SceneError> {
        let Kind::Num(range) = spec.kind else {
            unreachable!("a number key")
        };
        r.num_in(spec.name, default, |x| range.contains(x), range.expected)
    }
}

impl FromKey for bool {
    fn from_key(r: &mut crate::load::Reader, spec: &KeySpec, default: Self) -> Result<Self, crate::SceneError> {
        r.boolean(spec.name, default)
    }
}

impl FromKey for [f64; 3] {
    fn from_key(r: &mut crate::load::Reader, spec: &KeySpec, default: Self) -> Result<Self, crate::SceneError> {
        match spec.kind {
            Kind::Vector => r.vec3(spec.name, default),
            _ => r.color(spec.name, default),
        }
    }
}

/// An enumeration read from one of its names.
pub trait Named: Sized + Copy + PartialEq + 'static {
    /// Every value with its name in the file, in the docs' order.
    const NAMES: &'static [(&'static str, Self)];
}

impl<T: Named> FromKey for T {
    fn from_key(r: &mut crate::load::Reader, spec: &KeySpec, default: Self) -> Result<Self, crate::SceneError> {
        r.choice(spec.name, T::NAMES, default)
    }
}
