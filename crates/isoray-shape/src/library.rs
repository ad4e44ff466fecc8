//! The built-in functions, primitives and operators of the shape language.
//!
//! Every entry has a signature in [`FUNCTIONS`], checked uniformly, and a
//! lowering into scalar DAG nodes. The formulas are the standard ones of the
//! SDF literature (Hart 1996; Quílez, "distance functions"), documented in
//! `docs/SCENE.md`.

use crate::diag::{Diagnostic, Span};
use crate::ir::{BinOp, Builder, Node, UnOp};
use crate::lower::{Arg, Lowerer};
use crate::types::{Type, Val};

/// The kind of a parameter in a signature.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Param {
    /// A float.
    F,
    /// A vec3 exactly (a point).
    P,
    /// A vec3; a float broadcasts to all three components.
    V,
    /// Any type; all `G` arguments of a call share one vector type, floats broadcast.
    G,
}

/// What family a function belongs to (for documentation and help).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Category {
    /// GLSL-style built-in math.
    Builtin,
    /// A primitive distance function of the point.
    Primitive,
    /// Combines distances.
    Operator,
    /// Maps the point (returns a vec3) or adds a distance term.
    Domain,
}

/// A function signature.
#[derive(Debug, Clone, Copy)]
pub struct Signature {
    /// Name as called.
    pub name: &'static str,
    /// Parameter names and kinds.
    pub params: &'static [(&'static str, Param)],
    /// How many trailing parameters may be omitted.
    pub optional: usize,
    /// Family.
    pub category: Category,
    /// One line of documentation.
    pub doc: &'static str,
}

use Category::*;
use Param::*;

macro_rules! sig {
    ($name:literal, [$($p:literal : $k:ident),*], $opt:literal, $cat:ident, $doc:literal) => {
        Signature { name: $name, params: &[$(($p, $k)),*], optional: $opt, category: $cat, doc: $doc }
    };
}

