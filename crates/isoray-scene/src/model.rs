//! The scene model: camera, render settings, lights, materials, objects.
//! Every field has a documented default (see `docs/SCENE.md`).

use isoray_shape::{Library, Shape, Value};

/// A colour or vector of three components.
pub type Vec3 = [f64; 3];

use crate::schema::vector;

impl Named for Projection {
    const NAMES: &'static [(&'static str, Self)] = &[
        ("perspective", Projection::Perspective),
        ("equirect", Projection::Equirect),
    ];
}

const FOV: Range = range(
    0.0,
    false,
    180.0,
    false,
    "0 < fov < 180",
    "a vertical field of view in degrees, between 0 and 180",
);

settings! {
    /// The pinhole camera.
    ///
    /// Pixel (i, j), i to the right and j downwards, has its centre at
    /// ndc = ((i+0.5)/W*2-1, 1-(j+0.5)/H*2); its ray leaves `position` in the
    /// direction normalize(forward + ndc.x·tan(fov/2)·aspect·right + ndc.y·tan(fov/2)·up),
    /// with aspect = W/H, forward = normalize(target − position),
    /// right = normalize(forward × up), and up re-orthogonalised as right × forward.
    pub struct Camera, keys camera_keys {
        /// Eye position.
        position: Vec3 = [0.0, 0.0, 5.0], vector(), "the eye";
        /// Point looked at.
        target: Vec3 = [0.0, 0.0, 0.0], vector(), "the point looked at; must differ from `position`";
        /// Approximate up direction.
        up: Vec3 = [0.0, 1.0, 0.0], vector(), "approximate up direction; must not be parallel to `target − position` (or zero)";
        /// Vertical field of view in degrees.
        fov: f64 = 40.0, num(FOV), "vertical field of view in degrees";
        /// How directions map to pixels.
        projection: Projection = Projection::Perspective, choice::<Projection>(), "how directions map to pixels; `\"equirect\"`: every direction around `position` as an equirectangular map in world axes (see `[environment]`; `target`, `up` and `fov` are not used; make the image twice as wide as high)";
    }
}

impl Camera {
    /// Checks what the key descriptions cannot: a perspective camera needs
    /// a direction (`target` ≠ `position`) and an `up` that is not along it.
    pub fn check(&self) -> Result<(), CameraProblem> {
        if self.projection != Projection::Perspective {
            return Ok(());
        }
        let fwd = [
            self.target[0] - self.position[0],
            self.target[1] - self.position[1],
            self.target[2] - self.position[2],
        ];
        if norm3(fwd) < 1e-12 {
            return Err(CameraProblem::NoDirection);
        }
        if norm3(cross3(fwd, self.up)) < 1e-9 * norm3(fwd) * norm3(self.up).max(1e-300) {
            return Err(CameraProblem::UpAlongView);
        }
        Ok(())
    }

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
    /// Sebastian Aaltonen's improved soft shadow: the closest approach
    /// estimated from two successive distances (fewer artefacts at corners).
    Aaltonen,
}

/// What a ray that runs out of sphere-tracing steps inside the range is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StepLimit {
    /// A hit where it stopped (it is grazing a surface): most sphere tracers.
    Hit,
    /// A miss (the background): Unity's, Shadertoy's and Godot's raymarchers.
    Miss,
}

/// How the dents of a height map shift what a pixel shows (parallax mapping).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Parallax {
    /// Normal mapping only: the normal at the hit's own texel.
    None,
    /// Welsh's offset limiting: the texel moved by depth × the view's
    /// tangent component (not divided by its normal one, so grazing views
    /// stay bounded).
    Offset,
    /// Steep parallax: the view ray marched down through layers of depth
    /// to the first layer below the map.
    Steep,
    /// Parallax occlusion mapping: steep parallax, then the crossing
    /// interpolated between the last two layers.
    Occlusion,
}

/// Where a pixel's aa × aa samples lie.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AaPattern {
    /// A uniform grid: sample (i, j) at ((i + ½)/aa, (j + ½)/aa).
    Grid,
    /// A rotated grid (RGSS; angle atan ½ for aa = 2): every sample has its
    /// own row and column, ((i·aa + j + ½)/aa², (j·aa + aa − 1 − i + ½)/aa²).
    Rotated,
    /// Jittered: one sample at a random place in each grid cell (a hash of
    /// the pixel and the sample, the same on every run and backend).
    Jittered,
}

impl Named for AaPattern {
    const NAMES: &'static [(&'static str, Self)] = &[
        ("grid", AaPattern::Grid),
        ("rotated", AaPattern::Rotated),
        ("jittered", AaPattern::Jittered),
    ];
}

/// How rays advance.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum March {
    /// Sphere tracing: each step advances the distance (times `step_scale`).
    Sphere,
    /// Fixed-step raymarching: each step advances `fixed_step`, whatever
    /// the distance (a teaching mode: it misses features thinner than a step).
    Fixed,
}

impl Named for March {
    const NAMES: &'static [(&'static str, Self)] = &[("sphere", March::Sphere), ("fixed", March::Fixed)];
}

/// What a shadow factor multiplies.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ShadowTarget {
    /// The light's own direct term.
    Direct,
    /// The whole colour of the point (each light's factor in turn), as the
    /// Unity thesis does.
    All,
}

/// What the ambient-occlusion factor multiplies.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AoTarget {
    /// The ambient terms.
    Ambient,
    /// The whole colour of the point, as the Unity thesis does.
    All,
}

/// How the ambient-occlusion samples are weighted.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AoWeights {
    /// Sample i weighs 2⁻ⁱ (normalised): near samples count most.
    Halving,
    /// Every sample weighs 1 (their sum, unweighted), as the Unity thesis does.
    Uniform,
}

impl Named for Parallax {
    const NAMES: &'static [(&'static str, Self)] = &[
        ("none", Parallax::None),
        ("offset", Parallax::Offset),
        ("steep", Parallax::Steep),
        ("occlusion", Parallax::Occlusion),
    ];
}

impl Named for StepLimit {
    const NAMES: &'static [(&'static str, Self)] = &[("hit", StepLimit::Hit), ("miss", StepLimit::Miss)];
}

impl Named for ShadowTarget {
    const NAMES: &'static [(&'static str, Self)] = &[("direct", ShadowTarget::Direct), ("all", ShadowTarget::All)];
}

impl Named for AoTarget {
    const NAMES: &'static [(&'static str, Self)] = &[("ambient", AoTarget::Ambient), ("all", AoTarget::All)];
}

impl Named for AoWeights {
    const NAMES: &'static [(&'static str, Self)] = &[("halving", AoWeights::Halving), ("uniform", AoWeights::Uniform)];
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
    /// Debug: the image-plane coordinates uv = (2x − w, h − 2y)/h as
    /// colours, with a grid every 0.25 (no tracing).
    Uv,
    /// Debug: white where a ray hits, black where it misses.
    Mask,
    /// Debug: a heat map of the field's gradient norm at the hits (1, a
    /// true distance, in the middle): how far a field is from a distance.
    Gradient,
}

use crate::schema::{
    boolean, choice, colour, int, key, key_without_default, num, range, settings, unit_colour, DocValue, KeySpec, Kind,
    Named, Range,
};

impl Named for NormalMethod {
    const NAMES: &'static [(&'static str, Self)] = &[
        ("central", NormalMethod::Central),
        ("forward", NormalMethod::Forward),
        ("tetrahedron", NormalMethod::Tetrahedron),
        ("analytic", NormalMethod::Analytic),
    ];
}

