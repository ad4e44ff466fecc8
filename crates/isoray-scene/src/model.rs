//! The scene model: camera, render settings, lights, materials, objects.
//! Every field has a documented default (see `docs/SCENE.md`).

use isoray_shape::{Library, Shape, Value};

/// A colour or vector of three components.
pub type Vec3 = [f64; 3];

/// The pinhole camera.
///
/// Pixel (i, j), i to the right and j downwards, has its centre at
/// ndc = ((i+0.5)/W*2-1, 1-(j+0.5)/H*2); its ray leaves `position` in the
/// direction normalize(forward + ndc.x·tan(fov/2)·aspect·right + ndc.y·tan(fov/2)·up),
/// with aspect = W/H, forward = normalize(target − position),
/// right = normalize(forward × up), and up re-orthogonalised as right × forward.
#[derive(Debug, Clone, PartialEq)]
pub struct Camera {
    /// Eye position.
    pub position: Vec3,
    /// Point looked at.
    pub target: Vec3,
    /// Approximate up direction (default +y).
    pub up: Vec3,
    /// Vertical field of view in degrees (default 40).
    pub fov: f64,
    /// How directions map to pixels (default perspective).
    pub projection: Projection,
}

impl Camera {
    /// The camera's orthonormal frame, the one convention the ray tracer and
    /// the polygon pipeline share: (forward, right, up) with
    /// forward = normalize(target − position), right = normalize(forward × up)
    /// and up = right × forward.
    pub fn basis(&self) -> [Vec3; 3] {
        let norm = |v: Vec3| {
            let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            [v[0] / l, v[1] / l, v[2] / l]
        };
        let cross = |a: Vec3, b: Vec3| {
            [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ]
        };
        let forward = norm([
            self.target[0] - self.position[0],
            self.target[1] - self.position[1],
            self.target[2] - self.position[2],
        ]);
        let right = norm(cross(forward, self.up));
        let up = cross(right, forward);
        [forward, right, up]
    }

    /// tan(fov / 2).
    pub fn tan_half_fov(&self) -> f64 {
        (self.fov.to_radians() * 0.5).tan()
    }
}

/// How a camera maps directions to pixels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Projection {
    /// A pinhole camera with the vertical field of view `fov`.
    #[default]
    Perspective,
    /// Every direction, as an equirectangular environment map
    /// ([`crate::env`]) seen from the camera position in the world axes
    /// (`target` and `up` are not used); for images 2:1 wide.
    Equirect,
}

/// Normal estimation for shading.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NormalMethod {
    /// Central differences (6 evaluations).
    Central,
    /// Forward differences (4 evaluations).
    Forward,
    /// The tetrahedron technique (4 evaluations).
    Tetrahedron,
    /// Forward-mode automatic differentiation (exact).
    Analytic,
}

/// Shadow technique.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ShadowMode {
    /// No shadows.
    None,
    /// A shadow ray either reaches the light or not.
    Hard,
    /// Penumbra from the closest approach: min(k·h/t), k = 1/size.
    Soft,
    /// Penumbra estimate that tolerates slight penetration (smooth, no banding).
    Improved,
}

/// What the image shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum View {
    /// Lit and shaded.
    Shaded,
    /// Debug: a heat map of sphere-tracing steps per pixel.
    Steps,
    /// Debug: world-space normals mapped to colours.
    Normals,
}

