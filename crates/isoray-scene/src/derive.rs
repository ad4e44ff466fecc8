//! What renderers trace, derived from the objects: the scene's distance
//! (their union), the unsigned distance rays inside objects march, the
//! fields shadow rays trace past transparent objects, the closed forms of
//! planes and spheres and the union of the other objects.
//!
//! Everything here is a function of the objects' compiled fragments, their
//! materials, the render settings and the current inputs; [`assemble`] is
//! the one place it is computed, at load and whenever the inputs change
//! which objects are closed forms. Nothing outside this crate can set it,
//! so it cannot drift from the objects.

use isoray_shape::{Builder, Node, Shape};

use crate::analytic::Analytic;
use crate::model::{Material, Object, RenderSettings, ShadowShapes, View};

/// The distance of empty space: every ray misses.
pub(crate) const EMPTY: f64 = 1e9;

/// Data the renderers derive from the objects (see the module docs).
#[derive(Debug, Clone)]
pub struct Derived {
    /// The unsigned distance to the nearest object surface, min over objects
    /// of |dᵢ|: what rays travelling inside objects (refraction) trace.
    pub surfaces: Shape,
    /// When some object is transparent, what shadow rays trace: None when
    /// every object is opaque (shadow rays then trace the scene's shape).
    pub shadow: Option<ShadowShapes>,
    /// Per object, its closed form when it is exactly a plane or a sphere
    /// (recognised only when [`analytic_allowed`]).
    pub analytic: Vec<Option<Analytic>>,
    /// When some object is analytic: the union of the others, which rays
    /// outside objects march while the analytic ones are intersected.
    pub rest: Option<Shape>,
}

/// Whether closed forms are used with these settings: not with a smooth
/// union (`blend` > 0), not in the steps view, and not when turned off.
pub fn analytic_allowed(render: &RenderSettings) -> bool {
    render.blend == 0.0 && render.analytic && render.view != View::Steps
}

/// Builds the scene's graph from the objects' fragments: sets each
/// object's `shape`, and returns the scene's distance (the union, or the
/// smooth union with k = `render.blend`, folded in file order) and the
/// derived data at the inputs `inputs`.
pub(crate) fn assemble(
    objects: &mut [Object],
    materials: &[Material],
    render: &RenderSettings,
    inputs: &[f64],
) -> (Shape, Derived) {
    let mut builder = Builder::new();
    let nodes: Vec<Node> = objects
        .iter_mut()
        .map(|o| {
            let first = o.transform.as_ref().map(|t| t.inputs);
            let node = o.fragment.import(&mut builder, first);
            o.shape = o.fragment.shape(first, || Shape::from_tape(builder.tape(node)));
            node
        })
        .collect();
    let acc = match nodes.split_first() {
        None => builder.constant(EMPTY),
        Some((&first, rest)) => rest
            .iter()
            .fold(first, |acc, &n| builder.smooth_union(acc, n, render.blend)),
    };
    let shape = Shape::from_tape(builder.tape(acc));
    let u = match nodes.split_first() {
        None => builder.constant(EMPTY),
        Some((&first, rest)) => {
            let a0 = builder.abs(first);
            rest.iter().fold(a0, |u, &n| {
                let a = builder.abs(n);
                builder.min(u, a)
            })
        }
    };
    let surfaces = Shape::from_tape(builder.tape(u));
    // Planes and spheres are intersected in closed form; the rest is marched.
    let analytic: Vec<Option<Analytic>> = if analytic_allowed(render) {
        objects.iter().map(|o| o.closed_form(inputs)).collect()
    } else {
        vec![None; objects.len()]
    };
    // Shadows with transparent objects: opaque objects occlude (with the
    // penumbra estimate), transparent ones transmit (traced separately).
    let clear: Vec<bool> = objects
        .iter()
        .map(|o| materials[o.material].transparency > 0.0)
        .collect();
    let shadow = if clear.iter().any(|&c| c) {
        let pick = |b: &mut Builder, want: bool, unsigned: bool| {
            let mut acc: Option<Node> = None;
            for (&n, &c) in nodes.iter().zip(&clear) {
                if c != want {
                    continue;
                }
                let n = if unsigned { b.abs(n) } else { n };
                acc = Some(match acc {
                    None => n,
                    Some(a) if unsigned => b.min(a, n),
                    Some(a) => b.smooth_union(a, n, render.blend),
                });
            }
            acc.unwrap_or_else(|| b.constant(EMPTY))
        };
        let opaque = pick(&mut builder, false, false);
        let clear_union = pick(&mut builder, true, false);
        let clear_surfaces = pick(&mut builder, true, true);
        // The opaque objects not in closed form (analytic objects are
        // never blended: `analytic_allowed`).
        let closed = |k: usize| analytic[k].is_some();
        let opaque_rest = (0..nodes.len()).any(|k| !clear[k] && closed(k)).then(|| {
            let rest = (0..nodes.len())
                .filter(|&k| !clear[k] && !closed(k))
                .map(|k| nodes[k])
                .reduce(|a, n| builder.min(a, n))
                .unwrap_or_else(|| builder.constant(EMPTY));
            Shape::from_tape(builder.tape(rest))
        });
        Some(ShadowShapes {
            opaque: Shape::from_tape(builder.tape(opaque)),
            transparent: Shape::from_tape(builder.tape(clear_union)),
            transparent_surfaces: Shape::from_tape(builder.tape(clear_surfaces)),
            opaque_rest,
        })
    } else {
        None
    };
    let rest = if analytic.iter().any(Option::is_some) {
        let mut acc: Option<Node> = None;
        for (&n, a) in nodes.iter().zip(&analytic) {
            if a.is_none() {
                acc = Some(match acc {
                    None => n,
                    Some(x) => builder.min(x, n),
                });
            }
        }
        let root = acc.unwrap_or_else(|| builder.constant(EMPTY));
        Some(Shape::from_tape(builder.tape(root)))
    } else {
        None
    };
    (
        shape,
        Derived {
            surfaces,
            shadow,
            analytic,
            rest,
        },
    )
}
