//! Type checking and lowering of parsed shape text into the scalar DAG.
//!
//! The language is typed (`float`, `vec2`, `vec3`); lowering checks every
//! operation's types, reports mismatches at their span, and produces DAG
//! nodes through a [`Builder`], so a shape is compiled exactly once.

use std::collections::HashMap;

use std::sync::{Arc, Mutex};

use crate::algebraic::{taylor_bound, xyz_ring};
use crate::diag::{suggest, Diagnostic, SourceId, Span};
use crate::ir::{Builder, Node, UnOp};
use crate::library;
use crate::lipschitz::lipschitz_bound;
use crate::surface::{analyze, image_only_field, Analysis, BoundMethod, ParametricDef, SurfaceOptions};
use crate::syntax::{parse, BinaryOp, Expr, ExprKind, Program, TypeName};
use crate::types::{Type, Val, Value};

/// A user primitive: a named SDF with parameters, called like a built-in
/// with the point first and then the parameters in declaration order.
#[derive(Debug, Clone)]
pub struct Surface {
    /// Its name.
    pub name: String,
    /// Parameters in call order, with their defaults (which fix their types).
    pub params: Vec<(String, Value)>,
    /// The parsed body.
    pub program: Program,
    /// Where the body's text came from.
    pub source: SourceId,
    /// How the body defines the surface.
    pub mode: SurfaceMode,
    /// How the surface is traced (implicit and parametric modes).
    pub options: SurfaceOptions,
    /// The coordinate functions of a parametric surface (then `program` is
    /// the x coordinate).
    pub parametric: Option<Box<ParametricDef>>,
}

/// How a user surface's body defines it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SurfaceMode {
    /// The body is a signed distance (uses `p`).
    #[default]
    Sdf,
    /// The body is an equation f(x, y, z) = 0 (uses `x`, `y`, `z` or `p`); it
    /// is traced through the first-order distance estimate f / |∇f| with the
    /// exact gradient, guarded where the gradient vanishes.
    Implicit,
    /// The surface is the image of (x(s,t), y(s,t), z(s,t)); rational
    /// parametrizations are implicitized and traced like implicit ones.
    Parametric,
}

/// Where |∇f| is below this, the implicit distance estimate divides by it instead.
pub const GRADIENT_GUARD: f64 = 1e-9;

/// Analyses keyed by the content of a surface (its definition and those of
/// the surfaces it calls) and the bits of the values it bound.
type AnalysisMap = HashMap<(String, Vec<u64>), Arc<Analysis>>;

/// A shared cache of surface analyses (implicit equations, bounds,
/// implicitizations), keyed by content and bound values, never by name: a
/// library compiled again with it derives only what changed.
#[derive(Debug, Clone, Default)]
pub struct Analyses(Arc<Mutex<AnalysisMap>>);

impl Analyses {
    /// Number of cached analyses.
    pub fn len(&self) -> usize {
        self.0.lock().map(|m| m.len()).unwrap_or(0)
    }
    /// True when nothing is cached.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Everything shape text may refer to besides `p`: the scene's named
/// parameters and its user primitives.
///
/// The parameters are runtime inputs: shape text that names one reads it
/// from the variable slice at evaluation time (see [`Library::input_names`]
/// for the layout), so changing a value never recompiles. The time `t` is
/// input [`TIME`](crate::ir::TIME).
#[derive(Debug, Clone, Default)]
pub struct Library {
    params: Vec<(String, Value)>,
    /// The time the exact analyses bind (seconds).
    time: f64,
    surfaces: HashMap<String, Surface>,
    order: Vec<String>,
    /// Analyses of implicit and parametric surfaces, per surface and
    /// parameter values: each equation is derived (and implicitized) once.
    analyses: Analyses,
    /// Stops long analyses (implicitization) when cancelled.
    cancel: Option<isoray_job::CancelToken>,
    /// Told how far long analyses (implicitization) got.
    progress: Option<Reporter>,
}

/// A shared progress reporter (shown in `Debug` as present or not).
#[derive(Clone)]
struct Reporter(std::sync::Arc<dyn isoray_job::Progress + Send>);

impl std::fmt::Debug for Reporter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Reporter")
    }
}

impl Library {
    /// An empty library.
    pub fn new() -> Self {
        Self::default()
    }

    /// Defines (or redefines) a named parameter visible to all shape text.
    pub fn set_param(&mut self, name: &str, value: Value) {
        if let Some(slot) = self.params.iter_mut().find(|(n, _)| n == name) {
            slot.1 = value;
        } else {
            self.params.push((name.to_string(), value));
        }
    }

    /// The named parameters.
    pub fn params(&self) -> &[(String, Value)] {
        &self.params
    }

    /// Lets `token` stop long analyses: an implicitization in progress ends
    /// with an error that says it was cancelled, and nothing is cached.
    pub fn set_cancel(&mut self, token: isoray_job::CancelToken) {
        self.cancel = Some(token);
    }

    /// Lets `progress` hear how far long analyses get: an implicitization
    /// reports its stages (named `surface `NAME`: …`) and their units.
    pub fn set_progress(&mut self, progress: std::sync::Arc<dyn isoray_job::Progress + Send>) {
        self.progress = Some(Reporter(progress));
    }

    /// The reporter of long analyses, if any.
    pub fn progress(&self) -> Option<&std::sync::Arc<dyn isoray_job::Progress + Send>> {
        self.progress.as_ref().map(|r| &r.0)
    }

    /// The token that stops long analyses, if any.
    pub fn cancel_token(&self) -> Option<&isoray_job::CancelToken> {
        self.cancel.as_ref()
    }

    /// Uses `cache` for the analyses of surfaces (shared with other libraries).
    pub fn use_analyses(&mut self, cache: Analyses) {
        self.analyses = cache;
    }

    /// The analysis cache (clone it to share it).
    pub fn analyses(&self) -> &Analyses {
        &self.analyses
    }

