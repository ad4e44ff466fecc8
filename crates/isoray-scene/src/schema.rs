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
    /// A number or colour with components in [0, 1] (a number is grey).
    UnitColour,
    /// A string (a name, a path or shape text).
    Str,
    /// A structured value, described by its type column (`inline table { x, y, z }`).
    Text(&'static str),
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
    /// The default as the file would write it (empty when there is none).
    pub default: String,
    /// What leaving the key out means when there is no default (`required`,
    /// `none`), as the docs write it.
    pub absent: &'static str,
    /// What it does (one line, Markdown).
    pub doc: &'static str,
}

/// A key with a default written as the file would write it.
pub fn key(name: &'static str, kind: Kind, default: &str, doc: &'static str) -> KeySpec {
    KeySpec {
        name,
        kind,
        default: default.to_string(),
        absent: "",
        doc,
    }
}

/// A key without a default: `absent` says what leaving it out means.
pub fn key_without_default(name: &'static str, kind: Kind, absent: &'static str, doc: &'static str) -> KeySpec {
    KeySpec {
        name,
        kind,
        default: String::new(),
        absent,
        doc,
    }
}

/// Finds a key of a table's description.
pub fn spec<'a>(keys: &'a [KeySpec], name: &str) -> &'a KeySpec {
    keys.iter()
        .find(|k| k.name == name)
        .unwrap_or_else(|| panic!("no key `{name}` in the description"))
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
            Kind::UnitColour => "number or colour",
            Kind::Str => "string",
            Kind::Text(t) => t,
        }
    }

    /// The default of a number key.
    pub fn default_f64(&self) -> f64 {
        self.default
            .parse()
            .unwrap_or_else(|_| panic!("`{}` has a number default", self.name))
    }

    /// The default of a vector or colour key.
    pub fn default_vec3(&self) -> [f64; 3] {
        let v: Vec<f64> = self
            .default
            .trim_matches(|c| c == '[' || c == ']')
            .split(',')
            .map(|x| x.trim().parse().unwrap_or(f64::NAN))
            .collect();
        match v[..] {
            [a, b, c] if v.iter().all(|x| x.is_finite()) => [a, b, c],
            _ => panic!("`{}` has a default of three numbers", self.name),
        }
    }

    /// True for keys whose value is numbers (a number, a colour, a vector):
    /// the keys that may also be written as shape text of `t` and the
    /// parameters, and set live with `Scene::set_value`.
    pub fn is_numeric(&self) -> bool {
        matches!(self.kind, Kind::Num(_) | Kind::Colour | Kind::Vector | Kind::UnitColour)
    }

    /// Checks numbers given for this key from outside (a driven expression,
    /// a slider): one number for a number key, three for vectors and
    /// colours (one gives a grey colour). Returns the value's components,
    /// or what was expected.
    pub fn check_numbers(&self, value: &[f64]) -> Result<Vec<f64>, String> {
        if value.iter().any(|x| !x.is_finite()) {
            return Err(self.expected());
        }
        let ok = match (&self.kind, value) {
            (Kind::Num(r), [x]) => r.contains(*x),
            (Kind::Vector, [_, _, _]) => true,
            (Kind::Colour, [x]) if *x >= 0.0 => return Ok(vec![*x; 3]),
            (Kind::Colour, [_, _, _]) => value.iter().all(|x| *x >= 0.0),
            (Kind::UnitColour, [x]) if (0.0..=1.0).contains(x) => return Ok(vec![*x; 3]),
            (Kind::UnitColour, [_, _, _]) => value.iter().all(|x| (0.0..=1.0).contains(x)),
            _ => false,
        };
        if ok {
            Ok(value.to_vec())
        } else {
            Err(self.expected())
        }
    }

    /// What a value of this key must be, as errors say it.
    pub fn expected(&self) -> String {
        match &self.kind {
            Kind::Int { lo, hi } => format!("an integer from {lo} to {hi}"),
            Kind::Num(r) => r.expected.to_string(),
            Kind::Bool => "`true` or `false`".to_string(),
            Kind::Choice(names) => format!(
                "one of {}",
                names.iter().map(|n| format!("\"{n}\"")).collect::<Vec<_>>().join(", ")
            ),
            Kind::Colour => "a colour: one number or three, each ≥ 0".to_string(),
            Kind::Vector => "three numbers".to_string(),
            Kind::UnitColour => "a number from 0 to 1, or a colour [r, g, b] of such numbers".to_string(),
            Kind::Str => "a string".to_string(),
            Kind::Text(t) => t.to_string(),
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
            Kind::UnitColour => "components in [0, 1]".to_string(),
            Kind::Vector | Kind::Str | Kind::Text(_) => String::new(),
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
        let default = if self.default.is_empty() {
            self.absent.to_string()
        } else {
            format!("`{}`", self.default)
        };
        format!(
            "| `{}` | {} | {} | {}| {} |",
            self.name,
            self.type_name(),
            default,
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
/// descriptions, a reader and a setter. Each entry is
/// `/// doc` `name: Type = default, kind, "meaning in the docs";`
/// with `kind` one of [`int`], [`num`], [`boolean`], [`choice`], [`colour`],
/// [`vector`], [`unit_colour`]. An optional `extra { … }` block after the
/// keys declares fields that are not keys of their own (they are read by
/// hand from keys described separately), with their defaults.
macro_rules! settings {
    (
        $(#[$meta:meta])*
        pub struct $name:ident, keys $keys:ident {
            $(
                $(#[doc = $fdoc:literal])*
                $field:ident : $ty:ty = $default:expr, $kind:expr, $doc:literal;
            )*
        }
        $(extra {
            $(
                $(#[doc = $xdoc:literal])*
                $xfield:ident : $xty:ty = $xdefault:expr;
            )*
        })?
    ) => {
        $(#[$meta])*
        #[derive(Debug, Clone, PartialEq)]
        pub struct $name {
            $(
                $(#[doc = $fdoc])*
                pub $field: $ty,
            )*
            $($(
                $(#[doc = $xdoc])*
                pub $xfield: $xty,
            )*)?
        }

        impl Default for $name {
            fn default() -> Self {
                $name {
                    $($field: $default,)*
                    $($($xfield: $xdefault,)*)?
                }
            }
        }

        /// The keys of this table, in the order the docs list them.
        pub fn $keys() -> &'static [$crate::schema::KeySpec] {
            static KEYS: std::sync::LazyLock<Vec<$crate::schema::KeySpec>> = std::sync::LazyLock::new(|| {
                let d = $name::default();
                vec![
                    $(
                        $crate::schema::KeySpec {
                            name: stringify!($field),
                            kind: $kind,
                            default: $crate::schema::DocValue::doc_text(&d.$field),
                            absent: "",
                            doc: $doc,
                        },
                    )*
                ]
            });
            &KEYS
        }

        impl $name {
            /// Reads the table's keys (absent keys take their defaults),
            /// checking each against its description; the extra fields
            /// take their defaults.
            pub(crate) fn read(r: &mut $crate::reader::Reader) -> Result<Self, $crate::SceneError> {
                let d = $name::default();
                let keys = $keys();
                let mut keys = keys.iter();
                $(
                    let $field: $ty = $crate::schema::FromKey::from_key(r, keys.next().expect("one spec per field"), d.$field)?;
                )*
                #[allow(clippy::needless_update)]
                Ok($name { $($field,)* ..d })
            }

            /// The value of one of this table's keys as the file would
            /// write it (`32.0`, `[0.8, 0.8, 0.8]`, `"pow"`, `true`); None
            /// when `key` is not one of them.
            #[allow(dead_code)]
            pub fn value_text(&self, key: &str) -> Option<String> {
                $(
                    if key == stringify!($field) {
                        return Some($crate::schema::DocValue::doc_text(&self.$field));
                    }
                )*
                None
            }

            /// Sets a numeric key from numbers checked against its
            /// description: `None` when `key` is not one of this table's
            /// numeric keys, `Some(Err(expected))` when the value does not fit.
            #[allow(dead_code)]
            pub(crate) fn set_numbers(&mut self, key: &str, value: &[f64]) -> Option<Result<(), String>> {
                let keys = $keys();
                let mut keys = keys.iter();
                $(
                    let spec = keys.next().expect("one spec per field");
                    if key == stringify!($field) {
                        return $crate::schema::FromNumbers::from_numbers(spec, value)
                            .map(|r| r.map(|v| self.$field = v));
                    }
                )*
                None
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
/// A number or colour with components in [0, 1].
pub fn unit_colour() -> Kind {
    Kind::UnitColour
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
    fn from_key(r: &mut crate::reader::Reader, spec: &KeySpec, default: Self) -> Result<Self, crate::SceneError>;
}

impl FromKey for u32 {
    fn from_key(r: &mut crate::reader::Reader, spec: &KeySpec, default: Self) -> Result<Self, crate::SceneError> {
        let Kind::Int { lo, hi } = spec.kind else {
            unreachable!("an integer key")
        };
        r.int(spec.name, default, lo, hi)
    }
}

impl FromKey for f64 {
    fn from_key(r: &mut crate::reader::Reader, spec: &KeySpec, default: Self) -> Result<Self, crate::SceneError> {
        let Kind::Num(range) = spec.kind else {
            unreachable!("a number key")
        };
        r.num_in(spec.name, default, |x| range.contains(x), range.expected)
    }
}

impl FromKey for bool {
    fn from_key(r: &mut crate::reader::Reader, spec: &KeySpec, default: Self) -> Result<Self, crate::SceneError> {
        r.boolean(spec.name, default)
    }
}

impl FromKey for [f64; 3] {
    fn from_key(r: &mut crate::reader::Reader, spec: &KeySpec, default: Self) -> Result<Self, crate::SceneError> {
        match spec.kind {
            Kind::Vector => r.vec3(spec.name, default),
            Kind::UnitColour => r.unit_color(spec.name, default),
            _ => r.color(spec.name, default),
        }
    }
}

/// Values that can be set from numbers given from outside (sliders,
/// driven expressions): numbers and triples. Integers, booleans and
/// choices cannot.
pub(crate) trait FromNumbers: Sized {
    /// `None` when values of this type are not set from numbers.
    fn from_numbers(_spec: &KeySpec, _value: &[f64]) -> Option<Result<Self, String>> {
        None
    }
}

impl FromNumbers for f64 {
    fn from_numbers(spec: &KeySpec, value: &[f64]) -> Option<Result<Self, String>> {
        Some(spec.check_numbers(value).map(|v| v[0]))
    }
}

impl FromNumbers for [f64; 3] {
    fn from_numbers(spec: &KeySpec, value: &[f64]) -> Option<Result<Self, String>> {
        Some(spec.check_numbers(value).map(|v| [v[0], v[1], v[2]]))
    }
}

impl FromNumbers for u32 {}
impl FromNumbers for bool {}
impl<T: Named> FromNumbers for T {}

/// An enumeration read from one of its names.
pub trait Named: Sized + Copy + PartialEq + 'static {
    /// Every value with its name in the file, in the docs' order.
    const NAMES: &'static [(&'static str, Self)];
}

impl<T: Named> FromKey for T {
    fn from_key(r: &mut crate::reader::Reader, spec: &KeySpec, default: Self) -> Result<Self, crate::SceneError> {
        r.choice(spec.name, T::NAMES, default)
    }
}