/// Every built-in function, primitive and operator.
pub const FUNCTIONS: &[Signature] = &[
    sig!("length", ["v": G], 0, Builtin, "Euclidean length (|x| for a float)."),
    sig!("distance", ["a": G, "b": G], 0, Builtin, "length(a - b)."),
    sig!("dot", ["a": G, "b": G], 0, Builtin, "Dot product."),
    sig!("cross", ["a": V, "b": V], 0, Builtin, "Cross product of two vec3."),
    sig!("normalize", ["v": G], 0, Builtin, "v / length(v)."),
    sig!("abs", ["x": G], 0, Builtin, "Absolute value, componentwise."),
    sig!("sign", ["x": G], 0, Builtin, "-1, 0 or 1, componentwise."),
    sig!("floor", ["x": G], 0, Builtin, "Largest integer not above x."),
    sig!("ceil", ["x": G], 0, Builtin, "Smallest integer not below x."),
    sig!("fract", ["x": G], 0, Builtin, "x - floor(x)."),
    sig!("round", ["x": G], 0, Builtin, "Nearest integer (halves away from zero)."),
    sig!("sqrt", ["x": G], 0, Builtin, "Square root."),
    sig!("inversesqrt", ["x": G], 0, Builtin, "1 / sqrt(x)."),
    sig!("exp", ["x": G], 0, Builtin, "e^x."),
    sig!("exp2", ["x": G], 0, Builtin, "2^x."),
    sig!("log", ["x": G], 0, Builtin, "Natural logarithm."),
    sig!("log2", ["x": G], 0, Builtin, "Base-2 logarithm."),
    sig!("sin", ["x": G], 0, Builtin, "Sine (radians)."),
    sig!("cos", ["x": G], 0, Builtin, "Cosine (radians)."),
    sig!("tan", ["x": G], 0, Builtin, "Tangent (radians)."),
    sig!("asin", ["x": G], 0, Builtin, "Arc sine."),
    sig!("acos", ["x": G], 0, Builtin, "Arc cosine."),
    sig!("atan", ["x": G], 0, Builtin, "Arc tangent of x."),
    sig!("atan", ["y": G, "x": G], 0, Builtin, "Arc tangent of y/x in the right quadrant (atan2)."),
    sig!("radians", ["deg": G], 0, Builtin, "Degrees to radians."),
    sig!("degrees", ["rad": G], 0, Builtin, "Radians to degrees."),
    sig!("min", ["a": G, "b": G], 0, Builtin, "Smaller of a and b, componentwise."),
    sig!("max", ["a": G, "b": G], 0, Builtin, "Larger of a and b, componentwise."),
    sig!("pow", ["x": G, "y": G], 0, Builtin, "x^y."),
    sig!("mod", ["x": G, "y": G], 0, Builtin, "x - y*floor(x/y) (GLSL mod)."),
    sig!("step", ["edge": G, "x": G], 0, Builtin, "0 if x < edge, else 1."),
    sig!("clamp", ["x": G, "lo": G, "hi": G], 0, Builtin, "min(max(x, lo), hi)."),
    sig!("mix", ["a": G, "b": G, "t": G], 0, Builtin, "a + (b - a)*t."),
    sig!("smoothstep", ["e0": G, "e1": G, "x": G], 0, Builtin, "Hermite step from e0 to e1: t*t*(3-2t)."),
    // Primitives.
    sig!("sphere", ["p": P, "r": F], 0, Primitive, "Sphere of radius r at the origin (exact)."),
    sig!("box", ["p": P, "b": V], 0, Primitive, "Box with half extents b (exact inside and outside)."),
    sig!("round_box", ["p": P, "b": V, "r": F], 0, Primitive, "Box of half extents b whose edges are rounded with radius r (exact)."),
    sig!("plane", ["p": P, "n": V, "h": F], 0, Primitive, "dot(p, n) + h: exact when n is a unit vector."),
    sig!("ellipsoid", ["p": P, "r": V], 0, Primitive, "Ellipsoid with semi-axes r (Quílez's bound, not exact)."),
    sig!("cylinder", ["p": P, "h": F, "r": F], 0, Primitive, "Capped cylinder, axis y, half-height h, radius r (exact)."),
    sig!("capsule", ["p": P, "h": F, "r": F], 0, Primitive, "Capsule around the y segment from -h/2 to h/2, radius r (exact)."),
    sig!("torus", ["p": P, "R": F, "r": F], 0, Primitive, "Torus in the xz plane, major radius R, minor radius r (exact)."),
    sig!("cone", ["p": P, "angle": F, "h": F], 0, Primitive, "Solid cone, apex at the origin, opening downwards with half-angle `angle` (radians), base at y = -h (exact)."),
    sig!("tri_prism", ["p": P, "h": F, "w": F], 0, Primitive, "Triangular prism along z, half-length h, equilateral cross-section with inradius w/2 (bound)."),
    sig!("hex_prism", ["p": P, "h": F, "w": F], 0, Primitive, "Hexagonal prism along z, half-length h, hexagon apothem w (exact)."),
    sig!("octahedron", ["p": P, "s": F], 0, Primitive, "Regular octahedron with vertices at distance s on the axes (exact)."),
    // Operators on distances.
    sig!("union", ["a": F, "b": F], 0, Operator, "min(a, b); takes two or more distances."),
    sig!("intersection", ["a": F, "b": F], 0, Operator, "max(a, b); takes two or more distances."),
    sig!("difference", ["a": F, "b": F], 0, Operator, "a minus b: max(a, -b)."),
    sig!("smooth_union", ["a": F, "b": F, "k": F, "n": F], 1, Operator, "min(a,b) - max(k-|a-b|,0)^n / (2n k^(n-1)); n defaults to 2."),
    sig!("smooth_intersection", ["a": F, "b": F, "k": F, "n": F], 1, Operator, "max(a,b) + max(k-|a-b|,0)^n / (2n k^(n-1)); n defaults to 2."),
    sig!("smooth_difference", ["a": F, "b": F, "k": F, "n": F], 1, Operator, "smooth_intersection(a, -b, k, n)."),
    sig!("smin_cubic", ["a": F, "b": F, "k": F], 0, Operator, "Cubic polynomial smooth minimum: min(a,b) - h^3 k/6, h = max(k-|a-b|,0)/k."),
    sig!("smin_exp", ["a": F, "b": F, "k": F], 0, Operator, "Exponential smooth minimum: -k ln(e^(-a/k) + e^(-b/k))."),
    sig!("smooth_union_n", ["k": F, "a": F, "b": F], 0, Operator, "n-ary smooth union of two or more distances: -k ln(sum e^(-d_i/k)), the same in any order."),
    sig!("smin_pow", ["a": F, "b": F, "k": F], 0, Operator, "Power smooth minimum ((a^k b^k)/(a^k + b^k))^(1/k) for positive a, b; min(a,b) otherwise."),
    sig!("smin_root", ["a": F, "b": F, "k": F], 0, Operator, "Root smooth minimum: (a + b - sqrt((a-b)^2 + k^2)) / 2."),
    sig!("round", ["d": F, "r": F], 0, Operator, "d - r: grows a shape by r, rounding its edges."),
    sig!("onion", ["d": F, "t": F], 0, Operator, "|d| - t: a shell of thickness 2t."),
    // Domain operators (map the point) and distance terms.
    sig!("translate", ["p": P, "offset": V], 0, Domain, "p - offset: moves a shape by offset."),
    sig!("rotate_x", ["p": P, "angle": F], 0, Domain, "Rotates the shape by angle (radians) about the x axis (right-handed)."),
    sig!("rotate_y", ["p": P, "angle": F], 0, Domain, "Rotates the shape by angle about the y axis."),
    sig!("rotate_z", ["p": P, "angle": F], 0, Domain, "Rotates the shape by angle about the z axis."),
    sig!("rotate", ["p": P, "axis": V, "angle": F], 0, Domain, "Rotates the shape by angle about an axis through the origin."),
    sig!("twist_x", ["p": P, "k": F], 0, Domain, "Twists about x: the yz plane turns by k*x radians."),
    sig!("twist_y", ["p": P, "k": F], 0, Domain, "Twists about y: the xz plane turns by k*y radians."),
    sig!("twist_z", ["p": P, "k": F], 0, Domain, "Twists about z: the xy plane turns by k*z radians."),
    sig!("bend", ["p": P, "k": F], 0, Domain, "Bends along x: the xy plane turns by k*x radians."),
    sig!("elongate", ["p": P, "h": V], 0, Domain, "p - clamp(p, -h, h): stretches a shape by 2h."),
    sig!("mirror_x", ["p": P], 0, Domain, "(|x|, y, z): mirror symmetry across x = 0."),
    sig!("mirror_y", ["p": P], 0, Domain, "(x, |y|, z)."),
    sig!("mirror_z", ["p": P], 0, Domain, "(x, y, |z|)."),
    sig!("repeat", ["p": P, "s": V], 0, Domain, "p - s*round(p/s): infinite repetition with period s."),
    sig!("repeat_limited", ["p": P, "s": V, "l": V], 0, Domain, "p - s*clamp(round(p/s), -l, l): copies -l..l per axis."),
    sig!("displace", ["p": P, "amplitude": F, "frequency": F], 0, Domain, "amplitude*sin(f x) sin(f y) sin(f z): add it to a distance."),
];

/// Named constants.
pub fn constant(name: &str) -> Option<f64> {
    match name {
        "PI" => Some(std::f64::consts::PI),
        "TAU" => Some(std::f64::consts::TAU),
        _ => None,
    }
}