    /// Sets the time that exact analyses bind when a surface's parameters
    /// depend on `t` (shape text reads the time as an input).
    pub fn set_time(&mut self, t: f64) {
        self.time = t;
    }

    /// The time exact analyses bind.
    pub fn time(&self) -> f64 {
        self.time
    }

    /// The first input index of parameter `name` and its type: its
    /// components are that index and the ones after it.
    pub fn param_input(&self, name: &str) -> Option<(u32, Type)> {
        let mut at = 1u32;
        for (n, v) in &self.params {
            if n == name {
                return Some((at, v.ty()));
            }
            at += v.ty().width() as u32;
        }
        None
    }

    /// Number of inputs: the time and every parameter component.
    pub fn input_count(&self) -> usize {
        1 + self.params.iter().map(|(_, v)| v.ty().width()).sum::<usize>()
    }

    /// The names of the inputs in slice order: `t`, then each parameter
    /// (`NAME` for a number, `NAME.x`, `NAME.y`, `NAME.z` for a vector).
    pub fn input_names(&self) -> Vec<String> {
        let mut out = vec!["t".to_string()];
        for (n, v) in &self.params {
            match v.ty() {
                Type::Float => out.push(n.clone()),
                ty => out.extend(["x", "y", "z"][..ty.width()].iter().map(|c| format!("{n}.{c}"))),
            }
        }
        out
    }

    /// The current inputs: the time, then the parameter values.
    pub fn input_values(&self) -> Vec<f64> {
        let mut out = vec![self.time];
        for (_, v) in &self.params {
            match *v {
                Value::Float(x) => out.push(x),
                Value::Vec2(a) => out.extend(a),
                Value::Vec3(a) => out.extend(a),
            }
        }
        out
    }

    /// Parses and adds a user primitive. `source` identifies `text` in
    /// diagnostics. The body is type-checked by [`Library::check`].
    pub fn add_surface(
        &mut self,
        name: &str,
        params: Vec<(String, Value)>,
        text: &str,
        source: SourceId,
    ) -> Result<(), Diagnostic> {
        self.add_surface_with_mode(name, params, text, source, SurfaceMode::Sdf)
    }

    /// Parses and adds a user surface defined in the given mode.
    pub fn add_surface_with_mode(
        &mut self,
        name: &str,
        params: Vec<(String, Value)>,
        text: &str,
        source: SourceId,
        mode: SurfaceMode,
    ) -> Result<(), Diagnostic> {
        let program = parse(text, source)?;
        if !self.surfaces.contains_key(name) {
            self.order.push(name.to_string());
        }
        self.surfaces.insert(
            name.to_string(),
            Surface {
                name: name.to_string(),
                params,
                program,
                source,
                mode,
                options: SurfaceOptions::default(),
                parametric: None,
            },
        );
        Ok(())
    }

    /// Adds a parametric surface: `coords` are the x, y, z expressions in
    /// the parameters `s` and `t` (and the surface's params), each with the
    /// source id of its text.
    pub fn add_parametric_surface(
        &mut self,
        name: &str,
        params: Vec<(String, Value)>,
        coords: [(&str, SourceId); 3],
        domain: [[f64; 2]; 2],
        options: SurfaceOptions,
    ) -> Result<(), Diagnostic> {
        let mut programs = Vec::new();
        for (text, id) in coords {
            programs.push(parse(text, id)?);
        }
        let sources = [coords[0].1, coords[1].1, coords[2].1];
        let programs: [Program; 3] = programs.try_into().expect("three coordinates");
        self.add_surface_with_mode(name, params, coords[0].0, coords[0].1, SurfaceMode::Parametric)?;
        let s = self.surfaces.get_mut(name).expect("just added");
        s.options = options;
        s.parametric = Some(Box::new(ParametricDef {
            coords: programs,
            sources,
            domain,
        }));
        Ok(())
    }

    /// Sets how a surface is traced.
    pub fn set_surface_options(&mut self, name: &str, options: SurfaceOptions) {
        if let Some(s) = self.surfaces.get_mut(name) {
            s.options = options;
        }
    }

    /// What isoray derives for a surface (its equation, the bound it traces,
    /// timings) with the given constant parameters; computed once and cached.
    pub fn analysis(&self, s: &Surface, params: &[Value]) -> Result<Arc<Analysis>, Diagnostic> {
        let (content, inputs) = self.content_of(s);
        let vars = self.input_values();
        let mut bits: Vec<u64> = params
            .iter()
            .flat_map(|v| match v {
                Value::Float(x) => vec![x.to_bits()],
                Value::Vec2(a) => a.iter().map(|x| x.to_bits()).collect(),
                Value::Vec3(a) => a.iter().map(|x| x.to_bits()).collect(),
            })
            .collect();
        bits.extend(
            inputs
                .iter()
                .map(|&k| vars.get(k as usize).copied().unwrap_or(f64::NAN).to_bits()),
        );
        let key = (content, bits);
        if let Some(a) = self.analyses.0.lock().ok().and_then(|m| m.get(&key).cloned()) {
            return Ok(a);
        }
        let a = analyze(self, s, params);
        if let Some(c) = &self.cancel {
            if c.is_cancelled() {
                return Err(
                    Diagnostic::new(s.source, Span::default(), "cancelled").with_label("the analysis was cancelled")
                );
            }
        }
        let a = Arc::new(a?);
        if let Ok(mut m) = self.analyses.0.lock() {
            m.insert(key, a.clone());
        }
        Ok(a)
    }

