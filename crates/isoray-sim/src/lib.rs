//! # isoray-sim
//!
//! A scene's rigid bodies simulated by rapier3d, and the impacts that dent
//! them (the dents thesis's stage 1: the physics engine reports a
//! collision; `docs/DENTS.md`). Objects with `body = "fixed"`,
//! `"dynamic"` or `"kinematic"` become rigid bodies with colliders: an
//! exact ball or half-space for objects recognised as spheres and planes,
//! otherwise the object's mesh (its convex hull for moving bodies, the
//! mesh itself for fixed ones). A body's mass is its material's density
//! times its volume; restitutions combine by the minimum of the pair.
//! Each step reports the contacts that started in it, with the velocities
//! before the step: [`Impact`]. The simulation is deterministic (rapier's
//! `enhanced-determinism`, one thread, impacts sorted by their objects).

#![warn(missing_docs)]
// SceneError carries its rendered report for editors (see isoray-scene).
#![allow(clippy::result_large_err)]

use std::collections::BTreeSet;

use isoray_scene::{BodyKind, Collider, Placement, Scene};
use rapier3d::prelude::*;

mod dent;
pub mod run;
pub use dent::{dent_impact, DentRecord};
pub use isoray_dent::imprint::ImprintMethod;

/// Errors building a simulation.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// An object cannot be a rigid body as written.
    #[error("`object.{object}`: {message}")]
    Object {
        /// The object.
        object: usize,
        /// What is wrong.
        message: String,
    },
}

/// A contact that started during a step: between objects `a` and `b`,
/// the normal pointing from `a` towards `b`.
#[derive(Debug, Clone, PartialEq)]
pub struct Impact {
    /// The simulated time at the end of the step, seconds.
    pub time: f64,
    /// The step (from 1).
    pub step: u64,
    /// The first object.
    pub a: usize,
    /// The second object.
    pub b: usize,
    /// The contact point (the deepest of the pair's contacts), world.
    pub point: [f64; 3],
    /// The unit contact normal, from `a` towards `b`.
    pub normal: [f64; 3],
    /// How deep the colliders overlapped at the end of the step (≥ 0).
    pub penetration: f64,
    /// The bodies' velocities before the step.
    pub velocities: [[f64; 3]; 2],
    /// Their inverse masses (0 for fixed and kinematic bodies).
    pub inverse_masses: [f64; 2],
    /// |j| of the elastic (ε = 1) impulse from those velocities, N·s.
    pub impulse: f64,
    /// Whether the bodies were closing along the normal (only such impacts dent).
    pub approaching: bool,
}

/// One object's body in the simulation.
struct Body {
    object: usize,
    handle: RigidBodyHandle,
    collider: ColliderHandle,
    kind: BodyKind,
    /// The placement's scale (kept: rapier has none).
    scale: f64,
}

/// The rigid-body simulation of a scene.
pub struct Simulation {
    world: PhysicsWorld,
    bodies: Vec<Body>,
    /// Each collider's index in `bodies`.
    by_collider: std::collections::HashMap<ColliderHandle, usize>,
    /// Pairs of objects in contact after the last step.
    touching: BTreeSet<(usize, usize)>,
    time: f64,
    steps: u64,
}

impl std::fmt::Debug for Simulation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Simulation")
            .field("bodies", &self.bodies.len())
            .field("time", &self.time)
            .field("steps", &self.steps)
            .finish()
    }
}

fn v3(v: [f64; 3]) -> Vector {
    Vector::new(v[0] as f32, v[1] as f32, v[2] as f32)
}

fn arr(v: Vector) -> [f64; 3] {
    [v.x as f64, v.y as f64, v.z as f64]
}

/// The rotation of a placement (degrees about x, then y, then z, world axes).
pub fn rotation_of(deg: [f64; 3]) -> Rotation {
    let r = |d: f64| d.to_radians() as f32;
    Rotation::from_rotation_z(r(deg[2])) * Rotation::from_rotation_y(r(deg[1])) * Rotation::from_rotation_x(r(deg[0]))
}

/// A rotation as degrees about x, then y, then z (world axes): R = Rz·Ry·Rx.
pub fn degrees_of(q: Rotation) -> [f64; 3] {
    let (x, y, z) = (q * Vector::X, q * Vector::Y, q * Vector::Z);
    let (r00, r10, r20, r21, r22) = (x.x as f64, x.y as f64, x.z as f64, y.z as f64, z.z as f64);
    let beta = (-r20).clamp(-1.0, 1.0).asin();
    let (alpha, gamma) = if r20.abs() < 1.0 - 1e-9 {
        (r21.atan2(r22), r10.atan2(r00))
    } else {
        // Gimbal lock: x and z turn about the same axis; put it all in z.
        let (y0, y1) = (y.x as f64, y.y as f64);
        (0.0, (-y0).atan2(y1))
    };
    [alpha.to_degrees(), beta.to_degrees(), gamma.to_degrees()]
}