/// True when `name` is a built-in function, primitive or operator (or a constructor).
pub fn is_function(name: &str) -> bool {
    matches!(name, "vec2" | "vec3" | "float") || FUNCTIONS.iter().any(|s| s.name == name)
}

/// All callable names.
pub fn function_names() -> impl Iterator<Item = &'static str> {
    ["vec2", "vec3", "float"]
        .into_iter()
        .chain(FUNCTIONS.iter().map(|s| s.name))
}

/// A signature as text, e.g. `sphere(p: vec3, r: float)`.
pub fn signature_text(s: &Signature) -> String {
    let ps: Vec<String> = s
        .params
        .iter()
        .enumerate()
        .map(|(i, (n, k))| {
            let t = match k {
                F => "float",
                P | V => "vec3",
                G => "float|vec2|vec3",
            };
            let opt = if i >= s.params.len() - s.optional { "?" } else { "" };
            format!("{n}{opt}: {t}")
        })
        .collect();
    let variadic = if matches!(s.name, "union" | "intersection" | "smooth_union_n") {
        ", ..."
    } else {
        ""
    };
    format!("{}({}{variadic})", s.name, ps.join(", "))
}

/// The arguments of the variadic built-in `name` are all floats, or the
/// error at the first that is not: "`name` {what}: expected `float`, …".
fn all_floats(l: &mut Lowerer, name: &str, args: &[Arg], what: &str) -> Result<(), Diagnostic> {
    let one = FUNCTIONS.iter().find(|s| s.name == name).expect("listed");
    match args.iter().find(|a| a.v.ty != Type::Float) {
        None => Ok(()),
        Some(a) => Err(l
            .err(a.span, format!("`{name}` {what}: expected `float`, found `{}`", a.v.ty))
            .with_note(format!("signature: {}", signature_text(one)))),
    }
}

/// Lowers a call of a built-in; `None` when `name` is not one.
pub(crate) fn call(l: &mut Lowerer, name: &str, span: Span, args: &[Arg]) -> Option<Result<Val, Diagnostic>> {
    match name {
        "vec2" | "vec3" => return Some(construct(l, name, span, args)),
        "float" => {
            return Some(match args {
                [a] if a.v.ty == Type::Float => Ok(a.v),
                [a] => Ok(Val::float(a.v.c[0])),
                _ => Err(l
                    .err(span, format!("`float` takes 1 argument, found {}", args.len()))
                    .with_label("wrong number of arguments")),
            })
        }
        "smooth_union_n" if args.len() >= 3 => {
            if let Err(e) = all_floats(l, name, args, "takes numbers") {
                return Some(Err(e));
            }
            let k = args[0].v.s();
            let ds: Vec<Node> = args[1..].iter().map(|a| a.v.s()).collect();
            return Some(Ok(Val::float(smooth_union_n(l.b, k, &ds))));
        }
        "union" | "intersection" if args.len() > 2 => {
            if let Err(e) = all_floats(l, name, args, "combines distances") {
                return Some(Err(e));
            }
            let mut acc = args[0].v.s();
            for a in &args[1..] {
                acc = if name == "union" {
                    l.b.min(acc, a.v.s())
                } else {
                    l.b.max(acc, a.v.s())
                };
            }
            return Some(Ok(Val::float(acc)));
        }
        _ => {}
    }
    let sigs: Vec<&Signature> = FUNCTIONS.iter().filter(|s| s.name == name).collect();
    if sigs.is_empty() {
        return None;
    }
    let fits = |s: &&&Signature| args.len() <= s.params.len() && args.len() + s.optional >= s.params.len();
    let Some(sig) = sigs.iter().find(fits) else {
        let all: Vec<String> = sigs.iter().map(|s| signature_text(s)).collect();
        let want = sigs
            .iter()
            .map(|s| {
                if s.optional > 0 {
                    format!("{} to {}", s.params.len() - s.optional, s.params.len())
                } else {
                    s.params.len().to_string()
                }
            })
            .collect::<Vec<_>>()
            .join(" or ");
        return Some(Err(l
            .err(span, format!("`{name}` takes {want} argument(s), found {}", args.len()))
            .with_label("wrong number of arguments")
            .with_note(format!("signature: {}", all.join("  or  ")))));
    };
    if let Some(e) = check_period(l, name, args) {
        return Some(Err(e));
    }
    Some(check(l, sig, args).map(|vals| lower(l, sig, &vals)))
}

/// The period of `repeat` and `repeat_limited` must be positive: a zero
/// period would give NaN everywhere. Checked where the period is known at
/// load time: constants, and values of the parameters and time as they are;
/// a period that reads inputs is also kept as a guard to check again when
/// they change.
fn check_period(l: &mut Lowerer, name: &str, args: &[Arg]) -> Option<Diagnostic> {
    if !matches!(name, "repeat" | "repeat_limited") {
        return None;
    }
    let period = args.get(1)?;
    let vars = l.lib_input_values();
    for &n in period.v.comps() {
        let Some(v) = l.b.uniform_value(n, &vars) else { continue };
        if l.b.const_value(n).is_none() {
            l.guards.push((n, format!("the period of `{name}`")));
        }
        if !(v > 0.0 && v.is_finite()) {
            let what = if l.b.const_value(n).is_some() {
                String::new()
            } else {
                " with the parameters as they are".to_string()
            };
            return Some(
                l.err(
                    period.span,
                    format!("the period of `{name}` must be positive, found {v}{what}"),
                )
                .with_label("expected a period > 0 (for each axis)")
                .with_note("a very large period (such as 1e9) leaves an axis unrepeated"),
            );
        }
    }
    None
}