    /// A key for the content of surface `s`: its definition and those of the
    /// user surfaces it calls, directly or not; and the inputs (scene
    /// parameters, the time) those bodies read directly, which exact algebra
    /// binds at their current values.
    fn content_of(&self, s: &Surface) -> (String, Vec<u32>) {
        let mut todo = vec![s];
        let mut seen: Vec<&str> = Vec::new();
        let mut key = String::new();
        let mut inputs = Vec::new();
        while let Some(x) = todo.pop() {
            if seen.contains(&x.name.as_str()) {
                continue;
            }
            seen.push(&x.name);
            key.push_str(&format!(
                "{}|{:?}|{:?}|{:?}|{:?}|{:?};",
                x.name, x.params, x.mode, x.options, x.program, x.parametric
            ));
            let mut programs = vec![&x.program];
            if let Some(def) = &x.parametric {
                programs.extend(def.coords.iter());
            }
            let own: Vec<&str> = x.params.iter().map(|(n, _)| n.as_str()).collect();
            for prog in programs {
                for name in prog.names_used() {
                    if own.contains(&name.as_str()) {
                        continue;
                    }
                    if let Some((at, ty)) = self.param_input(&name) {
                        inputs.extend(at..at + ty.width() as u32);
                    } else if name == "t" && x.mode != SurfaceMode::Parametric {
                        inputs.push(crate::ir::TIME);
                    }
                }
                for f in prog.functions_called() {
                    if let Some(c) = self.surfaces.get(&f) {
                        todo.push(c);
                    }
                }
            }
        }
        inputs.sort_unstable();
        inputs.dedup();
        (key, inputs)
    }

    /// A key for everything that compiling shape text calling the functions
    /// `called` depends on in this library besides the text itself: the
    /// input layout (each parameter's name and type, in order) and the
    /// content of the user surfaces it calls, directly or not. Shape text
    /// compiled in two libraries with equal keys gives the same graph,
    /// except for inputs that exact algebra bound (see [`Compiled::bound`]).
    pub fn content_key(&self, called: &[String]) -> String {
        let mut key = String::new();
        for (n, v) in &self.params {
            key.push_str(&format!("{n}:{};", v.ty()));
        }
        key.push('|');
        for name in called {
            if let Some(s) = self.surfaces.get(name) {
                key.push_str(&self.content_of(s).0);
            }
        }
        key
    }

    /// The analysis of a surface with its default parameters.
    pub fn default_analysis(&self, name: &str) -> Option<Result<Arc<Analysis>, Diagnostic>> {
        let s = self.surfaces.get(name)?;
        let defaults: Vec<Value> = s.params.iter().map(|(_, v)| *v).collect();
        Some(self.analysis(s, &defaults))
    }

    /// Lowers a surface's raw body (the equation f for implicit surfaces,
    /// the distance for SDFs) at the point X, Y, Z of `b` with constant parameters.
    pub(crate) fn lower_raw(&self, b: &mut Builder, s: &Surface, params: &[Value]) -> Result<Node, Diagnostic> {
        let mut l = Lowerer::binding(b, self, s.source);
        let p = l.point();
        let args: Vec<Val> = params.iter().map(|v| v.lower(l.b)).collect();
        Ok(l.lower_body(s, p, &args)?.s())
    }

    /// Lowers the coordinates of a parametric surface at s = X, t = Y of `b`.
    pub(crate) fn lower_coords(&self, b: &mut Builder, s: &Surface, params: &[Value]) -> Result<[Node; 3], Diagnostic> {
        let def = s.parametric.as_ref().expect("a parametric surface");
        let mut out = [Node(0); 3];
        for (i, prog) in def.coords.iter().enumerate() {
            let mut l = Lowerer::binding(b, self, def.sources[i]);
            let (sv, tv) = (l.b.x(), l.b.y());
            l.scope.push(("s".to_string(), Val::float(sv)));
            l.scope.push(("t".to_string(), Val::float(tv)));
            for ((n, _), v) in s.params.iter().zip(params) {
                let lv = v.lower(l.b);
                l.scope.push((n.clone(), lv));
            }
            let v = l.program(prog)?;
            if v.ty != Type::Float {
                let coord = ["x", "y", "z"][i];
                return Err(Diagnostic::new(
                    def.sources[i],
                    prog.body.span,
                    format!(
                        "coordinate `{coord}` of surface `{}` must be a `float`, found `{}`",
                        s.name, v.ty
                    ),
                )
                .with_label(format!("this is a {}", v.ty)));
            }
            out[i] = v.s();
        }
        Ok(out)
    }

    /// The coordinate functions of the parametric surface `name` as three
    /// evaluation tapes, with its parameter domain, for tessellation.
    ///
    /// Each tape reads s from X and t from Y (Z is unused); see
    /// [`ParametricCoords`](crate::surface::ParametricCoords). `params` are
    /// the surface's parameter values in declaration order: `None` uses the
    /// defaults, and a shorter list takes the defaults for the parameters it
    /// leaves out. Unknown names, surfaces that are not parametric, too many
    /// parameters or parameters of the wrong type are errors; the diagnostic
    /// then has no text position (source 0 and an empty span) unless it comes
    /// from a coordinate's text.
    pub fn parametric_coords(
        &self,
        name: &str,
        params: Option<&[Value]>,
    ) -> Result<crate::surface::ParametricCoords, Diagnostic> {
        let Some(s) = self.surfaces.get(name) else {
            let mut d = Diagnostic::new(0, Span::default(), format!("unknown surface `{name}`"))
                .with_label("no surface of that name in the library");
            if let Some(n) = suggest(name, self.order.iter().map(String::as_str)) {
                d = d.with_note(format!("did you mean `{n}`?"));
            }
            return Err(d);
        };
        let Some(def) = s.parametric.as_ref().filter(|_| s.mode == SurfaceMode::Parametric) else {
            let mode = match s.mode {
                SurfaceMode::Sdf => "a signed distance",
                SurfaceMode::Implicit => "an implicit surface",
                SurfaceMode::Parametric => "parametric without coordinates",
            };
            return Err(Diagnostic::new(
                0,
                Span::default(),
                format!("surface `{name}` is not parametric, it is {mode}"),
            )
            .with_label("only parametric surfaces can be tessellated over (s, t)"));
        };
        let given = params.unwrap_or(&[]);
        if given.len() > s.params.len() {
            return Err(Diagnostic::new(
                0,
                Span::default(),
                format!(
                    "surface `{name}` takes {} parameter(s), found {}",
                    s.params.len(),
                    given.len()
                ),
            )
            .with_label("too many parameters"));
        }
        let mut values = Vec::with_capacity(s.params.len());
        for (i, (pname, default)) in s.params.iter().enumerate() {
            match given.get(i) {
                Some(v) if v.ty() != default.ty() => {
                    return Err(Diagnostic::new(
                        0,
                        Span::default(),
                        format!(
                            "parameter `{pname}` of surface `{name}` is a `{}`, found `{}`",
                            default.ty(),
                            v.ty()
                        ),
                    )
                    .with_label(format!("expected {}", default.ty())));
                }
                Some(v) => values.push(*v),
                None => values.push(*default),
            }
        }
        let mut b = Builder::new();
        let nodes = self.lower_coords(&mut b, s, &values)?;
        Ok(crate::surface::ParametricCoords {
            name: name.to_string(),
            coords: nodes.map(|n| b.tape(n)),
            domain: def.domain,
        })
    }