impl Simulation {
    /// The simulation of `scene`'s bodies, with its `[physics]` settings
    /// (the defaults when it has none).
    pub fn new(scene: &Scene) -> Result<Simulation, SimError> {
        let settings = scene.physics.unwrap_or_default();
        let mut world = PhysicsWorld::new();
        world.gravity = v3(settings.gravity);
        world.integration_parameters.dt = settings.timestep as f32;
        let mut bodies = Vec::new();
        for (i, o) in scene.objects.iter().enumerate() {
            let kind = o.physics.body;
            if kind == BodyKind::None {
                continue;
            }
            let place = scene.placement(i);
            let material = &scene.materials[o.material];
            let builder = match kind {
                BodyKind::Fixed => RigidBodyBuilder::fixed(),
                BodyKind::Dynamic => RigidBodyBuilder::dynamic(),
                _ => RigidBodyBuilder::kinematic_velocity_based(),
            };
            let rb = builder
                .pose(Pose::from_parts(v3(place.position), rotation_of(place.rotation)))
                .linvel(v3(o.physics.velocity))
                .angvel(v3(o.physics.angular_velocity))
                .can_sleep(false)
                .build();
            let handle = world.bodies.insert(rb);
            let collider = collider_of(scene, i, &place, kind)?
                .density(material.density as f32)
                .restitution(material.restitution as f32)
                .restitution_combine_rule(CoefficientCombineRule::Min)
                .friction(0.5)
                .build();
            let collider = world.colliders.insert_with_parent(collider, handle, &mut world.bodies);
            bodies.push(Body {
                object: i,
                handle,
                collider,
                kind,
                scale: place.scale,
            });
        }
        let by_collider = bodies.iter().enumerate().map(|(k, b)| (b.collider, k)).collect();
        Ok(Simulation {
            world,
            bodies,
            by_collider,
            touching: BTreeSet::new(),
            time: 0.0,
            steps: 0,
        })
    }

    /// Seconds simulated so far.
    pub fn time(&self) -> f64 {
        self.time
    }

    /// The fixed step, seconds.
    pub fn timestep(&self) -> f64 {
        self.world.integration_parameters.dt as f64
    }

    /// The objects that are bodies.
    pub fn objects(&self) -> Vec<usize> {
        self.bodies.iter().map(|b| b.object).collect()
    }

    /// Object `object`'s mass (kg; infinite for fixed and kinematic bodies).
    pub fn mass(&self, object: usize) -> Option<f64> {
        let b = self.bodies.iter().find(|b| b.object == object)?;
        let rb = &self.world.bodies[b.handle];
        Some(if rb.is_dynamic() {
            rb.mass() as f64
        } else {
            f64::INFINITY
        })
    }

    /// Advances one step; returns the contacts that started in it, sorted
    /// by their objects.
    pub fn step(&mut self) -> Vec<Impact> {
        let before: Vec<([f64; 3], f64)> = self
            .bodies
            .iter()
            .map(|b| {
                let rb = &self.world.bodies[b.handle];
                let inv = if rb.is_dynamic() { 1.0 / rb.mass() as f64 } else { 0.0 };
                (arr(rb.linvel()), inv)
            })
            .collect();
        self.world.step();
        self.steps += 1;
        self.time = self.steps as f64 * self.timestep();
        let index_of = |h: ColliderHandle| self.by_collider.get(&h).copied();
        let mut now = BTreeSet::new();
        let mut impacts = Vec::new();
        for pair in self.world.narrow_phase.contact_pairs() {
            // Touching: the solver pushed the pair apart in this step (a
            // speculative contact ahead of the bodies applies nothing).
            if pair.total_impulse_magnitude() <= 0.0 {
                continue;
            }
            let (Some(k1), Some(k2)) = (index_of(pair.collider1), index_of(pair.collider2)) else {
                continue;
            };
            let (o1, o2) = (self.bodies[k1].object, self.bodies[k2].object);
            let key = (o1.min(o2), o1.max(o2));
            now.insert(key);
            if self.touching.contains(&key) {
                continue;
            }
            let Some((manifold, contact)) = pair.find_deepest_contact() else {
                continue;
            };
            let pose1 = self.world.colliders[pair.collider1].position();
            let point = arr(pose1.transform_point(contact.local_p1));
            let mut normal = arr(manifold.data.normal);
            let (mut a, mut b) = (k1, k2);
            // Report with a < b (by object), the normal from a to b.
            if o1 > o2 {
                std::mem::swap(&mut a, &mut b);
                normal = normal.map(|c| -c);
            }
            let (va, ia) = before[a];
            let (vb, ib) = before[b];
            let j = isoray_dent::impulse::elastic_impulse(normal, va, vb, ia, ib);
            impacts.push(Impact {
                time: self.time,
                step: self.steps,
                a: self.bodies[a].object,
                b: self.bodies[b].object,
                point,
                normal,
                penetration: (-contact.dist as f64).max(0.0),
                velocities: [va, vb],
                inverse_masses: [ia, ib],
                impulse: (j[0] * j[0] + j[1] * j[1] + j[2] * j[2]).sqrt(),
                approaching: isoray_dent::impulse::approaching(normal, va, vb),
            });
        }
        self.touching = now;
        impacts.sort_by_key(|i| (i.a, i.b));
        impacts
    }