impl Named for ShadowMode {
    const NAMES: &'static [(&'static str, Self)] = &[
        ("none", ShadowMode::None),
        ("hard", ShadowMode::Hard),
        ("soft", ShadowMode::Soft),
        ("improved", ShadowMode::Improved),
        ("aaltonen", ShadowMode::Aaltonen),
    ];
}

impl Named for View {
    const NAMES: &'static [(&'static str, Self)] = &[
        ("shaded", View::Shaded),
        ("steps", View::Steps),
        ("normals", View::Normals),
        ("uv", View::Uv),
        ("mask", View::Mask),
        ("gradient", View::Gradient),
    ];
}

const STEP_SCALE: Range = range(0.0, false, 2.0, true, "0 < s ≤ 2", "a step scale in (0, 2]");
const FRACTION: Range = range(0.0, false, 1.0, true, "0 < f ≤ 1", "a fraction in (0, 1]");
const WEIGHT: Range = range(0.0, true, 1.0, false, "0 ≤ w < 1", "a number from 0 to below 1");

settings! {
    /// Render settings (`[render]`): each field's key, default, allowed
    /// values and meaning are in [`render_keys`] (and `docs/SCENE.md`).
    pub struct RenderSettings, keys render_keys {
        /// Image width in pixels.
        width: u32 = 960, int(1, 16384), "image width in pixels (`--width` overrides)";
        /// Image height in pixels.
        height: u32 = 540, int(1, 16384), "image height in pixels (`--height` overrides)";
        /// Supersampling factor: aa×aa samples per pixel on a uniform grid.
        aa: u32 = 1, int(1, 16), "supersampling: aa × aa samples per pixel (`--aa` overrides)";
        /// Where the supersamples lie in the pixel.
        aa_pattern: AaPattern = AaPattern::Grid, choice::<AaPattern>(), "where the aa × aa samples lie in a pixel: `\"grid\"` (uniform), `\"rotated\"` (rotated grid: each sample its own row and column, better on near-horizontal edges) or `\"jittered\"` (one random point per grid cell, deterministic)";
        /// Maximum sphere-tracing steps per ray.
        max_steps: u32 = 256, int(1, 100_000), "sphere-tracing steps per primary ray";
        /// A ray hits when the distance falls below this.
        hit_epsilon: f64 = 1e-4, num(Range::POSITIVE), "a ray hits when the distance falls below this";
        /// Hit when d < hit_epsilon·t instead.
        relative_epsilon: bool = false, boolean(), "hit when d < `hit_epsilon`·t instead (t = distance travelled)";
        /// Rays stop beyond this distance.
        max_distance: f64 = 100.0, num(Range::POSITIVE), "rays that travel further miss";
        /// Step = d·step_scale; below 1 for distance bounds that overestimate.
        step_scale: f64 = 1.0, num(STEP_SCALE), "each step advances s·d; use s < 1 for bounds that overestimate (section 8)";
        /// Normal estimation.
        normals: NormalMethod = NormalMethod::Tetrahedron, choice::<NormalMethod>(), "how normals are estimated (section 9.2)";
        /// Finite-difference step for normals.
        normal_epsilon: f64 = 1e-3, num(Range::POSITIVE), "finite-difference step of the normal estimate (unused by `\"analytic\"`)";
        /// Shadow technique.
        shadows: ShadowMode = ShadowMode::Soft, choice::<ShadowMode>(), "shadow technique (section 9.4)";
        /// The shadow term is raised to this power.
        shadow_exponent: f64 = 1.0, num(Range::POSITIVE), "the shadow factor is raised to this power";
        /// Shadow rays start this far from the surface.
        shadow_start: f64 = 0.01, num(Range::NON_NEGATIVE), "shadow rays start this far along the ray";
        /// Shadow rays stop after this distance.
        shadow_max_distance: f64 = 20.0, num(Range::POSITIVE), "shadow rays stop after this distance";
        /// Maximum steps of a shadow ray.
        shadow_max_steps: u32 = 128, int(1, 100_000), "steps per shadow ray";
        /// Ambient occlusion on.
        ao: bool = true, boolean(), "ambient occlusion on or off";
        /// AO samples along the normal.
        ao_samples: u32 = 5, int(1, 64), "AO samples along the normal";
        /// Distance between AO samples.
        ao_step: f64 = 0.05, num(Range::POSITIVE), "distance between AO samples";
        /// AO strength.
        ao_intensity: f64 = 1.0, num(Range::NON_NEGATIVE), "AO strength (0 turns AO off)";
        /// Colour of rays that miss (linear RGB).
        background: Vec3 = [0.95, 0.95, 0.95], colour(), "colour of rays that miss (linear RGB)";
        /// 0: objects combine by union; k > 0: smooth union with this k.
        blend: f64 = 0.0, num(Range::NON_NEGATIVE), "0: objects combine by union; k > 0: by smooth union with this k (see `[[object]]` below)";
        /// Fraction of the blend width over which materials mix (1 mixes
        /// over the whole width, small values give sharp colour seams).
        material_blend: f64 = 0.3, num(FRACTION), "with `blend` > 0: the fraction of the blend width over which materials mix; 1 mixes over the whole width, small values give sharp colour seams";
        /// What the image shows.
        view: View = View::Shaded, choice::<View>(), "what the image shows (section 9.7)";
        /// Bounces of reflected and refracted rays after the primary hit.
        max_depth: u32 = 5, int(0, 64), "bounces of reflected and refracted rays after the primary hit";
        /// Secondary rays whose weight (largest channel) falls below this stop.
        min_weight: f64 = 1e-3, num(WEIGHT), "a reflected or refracted ray whose weight (largest channel) is below this is not traced";
        /// How primary and secondary rays advance.
        march: March = March::Sphere, choice::<March>(), "how primary and secondary rays advance: `\"sphere\"` (sphere tracing, step d·`step_scale`) or `\"fixed\"` (fixed-step raymarching, step `fixed_step`; a hit where the distance first drops below `hit_epsilon`; a teaching mode that misses features thinner than a step; shadow rays' occluders and AO are found as before)";
        /// The step of fixed-step raymarching.
        fixed_step: f64 = 0.05, num(Range::POSITIVE), "with `march = \"fixed\"`: the length of every step";
        /// A ray out of steps inside the range: a hit or a miss.
        on_step_limit: StepLimit = StepLimit::Hit, choice::<StepLimit>(), "a primary or secondary ray that runs out of `max_steps` before `max_distance`: `\"hit\"` (it is grazing a surface) or `\"miss\"` (the background, as Unity-style raymarchers do)";
        /// The occluder threshold of shadow rays; 0 uses `hit_epsilon`.
        shadow_epsilon: f64 = 0.0, num(Range::NON_NEGATIVE), "a shadow ray meets an occluder where the distance falls below this; 0 (the default) uses `hit_epsilon` (the Unity thesis: a fixed 0.001)";
        /// Shadow factors never go below this: S' = floor + (1 − floor)·S.
        shadow_floor: f64 = 0.0, num(WEIGHT), "the least a shadow lets through: S' = floor + (1 − floor)·S (the Unity thesis: 0.5)";
        /// What a light's shadow factor multiplies.
        shadow_applies_to: ShadowTarget = ShadowTarget::Direct, choice::<ShadowTarget>(), "what a light's shadow factor multiplies: `\"direct\"` (its own light) or `\"all\"` (the whole colour of the point; a point facing away from the light is in its shadow)";
        /// How the AO samples are weighted.
        ao_weights: AoWeights = AoWeights::Halving, choice::<AoWeights>(), "AO sample weights: `\"halving\"` (sample i weighs 2⁻ⁱ, normalised) or `\"uniform\"` (1 each: the plain sum, as the Unity thesis)";
        /// What the AO factor multiplies.
        ao_applies_to: AoTarget = AoTarget::Ambient, choice::<AoTarget>(), "what ambient occlusion darkens: `\"ambient\"` (the ambient terms) or `\"all\"` (the whole colour)";
        /// A scene-wide ambient light, times each material's diffuse colour.
        ambient: Vec3 = [0.0, 0.0, 0.0], colour(), "a scene-wide ambient light (linear RGB) added as `ambient × diffuse` at every point, besides each material's own `ambient`";
        /// Intersect objects that are exactly planes or spheres in closed
        /// form (not with `blend` > 0 or the steps view).
        analytic: bool = true, boolean(), "objects whose distance is exactly a plane's or a sphere's (recognised numerically, whatever the text) are intersected in closed form and the other objects are marched up to them; not with `blend` > 0 or `view = \"steps\"`";
        /// Evaluate each region of space with the tape simplified for it.
        prune: bool = true, boolean(), "the CPU tracer evaluates each region of space with the scene's tape simplified for it (the `min`/`max` branches that cannot win there dropped; tapes of fewer than 500 instructions always run whole), and rays stop marching once they leave the box the surface lies in (found by interval bounds; not in the steps view), soft and hard shadow rays once they leave the box where occluders are nearer than the penumbra can see: the same image, bit for bit, but for a ray that grazes a surface and runs out of `max_steps` only past that box (unpruned it counts as a hit there, by `on_step_limit`; pruned it is the miss it is); `false` runs the whole tape at every step, up to `max_distance`";
        /// Parallax mapping of dent maps.
        parallax: Parallax = Parallax::None, choice::<Parallax>(), "parallax mapping of dent maps (`dents = \"bump\"`), in every renderer: `\"none\"` (normal mapping at the hit), `\"offset\"` (offset limiting: the texel shifted by depth × the view's tangent part), `\"steep\"` (the view ray marched down through `parallax_steps` layers) or `\"occlusion\"` (steep, with the crossing interpolated: parallax occlusion mapping)";
        /// Layers of steep and occlusion parallax.
        parallax_steps: u32 = 16, int(2, 256), "layers the view ray is marched through by `parallax = \"steep\"` and `\"occlusion\"`, over the deepest dent a map holds (half its `range`)";
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

settings! {
    /// A light (`[[light]]`). Its kind and where it is are read from the
    /// keys of [`light_keys`] that come before these.
    pub struct Light, keys light_value_keys {
        /// Area lights: shadow rays per shading point.
        samples: u32 = 16, int(1, 4096), "area lights: points sampled on the light per shaded point, each with a hard shadow ray";
        /// Linear RGB colour.
        color: Vec3 = [1.0; 3], colour(), "linear RGB";
        /// Multiplies the colour.
        intensity: f64 = 1.0, num(Range::NON_NEGATIVE), "multiplies `color`";
        /// Soft-shadow penumbra size: k = 1/size.
        size: f64 = 0.1, num(Range::POSITIVE), "penumbra size of soft and improved shadows: k = 1/size";
        /// Point and area lights: 1/(c + l·d + q·d²) with [c, l, q].
        attenuation: Vec3 = [1.0, 0.0, 0.0], colour(), "point and area lights: `[c, l, q]`, the light is divided by `c + l·d + q·d²` at distance d; ignored by directional lights";
    }
    extra {
        /// Directional, point or area.
        kind: LightKind = LightKind::Directional {
            direction: unit(DEFAULT_LIGHT_DIRECTION),
        };
    }
}

/// Why a camera cannot form an image.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CameraProblem {
    /// `target` equals `position`.
    NoDirection,
    /// `up` is parallel to the viewing direction, or zero.
    UpAlongView,
}

impl CameraProblem {
    /// What a camera value set from outside must be instead.
    pub fn expected(self) -> &'static str {
        match self {
            CameraProblem::NoDirection => "a `target` that differs from `position` (the camera has no direction)",
            CameraProblem::UpAlongView => "an `up` that is not parallel to the viewing direction (or zero)",
        }
    }
}