    /// A user primitive by name.
    pub fn surface(&self, name: &str) -> Option<&Surface> {
        self.surfaces.get(name)
    }

    /// Names of the user primitives in the order they were added.
    pub fn surface_names(&self) -> &[String] {
        &self.order
    }

    /// Type-checks every user primitive body (with its default parameters).
    pub fn check(&self) -> Result<(), Diagnostic> {
        let mut b = Builder::new();
        for name in &self.order {
            let s = &self.surfaces[name];
            if s.mode == SurfaceMode::Parametric {
                // Type-checks the coordinates and implicitizes once; a
                // parametrization without an equation is an error only where it is traced.
                let defaults: Vec<Value> = s.params.iter().map(|(_, v)| *v).collect();
                self.analysis(s, &defaults)?;
                continue;
            }
            let mut l = Lowerer::new(&mut b, self, s.source);
            let p = l.point();
            let args: Vec<Val> = s.params.iter().map(|(_, v)| v.lower(l.b)).collect();
            l.inline_surface(s, p, &args, Span::default())?;
        }
        Ok(())
    }

    /// Compiles shape text to a DAG node in `b` (the signed distance at `p`).
    pub fn compile(&self, b: &mut Builder, text: &str, source: SourceId) -> Result<Node, Diagnostic> {
        let program = parse(text, source)?;
        self.compile_program(b, &program, source)
    }

    /// Compiles an already parsed program.
    pub fn compile_program(&self, b: &mut Builder, program: &Program, source: SourceId) -> Result<Node, Diagnostic> {
        self.compile_tracked(b, program, source).map(|c| c.node)
    }

    /// Compiles a parsed program and reports which inputs its exact analyses
    /// bound as constants (the object must be compiled again when they change).
    pub fn compile_tracked(
        &self,
        b: &mut Builder,
        program: &Program,
        source: SourceId,
    ) -> Result<Compiled, Diagnostic> {
        let p = [b.x(), b.y(), b.z()];
        self.compile_at(b, program, source, p)
    }

    /// Compiles a parsed program with `p` bound to the given nodes (a
    /// transformed point), reporting the inputs its analyses bound.
    pub fn compile_at(
        &self,
        b: &mut Builder,
        program: &Program,
        source: SourceId,
        p: [Node; 3],
    ) -> Result<Compiled, Diagnostic> {
        let mut l = Lowerer::new(b, self, source);
        let p = Val::vec3(p[0], p[1], p[2]);
        l.scope.push(("p".to_string(), p));
        let v = l.program(program)?;
        if v.ty != Type::Float {
            return Err(Diagnostic::new(
                source,
                program.body.span,
                format!("a shape must be a `float` distance, but this is a `{}`", v.ty),
            )
            .with_label(format!("this is a {}", v.ty))
            .with_note("call a primitive such as `sphere(p, 1.0)`, or take a component such as `.x`"));
        }
        Ok(Compiled {
            node: v.s(),
            bound: l.bound,
            guards: l.guards,
        })
    }
}

impl Library {
    /// Compiles shape text that does not depend on the point (it may read
    /// constants, parameters and `t`, but not `p`) to its 1 to 3 components.
    pub fn compile_uniform(
        &self,
        b: &mut Builder,
        text: &str,
        source: SourceId,
    ) -> Result<(Type, Vec<Node>), Diagnostic> {
        let program = parse(text, source)?;
        let mut l = Lowerer::new(b, self, source);
        let v = l.program(&program)?;
        let comps = v.comps().to_vec();
        if comps.iter().any(|&n| !l.b.is_uniform(n)) {
            return Err(
                Diagnostic::new(source, program.body.span, "this value depends on the point")
                    .with_label("not the same everywhere")
                    .with_note("values of the scene may use numbers, parameters and `t`"),
            );
        }
        Ok((v.ty, comps))
    }
}

/// A compiled program: its node, and the inputs it bound as constants.
#[derive(Debug, Clone, PartialEq)]
pub struct Compiled {
    /// The signed distance.
    pub node: Node,
    /// Inputs whose values an exact analysis (implicit or parametric
    /// surface) bound at compile time, sorted; empty when every input stays live.
    pub bound: Vec<u32>,
    /// Values that must stay positive whatever the inputs become (the
    /// periods of `repeat` written with parameters or `t`), with what each
    /// is: nodes of the builder that read inputs and no coordinate. The
    /// compile checked them at the current inputs; whoever changes the
    /// inputs checks them again.
    pub guards: Vec<(Node, String)>,
}

