//! Rigid bodies and dents in a scene: the `[physics]` table, and the keys
//! of an `[[object]]` that make it a body (`body`, `collider`, `velocity`,
//! `angular_velocity`) or a dentable surface (`dents`, `dent_map`).
//! Materials carry the impact model's constants (`density`,
//! `restitution`, `dent_compliance`, `thickness`); see `docs/DENTS.md`.
//!
//! Also an object's current placement as numbers ([`Placement`]): where
//! physics, dents and normal mapping take points between the world and the
//! object's own coordinates.

use std::sync::Arc;

use crate::error::{SceneError, Sources};
use crate::reader::Reader;
use crate::schema::{key, key_without_default, num, KeySpec, Kind, Range};

type Result<T> = std::result::Result<T, SceneError>;
use crate::doc::Located;

/// `[physics]`: the rigid-body simulation's settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Physics {
    /// Gravity, m/s².
    pub gravity: [f64; 3],
    /// The fixed step, seconds.
    pub timestep: f64,
    /// Seconds simulated by `isoray simulate`.
    pub duration: f64,
}

impl Default for Physics {
    fn default() -> Self {
        Physics {
            gravity: [0.0, -9.81, 0.0],
            timestep: 1.0 / 60.0,
            duration: 2.0,
        }
    }
}

/// The keys of `[physics]`.
pub fn physics_keys() -> &'static [KeySpec] {
    static KEYS: std::sync::LazyLock<Vec<KeySpec>> = std::sync::LazyLock::new(|| {
        vec![
            key("gravity", Kind::Vector, "[0.0, -9.81, 0.0]", "gravity, m/s²"),
            key(
                "timestep",
                num(Range::POSITIVE),
                "0.016666666666666666",
                "the simulation's fixed step, seconds",
            ),
            key(
                "duration",
                num(Range::POSITIVE),
                "2.0",
                "seconds `isoray simulate` runs by default",
            ),
        ]
    });
    &KEYS
}

pub(crate) fn read_physics(src: &Sources, v: &Located) -> Result<Physics> {
    let mut r = Reader::new(src, v, "physics")?;
    let keys = physics_keys();
    let d = Physics::default();
    let p = Physics {
        gravity: r.vec3("gravity", d.gravity)?,
        timestep: r.num_key(crate::schema::spec(keys, "timestep"))?,
        duration: r.num_key(crate::schema::spec(keys, "duration"))?,
    };
    r.finish_keys(keys)?;
    Ok(p)
}

/// What the simulation does with an object.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BodyKind {
    /// Not simulated (the default): it neither moves nor collides.
    #[default]
    None,
    /// Collides, never moves.
    Fixed,
    /// Moves under gravity and contacts.
    Dynamic,
    /// Moves with its `velocity` and `angular_velocity`, pushes others.
    Kinematic,
}

/// The shape the simulation gives a body.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Collider {
    /// An exact ball or half-space for objects recognised as spheres and
    /// planes, otherwise the mesh (its convex hull for dynamic bodies).
    #[default]
    Auto,
    /// The convex hull of the object's mesh.
    Hull,
    /// The object's mesh itself (fixed and kinematic bodies).
    Mesh,
}

/// How impacts change a dentable object.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum DentMode {
    /// Never dented (the default).
    #[default]
    None,
    /// Dents in its height (bump) map, shaded by normal mapping.
    Bump,
    /// Dents as geometry (CSG edits of its shape).
    Sdf,
    /// The map while a dent is shallow, geometry when it is deep or the map saturates.
    Auto,
}

/// An object's dent map settings (`dent_map = { size, range, uv, extent }`).
#[derive(Debug, Clone, PartialEq)]
pub struct DentMapSettings {
    /// Texels per side.
    pub size: u32,
    /// Scene units of a full height unit (the thesis's k): dents down to range/2.
    pub range: f64,
    /// The uv mapping's name.
    pub uv: String,
    /// The mapped region: the object's own cube [−extent, extent]³.
    pub extent: f64,
    /// With `uv = "parametric"`: the object's parametric surface, sampled.
    pub parametric: Option<isoray_dent::param::ParametricUv>,
}

impl Default for DentMapSettings {
    fn default() -> Self {
        DentMapSettings {
            size: 512,
            range: 0.05,
            uv: "planar-xz".into(),
            extent: 1.0,
            parametric: None,
        }
    }
}