/// The default `direction` of a directional light (towards the light).
pub const DEFAULT_LIGHT_DIRECTION: Vec3 = [-1.0, 2.0, 1.0];

pub(crate) fn unit(v: Vec3) -> Vec3 {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    v.map(|x| x / l)
}

/// Every key of a `[[light]]` table: its kind and placement, then
/// [`light_value_keys`].
pub fn light_keys() -> &'static [KeySpec] {
    static KEYS: std::sync::LazyLock<Vec<KeySpec>> = std::sync::LazyLock::new(|| {
        let mut keys = vec![
            key(
                "kind",
                Kind::Choice(vec!["directional", "point", "sphere", "rect"]),
                "\"directional\"",
                "`\"directional\"` (at infinity), `\"point\"`, `\"sphere\"` or `\"rect\"` (area lights)",
            ),
            key(
                "direction",
                vector(),
                &DEFAULT_LIGHT_DIRECTION.doc_text(),
                "directional lights only: direction **towards** the light, normalised on load; must not be zero",
            ),
            key_without_default(
                "position",
                vector(),
                "required for point and area lights",
                "where the light is (the centre of an area light)",
            ),
            key("radius", num(Range::POSITIVE), "0.5", "sphere lights: the radius"),
            key_without_default(
                "u",
                vector(),
                "required for rect lights",
                "rect lights: one edge; the light is position + a·u + b·v for a, b in [−½, ½], emitting on both sides",
            ),
            key_without_default(
                "v",
                vector(),
                "required for rect lights",
                "rect lights: the other edge, not parallel to `u`",
            ),
        ];
        keys.extend(light_value_keys().iter().cloned());
        keys
    });
    &KEYS
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

const UNIT: Range = range(0.0, true, 1.0, true, "0 ≤ x ≤ 1", "a number from 0 to 1");
const IOR: Range = range(
    1.0,
    true,
    10.0,
    true,
    "1 ≤ n ≤ 10",
    "an index of refraction from 1 to 10",
);

impl Named for ShadingModel {
    const NAMES: &'static [(&'static str, Self)] = &[
        ("blinn-phong", ShadingModel::BlinnPhong),
        ("phong", ShadingModel::Phong),
    ];
}

impl Named for SpecularFunction {
    const NAMES: &'static [(&'static str, Self)] =
        &[("pow", SpecularFunction::Pow), ("schlick", SpecularFunction::Schlick)];
}