/// Lowers one snippet; holds the scope and the call stack of user primitives.
pub(crate) struct Lowerer<'a> {
    pub(crate) b: &'a mut Builder,
    lib: &'a Library,
    pub(crate) source: SourceId,
    scope: Vec<(String, Val)>,
    calls: Vec<String>,
    depth: usize,
    /// Inputs whose current values exact algebra bound as constants.
    bound: Vec<u32>,
    /// Uniform values that must stay positive (see [`Compiled::guards`]).
    pub(crate) guards: Vec<(Node, String)>,
    /// When set, inputs lower as these constant values (for exact algebra).
    bind: Option<Vec<f64>>,
}

/// A lowered argument and where it was written.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Arg {
    pub(crate) v: Val,
    pub(crate) span: Span,
}

const MAX_INLINE_DEPTH: usize = 64;

/// Bound on the recursion of lowering (expression depth across inlined surfaces).
const MAX_LOWER_DEPTH: usize = 5000;

impl<'a> Lowerer<'a> {
    fn new(b: &'a mut Builder, lib: &'a Library, source: SourceId) -> Self {
        Lowerer {
            b,
            lib,
            source,
            scope: Vec::new(),
            calls: Vec::new(),
            depth: 0,
            bound: Vec::new(),
            guards: Vec::new(),
            bind: None,
        }
    }

    /// A lowerer that binds every input at the library's current values.
    fn binding(b: &'a mut Builder, lib: &'a Library, source: SourceId) -> Self {
        let mut l = Lowerer::new(b, lib, source);
        l.bind = Some(lib.input_values());
        l
    }

    /// The library's current inputs (the time, then the parameters).
    pub(crate) fn lib_input_values(&self) -> Vec<f64> {
        self.lib.input_values()
    }

    /// Input `var`, or its bound value.
    fn input(&mut self, var: u32) -> Node {
        match &self.bind {
            Some(vals) => {
                let v = vals.get(var as usize).copied().unwrap_or(f64::NAN);
                self.b.constant(v)
            }
            None => self.b.input(var),
        }
    }

    fn point(&mut self) -> Val {
        let (x, y, z) = (self.b.x(), self.b.y(), self.b.z());
        Val::vec3(x, y, z)
    }

    pub(crate) fn err(&self, span: Span, msg: impl Into<String>) -> Diagnostic {
        Diagnostic::new(self.source, span, msg)
    }

    fn program(&mut self, prog: &Program) -> Result<Val, Diagnostic> {
        let depth = self.scope.len();
        for l in &prog.lets {
            let v = self.expr(&l.value)?;
            if let Some((ty, span)) = l.ty {
                let want = match ty {
                    TypeName::Float => Type::Float,
                    TypeName::Vec2 => Type::Vec2,
                    TypeName::Vec3 => Type::Vec3,
                };
                if want != v.ty {
                    return Err(self
                        .err(
                            l.value.span,
                            format!("`{}` is declared `{}` but its value is a `{}`", l.name, want, v.ty),
                        )
                        .with_label(format!("this is a {}", v.ty))
                        .with_note(format!("the declaration is at byte {}", span.start)));
                }
            }
            self.scope.push((l.name.clone(), v));
        }
        let r = self.expr(&prog.body);
        self.scope.truncate(depth);
        r
    }

    fn lookup(&self, name: &str) -> Option<Val> {
        self.scope.iter().rev().find(|(n, _)| n == name).map(|(_, v)| *v)
    }

    pub(crate) fn expr(&mut self, e: &Expr) -> Result<Val, Diagnostic> {
        if self.depth >= MAX_LOWER_DEPTH {
            return Err(self.err(e.span, "expression nested too deeply").with_label(format!(
                "more than {MAX_LOWER_DEPTH} levels, counting surfaces called inside surfaces"
            )));
        }
        self.depth += 1;
        let r = self.expr_inner(e);
        self.depth -= 1;
        r
    }

    fn expr_inner(&mut self, e: &Expr) -> Result<Val, Diagnostic> {
        match &e.kind {
            ExprKind::Num(v) => Ok(Val::float(self.b.constant(*v))),
            ExprKind::Var(name) => {
                if let Some(v) = self.lookup(name) {
                    return Ok(v);
                }
                if let Some((at, ty)) = self.lib.param_input(name) {
                    let cs: Vec<Node> = (0..ty.width() as u32).map(|k| self.input(at + k)).collect();
                    return Ok(Val::from_slice(&cs).expect("1..=3 components"));
                }
                if name == "t" {
                    return Ok(Val::float(self.input(crate::ir::TIME)));
                }
                if let Some(c) = library::constant(name) {
                    return Ok(Val::float(self.b.constant(c)));
                }
                let mut known: Vec<&str> = self.scope.iter().map(|(n, _)| n.as_str()).collect();
                known.extend(self.lib.params.iter().map(|(n, _)| n.as_str()));
                known.push("t");
                let mut d = self
                    .err(e.span, format!("unknown name `{name}`"))
                    .with_label("not a variable, parameter or binding in scope");
                if let Some(s) = suggest(name, known) {
                    d = d.with_note(format!("did you mean `{s}`?"));
                } else if library::is_function(name) || self.lib.surfaces.contains_key(name) {
                    d = d.with_note(format!(
                        "`{name}` is a function: call it with arguments, like `{name}(p, ...)`"
                    ));
                }
                Err(d)
            }
            ExprKind::Neg(a) => {
                let v = self.expr(a)?;
                Ok(self.map1(v, |b, x| b.neg(x)))
            }
            ExprKind::Binary(op, a, b) => {
                let (va, vb) = (self.expr(a)?, self.expr(b)?);
                if va.ty != vb.ty && va.ty != Type::Float && vb.ty != Type::Float {
                    let verb = match op {
                        BinaryOp::Add => "add",
                        BinaryOp::Sub => "subtract",
                        BinaryOp::Mul => "multiply",
                        BinaryOp::Div => "divide",
                        BinaryOp::Pow => "raise",
                    };
                    return Err(self
                        .err(e.span, format!("cannot {verb} `{}` and `{}`", va.ty, vb.ty))
                        .with_label(format!("{} {} {}", va.ty, op.symbol(), vb.ty))
                        .with_note("both sides must have the same type, or one side must be a float"));
                }
                let f = match op {
                    BinaryOp::Add => Builder::add,
                    BinaryOp::Sub => Builder::sub,
                    BinaryOp::Mul => Builder::mul,
                    BinaryOp::Div => Builder::div,
                    BinaryOp::Pow => |b: &mut Builder, x: Node, y: Node| b.binary(crate::ir::BinOp::Pow, x, y),
                };
                Ok(self.map2(va, vb, f))
            }
            ExprKind::Swizzle(a, comps) => {
                let v = self.expr(a)?;
                self.swizzle(v, comps, e.span)
            }
            ExprKind::Call { name, name_span, args } => {
                let mut lowered = Vec::with_capacity(args.len());
                for a in args {
                    lowered.push(Arg {
                        v: self.expr(a)?,
                        span: a.span,
                    });
                }
                self.call(name, *name_span, e.span, &lowered)
            }
        }
    }