/// Render settings (`[render]`).
#[derive(Debug, Clone, PartialEq)]
pub struct RenderSettings {
    /// Image width in pixels (default 960).
    pub width: u32,
    /// Image height in pixels (default 540).
    pub height: u32,
    /// Supersampling factor: aa×aa samples per pixel on a uniform grid (default 1).
    pub aa: u32,
    /// Maximum sphere-tracing steps per ray (default 256).
    pub max_steps: u32,
    /// A ray hits when the distance falls below this (default 1e-4).
    pub hit_epsilon: f64,
    /// Hit when d < hit_epsilon·t instead (default false).
    pub relative_epsilon: bool,
    /// Rays stop beyond this distance (default 100).
    pub max_distance: f64,
    /// Step = d·step_scale; below 1 for distance bounds that overestimate (default 1).
    pub step_scale: f64,
    /// Normal estimation (default tetrahedron).
    pub normals: NormalMethod,
    /// Finite-difference step for normals (default 1e-3).
    pub normal_epsilon: f64,
    /// Shadow technique (default soft).
    pub shadows: ShadowMode,
    /// The shadow term is raised to this power (default 1).
    pub shadow_exponent: f64,
    /// Shadow rays start this far from the surface (default 0.01).
    pub shadow_start: f64,
    /// Shadow rays stop after this distance (default 20).
    pub shadow_max_distance: f64,
    /// Maximum steps of a shadow ray (default 128).
    pub shadow_max_steps: u32,
    /// Ambient occlusion on (default true).
    pub ao: bool,
    /// AO samples along the normal (default 5).
    pub ao_samples: u32,
    /// Distance between AO samples (default 0.05).
    pub ao_step: f64,
    /// AO strength (default 1).
    pub ao_intensity: f64,
    /// Colour of rays that miss (linear RGB, default 0.95 grey).
    pub background: Vec3,
    /// 0: objects combine by union; k > 0: smooth union with this k (default 0).
    pub blend: f64,
    /// Fraction of the blend width over which materials mix (default 0.3;
    /// 1 mixes over the whole width, small values give sharp colour seams).
    pub material_blend: f64,
    /// What the image shows (default shaded).
    pub view: View,
    /// Bounces of reflected and refracted rays after the primary hit (default 5).
    pub max_depth: u32,
    /// Secondary rays whose weight (largest channel) falls below this stop (default 0.001).
    pub min_weight: f64,
    /// Intersect objects that are exactly planes or spheres in closed form
    /// (default true; not with `blend` > 0 or the steps view).
    pub analytic: bool,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            width: 960,
            height: 540,
            aa: 1,
            max_steps: 256,
            hit_epsilon: 1e-4,
            relative_epsilon: false,
            max_distance: 100.0,
            step_scale: 1.0,
            normals: NormalMethod::Tetrahedron,
            normal_epsilon: 1e-3,
            shadows: ShadowMode::Soft,
            shadow_exponent: 1.0,
            shadow_start: 0.01,
            shadow_max_distance: 20.0,
            shadow_max_steps: 128,
            ao: true,
            ao_samples: 5,
            ao_step: 0.05,
            ao_intensity: 1.0,
            background: [0.95, 0.95, 0.95],
            blend: 0.0,
            material_blend: 0.3,
            max_depth: 5,
            min_weight: 1e-3,
            analytic: true,
            view: View::Shaded,
        }
    }
}

/// The kind of a light.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LightKind {
    /// At infinity; `direction` points towards the light (normalised).
    Directional {
        /// Unit vector towards the light.
        direction: Vec3,
    },
    /// At a point.
    Point {
        /// Where it is.
        position: Vec3,
    },
    /// A glowing sphere, sampled at `Light::samples` points (hard shadow per sample).
    Sphere {
        /// Its centre.
        position: Vec3,
        /// Its radius.
        radius: f64,
    },
    /// A glowing parallelogram position + a·u + b·v, a, b ∈ [−½, ½], emitting
    /// on both sides, sampled at `Light::samples` points.
    Rect {
        /// Its centre.
        position: Vec3,
        /// One edge.
        u: Vec3,
        /// The other edge.
        v: Vec3,
    },
}

/// A light (`[[light]]`).
#[derive(Debug, Clone, PartialEq)]
pub struct Light {
    /// Directional or point.
    pub kind: LightKind,
    /// Linear RGB colour (default white).
    pub color: Vec3,
    /// Multiplies the colour (default 1).
    pub intensity: f64,
    /// Soft-shadow penumbra size: k = 1/size (default 0.1).
    pub size: f64,
    /// Point and area lights: 1/(c + l·d + q·d²) with [c, l, q] (default [1, 0, 0]: none).
    pub attenuation: Vec3,
    /// Area lights: shadow rays per shading point (default 16).
    pub samples: u32,
}

/// The specular model of a material.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ShadingModel {
    /// Phong: (R·V)^n.
    Phong,
    /// Blinn-Phong: (N·H)^n.
    BlinnPhong,
}