settings! {
    /// A material (`[material.NAME]`).
    pub struct Material, keys material_value_keys {
        /// Ambient reflectance.
        ambient: Vec3 = [0.1; 3], colour(), "ambient reflectance (multiplied by AO)";
        /// Diffuse reflectance.
        diffuse: Vec3 = [0.8; 3], colour(), "diffuse (Lambert) reflectance";
        /// Specular reflectance.
        specular: Vec3 = [0.5; 3], colour(), "specular reflectance";
        /// Specular exponent.
        shininess: f64 = 32.0, num(Range::POSITIVE), "specular exponent n";
        /// Emitted light, added unshadowed.
        emission: Vec3 = [0.0; 3], colour(), "emitted light, added without shadowing or AO";
        /// Phong or Blinn-Phong.
        model: ShadingModel = ShadingModel::BlinnPhong, choice::<ShadingModel>(), "the specular model (section 9.3)";
        /// Pow or Schlick.
        specular_function: SpecularFunction = SpecularFunction::Pow, choice::<SpecularFunction>(), "`\"pow\"`: cⁿ; `\"schlick\"`: c / (n − n·c + c)";
        /// Mirror reflectance per channel, 0..1.
        reflectivity: Vec3 = [0.0; 3], unit_colour(), "mirror reflectance (a number is grey)";
        /// Fraction of the light not reflected that is transmitted, 0..1.
        transparency: f64 = 0.0, num(UNIT), "the fraction of the light not reflected that passes through (refracted)";
        /// Index of refraction.
        ior: f64 = 1.5, num(IOR), "index of refraction (air is 1)";
        /// Beer–Lambert absorption per unit distance inside, per channel.
        absorption: Vec3 = [0.0; 3], colour(), "Beer–Lambert absorption per unit distance travelled inside";
        /// Weight the highlight by Fresnel–Schlick, 0.04 + 0.96·(1 − h·l)⁵.
        specular_fresnel: bool = false, boolean(), "weight the specular term by Fresnel–Schlick, F = 0.04 + 0.96·(1 − h·l)⁵ with h the half vector (the Granada thesis's Listing 3.3): highlights faint face-on, strong at grazing angles";
        /// kg/m³: a body's mass is its density times its volume.
        density: f64 = 1000.0, num(Range::POSITIVE), "kg/m³: a rigid body's mass is its density times its volume";
        /// ε: the bounce of an impact, and the yield impulse ε/(1 − ε).
        restitution: f64 = 0.5, num(UNIT), "ε: the share of the closing speed an impact gives back (the smaller of the pair's); a dent needs an impulse above ε/(1 − ε)";
        /// κ: the dent per unit of impulse beyond the yield, per N·s.
        dent_compliance: f64 = 0.0, num(Range::NON_NEGATIVE), "κ, per N·s: a dent is t·κ·max(0, ‖j‖ − ε/(1 − ε)) deep; 0 never dents";
        /// t: the body's thickness (of its walls, when hollow).
        thickness: f64 = 1.0, num(Range::POSITIVE), "t, scene units: the body's thickness (of its walls when hollow), scaling its dents";
    }
    extra {
        /// Its name.
        name: String = String::new();
        /// Fresnel weighting of reflection against refraction (keys
        /// `fresnel` and `fresnel_model`).
        fresnel: Fresnel = Fresnel::Schlick;
        /// A 3D checker: (index of the other material, cell size). Where
        /// ⌊x/s⌋ + ⌊y/s⌋ + ⌊z/s⌋ is odd, the other material is used.
        checker: Option<(usize, f64)> = None;
    }
}

/// Every key of a `[material.NAME]` table: [`material_value_keys`], then
/// the Fresnel and checker keys.
pub fn material_keys() -> &'static [KeySpec] {
    static KEYS: std::sync::LazyLock<Vec<KeySpec>> = std::sync::LazyLock::new(|| {
        let mut keys = material_value_keys().to_vec();
        keys.extend([
            key(
                "fresnel",
                boolean(),
                "true",
                "weight reflection against refraction by the Fresnel reflectance",
            ),
            key(
                "fresnel_model",
                Kind::Choice(vec!["schlick", "exact"]),
                "\"schlick\"",
                "`\"schlick\"`: R₀ + (1 − R₀)(1 − cos θ)⁵; `\"exact\"`: the Fresnel equations, unpolarised",
            ),
            key_without_default(
                "checker",
                Kind::Str,
                "none",
                "a 3D checker: where ⌊x/s⌋ + ⌊y/s⌋ + ⌊z/s⌋ is odd, the surface takes the named material instead (its shading; reflection and refraction stay this material's)",
            ),
            key(
                "checker_size",
                num(Range::POSITIVE),
                "1.0",
                "the checker's cell size s (only with `checker`)",
            ),
        ]);
        keys
    });
    &KEYS
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
            ..Material::default()
        }
    }
}

const ANGLE: Range = range(
    f64::NEG_INFINITY,
    false,
    f64::INFINITY,
    false,
    "",
    "an angle in degrees",
);
const LIPSCHITZ: Range = range(
    1.0,
    true,
    f64::INFINITY,
    false,
    "≥ 1",
    "a number ≥ 1 (the traced distance is divided by it)",
);

/// Every key of an `[[object]]` table.
pub fn object_keys() -> &'static [KeySpec] {
    static KEYS: std::sync::LazyLock<Vec<KeySpec>> = std::sync::LazyLock::new(|| {
        vec![
            key_without_default("shape", Kind::Str, "required", "shape text giving a `float` distance"),
            key("material", Kind::Str, "\"default\"", "the name of a `[material.NAME]`"),
            key_without_default("name", Kind::Str, "none", "a label, for your own reference"),
            key(
                "position",
                vector(),
                "[0.0, 0.0, 0.0]",
                "where the object's origin is placed",
            ),
            key(
                "rotation",
                vector(),
                "[0.0, 0.0, 0.0]",
                "degrees: the object is turned about x, then y, then z, in world axes (right-handed, counter-clockwise seen from the positive axis)",
            ),
            key(
                "scale",
                num(Range::POSITIVE),
                "1.0",
                "uniform scale; distances stay exact: d(p) = s·d₀(p/s)",
            ),
            key_without_default(
                "bone",
                Kind::Str,
                "none",
                "the `[[bone]]` that carries the object: `position` and `rotation` are then in the bone's frame",
            ),
        ]
        .into_iter()
        .chain(crate::physics::object_physics_keys())
        .collect()
    });
    &KEYS
}

/// Every key of a `[surface.NAME]` table.
pub fn surface_keys() -> &'static [KeySpec] {
    static KEYS: std::sync::LazyLock<Vec<KeySpec>> = std::sync::LazyLock::new(|| {
        vec![
            key_without_default(
                "params",
                Kind::Text("inline table"),
                "none",
                "parameter names with default values (number, 2 or 3 numbers, or `{ default = x, range = [min, max] }`); the default fixes each parameter's type",
            ),
            key_without_default(
                "sdf",
                Kind::Str,
                "one of `sdf`, `implicit`, `parametric`, `vm`",
                "the body: shape text whose `p` is the point argument",
            ),
            key_without_default(
                "implicit",
                Kind::Str,
                "one of the four",
                "an equation f = 0 in `x`, `y`, `z` (also `p`), the parameters and the built-ins",
            ),
            key_without_default(
                "parametric",
                Kind::Text("inline table `{ x, y, z }`"),
                "one of the four",
                "the coordinates as expressions in `s`, `t`, the parameters and the built-ins; rational ones are implicitized",
            ),
            key_without_default(
                "vm",
                Kind::Str,
                "one of the four",
                "a model in fidget's `.vm` tape format (path relative to the scene file), its `var-x`, `var-y`, `var-z` the point `p`",
            ),
            key_without_default(
                "domain",
                Kind::Text("inline table `{ s = [min, max], t = [min, max] }`"),
                "`[-1.0, 1.0]` each",
                "parametric only: the parameter domain (numerical check, `image_only`, tessellation)",
            ),
            key(
                "image_only",
                boolean(),
                "false",
                "parametric only: keep only points with a real preimage in the domain",
            ),
            key(
                "bound",
                Kind::Choice(vec!["auto", "taylor", "lipschitz", "first-order"]),
                "\"auto\"",
                "implicit and parametric: the distance bound traced (Taylor-root bound for polynomials, Lipschitz bound over a ball otherwise)",
            ),
            key(
                "lipschitz_factor",
                num(LIPSCHITZ),
                "1.0",
                "implicit and parametric: the traced distance is divided by it",
            ),
            key_without_default(
                "material",
                Kind::Str,
                "none",
                "the material of objects that call this surface and name no material",
            ),
        ]
    });
    &KEYS
}