    fn swizzle(&mut self, v: Val, comps: &str, span: Span) -> Result<Val, Diagnostic> {
        if v.ty == Type::Float {
            return Err(self
                .err(span, format!("cannot take components `.{comps}` of a `float`"))
                .with_label("a float has no components"));
        }
        if comps.is_empty() || comps.len() > 3 {
            return Err(self
                .err(span, format!("a swizzle takes 1 to 3 components, found `.{comps}`"))
                .with_label("expected e.g. `.x`, `.xz` or `.zyx`"));
        }
        let mut out = Vec::new();
        for ch in comps.chars() {
            let i = match ch {
                'x' | 'r' | 's' => 0,
                'y' | 'g' | 't' => 1,
                'z' | 'b' | 'p' => 2,
                _ => {
                    return Err(self
                        .err(span, format!("`{ch}` is not a component name in `.{comps}`"))
                        .with_label("components are x, y, z (or r, g, b)"))
                }
            };
            if i >= v.ty.width() {
                return Err(self
                    .err(span, format!("`.{ch}` is out of range for a `{}`", v.ty))
                    .with_label(format!("a {} has only {} components", v.ty, v.ty.width())));
            }
            out.push(v.c[i]);
        }
        Ok(Val::from_slice(&out).expect("1..=3 components"))
    }

    /// Applies `f` to each component.
    pub(crate) fn map1(&mut self, v: Val, f: impl Fn(&mut Builder, Node) -> Node) -> Val {
        let mut c = v.c;
        for (ci, &vi) in c.iter_mut().zip(&v.c).take(v.ty.width()) {
            *ci = f(self.b, vi);
        }
        Val { ty: v.ty, c }
    }

    /// Applies `f` componentwise; a float operand broadcasts.
    pub(crate) fn map2(&mut self, a: Val, b: Val, f: impl Fn(&mut Builder, Node, Node) -> Node) -> Val {
        let ty = if a.ty == Type::Float { b.ty } else { a.ty };
        let mut c = [a.c[0]; 3];
        for (i, ci) in c.iter_mut().enumerate().take(ty.width()) {
            *ci = f(self.b, a.at(i), b.at(i));
        }
        Val { ty, c }
    }

    /// Applies `f` componentwise over three operands with broadcasting.
    pub(crate) fn map3(&mut self, a: Val, b: Val, c3: Val, f: impl Fn(&mut Builder, Node, Node, Node) -> Node) -> Val {
        let ty = [a.ty, b.ty, c3.ty]
            .into_iter()
            .find(|t| *t != Type::Float)
            .unwrap_or(Type::Float);
        let mut c = [a.c[0]; 3];
        for (i, ci) in c.iter_mut().enumerate().take(ty.width()) {
            *ci = f(self.b, a.at(i), b.at(i), c3.at(i));
        }
        Val { ty, c }
    }

    fn call(&mut self, name: &str, name_span: Span, span: Span, args: &[Arg]) -> Result<Val, Diagnostic> {
        if let Some(s) = self.lib.surfaces.get(name) {
            return self.call_surface(s, name_span, span, args);
        }
        if let Some(r) = library::call(self, name, span, args) {
            return r;
        }
        let mut names: Vec<&str> = library::function_names().collect();
        names.extend(self.lib.surfaces.keys().map(|s| s.as_str()));
        let mut d = self
            .err(name_span, format!("unknown function `{name}`"))
            .with_label("not a built-in, primitive, operator or surface");
        if let Some(s) = suggest(name, names) {
            d = d.with_note(format!("did you mean `{s}`?"));
        }
        Err(d)
    }

    fn call_surface(&mut self, s: &Surface, name_span: Span, span: Span, args: &[Arg]) -> Result<Val, Diagnostic> {
        let sig = std::iter::once("p: vec3".to_string())
            .chain(
                s.params
                    .iter()
                    .map(|(n, v)| format!("{n}: {} = {}", v.ty(), fmt_value(v))),
            )
            .collect::<Vec<_>>()
            .join(", ");
        if args.is_empty() || args.len() > s.params.len() + 1 {
            return Err(self
                .err(
                    span,
                    format!(
                        "`{}` takes the point and up to {} parameter(s), found {} argument(s)",
                        s.name,
                        s.params.len(),
                        args.len()
                    ),
                )
                .with_label("wrong number of arguments")
                .with_note(format!("signature: {}({sig})", s.name)));
        }
        if args[0].v.ty != Type::Vec3 {
            return Err(self
                .err(
                    args[0].span,
                    format!(
                        "the first argument of `{}` is the point: expected `vec3`, found `{}`",
                        s.name, args[0].v.ty
                    ),
                )
                .with_label("expected vec3"));
        }
        let mut vals = Vec::new();
        for (i, (pname, default)) in s.params.iter().enumerate() {
            match args.get(i + 1) {
                Some(a) => {
                    let want = default.ty();
                    let v = if a.v.ty == want {
                        a.v
                    } else if a.v.ty == Type::Float {
                        Val::from_slice(&vec![a.v.s(); want.width()]).expect("width 1..=3")
                    } else {
                        return Err(self
                            .err(
                                a.span,
                                format!("parameter `{pname}` of `{}` is a `{want}`, found `{}`", s.name, a.v.ty),
                            )
                            .with_label(format!("expected {want}"))
                            .with_note(format!("signature: {}({sig})", s.name)));
                    };
                    vals.push(v);
                }
                None => vals.push(default.lower(self.b)),
            }
        }
        if self.calls.iter().any(|c| c == &s.name) {
            let chain = self.calls.join(" → ");
            return Err(self
                .err(
                    name_span,
                    format!("surface `{}` calls itself ({chain} → {})", s.name, s.name),
                )
                .with_label("recursive call"));
        }
        if self.calls.len() >= MAX_INLINE_DEPTH {
            return Err(self
                .err(name_span, "surfaces nested too deeply")
                .with_label(format!("more than {MAX_INLINE_DEPTH} levels")));
        }
        self.inline_surface(s, args[0].v, &vals, name_span)
    }