/// How the specular cosine is raised to the shininess.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SpecularFunction {
    /// cos^n.
    Pow,
    /// Schlick's rational approximation t / (n − n·t + t).
    Schlick,
}

/// A material (`[material.NAME]`).
#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    /// Its name.
    pub name: String,
    /// Ambient reflectance (default 0.1 grey).
    pub ambient: Vec3,
    /// Diffuse reflectance (default 0.8 grey).
    pub diffuse: Vec3,
    /// Specular reflectance (default 0.5 grey).
    pub specular: Vec3,
    /// Specular exponent (default 32).
    pub shininess: f64,
    /// Emitted light, added unshadowed (default black).
    pub emission: Vec3,
    /// Phong or Blinn-Phong (default Blinn-Phong).
    pub model: ShadingModel,
    /// Pow or Schlick (default pow).
    pub specular_function: SpecularFunction,
    /// Mirror reflectance per channel, 0..1 (default 0: none).
    pub reflectivity: Vec3,
    /// Fraction of the light not reflected that is transmitted, 0..1 (default 0: opaque).
    pub transparency: f64,
    /// Index of refraction (default 1.5).
    pub ior: f64,
    /// Beer–Lambert absorption per unit distance inside, per channel (default 0).
    pub absorption: Vec3,
    /// Fresnel weighting of reflection against refraction (default: on, Schlick).
    pub fresnel: Fresnel,
    /// A 3D checker: (index of the other material, cell size). Where
    /// ⌊x/s⌋ + ⌊y/s⌋ + ⌊z/s⌋ is odd, the other material is used.
    pub checker: Option<(usize, f64)>,
}

/// How reflection and refraction are weighted at a surface.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fresnel {
    /// No Fresnel term: `reflectivity` and `transparency` as given.
    Off,
    /// Schlick's approximation R₀ + (1 − R₀)(1 − cos θ)⁵.
    Schlick,
    /// The exact Fresnel equations for an unpolarised dielectric interface.
    Exact,
}

impl Material {
    /// True when rays leave this material's surface (reflection or refraction).
    pub fn is_optical(&self) -> bool {
        self.reflectivity.iter().any(|&r| r > 0.0) || self.transparency > 0.0
    }

    /// The material of objects that name none.
    pub fn default_named(name: &str) -> Material {
        Material {
            name: name.to_string(),
            ambient: [0.1; 3],
            diffuse: [0.8; 3],
            specular: [0.5; 3],
            shininess: 32.0,
            emission: [0.0; 3],
            model: ShadingModel::BlinnPhong,
            specular_function: SpecularFunction::Pow,
            reflectivity: [0.0; 3],
            transparency: 0.0,
            ior: 1.5,
            absorption: [0.0; 3],
            fresnel: Fresnel::Schlick,
            checker: None,
        }
    }
}

/// An object (`[[object]]`): a shape with a material.
#[derive(Debug, Clone)]
pub struct Object {
    /// Optional name.
    pub name: Option<String>,
    /// Index into [`Scene::materials`].
    pub material: usize,
    /// The shape text as written.
    pub source: String,
    /// The compiled shape.
    pub shape: Shape,
    /// Where the object is placed (`position`, `rotation`, `scale`), when
    /// any of them is given.
    pub transform: Option<Transform>,
    /// Inputs whose values were bound into `shape` as constants by exact
    /// algebra (implicit and parametric surfaces): changing one recompiles
    /// the object. Every other input the shape reads stays live.
    pub bound_inputs: Vec<u32>,
}

/// An object's placement: its shape d₀ is rotated about x, then y, then z
/// (world axes, degrees), scaled uniformly by s and moved to `position`:
/// d(p) = s·d₀(R⁻¹(p − c)/s), so distances stay exact.
///
/// The seven values are runtime inputs of the object's tape (from index
/// `inputs`: position x, y, z, rotation x, y, z, scale), computed from
/// `values` whenever the time or a parameter changes; animation, physics
/// and the studio move an object without recompiling it.
#[derive(Debug, Clone)]
pub struct Transform {
    /// The first of the object's seven inputs.
    pub inputs: u32,
    /// The expressions of the seven values (constants, or of `t` and the parameters).
    pub values: [Shape; 7],
    /// Where `scale` was written, for errors.
    pub(crate) scale_origin: Option<crate::doc::Origin>,
}