/// Every key of the `[environment]` table.
pub fn environment_keys() -> &'static [KeySpec] {
    static KEYS: std::sync::LazyLock<Vec<KeySpec>> = std::sync::LazyLock::new(|| {
        vec![
            key_without_default(
                "image",
                Kind::Str,
                "one of `image`, `cube`, `gradient`",
                "an equirectangular map: a Radiance `.hdr`, OpenEXR `.exr` (linear) or 8-bit `.png` (sRGB, converted to linear), relative to the scene file",
            ),
            key_without_default(
                "cube",
                Kind::Text("inline table `{ px, nx, py, ny, pz, nz }`"),
                "one of `image`, `cube`, `gradient`",
                "six square faces of the same size, named by the axis each faces (OpenGL cube-map layout)",
            ),
            key_without_default(
                "gradient",
                Kind::Text("inline table `{ zenith, horizon, nadir }`"),
                "one of `image`, `cube`, `gradient`",
                "a sky: `horizon` (default `[0.85, 0.88, 0.93]`) at the horizon blending linearly with the height of the direction to `zenith` (default `[0.35, 0.5, 0.8]`) straight up and `nadir` (default `[0.3, 0.3, 0.32]`) straight down; `gradient = {}` takes all three defaults",
            ),
            key("rotation", num(ANGLE), "0.0", "turn about +y, degrees (right-handed)"),
            key("intensity", num(Range::NON_NEGATIVE), "1.0", "multiplies the map"),
        ]
    });
    &KEYS
}

/// The documented tables: the heading of each in `docs/SCENE.md` and its keys.
pub fn key_tables() -> Vec<(&'static str, &'static [KeySpec])> {
    vec![
        ("### `[camera]`", camera_keys()),
        ("### `[environment]`", environment_keys()),
        ("### `[render]`", render_keys()),
        ("### `[[light]]`", light_keys()),
        ("### `[material.NAME]`", material_keys()),
        ("### `[surface.NAME]`", surface_keys()),
        ("### `[[object]]`", object_keys()),
        ("### `[[mesh]]`", crate::meshes::mesh_keys()),
        ("### `[animation]`", crate::animation::animation_keys()),
        ("### `[[track]]`", crate::animation::track_keys()),
        ("### `[[midi]]`", crate::midi::midi_keys()),
        ("### `[[bone]]`", crate::skeleton::bone_keys()),
        ("### `[skeleton]`", crate::skeleton::skeleton_keys()),
        ("### `[physics]`", crate::physics::physics_keys()),
        ("### `[[object.sdf_dent]]`", crate::sdf_dents::sdf_dent_keys()),
    ]
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
    /// The bone that carries the object (`bone = "NAME"`): its placement
    /// is then in the bone's frame.
    pub bone: Option<usize>,
    /// Inputs whose values were bound into `shape` as constants by exact
    /// algebra (implicit and parametric surfaces): changing one recompiles
    /// the object. Every other input the shape reads stays live.
    pub bound_inputs: Vec<u32>,
    /// Its rigid body and dent keys, and its current dent maps.
    pub physics: crate::physics::ObjectPhysics,
    /// The compiled shape apart from the scene (shared with the object cache).
    pub(crate) fragment: std::sync::Arc<crate::compile::Fragment>,
}

impl Object {
    /// The plane or sphere the object's distance is, at the inputs
    /// `inputs`, for intersecting it in closed form; None for any other
    /// shape, and for an object with dents cut into it (a dented sphere
    /// matches its sphere almost everywhere, but rays must see the dents).
    pub fn closed_form(&self, inputs: &[f64]) -> Option<crate::analytic::Analytic> {
        if !self.physics.sdf_dents.is_empty() {
            return None;
        }
        crate::analytic::Analytic::recognise(&self.shape, inputs)
    }
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
        self.lower_point_at(b, self.inputs)
    }

    /// [`Transform::lower_point`] reading the seven inputs from `k` on.
    pub(crate) fn lower_point_at(&self, b: &mut isoray_shape::Builder, k: u32) -> [isoray_shape::Node; 3] {
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
        Self::lower_distance_at(b, d, self.inputs)
    }

    /// [`Transform::lower_distance`] reading the seven inputs from `k` on.
    pub(crate) fn lower_distance_at(
        b: &mut isoray_shape::Builder,
        d: isoray_shape::Node,
        k: u32,
    ) -> isoray_shape::Node {
        let scale = b.input(k + 6);
        b.mul(d, scale)
    }
}

/// A loaded, checked and compiled scene.
#[derive(Debug, Clone)]
pub struct Scene {
    /// The clock (`[animation]`): frame rate and duration, when given.
    pub animation: Option<crate::animation::Animation>,
    /// The rigid-body simulation's settings (`[physics]`), when given.
    pub physics: Option<crate::physics::Physics>,
    /// Keyframe tracks (`[[track]]`), applied whenever the time changes.
    pub tracks: Vec<crate::animation::Track>,
    /// The skeleton (`[[bone]]`), parents before children, at rest.
    pub bones: Vec<crate::skeleton::Bone>,
    /// MIDI mappings (`[[midi]]`): controllers to scene values.
    pub midi: Vec<crate::midi::MidiMapping>,
    /// What MIDI input drives now: the step tracks of a take
    /// ([`Scene::play_midi`]) or live values ([`Scene::set_midi_value`]).
    pub(crate) midi_tracks: Vec<crate::animation::Track>,
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
    /// Triangle meshes (`[[mesh]]`) in file order: drawn with the objects,
    /// not part of [`Scene::shape`].
    pub meshes: Vec<crate::meshes::MeshObject>,
    /// The scene's named parameters (`[params]`).
    pub params: Vec<(String, Value)>,
    /// The whole scene's distance: the union (or smooth union) of the objects.
    pub shape: Shape,
    /// What renderers derive from the objects (see [`Scene::derived`]).
    pub(crate) derived: crate::derive::Derived,
    /// What rays leaving the scene see (None: `render.background`).
    pub environment: Option<crate::env::Environment>,
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
    /// Camera, light and material values written as shape text of `t` and
    /// the parameters: computed again whenever those change.
    pub driven: Vec<Driven>,
    /// What the scene was loaded from, to compile it again when a value
    /// that exact algebra bound changes.
    pub(crate) origin: std::sync::Arc<SceneOrigin>,
    /// The compiled objects this scene and its recompilations share.
    pub(crate) cache: crate::compile::ObjectCache,
}

/// What a change of the base inputs leads to: the new inputs (placements
/// computed again), the indices that changed, and the driven values.
type NextInputs = (Vec<f64>, Vec<u32>, Option<Values>, Vec<(String, Value)>);

/// The world frames of the bones at time `t`: their rest frames with the
/// rotations and positions that tracks drive.
pub(crate) fn bone_frames<'a>(
    bones: &[crate::skeleton::Bone],
    tracks: impl IntoIterator<Item = &'a crate::animation::Track>,
    t: f64,
) -> Vec<crate::skeleton::Frame> {
    if bones.is_empty() {
        return Vec::new();
    }
    let mut locals = crate::skeleton::rest_frames(bones);
    for tr in tracks {
        if let crate::animation::Drive::Bone { bone, rotation } = *tr.drive() {
            if let Some(v) = tr.sample(t) {
                if rotation {
                    locals[bone].rotation = crate::skeleton::rotation_of(&v);
                } else {
                    locals[bone].position = glam::DVec3::new(v[0], v[1], v[2]);
                }
            }
        }
    }
    crate::skeleton::world_frames(bones, &locals)
}