impl DentMapSettings {
    /// The uv mapping these settings name.
    pub fn mapping(&self) -> std::result::Result<isoray_dent::uv::UvMapping, String> {
        if self.uv == "parametric" {
            return match &self.parametric {
                Some(m) => Ok(isoray_dent::uv::UvMapping::Parametric(m.clone())),
                None => Err("uv = \"parametric\" needs the object's shape to call a parametric surface".into()),
            };
        }
        let e = self.extent;
        isoray_dent::uv::UvMapping::named(&self.uv, [-e; 3], [e; 3])
    }

    /// An untouched map (height and normals) of these settings.
    pub fn blank(&self) -> std::result::Result<isoray_dent::DentMaps, String> {
        let mapping = self.mapping()?;
        // A texel's size in scene units: the planar picture's side, or a
        // row of the spherical map (half a great circle) over the texels.
        let across = match &mapping {
            isoray_dent::uv::UvMapping::Parametric(m) => m.span(),
            m if m.wraps_columns() => std::f64::consts::PI * self.extent,
            _ => 2.0 * self.extent,
        };
        Ok(isoray_dent::DentMaps::new(
            mapping,
            self.size,
            self.range,
            across / self.size as f64,
        ))
    }
}

/// An object's physics and dent keys.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ObjectPhysics {
    /// `body`.
    pub body: BodyKind,
    /// `collider`.
    pub collider: Collider,
    /// `velocity`, m/s, at the start.
    pub velocity: [f64; 3],
    /// `angular_velocity`, rad/s about world x, y, z, at the start.
    pub angular_velocity: [f64; 3],
    /// `dents`.
    pub dents: DentMode,
    /// `dent_map`.
    pub dent_map: DentMapSettings,
    /// The object's current dent maps (None: untouched, or not dentable).
    pub maps: Option<Arc<isoray_dent::DentMaps>>,
    /// Dents cut into its geometry (`[[object.sdf_dent]]`), in order.
    pub sdf_dents: Vec<crate::sdf_dents::SdfDent>,
    /// `dent_rim`: the soft rim of the dents impacts cut into its geometry.
    pub dent_rim: f64,
}

/// Samples per side of a parametric dent mapping's grid.
const PARAMETRIC_SAMPLES: usize = 129;

/// The (s, t) mapping of the parametric surface `name` of `lib` (default
/// parameters), for `uv = "parametric"`.
pub(crate) fn parametric_mapping(
    lib: &isoray_shape::Library,
    name: &str,
) -> std::result::Result<isoray_dent::param::ParametricUv, String> {
    let coords = lib.parametric_coords(name, None).map_err(|d| d.message.clone())?;
    let [[s0, s1], [t0, t1]] = coords.domain;
    let mut evals = coords.coords.each_ref().map(isoray_shape::PointEvaluator::<f64>::new);
    isoray_dent::param::ParametricUv::new(name, PARAMETRIC_SAMPLES, |u, v| {
        let (s, t) = (s0 + u * (s1 - s0), t0 + v * (t1 - t0));
        Some(std::array::from_fn(|k| evals[k].eval(&[], s, t, 0.0)))
    })
}

impl ObjectPhysics {
    /// The object's dent maps as they are now: a copy of its maps, or
    /// untouched ones of its `dent_map` settings.
    pub fn current_maps(&self) -> std::result::Result<isoray_dent::DentMaps, String> {
        match &self.maps {
            Some(m) => Ok(m.as_ref().clone()),
            None => self.dent_map.blank(),
        }
    }
}

const BODIES: &[(&str, BodyKind)] = &[
    ("none", BodyKind::None),
    ("fixed", BodyKind::Fixed),
    ("dynamic", BodyKind::Dynamic),
    ("kinematic", BodyKind::Kinematic),
];
const COLLIDERS: &[(&str, Collider)] = &[
    ("auto", Collider::Auto),
    ("hull", Collider::Hull),
    ("mesh", Collider::Mesh),
];
const DENTS: &[(&str, DentMode)] = &[
    ("none", DentMode::None),
    ("bump", DentMode::Bump),
    ("sdf", DentMode::Sdf),
    ("auto", DentMode::Auto),
];
const UVS: &[&str] = &["planar-xz", "planar-xy", "planar-yz", "spherical", "parametric"];