fn check(l: &mut Lowerer, sig: &Signature, args: &[Arg]) -> Result<Vec<Val>, Diagnostic> {
    let mismatch = |l: &Lowerer, a: &Arg, pname: &str, want: &str| {
        l.err(
            a.span,
            format!(
                "argument `{pname}` of `{}` must be {want}, found `{}`",
                sig.name, a.v.ty
            ),
        )
        .with_label(format!("expected {want}"))
        .with_note(format!("signature: {}", signature_text(sig)))
    };
    let mut generic: Option<(Type, Span)> = None;
    let mut out = Vec::with_capacity(args.len());
    for (a, (pname, kind)) in args.iter().zip(sig.params) {
        let v = match kind {
            F if a.v.ty != Type::Float => return Err(mismatch(l, a, pname, "a `float`")),
            P if a.v.ty != Type::Vec3 => {
                return Err(mismatch(l, a, pname, "a `vec3` point")
                    .with_note("primitives take the point first, e.g. `sphere(p - vec3(1.0, 0.0, 0.0), 0.5)`"))
            }
            V if a.v.ty == Type::Vec2 => {
                return Err(mismatch(
                    l,
                    a,
                    pname,
                    "a `vec3` (or a float, used for all three components)",
                ))
            }
            V if a.v.ty == Type::Float => Val::vec3(a.v.s(), a.v.s(), a.v.s()),
            G if a.v.ty != Type::Float => {
                if let Some((t, s)) = generic {
                    if t != a.v.ty {
                        return Err(l
                            .err(
                                a.span,
                                format!(
                                    "argument `{pname}` of `{}` is a `{}` but an earlier argument is a `{t}`",
                                    sig.name, a.v.ty
                                ),
                            )
                            .with_label(format!("expected {t} or float"))
                            .with_note(format!("the `{t}` argument starts at byte {}", s.start)));
                    }
                } else {
                    generic = Some((a.v.ty, a.span));
                }
                a.v
            }
            _ => a.v,
        };
        out.push(v);
    }
    if sig.name == "cross" || sig.name == "dot" || sig.name == "distance" {
        // Already unified above; nothing more to check.
    }
    Ok(out)
}

fn construct(l: &mut Lowerer, name: &str, span: Span, args: &[Arg]) -> Result<Val, Diagnostic> {
    let want = if name == "vec2" { 2 } else { 3 };
    if let [a] = args {
        if a.v.ty == Type::Float {
            return Ok(Val::from_slice(&vec![a.v.s(); want]).expect("2 or 3"));
        }
    }
    let mut comps = Vec::new();
    for a in args {
        comps.extend_from_slice(a.v.comps());
    }
    if comps.len() != want {
        return Err(l
            .err(
                span,
                format!("`{name}` needs {want} components in total, found {}", comps.len()),
            )
            .with_label("wrong number of components")
            .with_note(format!(
                "write `{name}(x)` to broadcast one float, or give {want} components"
            )));
    }
    Ok(Val::from_slice(&comps).expect("2 or 3"))
}

fn f(v: Node) -> Val {
    Val::float(v)
}