/// Overwrites the components of object `object`'s seven placement values
/// (`values`, from its first input on) that tracks drive at time `t`.
pub(crate) fn place_by_tracks<'a>(
    tracks: impl IntoIterator<Item = &'a crate::animation::Track>,
    object: usize,
    t: f64,
    values: &mut [f64],
) {
    for tr in tracks {
        if let crate::animation::Drive::Placement { object: o, first } = *tr.drive() {
            if o == object {
                if let Some(v) = tr.sample(t) {
                    values[first..first + v.len()].copy_from_slice(&v);
                }
            }
        }
    }
}

/// The values that [`Scene::set_value`] and driven expressions change,
/// gathered so that a set of changes is checked before any is stored.
#[derive(Debug, Clone)]
struct Values {
    camera: Camera,
    lights: Vec<Light>,
    materials: Vec<Material>,
}

impl Values {
    /// The numbers of `key` (as [`Scene::set_value`] names keys), if any.
    fn get(&self, key: &str) -> Option<Vec<f64>> {
        let numbers = |text: String| -> Option<Vec<f64>> {
            let t = text.trim().trim_start_matches('[').trim_end_matches(']');
            t.split(',').map(|x| x.trim().parse::<f64>().ok()).collect()
        };
        let parts: Vec<&str> = key.split('.').collect();
        match parts[..] {
            ["camera", field] => numbers(self.camera.value_text(field)?),
            ["light", i, field] => {
                let light = self.lights.get(i.parse::<usize>().ok()?)?;
                match (field, &light.kind) {
                    ("direction", LightKind::Directional { direction }) => Some(direction.to_vec()),
                    (
                        "position",
                        LightKind::Point { position }
                        | LightKind::Sphere { position, .. }
                        | LightKind::Rect { position, .. },
                    ) => Some(position.to_vec()),
                    ("radius", LightKind::Sphere { radius, .. }) => Some(vec![*radius]),
                    ("u", LightKind::Rect { u, .. }) => Some(u.to_vec()),
                    ("v", LightKind::Rect { v, .. }) => Some(v.to_vec()),
                    _ => numbers(light.value_text(field)?),
                }
            }
            ["material", name, field] => {
                let m = self.materials.iter().find(|m| m.name == name)?;
                if field == "checker_size" {
                    return m.checker.as_ref().map(|c| vec![c.1]);
                }
                numbers(m.value_text(field)?)
            }
            _ => None,
        }
    }

    /// Sets the value of `key` (as [`Scene::set_value`] describes), checked
    /// against the key's description and the rules the loader applies.
    fn set(&mut self, key: &str, value: &[f64]) -> Result<(), crate::SceneError> {
        let shown = value.iter().map(|x| format!("{x}")).collect::<Vec<_>>().join(", ");
        let err = |what: &str| crate::SceneError::usage(format!("`{key}` = {shown}: expected {what}"));
        let unknown = || crate::SceneError::usage(format!("`{key}` is not a value that can be set or driven"));
        let set = |r: Option<Result<(), String>>| match r {
            None => Err(unknown()),
            Some(r) => r.map_err(|what| err(&what)),
        };
        let three = |spec: &KeySpec| {
            spec.check_numbers(value)
                .map(|v| [v[0], v[1], v[2]])
                .map_err(|what| err(&what))
        };
        let parts: Vec<&str> = key.split('.').collect();
        match parts[..] {
            ["camera", field] => {
                let mut camera = self.camera.clone();
                set(camera.set_numbers(field, value))?;
                camera.check().map_err(|p| err(p.expected()))?;
                self.camera = camera;
                Ok(())
            }
            ["light", i, field] => {
                let Some(light) = i.parse::<usize>().ok().and_then(|k| self.lights.get_mut(k)) else {
                    return Err(crate::SceneError::usage(format!(
                        "`{key}`: the scene has {} light(s)",
                        self.lights.len()
                    )));
                };
                let keys = light_keys();
                let Some(spec) = keys.iter().find(|k| k.name == field) else {
                    return Err(unknown());
                };
                let misplaced = || crate::SceneError::usage(format!("`{key}` does not apply to this kind of light"));
                match (field, &mut light.kind) {
                    ("direction", LightKind::Directional { direction }) => {
                        let d = three(spec)?;
                        if norm3(d) < 1e-12 {
                            return Err(err("a direction towards the light (not zero)"));
                        }
                        *direction = unit(d);
                    }
                    (
                        "position",
                        LightKind::Point { position }
                        | LightKind::Sphere { position, .. }
                        | LightKind::Rect { position, .. },
                    ) => *position = three(spec)?,
                    ("radius", LightKind::Sphere { radius, .. }) => {
                        *radius = spec.check_numbers(value).map_err(|what| err(&what))?[0]
                    }
                    ("u" | "v", LightKind::Rect { u, v, .. }) => {
                        let e = three(spec)?;
                        let (nu, nv) = if field == "u" { (e, *v) } else { (*u, e) };
                        if norm3(cross3(nu, nv)) < 1e-12 {
                            return Err(err("an edge that is not parallel to the other one (or zero)"));
                        }
                        (*u, *v) = (nu, nv);
                    }
                    ("direction" | "position" | "radius" | "u" | "v", _) => return Err(misplaced()),
                    _ => set(light.set_numbers(field, value))?,
                }
                Ok(())
            }
            ["material", name, field] => {
                let Some(m) = self.materials.iter_mut().find(|m| m.name == name) else {
                    return Err(crate::SceneError::usage(format!(
                        "`{key}`: no material named \"{name}\""
                    )));
                };
                if field == "checker_size" {
                    let keys = material_keys();
                    let size = crate::schema::spec(keys, field)
                        .check_numbers(value)
                        .map_err(|what| err(&what))?[0];
                    let Some(checker) = &mut m.checker else {
                        return Err(crate::SceneError::usage(format!(
                            "`{key}`: the material has no `checker`"
                        )));
                    };
                    checker.1 = size;
                    return Ok(());
                }
                set(m.set_numbers(field, value))
            }
            _ => Err(unknown()),
        }
    }
}

pub(crate) fn norm3(a: Vec3) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

pub(crate) fn cross3(a: Vec3, b: Vec3) -> Vec3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// A scene value written as shape text of the time and the parameters,
/// such as `intensity = "1.0 + 0.5 * sin(t)"`.
#[derive(Debug, Clone)]
pub struct Driven {
    /// The dotted key it sets (`light.0.intensity`, `camera.position`).
    pub key: String,
    /// One expression per component (1, or 3 for vectors and colours).
    pub values: Vec<Shape>,
    /// Where it was written.
    pub(crate) origin: crate::doc::Origin,
}

/// The texts a scene was loaded from.
#[derive(Debug)]
pub(crate) struct SceneOrigin {
    pub(crate) sources: crate::error::Sources,
    /// The document as loaded (overrides applied), for [`Scene::origin_of`].
    pub(crate) root: Vec<crate::doc::Entry>,
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
    /// When some opaque object is a plane or sphere in closed form
    /// ([`crate::Derived::analytic`]): the union of the other opaque
    /// objects, which hard shadow rays march while the closed forms are
    /// intersected.
    pub opaque_rest: Option<Shape>,
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
    /// What renderers trace besides the objects, derived from them: the
    /// unsigned field, the shadow fields, the closed forms and the union of
    /// the marched objects. Kept consistent with the objects by the scene.
    pub fn derived(&self) -> &crate::derive::Derived {
        &self.derived
    }

