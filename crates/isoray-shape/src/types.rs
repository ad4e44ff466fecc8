//! Types and typed values of the shape language.

use crate::ir::{Builder, Node};

/// The type of an expression.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Type {
    /// A scalar.
    Float,
    /// Two components.
    Vec2,
    /// Three components.
    Vec3,
}

impl Type {
    /// Number of scalar components.
    pub fn width(self) -> usize {
        match self {
            Type::Float => 1,
            Type::Vec2 => 2,
            Type::Vec3 => 3,
        }
    }
    /// The type with `n` components.
    pub fn of_width(n: usize) -> Option<Type> {
        match n {
            1 => Some(Type::Float),
            2 => Some(Type::Vec2),
            3 => Some(Type::Vec3),
            _ => None,
        }
    }
    /// The name as written in source.
    pub fn name(self) -> &'static str {
        match self {
            Type::Float => "float",
            Type::Vec2 => "vec2",
            Type::Vec3 => "vec3",
        }
    }
}

impl std::fmt::Display for Type {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// A typed value during lowering: 1 to 3 scalar DAG nodes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Val {
    /// Its type.
    pub ty: Type,
    /// The components; only the first `ty.width()` are meaningful.
    pub c: [Node; 3],
}

impl Val {
    /// A float value.
    pub fn float(n: Node) -> Val {
        Val {
            ty: Type::Float,
            c: [n, n, n],
        }
    }
    /// A vector from components (1 to 3).
    pub fn from_slice(cs: &[Node]) -> Option<Val> {
        let ty = Type::of_width(cs.len())?;
        let mut c = [cs[0]; 3];
        c[..cs.len()].copy_from_slice(cs);
        Some(Val { ty, c })
    }
    /// A vec3.
    pub fn vec3(x: Node, y: Node, z: Node) -> Val {
        Val {
            ty: Type::Vec3,
            c: [x, y, z],
        }
    }
    /// The meaningful components.
    pub fn comps(&self) -> &[Node] {
        &self.c[..self.ty.width()]
    }
    /// Component `i`; a float broadcasts to every component.
    pub fn at(&self, i: usize) -> Node {
        if self.ty == Type::Float {
            self.c[0]
        } else {
            self.c[i]
        }
    }
    /// The scalar of a float value.
    pub fn s(&self) -> Node {
        self.c[0]
    }
}

/// A parameter value given by a scene (a number or a vector).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Value {
    /// A number.
    Float(f64),
    /// Two numbers.
    Vec2([f64; 2]),
    /// Three numbers.
    Vec3([f64; 3]),
}

impl Value {
    /// The value as a scene file writes it: `0.5`, `[1.0, 2.0]`,
    /// `[1.0, 2.0, 3.0]` (shortest exact decimals).
    ///
    /// ```
    /// use isoray_shape::Value;
    /// assert_eq!(Value::Float(0.5).toml_text(), "0.5");
    /// assert_eq!(Value::Vec3([1.0, 0.1, 3.0]).toml_text(), "[1.0, 0.1, 3.0]");
    /// ```
    pub fn toml_text(&self) -> String {
        match self {
            Value::Float(x) => format!("{x:?}"),
            Value::Vec2([x, y]) => format!("[{x:?}, {y:?}]"),
            Value::Vec3([x, y, z]) => format!("[{x:?}, {y:?}, {z:?}]"),
        }
    }

    /// Its numbers, in order.
    ///
    /// ```
    /// use isoray_shape::Value;
    /// assert_eq!(Value::Vec2([1.0, 2.0]).components(), vec![1.0, 2.0]);
    /// assert_eq!(Value::from_components(&[1.0, 2.0]), Value::Vec2([1.0, 2.0]));
    /// ```
    pub fn components(&self) -> Vec<f64> {
        match *self {
            Value::Float(x) => vec![x],
            Value::Vec2(a) => a.to_vec(),
            Value::Vec3(a) => a.to_vec(),
        }
    }

    /// The value of 2 or 3 numbers as a vector, otherwise of the first
    /// number (0 for none).
    pub fn from_components(v: &[f64]) -> Value {
        match *v {
            [x, y] => Value::Vec2([x, y]),
            [x, y, z] => Value::Vec3([x, y, z]),
            _ => Value::Float(v.first().copied().unwrap_or(0.0)),
        }
    }

    /// Its type.
    pub fn ty(&self) -> Type {
        match self {
            Value::Float(_) => Type::Float,
            Value::Vec2(_) => Type::Vec2,
            Value::Vec3(_) => Type::Vec3,
        }
    }
    /// Builds constant nodes for it.
    pub fn lower(&self, b: &mut Builder) -> Val {
        match *self {
            Value::Float(v) => Val::float(b.constant(v)),
            Value::Vec2([x, y]) => {
                let (x, y) = (b.constant(x), b.constant(y));
                Val {
                    ty: Type::Vec2,
                    c: [x, y, y],
                }
            }
            Value::Vec3([x, y, z]) => {
                let (x, y, z) = (b.constant(x), b.constant(y), b.constant(z));
                Val::vec3(x, y, z)
            }
        }
    }
}