    fn inline_surface(&mut self, s: &Surface, p: Val, params: &[Val], span: Span) -> Result<Val, Diagnostic> {
        if s.mode == SurfaceMode::Parametric {
            return self.parametric_distance(s, p, params, span);
        }
        let v = self.lower_body(s, p, params)?;
        if s.mode == SurfaceMode::Implicit {
            return self.implicit_distance(s, v.s(), p, params, span);
        }
        Ok(v)
    }

    /// The body of an SDF or implicit surface at `p`: the distance, or f.
    fn lower_body(&mut self, s: &Surface, p: Val, params: &[Val]) -> Result<Val, Diagnostic> {
        let saved_scope = std::mem::take(&mut self.scope);
        let saved_source = self.source;
        self.source = s.source;
        self.calls.push(s.name.clone());
        self.scope.push(("p".to_string(), p));
        if s.mode == SurfaceMode::Implicit {
            for (i, n) in ["x", "y", "z"].iter().enumerate() {
                self.scope.push((n.to_string(), Val::float(p.c[i])));
            }
        }
        for ((n, _), v) in s.params.iter().zip(params) {
            self.scope.push((n.clone(), *v));
        }
        let r = self.program(&s.program);
        self.calls.pop();
        self.source = saved_source;
        self.scope = saved_scope;
        let v = r?;
        if v.ty != Type::Float {
            let what = if s.mode == SurfaceMode::Implicit {
                "an equation f(x, y, z) = 0 must be a `float`"
            } else {
                "must give a `float` distance"
            };
            return Err(Diagnostic::new(
                s.source,
                s.program.body.span,
                format!("surface `{}`: {what}, found `{}`", s.name, v.ty),
            )
            .with_label(format!("this is a {}", v.ty)));
        }
        Ok(v)
    }

    /// The parameter values, when every one is a constant or a value of the
    /// inputs alone (then bound at the library's current values, and the
    /// inputs it read recorded in `bound`).
    fn const_values(&mut self, params: &[Val]) -> Option<Vec<Value>> {
        let vars = self.lib.input_values();
        let mut read = Vec::new();
        let r: Option<Vec<Value>> = params
            .iter()
            .map(|v| {
                let c: Option<Vec<f64>> = (0..v.ty.width())
                    .map(|i| {
                        let n = v.c[i];
                        self.b.const_value(n).or_else(|| {
                            let x = self.b.uniform_value(n, &vars)?;
                            read.extend(self.b.inputs_of(n));
                            Some(x)
                        })
                    })
                    .collect();
                let c = c?;
                Some(match c.len() {
                    1 => Value::Float(c[0]),
                    2 => Value::Vec2([c[0], c[1]]),
                    _ => Value::Vec3([c[0], c[1], c[2]]),
                })
            })
            .collect();
        if r.is_some() {
            self.bound.extend(read);
            self.bound.sort_unstable();
            self.bound.dedup();
        }
        r
    }

    /// Records the inputs an analysis of `s` bound (those its bodies read directly).
    fn note_bound(&mut self, s: &Surface) {
        if self.bind.is_some() {
            return;
        }
        let (_, inputs) = self.lib.content_of(s);
        self.bound.extend(inputs);
        self.bound.sort_unstable();
        self.bound.dedup();
    }

    /// Divides a bound by the surface's Lipschitz safety factor.
    fn apply_factor(&mut self, s: &Surface, d: Node) -> Val {
        let k = s.options.lipschitz_factor;
        Val::float(if k == 1.0 { d } else { self.b.mul_c(d, 1.0 / k) })
    }

    /// The traced distance of an implicit surface: the Taylor-root bound of
    /// its square-free part when the equation is a polynomial, else the
    /// Lipschitz bound over a ball (or f/|∇f| when asked for).
    fn implicit_distance(
        &mut self,
        s: &Surface,
        f: Node,
        p: Val,
        params: &[Val],
        span: Span,
    ) -> Result<Val, Diagnostic> {
        self.check_gradient(s, f)?;
        let method = s.options.bound;
        if method == BoundMethod::FirstOrder {
            let d = first_order(self.b, f);
            return Ok(self.apply_factor(s, d));
        }
        let Some(vals) = self.const_values(params) else {
            return Err(self
                .err(span, format!("surface `{}` needs constant parameters here", s.name))
                .with_label("a parameter depends on the point")
                .with_note("its distance bound is derived once per set of parameter values, so they may use constants, scene parameters and `t` but not `p`; or set bound = \"first-order\" on the surface"));
        };
        let a = self.lib.analysis(s, &vals)?;
        self.note_bound(s);
        let pc = [p.c[0], p.c[1], p.c[2]];
        let taylor = a
            .equation
            .as_ref()
            .map_err(Clone::clone)
            .and_then(|eq| match &eq.taylor_terms {
                Ok(_) => Ok(&eq.poly),
                Err(why) => Err(why.clone()),
            });
        let d = match (taylor, method) {
            (Ok(poly), BoundMethod::Auto | BoundMethod::Taylor) => taylor_bound(self.b, &xyz_ring(), poly, pc),
            (Err(why), BoundMethod::Taylor) => {
                return Err(self
                    .err(span, format!("surface `{}` asks for bound = \"taylor\", but {why}", s.name))
                    .with_label("no Taylor-root bound for this call")
                    .with_note("the Taylor-root bound needs a polynomial equation of moderate size; use bound = \"lipschitz\" or \"auto\""))
            }
            _ => match &a.field {
                Some(field) => lipschitz_bound(field, self.b, pc),
                None => first_order(self.b, f),
            },
        };
        Ok(self.apply_factor(s, d))
    }