/// The object keys of this module, for `object_keys`.
pub(crate) fn object_physics_keys() -> Vec<KeySpec> {
    fn names<T>(o: &[(&'static str, T)]) -> Vec<&'static str> {
        o.iter().map(|(n, _)| *n).collect()
    }
    vec![
        key(
            "body",
            Kind::Choice(names(BODIES)),
            "\"none\"",
            "the rigid body it is in `isoray simulate`: `\"fixed\"` collides and never moves, `\"dynamic\"` falls and bounces, `\"kinematic\"` moves at its velocity and pushes others",
        ),
        key(
            "collider",
            Kind::Choice(names(COLLIDERS)),
            "\"auto\"",
            "its shape in the simulation: `\"auto\"` an exact ball or half-space for spheres and planes, else its mesh (the convex hull for dynamic bodies); `\"hull\"`; `\"mesh\"`",
        ),
        key("velocity", Kind::Vector, "[0.0, 0.0, 0.0]", "m/s at the start of the simulation"),
        key(
            "angular_velocity",
            Kind::Vector,
            "[0.0, 0.0, 0.0]",
            "rad/s about world x, y and z at the start",
        ),
        key(
            "dents",
            Kind::Choice(names(DENTS)),
            "\"none\"",
            "what impacts do to it: `\"bump\"` dents in its height map, shaded by normal mapping; `\"sdf\"` dents as geometry; `\"auto\"` the map while shallow, geometry when deep",
        ),
        key(
            "dent_rim",
            num(Range::NON_NEGATIVE),
            "0.0",
            "the soft rim of the dents impacts cut into its geometry (`dents = \"sdf\"` or `\"auto\"`): their edges are rounded over this width, in its own units",
        ),
        key_without_default(
            "sdf_dent",
            Kind::Text("array of tables"),
            "none",
            "dents cut into its geometry, one `[[object.sdf_dent]]` table each (see below); `isoray simulate --save-scene` writes them",
        ),
        key(
            "dent_map",
            Kind::Text("inline table"),
            "{ size = 512, range = 0.05, uv = \"planar-xz\", extent = 1.0 }",
            "its height map: `size` texels a side, `range` scene units of a full height unit (dents down to range/2), `uv` the mapping (`planar-xz`, `planar-xy`, `planar-yz`: a height field seen from the + side of y, z, x; `spherical`: a body around its origin; `parametric`: the (s, t) of the parametric surface its shape calls, with its default parameters), `extent`: the mapped region is the object's own cube [−extent, extent]³",
        ),
    ]
}

/// Reads an object's physics and dent keys (`ctx`: `object.N`).
pub(crate) fn read_object_physics(src: &Sources, r: &mut Reader, ctx: &str) -> Result<ObjectPhysics> {
    let mut out = ObjectPhysics {
        body: r.choice("body", BODIES, BodyKind::None)?,
        collider: r.choice("collider", COLLIDERS, Collider::Auto)?,
        velocity: r.vec3("velocity", [0.0; 3])?,
        angular_velocity: r.vec3("angular_velocity", [0.0; 3])?,
        dents: r.choice("dents", DENTS, DentMode::None)?,
        dent_rim: r.num_in("dent_rim", 0.0, |x| x >= 0.0 && x.is_finite(), "a number ≥ 0")?,
        ..Default::default()
    };
    if let Some(v) = r.get("dent_map") {
        let ctx = format!("{ctx}.dent_map");
        let mut m = Reader::new(src, v, &ctx)?;
        let d = DentMapSettings::default();
        let size = m.int("size", d.size, 8, 16384)?;
        let range = m.num_in("range", d.range, |x| x > 0.0, "a positive number of scene units")?;
        let extent = m.num_in("extent", d.extent, |x| x > 0.0, "a positive number of scene units")?;
        let uv = match m.string("uv")? {
            None => d.uv,
            Some((name, loc)) => {
                let known = if name == "parametric" {
                    Ok(())
                } else {
                    isoray_dent::uv::UvMapping::named(name, [-1.0; 3], [1.0; 3]).map(|_| ())
                };
                if let Err(why) = known {
                    let notes = match isoray_shape::diag::suggest(name, UVS.iter().copied()) {
                        Some(s) if name != "triplanar" => vec![format!("did you mean \"{s}\"?")],
                        _ => vec![],
                    };
                    return Err(src
                        .error(
                            loc.origin,
                            format!("`{ctx}.uv`: {why}"),
                            Some("not a one-to-one mapping"),
                            &notes,
                        )
                        .with_key(format!("{ctx}.uv")));
                }
                name.to_string()
            }
        };
        m.finish(&["size", "range", "uv", "extent"])?;
        out.dent_map = DentMapSettings {
            size,
            range,
            uv,
            extent,
            parametric: None,
        };
    }
    Ok(out)
}

/// An object's placement as numbers: its own coordinates q are at
/// `position` + `scale`·R·q in the world, R turning about x, then y,
/// then z (world axes, degrees; `rotation`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placement {
    /// Where the object's origin is.
    pub position: [f64; 3],
    /// Degrees about x, then y, then z.
    pub rotation: [f64; 3],
    /// Uniform scale.
    pub scale: f64,
}

impl Default for Placement {
    fn default() -> Self {
        Placement {
            position: [0.0; 3],
            rotation: [0.0; 3],
            scale: 1.0,
        }
    }
}

fn rot(axis: usize, deg: f64, v: [f64; 3]) -> [f64; 3] {
    let (s, c) = deg.to_radians().sin_cos();
    let (a, b) = match axis {
        0 => (1, 2),
        1 => (2, 0),
        _ => (0, 1),
    };
    let mut out = v;
    out[a] = c * v[a] - s * v[b];
    out[b] = s * v[a] + c * v[b];
    out
}

impl Placement {
    /// The seven values of the object's placement inputs: position x, y,
    /// z, rotation x, y, z (degrees), scale.
    pub fn values(&self) -> [f64; 7] {
        let (p, r) = (self.position, self.rotation);
        [p[0], p[1], p[2], r[0], r[1], r[2], self.scale]
    }

    /// The placement of seven input values ([`Placement::values`]).
    pub fn from_values(v: &[f64]) -> Placement {
        Placement {
            position: [v[0], v[1], v[2]],
            rotation: [v[3], v[4], v[5]],
            scale: v[6],
        }
    }

    /// R·v: a direction of the object in the world.
    pub fn dir_to_world(&self, v: [f64; 3]) -> [f64; 3] {
        rot(
            2,
            self.rotation[2],
            rot(1, self.rotation[1], rot(0, self.rotation[0], v)),
        )
    }

    /// R⁻¹·v: a world direction in the object's axes.
    pub fn dir_to_local(&self, v: [f64; 3]) -> [f64; 3] {
        rot(
            0,
            -self.rotation[0],
            rot(1, -self.rotation[1], rot(2, -self.rotation[2], v)),
        )
    }

    /// The world point of the object's point q.
    pub fn to_world(&self, q: [f64; 3]) -> [f64; 3] {
        let r = self.dir_to_world(q);
        std::array::from_fn(|i| self.position[i] + self.scale * r[i])
    }

    /// The object's point at world point p.
    pub fn to_local(&self, p: [f64; 3]) -> [f64; 3] {
        let d: [f64; 3] = std::array::from_fn(|i| (p[i] - self.position[i]) / self.scale);
        self.dir_to_local(d)
    }

    /// This placement seen from `frame`'s own coordinates: the placement
    /// P with frame.to_world(P.to_world(q)) = self.to_world(q).
    pub fn relative_to(&self, frame: &Placement) -> Placement {
        // Columns of the rotation: frame⁻¹ · self applied to the axes.
        let cols: [[f64; 3]; 3] = std::array::from_fn(|k| {
            let mut e = [0.0; 3];
            e[k] = 1.0;
            frame.dir_to_local(self.dir_to_world(e))
        });
        let m = |r: usize, c: usize| cols[c][r];
        Placement {
            position: frame.to_local(self.position),
            rotation: euler_xyz(m),
            scale: self.scale / frame.scale,
        }
    }
}

/// The angles (degrees) about x, then y, then z (world axes) of the
/// rotation matrix `m(row, column)` = R_z·R_y·R_x.
fn euler_xyz(m: impl Fn(usize, usize) -> f64) -> [f64; 3] {
    let sy = (-m(2, 0)).clamp(-1.0, 1.0);
    let y = sy.asin();
    if sy.abs() < 1.0 - 1e-12 {
        [m(2, 1).atan2(m(2, 2)), y, m(1, 0).atan2(m(0, 0))].map(f64::to_degrees)
    } else {
        // Gimbal lock: only x − z (or x + z) is defined; take z = 0.
        [(-m(1, 2)).atan2(m(1, 1)), y, 0.0].map(f64::to_degrees)
    }
}

impl crate::Scene {
    /// Object `i`'s current placement (at the scene's inputs; identity when
    /// it has none).
    pub fn placement(&self, i: usize) -> Placement {
        let Some(t) = &self.objects[i].transform else {
            return Placement::default();
        };
        Placement::from_values(&self.inputs[t.inputs as usize..t.inputs as usize + 7])
    }

    /// The normal at world point `p` of object `object` whose undented
    /// normal there is `n`, tilted by its dent maps (`dents = "bump"` or
    /// `"auto"`): the height map's normal in the tangent frame of its uv
    /// mapping, in full precision, at the texel the view picks by
    /// `render.parallax` (`to_eye`: the unit direction from `p` towards
    /// the viewer; unused without parallax). None where the object has no
    /// maps, or `p` is off the mapped side or region: the normal is then `n`.
    pub fn dent_normal(&self, object: usize, p: [f64; 3], n: [f64; 3], to_eye: [f64; 3]) -> Option<[f64; 3]> {
        let o = self.objects.get(object)?;
        if !matches!(o.physics.dents, DentMode::Bump | DentMode::Auto) {
            return None;
        }
        let maps = o.physics.maps.as_ref()?;
        let place = self.placement(object);
        let q = place.to_local(p);
        let nl = place.dir_to_local(n);
        if !maps.mapping.faces(q, nl) {
            return None;
        }
        let uv = maps.mapping.uv(q)?;
        // Seen from the back of a parametric sheet, the dents are bumps:
        // the normal of the front, negated.
        let side = maps.mapping.side(q, nl);
        let nl = nl.map(|c| c * side);
        let (t, b) = maps.mapping.frame(q, nl);
        let frame = [t, b, nl];
        let uv = match self.render.parallax {
            crate::Parallax::None => uv,
            mode => parallax_uv(
                maps,
                q,
                frame,
                place.dir_to_local(to_eye),
                mode,
                self.render.parallax_steps,
            )
            .unwrap_or(uv),
        };
        let ts = maps.normal_at(uv);
        let local: [f64; 3] = std::array::from_fn(|i| side * (ts[0] * t[i] + ts[1] * b[i] + ts[2] * nl[i]));
        let w = place.dir_to_world(local);
        let l = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
        (l > 0.0 && l.is_finite()).then(|| w.map(|c| c / l))
    }

    /// The index of the object named `name`.
    pub fn object_named(&self, name: &str) -> Option<usize> {
        self.objects.iter().position(|o| o.name.as_deref() == Some(name))
    }

    /// Gives each named dentable object (`dents` other than `"none"`) the
    /// heights of `NAME-height.png` in `dir` where that file exists (its
    /// normals recomputed); returns the names of those that got maps. An
    /// error names a file that cannot be read or does not fit the
    /// object's `dent_map`.
    pub fn attach_dent_maps(&mut self, dir: &std::path::Path) -> std::result::Result<Vec<String>, String> {
        if !dir.is_dir() {
            return Err(format!("{}: no such folder of dent maps", dir.display()));
        }
        let mut attached = Vec::new();
        for (i, o) in self.objects.iter_mut().enumerate() {
            let Some(name) = o.name.clone() else { continue };
            if o.physics.dents == DentMode::None {
                continue;
            }
            let (height, _) = isoray_dent::DentMaps::paths(dir, &name);
            if !height.exists() {
                continue;
            }
            let blank = o
                .physics
                .dent_map
                .blank()
                .map_err(|e| format!("`object.{i}.dent_map`: {e}"))?;
            let maps = blank.with_heights_from(dir, &name).map_err(|e| e.to_string())?;
            o.physics.maps = Some(Arc::new(maps));
            attached.push(name);
        }
        Ok(attached)
    }
}

/// The uv a view towards `to_eye` (the object's own axes) sees at the
/// surface point q of a dented map, by parallax mapping in the tangent
/// frame `[t, b, n]`: the view ray enters at q and goes down into the
/// dents (depth below the untouched surface, `DentMaps::depth_at`).
/// `Offset` moves q by depth × the view's tangent part (Welsh's offset
/// limiting); `Steep` marches the ray down through `steps` layers over
/// the deepest dent the map holds (range/2) to the first below the map;
/// `Occlusion` interpolates the crossing between the last two layers.
/// None for a view along or below the surface.
fn parallax_uv(
    maps: &isoray_dent::DentMaps,
    q: [f64; 3],
    [t, b, n]: [[f64; 3]; 3],
    to_eye: [f64; 3],
    mode: crate::Parallax,
    steps: u32,
) -> Option<[f64; 2]> {
    let dot = |a: [f64; 3], c: [f64; 3]| a[0] * c[0] + a[1] * c[1] + a[2] * c[2];
    let (vx, vy, vz) = (dot(to_eye, t), dot(to_eye, b), dot(to_eye, n));
    if vz <= 1e-6 {
        return None;
    }
    // The surface point moved by (dx, dy) in the tangent plane, and its uv.
    let at = |dx: f64, dy: f64| -> Option<[f64; 2]> {
        maps.mapping.uv(std::array::from_fn(|i| q[i] + dx * t[i] + dy * b[i]))
    };
    match mode {
        crate::Parallax::None => maps.mapping.uv(q),
        crate::Parallax::Offset => {
            let d = maps.depth_at(maps.mapping.uv(q)?);
            at(-d * vx, -d * vy)
        }
        crate::Parallax::Steep | crate::Parallax::Occlusion => {
            // Along the ray, depth s lies (s/vz)·(vx, vy) back from q.
            let layer = 0.5 * maps.height.range / steps as f64;
            let (sx, sy) = (-vx / vz, -vy / vz);
            let mut before: Option<(f64, f64)> = None; // (depth of the ray, gap to the map)
            for i in 0..=steps {
                let s = i as f64 * layer;
                let uv = at(s * sx, s * sy)?;
                let gap = maps.depth_at(uv) - s;
                if gap <= 0.0 {
                    if mode == crate::Parallax::Steep {
                        return Some(uv);
                    }
                    let s = match before {
                        Some((s0, g0)) => s0 + (s - s0) * g0 / (g0 - gap),
                        None => s,
                    };
                    return at(s * sx, s * sy);
                }
                before = Some((s, gap));
            }
            at(0.5 * maps.height.range * sx, 0.5 * maps.height.range * sy)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_relative_placement_composes_back() {
        let a = Placement {
            position: [1.0, -2.0, 0.5],
            rotation: [20.0, 35.0, -70.0],
            scale: 1.5,
        };
        let b = Placement {
            position: [0.3, 0.2, -1.0],
            rotation: [-40.0, 10.0, 100.0],
            scale: 0.25,
        };
        // The last pair is in gimbal lock (y = 90° relative to the identity).
        let gimbal = Placement {
            position: [0.5, 0.0, 0.0],
            rotation: [30.0, 90.0, 10.0],
            scale: 2.0,
        };
        for (a, b) in [(a, b), (b, a), (Placement::default(), gimbal)] {
            let rel = b.relative_to(&a);
            for q in [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.3, -0.7, 2.0]] {
                let (x, y) = (a.to_world(rel.to_world(q)), b.to_world(q));
                for i in 0..3 {
                    assert!((x[i] - y[i]).abs() < 1e-9, "{b:?}: {x:?} vs {y:?}");
                }
            }
        }
    }

    /// Parallax over a flat-bottomed pit of depth D seen 30° off the
    /// normal: offset limiting moves the texel by D·sin θ, steep parallax
    /// by the first layer below D times tan θ, occlusion by D·tan θ (the
    /// ray's exact crossing of the flat bottom).
    #[test]
    fn parallax_finds_the_bottom_of_a_pit() {
        let settings = DentMapSettings {
            size: 256,
            range: 0.2,
            uv: "planar-xz".into(),
            extent: 1.0,
            parametric: None,
        };
        let mut maps = settings.blank().unwrap();
        let depth = 0.07;
        let h = maps.height.value_of(-depth);
        for y in 64..192 {
            for x in 64..192 {
                maps.height.lower_min(x, y, h);
            }
        }
        assert!((maps.depth_at([0.5, 0.5]) - depth).abs() < 1e-6);
        let q = [0.0, 0.0, 0.0];
        let n = [0.0, 1.0, 0.0];
        let (t, b) = maps.mapping.frame(q, n);
        // The eye 30° from the normal, towards +t (+x: u grows with x).
        let th = 30f64.to_radians();
        let eye: [f64; 3] = std::array::from_fn(|i| th.sin() * t[i] + th.cos() * n[i]);
        let u_of = |mode, steps| parallax_uv(&maps, q, [t, b, n], eye, mode, steps).unwrap()[0];
        // u spans 2 scene units over [0, 1]; the view moves the texel away from the eye.
        let shift = |u: f64| (0.5 - u) * 2.0;
        let d = depth as f32 as f64; // the map keeps f32 texels
        assert!((shift(u_of(crate::Parallax::Offset, 16)) - d * th.sin()).abs() < 1e-6);
        assert!((shift(u_of(crate::Parallax::Occlusion, 16)) - d * th.tan()).abs() < 1e-6);
        let layer = 0.1 / 16.0;
        let steep = (d / layer).ceil() * layer * th.tan();
        assert!((shift(u_of(crate::Parallax::Steep, 16)) - steep).abs() < 1e-6);
        assert_eq!(parallax_uv(&maps, q, [t, b, n], t, crate::Parallax::Offset, 16), None);
    }

    #[test]
    fn a_parametric_mapping_needs_a_parametric_surface() {
        let text = "[[object]]\nshape = \"sphere(p, 1.0)\"\ndents = \"bump\"\ndent_map = { uv = \"parametric\" }\n";
        let e = crate::load_str(text, "t.toml", &[]).unwrap_err();
        assert!(
            e.rendered
                .contains("needs the object's shape to call a parametric surface"),
            "{}",
            e.rendered
        );
        assert!(e.rendered.contains("t.toml:1:"), "{}", e.rendered);
        let ok = "[surface.patch]\nparametric = { x = \"s\", y = \"0.1*s*t\", z = \"t\" }\nimage_only = true\n\
                  [[object]]\nshape = \"patch(p)\"\ndents = \"bump\"\ndent_map = { uv = \"parametric\" }\n";
        let s = crate::load_str(ok, "t.toml", &[]).unwrap_or_else(|e| panic!("{e}"));
        let m = s.objects[0].physics.dent_map.mapping().unwrap();
        // (s, t) = (0.5, −0.5) is (u, v) = (0.75, 0.25) over the default domain [−1, 1]².
        let uv = m.uv([0.5, -0.025, -0.5]).unwrap();
        assert!((uv[0] - 0.75).abs() < 1e-6 && (uv[1] - 0.25).abs() < 1e-6, "{uv:?}");
    }

    #[test]
    fn placements_invert_and_turn_about_x_then_y_then_z() {
        let p = Placement {
            position: [1.0, 2.0, 3.0],
            rotation: [30.0, -45.0, 60.0],
            scale: 2.0,
        };
        let q = [0.3, -0.7, 1.1];
        let back = p.to_local(p.to_world(q));
        for i in 0..3 {
            assert!((back[i] - q[i]).abs() < 1e-12);
        }
        // 90° about z takes x to y (counter-clockwise seen from +z).
        let z = Placement {
            rotation: [0.0, 0.0, 90.0],
            ..Default::default()
        };
        let v = z.dir_to_world([1.0, 0.0, 0.0]);
        assert!(v[0].abs() < 1e-12 && (v[1] - 1.0).abs() < 1e-12);
        // 90° about x takes y to z; about y takes z to x.
        let x = Placement {
            rotation: [90.0, 0.0, 0.0],
            ..Default::default()
        };
        assert!((x.dir_to_world([0.0, 1.0, 0.0])[2] - 1.0).abs() < 1e-12);
        let y = Placement {
            rotation: [0.0, 90.0, 0.0],
            ..Default::default()
        };
        assert!((y.dir_to_world([0.0, 0.0, 1.0])[0] - 1.0).abs() < 1e-12);
    }
}