/// Lowers a checked call.
fn lower(l: &mut Lowerer, sig: &Signature, a: &[Val]) -> Val {
    let name = sig.name;
    match (name, a.len()) {
        ("length", _) => f(l.length(a[0])),
        ("distance", _) => {
            let d = l.map2(a[0], a[1], Builder::sub);
            f(l.length(d))
        }
        ("dot", _) => f(l.dot(a[0], a[1])),
        ("cross", _) => {
            let (u, v) = (a[0].c, a[1].c);
            let b = &mut *l.b;
            let mut c = |i: usize, j: usize| {
                let m1 = b.mul(u[i], v[j]);
                let m2 = b.mul(u[j], v[i]);
                b.sub(m1, m2)
            };
            let (x, y, z) = (c(1, 2), c(2, 0), c(0, 1));
            Val::vec3(x, y, z)
        }
        ("normalize", _) => {
            let len = l.length(a[0]);
            l.map2(a[0], f(len), Builder::div)
        }
        ("abs", _) => l.un(UnOp::Abs, a[0]),
        ("sign", _) => l.un(UnOp::Sign, a[0]),
        ("floor", _) => l.un(UnOp::Floor, a[0]),
        ("ceil", _) => l.map1(a[0], |b, x| {
            let n = b.neg(x);
            let fl = b.unary(UnOp::Floor, n);
            b.neg(fl)
        }),
        ("fract", _) => l.map1(a[0], |b, x| {
            let fl = b.unary(UnOp::Floor, x);
            b.sub(x, fl)
        }),
        ("round", 1) => l.un(UnOp::Round, a[0]),
        ("sqrt", _) => l.un(UnOp::Sqrt, a[0]),
        ("inversesqrt", _) => l.map1(a[0], |b, x| {
            let s = b.sqrt(x);
            let one = b.constant(1.0);
            b.div(one, s)
        }),
        ("exp", _) => l.un(UnOp::Exp, a[0]),
        ("exp2", _) => l.map1(a[0], |b, x| {
            let k = b.mul_c(x, std::f64::consts::LN_2);
            b.unary(UnOp::Exp, k)
        }),
        ("log", _) => l.un(UnOp::Ln, a[0]),
        ("log2", _) => l.map1(a[0], |b, x| {
            let ln = b.unary(UnOp::Ln, x);
            b.mul_c(ln, std::f64::consts::LOG2_E)
        }),
        ("sin", _) => l.un(UnOp::Sin, a[0]),
        ("cos", _) => l.un(UnOp::Cos, a[0]),
        ("tan", _) => l.un(UnOp::Tan, a[0]),
        ("asin", _) => l.un(UnOp::Asin, a[0]),
        ("acos", _) => l.un(UnOp::Acos, a[0]),
        ("atan", 1) => l.un(UnOp::Atan, a[0]),
        ("atan", 2) => l.map2(a[0], a[1], |b, y, x| b.binary(BinOp::Atan2, y, x)),
        ("radians", _) => l.map1(a[0], |b, x| b.mul_c(x, std::f64::consts::PI / 180.0)),
        ("degrees", _) => l.map1(a[0], |b, x| b.mul_c(x, 180.0 / std::f64::consts::PI)),
        ("min", _) => l.map2(a[0], a[1], Builder::min),
        ("max", _) => l.map2(a[0], a[1], Builder::max),
        ("pow", _) => l.map2(a[0], a[1], |b, x, y| b.binary(BinOp::Pow, x, y)),
        ("mod", _) => l.map2(a[0], a[1], glsl_mod),
        ("step", _) => l.map2(a[0], a[1], |b, e, x| {
            let d = b.sub(e, x);
            let (zero, one) = (b.constant(0.0), b.constant(1.0));
            b.select(d, zero, one)
        }),
        ("clamp", _) => l.map3(a[0], a[1], a[2], |b, x, lo, hi| b.clamp(x, lo, hi)),
        ("mix", _) => l.map3(a[0], a[1], a[2], mix),
        ("smoothstep", _) => l.map3(a[0], a[1], a[2], |b, e0, e1, x| {
            let num = b.sub(x, e0);
            let den = b.sub(e1, e0);
            let t = b.div(num, den);
            let (zero, one) = (b.constant(0.0), b.constant(1.0));
            let t = b.clamp(t, zero, one);
            let tt = b.square(t);
            let two_t = b.mul_c(t, 2.0);
            let three = b.constant(3.0);
            let k = b.sub(three, two_t);
            b.mul(tt, k)
        }),
        ("sphere", _) => {
            let len = l.length(a[0]);
            f(l.b.sub(len, a[1].s()))
        }
        ("box", _) => f(sd_box(l, a[0], a[1], None)),
        ("round_box", _) => f(sd_box(l, a[0], a[1], Some(a[2].s()))),
        ("plane", _) => {
            let d = l.dot(a[0], a[1]);
            f(l.b.add(d, a[2].s()))
        }
        ("ellipsoid", _) => f(sd_ellipsoid(l, a[0], a[1])),
        ("cylinder", _) => {
            let p = a[0];
            let rxz = xz_len(l, p);
            let dx = l.b.sub(rxz, a[2].s());
            let ay = l.b.abs(p.c[1]);
            let dy = l.b.sub(ay, a[1].s());
            f(box2_tail(l, dx, dy))
        }
        ("capsule", _) => {
            let p = a[0];
            let half = l.b.mul_c(a[1].s(), 0.5);
            let nhalf = l.b.neg(half);
            let cy = l.b.clamp(p.c[1], nhalf, half);
            let y = l.b.sub(p.c[1], cy);
            let len = l.length(Val::vec3(p.c[0], y, p.c[2]));
            f(l.b.sub(len, a[2].s()))
        }
        ("torus", _) => {
            let p = a[0];
            let rxz = xz_len(l, p);
            let q = l.b.sub(rxz, a[1].s());
            let len = l.length(Val::from_slice(&[q, p.c[1]]).expect("vec2"));
            f(l.b.sub(len, a[2].s()))
        }
        ("cone", _) => f(sd_cone(l, a[0], a[1].s(), a[2].s())),
        ("tri_prism", _) => {
            let (p, h, w) = (a[0], a[1].s(), a[2].s());
            let b = &mut *l.b;
            let qx = b.abs(p.c[0]);
            let qz = b.abs(p.c[2]);
            let t1 = b.mul_c(qx, 3f64.sqrt() / 2.0);
            let t2 = b.mul_c(p.c[1], 0.5);
            let slant = b.add(t1, t2);
            let bottom = b.neg(p.c[1]);
            let tri = b.max(slant, bottom);
            let hw = b.mul_c(w, 0.5);
            let tri = b.sub(tri, hw);
            let len = b.sub(qz, h);
            f(b.max(len, tri))
        }
        ("hex_prism", _) => f(sd_hex_prism(l, a[0], a[1].s(), a[2].s())),
        ("octahedron", _) => f(sd_octahedron(l, a[0], a[1].s())),
        ("union", _) => f(l.b.min(a[0].s(), a[1].s())),
        ("intersection", _) => f(l.b.max(a[0].s(), a[1].s())),
        ("difference", _) => {
            let nb = l.b.neg(a[1].s());
            f(l.b.max(a[0].s(), nb))
        }
        ("smooth_union" | "smooth_intersection" | "smooth_difference", _) => {
            let n = if a.len() > 3 { a[3].s() } else { l.b.constant(2.0) };
            let (x, mut y, k) = (a[0].s(), a[1].s(), a[2].s());
            if name == "smooth_difference" {
                y = l.b.neg(y);
            }
            f(smooth_minmax(l.b, x, y, k, n, name == "smooth_union"))
        }
        ("smin_cubic", _) => {
            let three = l.b.constant(3.0);
            f(smooth_minmax(l.b, a[0].s(), a[1].s(), a[2].s(), three, true))
        }
        ("smin_exp", _) => f(smin_exp(l.b, a[0].s(), a[1].s(), a[2].s())),
        ("smin_pow", _) => f(smin_pow(l.b, a[0].s(), a[1].s(), a[2].s())),
        ("smin_root", _) => {
            let b = &mut *l.b;
            let (x, y, k) = (a[0].s(), a[1].s(), a[2].s());
            let d = b.sub(x, y);
            let d2 = b.square(d);
            let k2 = b.square(k);
            let s = b.add(d2, k2);
            let r = b.sqrt(s);
            let sum = b.add(x, y);
            let t = b.sub(sum, r);
            f(b.mul_c(t, 0.5))
        }
        ("round", 2) => f(l.b.sub(a[0].s(), a[1].s())),
        ("onion", _) => {
            let ad = l.b.abs(a[0].s());
            f(l.b.sub(ad, a[1].s()))
        }
        ("translate", _) => l.map2(a[0], a[1], Builder::sub),
        ("rotate_x", _) => rotate_plane(l, a[0], a[1].s(), 1, 2),
        ("rotate_y", _) => rotate_plane(l, a[0], a[1].s(), 2, 0),
        ("rotate_z", _) => rotate_plane(l, a[0], a[1].s(), 0, 1),
        ("rotate", _) => rotate_axis(l, a[0], a[1], a[2].s()),
        ("twist_x", _) => {
            let ang = l.b.mul(a[1].s(), a[0].c[0]);
            rotate_plane(l, a[0], ang, 1, 2)
        }
        ("twist_y", _) => {
            let ang = l.b.mul(a[1].s(), a[0].c[1]);
            rotate_plane(l, a[0], ang, 2, 0)
        }
        ("twist_z", _) => {
            let ang = l.b.mul(a[1].s(), a[0].c[2]);
            rotate_plane(l, a[0], ang, 0, 1)
        }
        ("bend", _) => {
            // Quílez's cheap bend: (c x + s y, -s x + c y, z) with angle k x.
            let p = a[0];
            let ang = l.b.mul(a[1].s(), p.c[0]);
            let b = &mut *l.b;
            let c = b.unary(UnOp::Cos, ang);
            let s = b.unary(UnOp::Sin, ang);
            let cx = b.mul(c, p.c[0]);
            let sy = b.mul(s, p.c[1]);
            let sx = b.mul(s, p.c[0]);
            let cy = b.mul(c, p.c[1]);
            let x = b.add(cx, sy);
            let y = b.sub(cy, sx);
            Val::vec3(x, y, p.c[2])
        }
        ("elongate", _) => l.map2(a[0], a[1], |b, x, h| {
            let nh = b.neg(h);
            let c = b.clamp(x, nh, h);
            b.sub(x, c)
        }),
        ("mirror_x" | "mirror_y" | "mirror_z", _) => {
            let i = match name {
                "mirror_x" => 0,
                "mirror_y" => 1,
                _ => 2,
            };
            let mut p = a[0];
            p.c[i] = l.b.abs(p.c[i]);
            p
        }
        ("repeat", _) => l.map2(a[0], a[1], |b, x, s| {
            let q = b.div(x, s);
            let r = b.unary(UnOp::Round, q);
            let m = b.mul(s, r);
            b.sub(x, m)
        }),
        ("repeat_limited", _) => l.map3(a[0], a[1], a[2], |b, x, s, lim| {
            let q = b.div(x, s);
            let r = b.unary(UnOp::Round, q);
            let nl = b.neg(lim);
            let r = b.clamp(r, nl, lim);
            let m = b.mul(s, r);
            b.sub(x, m)
        }),
        ("displace", _) => {
            let (p, amp, fr) = (a[0], a[1].s(), a[2].s());
            let b = &mut *l.b;
            let mut acc = amp;
            for i in 0..3 {
                let t = b.mul(fr, p.c[i]);
                let s = b.unary(UnOp::Sin, t);
                acc = b.mul(acc, s);
            }
            f(acc)
        }
        _ => unreachable!("every signature has a lowering: {name}/{}", a.len()),
    }
}