    /// The traced distance of a parametric surface: the bound of its implicit equation.
    fn parametric_distance(&mut self, s: &Surface, p: Val, params: &[Val], span: Span) -> Result<Val, Diagnostic> {
        let Some(vals) = self.const_values(params) else {
            return Err(self
                .err(
                    span,
                    format!("the parameters of parametric surface `{}` must be constants", s.name),
                )
                .with_label("this depends on the point")
                .with_note("each set of parameter values is implicitized once: they may use constants, scene parameters and `t` but not `p`"));
        };
        let a = self.lib.analysis(s, &vals)?;
        self.note_bound(s);
        let pc = [p.c[0], p.c[1], p.c[2]];
        let mut d = match (&a.equation, &a.field, s.options.bound) {
            (Ok(eq), _, BoundMethod::FirstOrder) => {
                let f = crate::algebraic::build_equation(self.b, &eq.poly, pc);
                first_order(self.b, f)
            }
            (Ok(eq), _, BoundMethod::Auto | BoundMethod::Taylor) if eq.taylor_terms.is_ok() => {
                taylor_bound(self.b, &xyz_ring(), &eq.poly, pc)
            }
            (Ok(eq), _, BoundMethod::Taylor) => {
                let why = eq.taylor_terms.clone().err().unwrap_or_default();
                return Err(self
                    .err(
                        span,
                        format!("surface `{}` asks for bound = \"taylor\", but {why}", s.name),
                    )
                    .with_label("no Taylor-root bound for this call"));
            }
            (Ok(_), Some(field), _) => lipschitz_bound(field, self.b, pc),
            (Ok(eq), None, _) => {
                let f = crate::algebraic::build_equation(self.b, &eq.poly, pc);
                first_order(self.b, f)
            }
            (Err(why), _, _) => {
                return Err(self
                    .err(span, format!("surface `{}` cannot be sphere-traced: {why}", s.name))
                    .with_label("no implicit equation")
                    .with_note("only rational parametrizations can be implicitized; others will be tessellated by the mesh pipeline"));
            }
        };
        if let (true, Some(coords)) = (s.options.image_only, a.parametrization.as_ref()) {
            let def = s.parametric.as_ref().expect("a parametric surface");
            d = image_only_field(self.b, coords, def.domain, pc, d);
        }
        Ok(self.apply_factor(s, d))
    }

    /// Rejects an equation whose gradient is identically zero.
    fn check_gradient(&mut self, s: &Surface, f: Node) -> Result<(), Diagnostic> {
        let g: Vec<Node> = (0..3).map(|v| self.b.derivative(f, v)).collect();
        if g.iter().all(|&n| self.b.const_value(n) == Some(0.0)) {
            return Err(Diagnostic::new(
                s.source,
                s.program.body.span,
                format!("the gradient of surface `{}`'s equation is identically zero", s.name),
            )
            .with_label("this equation does not depend on x, y or z")
            .with_note("an implicit surface needs an equation f(x, y, z) = 0 that varies with the point"));
        }
        Ok(())
    }

    /// Length of a value (|x| for a float).
    pub(crate) fn length(&mut self, v: Val) -> Node {
        if v.ty == Type::Float {
            return self.b.abs(v.s());
        }
        let mut acc = self.b.square(v.c[0]);
        for i in 1..v.ty.width() {
            let s = self.b.square(v.c[i]);
            acc = self.b.add(acc, s);
        }
        self.b.sqrt(acc)
    }

    /// Dot product of two values of the same type.
    pub(crate) fn dot(&mut self, a: Val, c: Val) -> Node {
        let w = a.ty.width().max(c.ty.width());
        let mut acc = self.b.mul(a.at(0), c.at(0));
        for i in 1..w {
            let m = self.b.mul(a.at(i), c.at(i));
            acc = self.b.add(acc, m);
        }
        acc
    }

    /// Largest component.
    pub(crate) fn max_comp(&mut self, v: Val) -> Node {
        let mut m = v.c[0];
        for i in 1..v.ty.width() {
            m = self.b.max(m, v.c[i]);
        }
        m
    }

    /// A unary op on every component.
    pub(crate) fn un(&mut self, op: UnOp, v: Val) -> Val {
        self.map1(v, |b, x| b.unary(op, x))
    }
}

/// The first-order distance estimate f / max(|∇f|, guard) with the exact (symbolic) gradient.
pub(crate) fn first_order(b: &mut Builder, f: Node) -> Node {
    let g: Vec<Node> = (0..3).map(|v| b.derivative(f, v)).collect();
    let mut n2 = b.square(g[0]);
    for &c in &g[1..] {
        let sq = b.square(c);
        n2 = b.add(n2, sq);
    }
    let norm = b.sqrt(n2);
    let guard = b.constant(GRADIENT_GUARD);
    let den = b.max(norm, guard);
    b.div(f, den)
}

fn fmt_value(v: &Value) -> String {
    match v {
        Value::Float(x) => format!("{x}"),
        Value::Vec2([x, y]) => format!("vec2({x}, {y})"),
        Value::Vec3([x, y, z]) => format!("vec3({x}, {y}, {z})"),
    }
}