    /// Where the value of a dotted key was written (`light.0.intensity`,
    /// `object.2.shape`, `params.k`): a span of the scene file, an
    /// override, or [`crate::doc::Origin::Implicit`] for a default. None
    /// when the scene has no such key. For editors that show a value's
    /// source or an error next to its field.
    pub fn origin_of(&self, key: &str) -> Option<crate::doc::Origin> {
        crate::doc::find(&self.origin.root, key).map(|v| v.origin)
    }

    /// The object cache this scene compiles with: pass it to later loads
    /// (with [`crate::LoadOptions::objects`]) to reuse unchanged objects.
    pub fn object_cache(&self) -> &crate::compile::ObjectCache {
        &self.cache
    }

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
        let (next, changed, values, params) = self.next_inputs(&[isoray_shape::TIME], |inputs| inputs[0] = t)?;
        self.library.set_time(t);
        self.store_params(params);
        self.apply_inputs(next, changed, values)
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
        let comps = value.components();
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
        if let Some(i) = self.tracks.iter().position(|tr| tr.target == key) {
            return Err(crate::SceneError::usage(format!(
                "`{key}` is driven by `track.{i}`: change the track's keys, or remove it"
            ))
            .with_key(key));
        }
        // A take that drives the parameter keeps this as its value before
        // its first event.
        for tr in &mut self.midi_tracks {
            if tr.target == key && !tr.hold_first {
                tr.rest = Some(comps.clone());
            }
        }
        let vars: Vec<u32> = (at..at + ty.width() as u32).collect();
        let (next, changed, values, _) = self.next_inputs(&vars, |inputs| {
            for (k, x) in comps.iter().enumerate() {
                inputs[at as usize + k] = *x;
            }
        })?;
        self.library.set_param(name, value);
        if let Some(p) = self.params.iter_mut().find(|(n, _)| n == name) {
            p.1 = value;
        }
        self.apply_inputs(next, changed, values)
    }

    /// Moves object `i` to `placement` (the simulation does, each step):
    /// its seven placement inputs are set as given, nothing recompiles. An
    /// error when the object has no placement inputs (give it a
    /// `position`, or a moving `body`) or the scale is not positive.
    pub fn set_placement(&mut self, i: usize, placement: crate::physics::Placement) -> Result<(), crate::SceneError> {
        let Some(tr) = self.objects.get(i).and_then(|o| o.transform.as_ref()) else {
            return Err(crate::SceneError::usage(format!(
                "`object.{i}` cannot be moved: it has no placement (give it a `position`)"
            )));
        };
        let v = placement;
        if !(v.scale > 0.0 && v.scale.is_finite()) || v.position.iter().chain(&v.rotation).any(|x| !x.is_finite()) {
            return Err(crate::SceneError::usage(format!(
                "`object.{i}`: a placement needs finite numbers and a positive scale, found {v:?}"
            )));
        }
        let values = v.values();
        let mut next = self.inputs.clone();
        let mut changed = Vec::new();
        for (k, x) in values.into_iter().enumerate() {
            let at = tr.inputs as usize + k;
            if next[at].to_bits() != x.to_bits() {
                next[at] = x;
                changed.push(at as u32);
            }
        }
        if changed.is_empty() {
            return Ok(());
        }
        self.apply_inputs(next, changed, None)
    }

    /// Stores parameter values that tracks set.
    fn store_params(&mut self, params: Vec<(String, Value)>) {
        for (name, value) in params {
            self.library.set_param(&name, value);
            if let Some(p) = self.params.iter_mut().find(|(n, _)| *n == name) {
                p.1 = value;
            }
        }
    }

    /// The inputs after setting base inputs with `set`, with every object
    /// placement computed again, and the indices that changed (`vars` and
    /// the placements that moved); an error when a scale is not positive.
    fn next_inputs(&self, vars: &[u32], set: impl FnOnce(&mut Vec<f64>)) -> Result<NextInputs, crate::SceneError> {
        let mut next = self.inputs.clone();
        set(&mut next);
        let mut changed = vars.to_vec();
        let t = next.first().copied().unwrap_or(0.0);
        // Parameters driven by tracks, before anything reads them.
        let mut tracked_params = Vec::new();
        for tr in self.all_tracks() {
            let crate::animation::Drive::Param { name, at } = tr.drive() else {
                continue;
            };
            let Some(v) = tr.sample(t) else { continue };
            for (c, x) in v.iter().enumerate() {
                let k = *at as usize + c;
                if x.to_bits() != next[k].to_bits() {
                    next[k] = *x;
                    changed.push(k as u32);
                }
            }
            tracked_params.push((name.clone(), Value::from_components(&v)));
        }
        let frames = bone_frames(&self.bones, self.all_tracks(), t);
        for (i, o) in self.objects.iter().enumerate() {
            for (guard, what) in &o.fragment.guards {
                let v = guard.eval_with(&next, [0.0; 3]);
                if !(v > 0.0 && v.is_finite()) {
                    return Err(crate::SceneError::usage(format!(
                        "`object.{i}.shape`: {what} must be positive, found {v} (at t = {})",
                        next.first().copied().unwrap_or(0.0)
                    ))
                    .with_key(format!("object.{i}.shape")));
                }
            }
            let Some(tr) = &o.transform else { continue };
            let mut placement = [0.0; 7];
            for (k, value) in tr.values.iter().enumerate() {
                placement[k] = value.eval_with(&next, [0.0; 3]);
            }
            place_by_tracks(self.all_tracks(), i, t, &mut placement);
            if let Some(b) = o.bone {
                crate::skeleton::carry(&frames[b], &mut placement);
            }
            crate::read::check_scale(&self.origin.sources, i, tr, placement[6])?;
            for (k, v) in placement.into_iter().enumerate() {
                let at = tr.inputs as usize + k;
                if v.to_bits() != next[at].to_bits() {
                    next[at] = v;
                    changed.push(at as u32);
                }
            }
        }
        let values = self.driven_values(&next)?;
        Ok((next, changed, values, tracked_params))
    }

    /// Sets a camera, light or material value by its dotted key, as written
    /// in the file: `camera.position`, `camera.fov`, `light.0.intensity`,
    /// `light.1.color`, `material.gold.diffuse`, … — every key whose
    /// description ([`crate::schema::KeySpec::is_numeric`]) is numbers.
    /// `value` has 3 components for vectors and colours (1 gives a grey
    /// colour) and 1 for numbers. The value is checked as the loader checks
    /// it; an error changes nothing.
    pub fn set_value(&mut self, key: &str, value: &[f64]) -> Result<(), crate::SceneError> {
        let mut values = self.values();
        values.set(key, value)?;
        self.store_values(values);
        Ok(())
    }

    fn values(&self) -> Values {
        Values {
            camera: self.camera.clone(),
            lights: self.lights.clone(),
            materials: self.materials.clone(),
        }
    }

    fn store_values(&mut self, v: Values) {
        self.camera = v.camera;
        self.lights = v.lights;
        self.materials = v.materials;
    }

    /// The camera, lights and materials with every driven value computed
    /// at the inputs `vars`, checked; None when no value is driven.
    fn driven_values(&self, vars: &[f64]) -> Result<Option<Values>, crate::SceneError> {
        let tracked = self
            .all_tracks()
            .filter(|tr| matches!(tr.drive(), crate::animation::Drive::Value));
        if self.driven.is_empty() && tracked.clone().next().is_none() {
            return Ok(None);
        }
        let t = vars.first().copied().unwrap_or(0.0);
        let mut values = self.values();
        for d in &self.driven {
            let v: Vec<f64> = d.values.iter().map(|s| s.eval_with(vars, [0.0; 3])).collect();
            values
                .set(&d.key, &v)
                .map_err(|e| crate::SceneError::usage(format!("{} (at t = {t}, from its expression)", e.message)))?;
        }
        for tr in tracked {
            if let Some(v) = tr.sample(t) {
                values
                    .set(&tr.target, &v)
                    .map_err(|e| crate::SceneError::usage(format!("{} (at t = {t}, from its track)", e.message)))?;
            }
        }
        Ok(Some(values))
    }

    /// At load: checks every key of the tracks on camera, light and
    /// material values as the loader checks such a value (an error points
    /// at the track), then applies them at the scene's time.
    pub(crate) fn start_tracks(&mut self) -> Result<(), crate::SceneError> {
        let src = &self.origin.sources;
        let probes: Vec<crate::animation::Track> = self.midi.iter().enumerate().map(|(i, m)| m.probe(i)).collect();
        for tr in self.tracks.iter().chain(&probes) {
            if !matches!(tr.drive(), crate::animation::Drive::Value) {
                continue;
            }
            for (t, v) in &tr.keys {
                let mut scratch = self.values();
                scratch.set(&tr.target, v).map_err(|e| {
                    let which = if tr.is_midi() {
                        "its range".to_string()
                    } else {
                        format!("the key at t = {t}")
                    };
                    tr.error(src, format!("`{}`, {which}: {}", tr.label, e.message), &[])
                })?;
            }
        }
        if let Some(values) = self.driven_values(&self.inputs)? {
            self.store_values(values);
        }
        Ok(())
    }

    /// The file's tracks, then what MIDI input drives.
    fn all_tracks(&self) -> impl Iterator<Item = &crate::animation::Track> + Clone {
        self.tracks.iter().chain(&self.midi_tracks)
    }

    /// Plays a take of MIDI events (from [`crate::midi::read_midi_file`]):
    /// from now on each mapping's target is the value of the last event its
    /// controller sent at or before the scene's time, and the scene's own
    /// value before the first. The scene moves to its current time again.
    pub fn play_midi(&mut self, events: &[crate::midi::MidiEvent]) -> Result<(), crate::SceneError> {
        // The values before each controller's first event: the scene's own,
        // from before any take.
        self.midi_tracks.clear();
        self.set_time(self.time())?;
        let mut tracks = crate::midi::take_tracks(&self.midi, events);
        for tr in &mut tracks {
            tr.rest = self.own_value(tr);
        }
        self.midi_tracks = tracks;
        self.set_time(self.time())
    }

    /// The value a track's target has now.
    fn own_value(&self, tr: &crate::animation::Track) -> Option<Vec<f64>> {
        use crate::animation::Drive;
        match tr.drive() {
            Drive::Param { name, .. } => self.params.iter().find(|(n, _)| n == name).map(|(_, v)| v.components()),
            Drive::Placement { object, first } => {
                let tr_inputs = self.objects.get(*object)?.transform.as_ref()?.inputs as usize;
                let at = tr_inputs + first;
                let width = if *first == 6 { 1 } else { 3 };
                self.inputs.get(at..at + width).map(<[f64]>::to_vec)
            }
            Drive::Value => self.values().get(&tr.target),
            Drive::Bone { bone, rotation } => {
                let b = self.bones.get(*bone)?;
                Some(if *rotation {
                    b.rotation.to_vec()
                } else {
                    b.position.to_vec()
                })
            }
            Drive::Unresolved => None,
        }
    }

    /// Live MIDI input: mapping `mapping` now holds the value controller
    /// value `v` gives, at every time, until the next call (or a take).
    pub fn set_midi_value(&mut self, mapping: usize, v: u8) -> Result<(), crate::SceneError> {
        let Some(m) = self.midi.get(mapping) else {
            return Err(crate::SceneError::usage(format!(
                "the scene has {} MIDI mapping(s), not {}",
                self.midi.len(),
                mapping + 1
            )));
        };
        let mut t = crate::animation::Track::new(
            &m.target,
            vec![(0.0, vec![m.value(v)])],
            crate::Interpolation::Step,
            false,
        );
        t.drive = m.drive.clone();
        t.label = format!("midi.{mapping}");
        self.midi_tracks.retain(|o| o.target != m.target);
        self.midi_tracks.push(t);
        self.set_time(self.time())
    }

    /// The track that drives `key` (`params.k`, `light.0.intensity`), if any.
    pub fn track_of(&self, key: &str) -> Option<&crate::animation::Track> {
        self.tracks.iter().find(|t| t.target == key)
    }

    /// Applies new inputs: recompiles objects that bound a changed one, and
    /// re-derives the closed forms of objects that read one.
    fn apply_inputs(
        &mut self,
        next: Vec<f64>,
        changed: Vec<u32>,
        values: Option<Values>,
    ) -> Result<(), crate::SceneError> {
        if let Some(values) = values {
            self.store_values(values);
        }
        self.inputs = next;
        let vars = &changed[..];
        let bound = self
            .objects
            .iter()
            .any(|o| o.bound_inputs.iter().any(|v| vars.contains(v)));
        if bound {
            return self.recompile();
        }
        if !crate::derive::analytic_allowed(&self.render) {
            return Ok(());
        }
        for (i, o) in self.objects.iter().enumerate() {
            if !o.shape.tape().vars().iter().any(|v| vars.contains(v)) {
                continue;
            }
            let now = o.closed_form(&self.inputs);
            // A change of which objects are closed forms changes what is
            // marched: derive again from the compiled objects.
            if now.is_some() != self.derived.analytic[i].is_some() {
                self.rederive();
                return Ok(());
            }
            self.derived.analytic[i] = now;
        }
        Ok(())
    }

    /// Builds the scene's distance and the derived data again from the
    /// compiled objects (nothing is compiled).
    fn rederive(&mut self) {
        let (shape, derived) = crate::derive::assemble(&mut self.objects, &self.materials, &self.render, &self.inputs);
        self.shape = shape;
        self.derived = derived;
    }

    /// Compiles the scene again from its sources with the current
    /// parameter values and time: objects whose bound inputs did not change
    /// come from the object cache, analyses from the analysis cache.
    fn recompile(&mut self) -> Result<(), crate::SceneError> {
        let sources = self.origin.sources.clone();
        self.recompile_from(sources)
    }

    /// [`Scene::recompile`] from `sources` (which the scene then keeps).
    pub(crate) fn recompile_from(&mut self, sources: crate::error::Sources) -> Result<(), crate::SceneError> {
        let mut src = sources.clone();
        for (name, v) in &self.params {
            src.overrides.push(format!("params.{name}={}", v.toml_text()));
        }
        let opts = crate::LoadOptions {
            time: self.time(),
            analyses: Some(self.library.analyses().clone()),
            cancel: self.library.cancel_token().cloned(),
            objects: Some(self.cache.clone()),
            progress: self.library.progress().cloned(),
        };
        let fresh = crate::load_str_with(&src.text, &src.path, &src.overrides, &opts)?;
        let origin = if sources == self.origin.sources {
            self.origin.clone()
        } else {
            std::sync::Arc::new(SceneOrigin {
                sources,
                root: fresh.origin.root.clone(),
            })
        };
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