impl Transform {
    /// The nodes of R⁻¹(p − c)/s for the point X, Y, Z of `b`.
    pub fn lower_point(&self, b: &mut isoray_shape::Builder) -> [isoray_shape::Node; 3] {
        let k = self.inputs;
        let input = |b: &mut isoray_shape::Builder, j: u32| b.input(k + j);
        let (x, y, z) = (b.x(), b.y(), b.z());
        let (cx, cy, cz) = (input(b, 0), input(b, 1), input(b, 2));
        let mut q = [b.sub(x, cx), b.sub(y, cy), b.sub(z, cz)];
        // Undo the rotations in reverse order: z, then y, then x.
        for (axis, j) in [(2usize, 5u32), (1, 4), (0, 3)] {
            let deg = input(b, j);
            let rad = b.mul_c(deg, std::f64::consts::PI / 180.0);
            let (c, s) = (
                b.unary(isoray_shape::ir::UnOp::Cos, rad),
                b.unary(isoray_shape::ir::UnOp::Sin, rad),
            );
            // The plane of the rotation, in right-handed order (u, v).
            let (u, v) = match axis {
                0 => (1, 2),
                1 => (2, 0),
                _ => (0, 1),
            };
            // Turning by −θ: (u cos θ + v sin θ, −u sin θ + v cos θ).
            let (uc, vs) = (b.mul(q[u], c), b.mul(q[v], s));
            let (us, vc) = (b.mul(q[u], s), b.mul(q[v], c));
            let nu = b.add(uc, vs);
            let nv = b.sub(vc, us);
            q[u] = nu;
            q[v] = nv;
        }
        let scale = input(b, 6);
        q.map(|c| b.div(c, scale))
    }

    /// s·d for the object's distance d at the transformed point.
    pub fn lower_distance(&self, b: &mut isoray_shape::Builder, d: isoray_shape::Node) -> isoray_shape::Node {
        let scale = b.input(self.inputs + 6);
        b.mul(d, scale)
    }
}

/// A loaded, checked and compiled scene.
#[derive(Debug, Clone)]
pub struct Scene {
    /// The camera.
    pub camera: Camera,
    /// Render settings.
    pub render: RenderSettings,
    /// Lights in file order.
    pub lights: Vec<Light>,
    /// Materials; objects refer to them by index.
    pub materials: Vec<Material>,
    /// Objects in file order.
    pub objects: Vec<Object>,
    /// The scene's named parameters (`[params]`).
    pub params: Vec<(String, Value)>,
    /// The whole scene's distance: the union (or smooth union) of the objects.
    pub shape: Shape,
    /// The unsigned distance to the nearest object surface, min over objects
    /// of |dᵢ|: what rays travelling inside objects (refraction) trace.
    pub surfaces: Shape,
    /// When some object is transparent, what shadow rays trace: None when
    /// every object is opaque (shadow rays then trace `shape`).
    pub shadow: Option<ShadowShapes>,
    /// What rays leaving the scene see (None: `render.background`).
    pub environment: Option<crate::env::Environment>,
    /// Per object, its closed form when it is exactly a plane or a sphere
    /// (recognised only when `render.blend` = 0).
    pub analytic: Vec<Option<crate::analytic::Analytic>>,
    /// When some object is analytic: the union of the others, which rays
    /// outside objects march while the analytic ones are intersected.
    pub rest: Option<Shape>,
    /// The scene's parameters and user surfaces, with their cached analyses.
    pub library: Library,
    /// Ranges declared for number parameters (for sliders), in file order.
    pub param_ranges: Vec<ParamRange>,
    /// The current runtime inputs every shape reads: the time `t`, then
    /// each parameter component (see [`Library::input_names`]). Pass them
    /// to evaluators; change them with [`Scene::set_time`] and [`Scene::set_param`].
    pub inputs: Vec<f64>,
    /// The names of `inputs`, in order.
    pub input_names: Vec<String>,
    /// What the scene was loaded from, to compile it again when a value
    /// that exact algebra bound changes.
    pub(crate) origin: std::sync::Arc<SceneOrigin>,
}