fn glsl_mod(b: &mut Builder, x: Node, y: Node) -> Node {
    let q = b.div(x, y);
    let fl = b.unary(UnOp::Floor, q);
    let m = b.mul(y, fl);
    b.sub(x, m)
}

fn mix(b: &mut Builder, x: Node, y: Node, t: Node) -> Node {
    let d = b.sub(y, x);
    let m = b.mul(d, t);
    b.add(x, m)
}

fn xz_len(l: &mut Lowerer, p: Val) -> Node {
    l.length(Val::from_slice(&[p.c[0], p.c[2]]).expect("vec2"))
}

/// min(max(dx, dy), 0) + length(max((dx, dy), 0)): the exact 2D box tail.
fn box2_tail(l: &mut Lowerer, dx: Node, dy: Node) -> Node {
    let b = &mut *l.b;
    let zero = b.constant(0.0);
    let m = b.max(dx, dy);
    let inside = b.min(m, zero);
    let ox = b.max(dx, zero);
    let oy = b.max(dy, zero);
    let ox2 = b.square(ox);
    let oy2 = b.square(oy);
    let s = b.add(ox2, oy2);
    let outside = b.sqrt(s);
    b.add(inside, outside)
}

fn sd_box(l: &mut Lowerer, p: Val, half: Val, r: Option<Node>) -> Node {
    let q = l.map2(p, half, |b, x, h| {
        let ax = b.abs(x);
        b.sub(ax, h)
    });
    let q = match r {
        Some(r) => l.map2(q, Val::float(r), Builder::add),
        None => q,
    };
    let zero = Val::float(l.b.constant(0.0));
    let pos = l.map2(q, zero, Builder::max);
    let outside = l.length(pos);
    let m = l.max_comp(q);
    let inside = l.b.min(m, zero.s());
    let d = l.b.add(outside, inside);
    match r {
        Some(r) => l.b.sub(d, r),
        None => d,
    }
}