    /// The bodies' current placements (moving bodies only: fixed ones
    /// never move).
    pub fn placements(&self) -> Vec<(usize, Placement)> {
        self.bodies
            .iter()
            .filter(|b| b.kind != BodyKind::Fixed)
            .map(|b| {
                let rb = &self.world.bodies[b.handle];
                (
                    b.object,
                    Placement {
                        position: arr(rb.translation()),
                        rotation: degrees_of(*rb.rotation()),
                        scale: b.scale,
                    },
                )
            })
            .collect()
    }

    /// Moves the scene's moving objects to their bodies' placements.
    pub fn place(&self, scene: &mut Scene) -> Result<(), isoray_scene::SceneError> {
        for (i, p) in self.placements() {
            scene.set_placement(i, p)?;
        }
        Ok(())
    }
}

/// The collider of object `i` in its body's frame.
fn collider_of(scene: &Scene, i: usize, place: &Placement, kind: BodyKind) -> Result<ColliderBuilder, SimError> {
    let o = &scene.objects[i];
    let err = |message: String| SimError::Object { object: i, message };
    if o.physics.collider == Collider::Auto {
        match isoray_scene::analytic::Analytic::recognise(&o.shape, &scene.inputs) {
            Some(isoray_scene::analytic::Analytic::Sphere { c, r }) => {
                let local = place.to_local(c);
                return Ok(ColliderBuilder::ball(r as f32).translation(v3(local.map(|x| x * place.scale))));
            }
            Some(isoray_scene::analytic::Analytic::Plane { n, h }) => {
                if kind != BodyKind::Fixed {
                    return Err(err("an unbounded plane can only be a `fixed` body".into()));
                }
                let nl = place.dir_to_local(n);
                // The plane's point nearest the origin, in the body's frame.
                let p = place
                    .to_local([-h * n[0], -h * n[1], -h * n[2]])
                    .map(|x| x * place.scale);
                return Ok(ColliderBuilder::new(SharedShape::halfspace(v3(nl))).translation(v3(p)));
            }
            None => {}
        }
    }
    // The object's mesh, in its own frame (scaled: rapier bodies have no
    // scale): a parametric dent map's sheet is its sampled (s, t) grid (a
    // sheet's field has no inside to mesh), anything else is meshed.
    let mesh = match &o.physics.dent_map.parametric {
        Some(m) if o.physics.dent_map.uv == "parametric" => {
            let (n, pts) = m.grid();
            let at = |i: usize, j: usize| (j * n + i) as u32;
            let mut triangles = Vec::with_capacity(2 * (n - 1) * (n - 1));
            for j in 0..n - 1 {
                for i in 0..n - 1 {
                    triangles.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
                    triangles.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
                }
            }
            // The grid is in the object's own coordinates: to the world first.
            let positions = pts.iter().map(|q| place.to_world(*q).map(|x| x as f32)).collect();
            isoray_mesh::Mesh {
                positions,
                triangles,
                ..Default::default()
            }
        }
        _ => {
            let tape = o.shape.tape().bind(&scene.inputs);
            let settings = isoray_mesh::MeshSettings {
                resolution: 48,
                ..Default::default()
            };
            isoray_mesh::mesh_shape(&tape, &settings)
                .map_err(|e| err(format!("cannot mesh it for its collider: {e}")))?
                .0
        }
    };
    let points: Vec<Vector> = mesh
        .positions
        .iter()
        .map(|p| {
            let q = place.to_local([p[0] as f64, p[1] as f64, p[2] as f64]);
            v3(q.map(|x| x * place.scale))
        })
        .collect();
    let moving = kind != BodyKind::Fixed;
    if moving || o.physics.collider == Collider::Hull {
        ColliderBuilder::convex_hull(&points)
            .ok_or_else(|| err("its mesh has no convex hull (is it flat or empty?)".into()))
    } else {
        ColliderBuilder::trimesh(points, mesh.triangles.clone()).map_err(|e| err(format!("its mesh: {e}")))
    }
}