/// The texts a scene was loaded from.
#[derive(Debug)]
pub(crate) struct SceneOrigin {
    pub(crate) sources: crate::error::Sources,
}

/// The fields shadow rays trace in a scene with transparent objects.
#[derive(Debug, Clone)]
pub struct ShadowShapes {
    /// The union of the opaque objects (occluders; a constant 10⁹ if none).
    pub opaque: Shape,
    /// The union of the transparent objects.
    pub transparent: Shape,
    /// The unsigned distance to the nearest transparent surface.
    pub transparent_surfaces: Shape,
}

/// The range declared for a number parameter: `{ default = 1.0, range = [0.5, 2.0] }`.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamRange {
    /// Where the parameter is: `params.NAME` or `surface.NAME.params.PARAM`.
    pub key: String,
    /// [min, max].
    pub range: [f64; 2],
}

impl Scene {
    /// The scene's signed distance at a point (at the current inputs).
    pub fn distance(&self, p: [f64; 3]) -> f64 {
        self.shape.eval_with(&self.inputs, p)
    }

    /// `shape` with the scene's current inputs fixed: it reads no input and
    /// gives what `shape` gives now. For consumers that take a shape at one
    /// moment, such as the mesher.
    pub fn frozen(&self, shape: &Shape) -> Shape {
        Shape::from_tape(shape.tape().bind(&self.inputs))
    }

    /// The time `t` in seconds.
    pub fn time(&self) -> f64 {
        self.inputs.first().copied().unwrap_or(0.0)
    }

    /// Moves the scene to time `t`. Shapes read the time as an input, so
    /// nothing is recompiled, except objects whose implicit or parametric
    /// surfaces bound `t` into their exact analysis (then the scene is
    /// compiled again with the analyses cached by value).
    pub fn set_time(&mut self, t: f64) -> Result<(), crate::SceneError> {
        if !t.is_finite() {
            return Err(crate::SceneError::usage(format!(
                "the time must be a finite number of seconds, found {t}"
            )));
        }
        let (next, changed) = self.next_inputs(&[isoray_shape::TIME], |inputs| inputs[0] = t)?;
        self.library.set_time(t);
        self.apply_inputs(next, changed)
    }

    /// Sets a number or vector parameter (`[params]`) to `value`: an error
    /// when the parameter does not exist, has another type, or is outside
    /// its declared range (the message names the range).
    pub fn set_param(&mut self, name: &str, value: Value) -> Result<(), crate::SceneError> {
        let Some((at, ty)) = self.library.param_input(name) else {
            let names: Vec<&str> = self.library.params().iter().map(|(n, _)| n.as_str()).collect();
            let mut msg = format!("the scene has no parameter `{name}`");
            if let Some(s) = isoray_shape::diag::suggest(name, names.iter().copied()) {
                msg.push_str(&format!(" (did you mean `{s}`?)"));
            }
            return Err(crate::SceneError::usage(msg));
        };
        if value.ty() != ty {
            return Err(crate::SceneError::usage(format!(
                "parameter `{name}` is a `{ty}`, found a `{}`",
                value.ty()
            )));
        }
        let comps: Vec<f64> = match value {
            Value::Float(x) => vec![x],
            Value::Vec2(a) => a.to_vec(),
            Value::Vec3(a) => a.to_vec(),
        };
        if comps.iter().any(|x| !x.is_finite()) {
            return Err(crate::SceneError::usage(format!("parameter `{name}` must be finite")));
        }
        let key = format!("params.{name}");
        if let (Some(r), Value::Float(x)) = (self.param_ranges.iter().find(|r| r.key == key), value) {
            if x < r.range[0] || x > r.range[1] {
                return Err(crate::SceneError::usage(format!(
                    "`{key}` = {x} is outside its range [{}, {}]",
                    r.range[0], r.range[1]
                )));
            }
        }
        let vars: Vec<u32> = (at..at + ty.width() as u32).collect();
        let (next, changed) = self.next_inputs(&vars, |inputs| {
            for (k, x) in comps.iter().enumerate() {
                inputs[at as usize + k] = *x;
            }
        })?;
        self.library.set_param(name, value);
        if let Some(p) = self.params.iter_mut().find(|(n, _)| n == name) {
            p.1 = value;
        }
        self.apply_inputs(next, changed)
    }