fn sd_ellipsoid(l: &mut Lowerer, p: Val, r: Val) -> Node {
    let pr = l.map2(p, r, Builder::div);
    let k0 = l.length(pr);
    let rr = l.map2(r, r, Builder::mul);
    let prr = l.map2(p, rr, Builder::div);
    let k1 = l.length(prr);
    let b = &mut *l.b;
    let one = b.constant(1.0);
    let k0m1 = b.sub(k0, one);
    let num = b.mul(k0, k0m1);
    let d = b.div(num, k1);
    // At the centre the bound is 0/0: use -min(r) there.
    let cond = b.add_c(k1, -1e-12);
    let mr = b.min(r.c[0], r.c[1]);
    let mr = b.min(mr, r.c[2]);
    let centre = b.neg(mr);
    b.select(cond, d, centre)
}

fn sd_cone(l: &mut Lowerer, p: Val, angle: Node, h: Node) -> Node {
    let wx = xz_len(l, p);
    let wy = p.c[1];
    let b = &mut *l.b;
    let zero = b.constant(0.0);
    let one = b.constant(1.0);
    let tan = b.unary(UnOp::Tan, angle);
    let qx = b.mul(h, tan);
    let qy = b.neg(h);
    // a = w - q*clamp(dot(w,q)/dot(q,q), 0, 1)
    let wq1 = b.mul(wx, qx);
    let wq2 = b.mul(wy, qy);
    let wq = b.add(wq1, wq2);
    let qq1 = b.square(qx);
    let qq2 = b.square(qy);
    let qq = b.add(qq1, qq2);
    let t = b.div(wq, qq);
    let t = b.clamp(t, zero, one);
    let tqx = b.mul(qx, t);
    let tqy = b.mul(qy, t);
    let ax = b.sub(wx, tqx);
    let ay = b.sub(wy, tqy);
    // b = w - q*vec2(clamp(w.x/q.x, 0, 1), 1)
    let u = b.div(wx, qx);
    let u = b.clamp(u, zero, one);
    let uqx = b.mul(qx, u);
    let bx = b.sub(wx, uqx);
    let by = b.sub(wy, qy);
    let k = b.unary(UnOp::Sign, qy);
    let aa1 = b.square(ax);
    let aa2 = b.square(ay);
    let aa = b.add(aa1, aa2);
    let bb1 = b.square(bx);
    let bb2 = b.square(by);
    let bb = b.add(bb1, bb2);
    let d = b.min(aa, bb);
    // s = max(k*(w.x*q.y - w.y*q.x), k*(w.y - q.y))
    let c1 = b.mul(wx, qy);
    let c2 = b.mul(wy, qx);
    let cr = b.sub(c1, c2);
    let s1 = b.mul(k, cr);
    let s2 = b.mul(k, by);
    let s = b.max(s1, s2);
    let sd = b.sqrt(d);
    let sg = b.unary(UnOp::Sign, s);
    b.mul(sd, sg)
}

fn sd_hex_prism(l: &mut Lowerer, p: Val, h: Node, w: Node) -> Node {
    let (kx, ky, kz) = (-(3f64.sqrt()) / 2.0, 0.5, 1.0 / 3f64.sqrt());
    let b = &mut *l.b;
    let zero = b.constant(0.0);
    let px = b.abs(p.c[0]);
    let py = b.abs(p.c[1]);
    let pz = b.abs(p.c[2]);
    let d1 = b.mul_c(px, kx);
    let d2 = b.mul_c(py, ky);
    let d = b.add(d1, d2);
    let m = b.min(d, zero);
    let t = b.mul_c(m, 2.0);
    let tx = b.mul_c(t, kx);
    let ty = b.mul_c(t, ky);
    let px = b.sub(px, tx);
    let py = b.sub(py, ty);
    let lim = b.mul_c(w, kz);
    let nlim = b.neg(lim);
    let cx = b.clamp(px, nlim, lim);
    let ex = b.sub(px, cx);
    let ey = b.sub(py, w);
    let e1 = b.square(ex);
    let e2 = b.square(ey);
    let e = b.add(e1, e2);
    let len = b.sqrt(e);
    let sg = b.unary(UnOp::Sign, ey);
    let dx = b.mul(len, sg);
    let dy = b.sub(pz, h);
    box2_tail(l, dx, dy)
}

fn sd_octahedron(l: &mut Lowerer, p: Val, s: Node) -> Node {
    let b = &mut *l.b;
    let (x, y, z) = (b.abs(p.c[0]), b.abs(p.c[1]), b.abs(p.c[2]));
    let sum = b.add(x, y);
    let sum = b.add(sum, z);
    let m = b.sub(sum, s);
    let cond = |b: &mut Builder, c: Node| {
        let t = b.mul_c(c, 3.0);
        b.sub(m, t)
    };
    let (c1, c2, c3) = (cond(b, x), cond(b, y), cond(b, z));
    // q = p.xyz if c1, p.yzx if c2, else p.zxy.
    let pick = |b: &mut Builder, v1: Node, v2: Node, v3: Node| {
        let inner = b.select(c2, v2, v3);
        b.select(c1, v1, inner)
    };
    let qx = pick(b, x, y, z);
    let qy = pick(b, y, z, x);
    let qz = pick(b, z, x, y);
    let zero = b.constant(0.0);
    let t = b.sub(qz, qy);
    let t = b.add(t, s);
    let t = b.mul_c(t, 0.5);
    let k = b.clamp(t, zero, s);
    let ry = b.sub(qy, s);
    let ry = b.add(ry, k);
    let rz = b.sub(qz, k);
    let r = l.length(Val::vec3(qx, ry, rz));
    let b = &mut *l.b;
    let far = b.mul_c(m, 1.0 / 3f64.sqrt());
    let inner = b.select(c3, r, far);
    let inner = b.select(c2, r, inner);
    b.select(c1, r, inner)
}

/// min(a,b) - corr (or max(a,b) + corr) with corr = max(k-|a-b|,0)^n / (2n k^(n-1)).
fn smooth_minmax(b: &mut Builder, x: Node, y: Node, k: Node, n: Node, is_min: bool) -> Node {
    if b.const_value(k).is_some_and(|k| k <= 0.0) {
        return if is_min { b.min(x, y) } else { b.max(x, y) };
    }
    let d = b.sub(x, y);
    let ad = b.abs(d);
    let zero = b.constant(0.0);
    let kd = b.sub(k, ad);
    let hh = b.max(kd, zero);
    let hn = b.binary(BinOp::Pow, hh, n);
    let tiny = b.constant(1e-30);
    let kk = b.max(k, tiny);
    let n1 = b.add_c(n, -1.0);
    let kn1 = b.binary(BinOp::Pow, kk, n1);
    let two_n = b.mul_c(n, 2.0);
    let den = b.mul(two_n, kn1);
    let corr = b.div(hn, den);
    if is_min {
        let m = b.min(x, y);
        b.sub(m, corr)
    } else {
        let m = b.max(x, y);
        b.add(m, corr)
    }
}

/// -k ln(e^(-a/k) + e^(-b/k)), computed stably as min - k ln(1 + e^(-|a-b|/k)).
fn smin_exp(b: &mut Builder, x: Node, y: Node, k: Node) -> Node {
    if b.const_value(k).is_some_and(|k| k <= 0.0) {
        return b.min(x, y);
    }
    let m = b.min(x, y);
    let d = b.sub(x, y);
    let ad = b.abs(d);
    let t = b.div(ad, k);
    let nt = b.neg(t);
    let e = b.unary(UnOp::Exp, nt);
    let one = b.constant(1.0);
    let s = b.add(one, e);
    let ln = b.unary(UnOp::Ln, s);
    let corr = b.mul(k, ln);
    b.sub(m, corr)
}

/// The n-ary exponential smooth minimum, m − k·ln Σ e^(−(dᵢ − m)/k) with
/// m = min dᵢ (the same value as −k·ln Σ e^(−dᵢ/k), without overflow):
/// symmetric in the dᵢ, unlike a fold of a two-argument smooth minimum.
/// min(dᵢ) for a constant k ≤ 0.
fn smooth_union_n(b: &mut Builder, k: Node, ds: &[Node]) -> Node {
    let mut m = ds[0];
    for &d in &ds[1..] {
        m = b.min(m, d);
    }
    if b.const_value(k).is_some_and(|k| k <= 0.0) {
        return m;
    }
    let mut sum = None;
    for &d in ds {
        let x = b.sub(d, m);
        let t = b.div(x, k);
        let nt = b.neg(t);
        let e = b.unary(UnOp::Exp, nt);
        sum = Some(match sum {
            None => e,
            Some(s) => b.add(s, e),
        });
    }
    let ln = b.unary(UnOp::Ln, sum.expect("two or more distances"));
    let corr = b.mul(k, ln);
    b.sub(m, corr)
}

/// ((a^k b^k)/(a^k + b^k))^(1/k) for a, b > 0; min(a, b) where either is not positive.
fn smin_pow(b: &mut Builder, x: Node, y: Node, k: Node) -> Node {
    // (a^k b^k / (a^k + b^k))^(1/k) = m (1 + (m/M)^k)^(-1/k) with m = min, M = max:
    // the same value, without overflowing a^k b^k in f32.
    let m = b.min(x, y);
    let big = b.max(x, y);
    let ratio = b.div(m, big);
    let rk = b.binary(BinOp::Pow, ratio, k);
    let one = b.constant(1.0);
    let s = b.add(one, rk);
    let nk = b.neg(k);
    let e = b.div(one, nk);
    let f = b.binary(BinOp::Pow, s, e);
    let r = b.mul(m, f);
    b.select(m, r, m)
}

/// Turns the (i, j) coordinate plane of p by -angle, so that the shape evaluated
/// at the result appears turned by +angle (right-handed about the third axis).
fn rotate_plane(l: &mut Lowerer, p: Val, angle: Node, i: usize, j: usize) -> Val {
    let b = &mut *l.b;
    let c = b.unary(UnOp::Cos, angle);
    let s = b.unary(UnOp::Sin, angle);
    let (u, v) = (p.c[i], p.c[j]);
    let cu = b.mul(c, u);
    let sv = b.mul(s, v);
    let su = b.mul(s, u);
    let cv = b.mul(c, v);
    let nu = b.add(cu, sv);
    let nv = b.sub(cv, su);
    let mut out = p;
    out.c[i] = nu;
    out.c[j] = nv;
    out
}

/// Rodrigues' rotation of p by -angle about the unit axis.
fn rotate_axis(l: &mut Lowerer, p: Val, axis: Val, angle: Node) -> Val {
    let len = l.length(axis);
    let k = l.map2(axis, Val::float(len), Builder::div);
    let kxp = {
        let (u, v) = (k.c, p.c);
        let b = &mut *l.b;
        let mut c = |i: usize, j: usize| {
            let m1 = b.mul(u[i], v[j]);
            let m2 = b.mul(u[j], v[i]);
            b.sub(m1, m2)
        };
        let (x, y, z) = (c(1, 2), c(2, 0), c(0, 1));
        Val::vec3(x, y, z)
    };
    let kdp = l.dot(k, p);
    let b = &mut *l.b;
    let na = b.neg(angle);
    let c = b.unary(UnOp::Cos, na);
    let s = b.unary(UnOp::Sin, na);
    let one = b.constant(1.0);
    let omc = b.sub(one, c);
    let w = b.mul(kdp, omc);
    let mut out = p;
    for i in 0..3 {
        let t1 = b.mul(p.c[i], c);
        let t2 = b.mul(kxp.c[i], s);
        let t3 = b.mul(k.c[i], w);
        let t = b.add(t1, t2);
        out.c[i] = b.add(t, t3);
    }
    out
}