    /// The inputs after setting base inputs with `set`, with every object
    /// placement computed again, and the indices that changed (`vars` and
    /// the placements that moved); an error when a scale is not positive.
    fn next_inputs(
        &self,
        vars: &[u32],
        set: impl FnOnce(&mut Vec<f64>),
    ) -> Result<(Vec<f64>, Vec<u32>), crate::SceneError> {
        let mut next = self.inputs.clone();
        set(&mut next);
        let mut changed = vars.to_vec();
        for (i, o) in self.objects.iter().enumerate() {
            let Some(tr) = &o.transform else { continue };
            for (k, value) in tr.values.iter().enumerate() {
                let at = tr.inputs as usize + k;
                let v = value.eval_with(&next, [0.0; 3]);
                if k == 6 {
                    crate::load::check_scale(&self.origin.sources, i, tr, v)?;
                }
                if v.to_bits() != next[at].to_bits() {
                    next[at] = v;
                    changed.push(at as u32);
                }
            }
        }
        Ok((next, changed))
    }

    /// Applies new inputs: recompiles objects that bound a changed one, and
    /// re-derives the closed forms of objects that read one.
    fn apply_inputs(&mut self, next: Vec<f64>, changed: Vec<u32>) -> Result<(), crate::SceneError> {
        self.inputs = next;
        let vars = &changed[..];
        let bound = self
            .objects
            .iter()
            .any(|o| o.bound_inputs.iter().any(|v| vars.contains(v)));
        if bound {
            return self.recompile();
        }
        if !crate::load::analytic_allowed(&self.render) {
            return Ok(());
        }
        for (i, o) in self.objects.iter().enumerate() {
            if !o.shape.tape().vars().iter().any(|v| vars.contains(v)) {
                continue;
            }
            let now = crate::analytic::Analytic::recognise(&o.shape, &self.inputs);
            // A change of which objects are closed forms changes what is marched.
            if now.is_some() != self.analytic[i].is_some() {
                return self.recompile();
            }
            self.analytic[i] = now;
        }
        Ok(())
    }

    /// Compiles the scene again from its sources with the current
    /// parameter values and time (analyses come from the cache by value).
    fn recompile(&mut self) -> Result<(), crate::SceneError> {
        let mut src = self.origin.sources.clone();
        for (name, v) in &self.params {
            let text = match v {
                Value::Float(x) => format!("params.{name}={x:?}"),
                Value::Vec2([x, y]) => format!("params.{name}=[{x:?}, {y:?}]"),
                Value::Vec3([x, y, z]) => format!("params.{name}=[{x:?}, {y:?}, {z:?}]"),
            };
            src.overrides.push(text);
        }
        let opts = crate::LoadOptions {
            time: self.time(),
            analyses: Some(self.library.analyses().clone()),
        };
        let fresh = crate::load_str_with(&src.text, &src.path, &src.overrides, &opts)?;
        let origin = self.origin.clone();
        *self = fresh;
        self.origin = origin;
        Ok(())
    }
}

impl Scene {
    /// The implicit and parametric surfaces that object `i`'s shape calls,
    /// directly or through other surfaces, in order of first call.
    pub fn equation_surfaces(&self, i: usize) -> Vec<String> {
        let Some(o) = self.objects.get(i) else {
            return Vec::new();
        };
        let mut todo: Vec<String> = isoray_shape::syntax::parse(&o.source, 0)
            .map(|p| p.functions_called())
            .unwrap_or_default();
        let mut seen: Vec<String> = Vec::new();
        let mut out = Vec::new();
        while let Some(name) = todo.first().cloned() {
            todo.remove(0);
            if seen.contains(&name) {
                continue;
            }
            seen.push(name.clone());
            let Some(s) = self.library.surface(&name) else {
                continue;
            };
            if s.mode != isoray_shape::SurfaceMode::Sdf {
                out.push(name.clone());
            }
            todo.extend(s.program.functions_called());
            if let Some(def) = &s.parametric {
                for c in &def.coords {
                    todo.extend(c.functions_called());
                }
            }
        }
        out
    }
}
