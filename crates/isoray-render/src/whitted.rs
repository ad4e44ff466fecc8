//! Recursive (Whitted-style) ray tracing as wavefronts: the hits of one
//! generation of rays are shaded together, and the reflected and refracted
//! rays they spawn form the next generation, traced again in packets.
//!
//! Each ray carries the sample it contributes to, its weight (the product of
//! the reflectances and transmittances along its path) and the stack of
//! objects it is inside. Rays outside every object trace the scene's
//! distance; rays inside objects trace the unsigned distance to the nearest
//! surface, so they find the far side of the object they travel through, or
//! an object nested in it. Inside an absorbing object, the weight falls by
//! Beer–Lambert, exp(−σ·length).

use glam::Vec3;
use isoray_shade::lights::hash;
use isoray_shade::optics::{beer_lambert, interface, reflect};
use isoray_shade::{to_vec3, MaterialSample};

use crate::trace::{sphere_trace_capped, Hit, Rays};
use crate::{Ctx, HitSet, Worker};

/// The fields shadow rays trace when some object is transparent.
pub(crate) struct ShadowEvals<'s> {
    /// The union of the opaque objects (occluders).
    pub(crate) opaque: crate::trace::Field<'s>,
    /// The union of the transparent objects.
    pub(crate) clear: crate::trace::Field<'s>,
    /// The unsigned distance to the nearest transparent surface.
    pub(crate) clear_surfaces: crate::trace::Field<'s>,
    /// The opaque objects not in closed form, when some are.
    pub(crate) opaque_rest: Option<crate::trace::Field<'s>>,
}

/// Interfaces a shadow ray crosses at most (it keeps its transmission after).
const MAX_SHADOW_SEGMENTS: usize = 8;

/// The objects a ray is inside, innermost last.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct Media {
    objs: [u16; 6],
    len: u8,
}

impl Media {
    fn top(&self) -> Option<usize> {
        (self.len > 0).then(|| self.objs[self.len as usize - 1] as usize)
    }
    fn contains(&self, o: usize) -> bool {
        self.objs[..self.len as usize].iter().any(|&x| x as usize == o)
    }
    fn push(&mut self, o: usize) {
        if (self.len as usize) < self.objs.len() {
            self.objs[self.len as usize] = o as u16;
            self.len += 1;
        }
    }
    fn remove(&mut self, o: usize) {
        if let Some(i) = self.objs[..self.len as usize].iter().rposition(|&x| x as usize == o) {
            self.objs.copy_within(i + 1..self.len as usize, i);
            self.len -= 1;
        }
    }
    pub(crate) fn is_inside(&self) -> bool {
        self.len > 0
    }
}

/// One packet of rays of a generation, with their path state.
#[derive(Default)]
struct Packet {
    rays: Rays,
    sample: Vec<u32>,
    weight: Vec<Vec3>,
    media: Vec<Media>,
    /// The surface point each ray left (its origin is offset from it).
    from: Vec<Vec3>,
}

impl Packet {
    fn push(&mut self, o: Vec3, d: Vec3, sample: u32, weight: Vec3, media: Media, from: Vec3) {
        self.rays.push(o.to_array(), d.to_array());
        self.sample.push(sample);
        self.weight.push(weight);
        self.media.push(media);
        self.from.push(from);
    }
}

/// Secondary rays start this many hit epsilons off the surface, on the side
/// they travel into, so they do not find their own surface again.
const OFFSET: f32 = 10.0;

/// Shadow rays through transparent objects step past an interface by
/// OFFSET hit epsilons over the cosine of their angle with its normal, this
/// cosine at least (at most 20 times the plain step).
const MIN_COS: f32 = 0.05;

/// [`Worker::transmission`] when every transparent object is a plane or
/// a sphere (`closed`): each ray's crossings of their surfaces before
/// `tmax`, in order, toggle the objects it is inside, and each stretch
/// inside absorbs over its exact length (a grazing ray's short chord
/// included).
fn transmission_closed(
    ctx: &Ctx,
    closed: &[(usize, isoray_scene::analytic::Analytic)],
    o: &[Vec3],
    l: &[Vec3],
    tmax: &[f32],
    start: &[Media],
) -> Vec<Vec3> {
    let mut crossings: Vec<(f32, usize)> = Vec::new();
    let absorb = |media: &Media, length: f32| match media.top() {
        Some(top) => beer_lambert(ctx.surfaces[top].absorption, length),
        None => Vec3::ONE,
    };
    (0..o.len())
        .map(|r| {
            crossings.clear();
            for &(obj, a) in closed {
                for t in a.intersect(o[r].to_array(), l[r].to_array()) {
                    if t > 0.0 && t < tmax[r] {
                        crossings.push((t, obj));
                    }
                }
            }
            crossings.sort_by(|x, y| x.0.total_cmp(&y.0));
            let (mut out, mut media, mut at) = (Vec3::ONE, start[r], 0.0);
            for &(t, obj) in &crossings {
                out *= absorb(&media, t - at);
                if media.contains(obj) {
                    media.remove(obj);
                } else {
                    out *= ctx.surfaces[obj].interface_transmittance();
                    media.push(obj);
                }
                at = t;
                if out.max_element() <= 1e-4 {
                    return out;
                }
            }
            // Inside up to the light: absorb the rest.
            out * absorb(&media, (tmax[r] - at).min(1e4))
        })
        .collect()
}

impl Worker<'_> {
    /// Shades the primary hits `hs` of `self.rays` and follows reflected and
    /// refracted rays to `render.max_depth`, accumulating into `samples`.
    /// Returns the evaluations spent.
    pub(crate) fn trace_paths(&mut self, ctx: &Ctx, hs: HitSet, samples: &mut [Vec3]) -> u64 {
        let s = &ctx.scene.render;
        let background = to_vec3(s.background);
        let n = self.rays.len();
        samples.iter_mut().for_each(|x| *x = Vec3::ZERO);
        let mut evals = 0;
        let primary = Packet {
            rays: std::mem::take(&mut self.rays),
            sample: (0..n as u32).collect(),
            weight: vec![Vec3::ONE; n],
            media: vec![Media::default(); n],
            from: Vec::new(),
        };
        let mut generation = vec![(primary, Some(hs))];
        let eps = s.hit_epsilon as f32;
        for depth in 0..=s.max_depth {
            let mut next_out = Packet::default();
            let mut next_in = Packet::default();
            for (mut packet, traced) in generation.drain(..) {
                if packet.sample.is_empty() {
                    continue;
                }
                let inside = packet.media[0].is_inside();
                self.rays = std::mem::take(&mut packet.rays);
                let mut hs = match traced {
                    Some(hs) => hs,
                    None => {
                        let (hs, e) = self.trace_and_normals(ctx, inside);
                        evals += e;
                        hs
                    }
                };
                // Beer–Lambert over the segment just travelled inside an object,
                // from the surface point the ray left to the one it reached.
                let (surfaces, objects) = self.materials(ctx, &hs, &mut evals, inside);
                // Dented objects' normals tilted by their normal maps.
                crate::dents::perturb(ctx.scene, &mut hs, &objects, &self.rays);
                if inside {
                    for (k, &i) in hs.idx.iter().enumerate() {
                        if let Some(o) = packet.media[i].top() {
                            let sigma = ctx.surfaces[o].absorption;
                            let length = (Vec3::new(hs.px[k], hs.py[k], hs.pz[k]) - packet.from[i]).length();
                            packet.weight[i] *= beer_lambert(sigma, length);
                        }
                    }
                }
                // Misses see the background (a ray lost inside an object sees nothing).
                let mut hit = vec![false; self.rays.len()];
                for &i in &hs.idx {
                    hit[i] = true;
                }
                for (i, h) in hit.iter().enumerate() {
                    if !h && !packet.media[i].is_inside() {
                        let sky = match &ctx.scene.environment {
                            Some(env) => Vec3::from(env.radiance([self.rays.dx[i], self.rays.dy[i], self.rays.dz[i]])),
                            None => background,
                        };
                        samples[packet.sample[i] as usize] += packet.weight[i] * sky;
                    }
                }
                // The Fresnel split at each hit, and the rays it spawns.
                let m = hs.idx.len();
                let touching = self.touching(ctx, &hs, &objects, &mut evals);
                let mut local = vec![Vec3::ONE; m];
                for k in 0..m {
                    let i = hs.idx[k];
                    let surf: &MaterialSample = &surfaces[k];
                    if !surf.is_optical() {
                        continue;
                    }
                    let d = Vec3::new(self.rays.dx[i], self.rays.dy[i], self.rays.dz[i]);
                    let nrm = Vec3::new(hs.nx[k], hs.ny[k], hs.nz[k]);
                    let p = Vec3::new(hs.px[k], hs.py[k], hs.pz[k]);
                    let media = packet.media[i];
                    let n1 = media.top().map_or(1.0, |t| ctx.surfaces[t].ior);
                    // Every object whose surface is here (touching objects
                    // share it): leave those the ray is in, enter the others.
                    let mut after = media;
                    for &o in touching[k].iter() {
                        if after.contains(o) {
                            after.remove(o);
                        } else {
                            after.push(o);
                        }
                    }
                    let n2 = after.top().map_or(1.0, |t| ctx.surfaces[t].ior);
                    let at = interface(surf, d, nrm, -nrm.dot(d), n1, n2);
                    let (sp, transmitted) = (at.split, at.refracted);
                    local[k] = sp.local;
                    if depth == s.max_depth {
                        continue;
                    }
                    let w = packet.weight[i];
                    let off = OFFSET * eps;
                    let wr = w * sp.reflect;
                    if wr.max_element() >= s.min_weight as f32 {
                        let target = if media.is_inside() { &mut next_in } else { &mut next_out };
                        target.push(p + nrm * off, reflect(d, nrm), packet.sample[i], wr, media, p);
                        self.counts.reflected += 1;
                    }
                    if let Some(t) = transmitted {
                        let wt = w * sp.transmit;
                        if wt.max_element() >= s.min_weight as f32 {
                            let target = if after.is_inside() { &mut next_in } else { &mut next_out };
                            target.push(p - nrm * off, t, packet.sample[i], wt, after, p);
                            self.counts.refracted += 1;
                        }
                    }
                }
                let hit_media: Vec<Media> = hs.idx.iter().map(|&i| packet.media[i]).collect();
                let (tx, ty) = self.tile_origin;
                let seeds: Vec<u32> = hs
                    .idx
                    .iter()
                    .map(|&i| hash(hash(hash(tx) ^ ty) ^ packet.sample[i]).wrapping_add(depth))
                    .collect();
                let colors = self.shade(ctx, &hs, &surfaces, &local, &hit_media, &seeds, &mut evals);
                for (k, &i) in hs.idx.iter().enumerate() {
                    samples[packet.sample[i] as usize] += packet.weight[i] * colors[k];
                }
            }
            generation.push((next_out, None));
            generation.push((next_in, None));
        }
        evals
    }

    /// The colour transmitted along straight shadow rays (o + t·l, t < tmax)
    /// through the transparent objects: each interface multiplies by the
    /// object's transparency × (1 − reflectivity), each stretch inside by
    /// exp(−absorption × length). `start` holds the transparent objects each
    /// ray starts inside. Refraction is not followed (no caustics).
    pub(crate) fn transmission(
        &mut self,
        ctx: &Ctx,
        o: &[Vec3],
        l: &[Vec3],
        tmax: &[f32],
        start: &[Media],
    ) -> (Vec<Vec3>, u64) {
        if let Some(closed) = &ctx.clear_closed {
            return (transmission_closed(ctx, closed, o, l, tmax, start), 0);
        }
        let s = &ctx.scene.render;
        let off = OFFSET * s.hit_epsilon as f32;
        let n = o.len();
        let mut out = vec![Vec3::ONE; n];
        let mut origin = o.to_vec();
        let mut left = tmax.to_vec();
        let mut media = start.to_vec();
        // The step each ray took past its last interface (absorbed over
        // too: its segment began that far before the traced origin).
        let mut step = vec![off; n];
        let mut active: Vec<usize> = (0..n).collect();
        let mut evals = 0;
        let clear_of = |obj: usize| ctx.surfaces[obj].interface_transmittance();
        for _ in 0..MAX_SHADOW_SEGMENTS {
            if active.is_empty() {
                break;
            }
            let mut still = Vec::new();
            for inside in [false, true] {
                let group: Vec<usize> = active
                    .iter()
                    .copied()
                    .filter(|&i| media[i].is_inside() == inside)
                    .collect();
                if group.is_empty() {
                    continue;
                }
                let Some(mut found) = self.next_interfaces(ctx, inside, &group, &origin, l, &left, &mut evals) else {
                    break;
                };
                if inside {
                    // A ray the step carried out of every transparent object
                    // (a grazing chord shorter than the step) left the one it
                    // is in within the step.
                    let left_within = self.outside_all(&group, &origin, &mut evals);
                    for (r, &i) in group.iter().enumerate() {
                        if let (true, Some(top)) = (left_within[r], media[i].top()) {
                            found[r] = Some((0.0, top));
                        }
                    }
                }
                let crossing: Vec<Vec3> = group
                    .iter()
                    .zip(&found)
                    .filter_map(|(&i, hit)| hit.map(|(t, _)| origin[i] + l[i] * t))
                    .collect();
                let normals = self.clear_normals(ctx, &crossing, &mut evals);
                let mut k = 0;
                for (&i, hit) in group.iter().zip(found) {
                    let Some((t, obj)) = hit else {
                        // No further interface before the light (inside: absorb the rest).
                        if let Some(top) = media[i].top() {
                            out[i] *= beer_lambert(ctx.surfaces[top].absorption, left[i].min(1e4));
                        }
                        continue;
                    };
                    if let Some(top) = media[i].top() {
                        out[i] *= beer_lambert(ctx.surfaces[top].absorption, t + step[i]);
                    }
                    if media[i].contains(obj) {
                        media[i].remove(obj);
                    } else {
                        out[i] *= clear_of(obj);
                        media[i].push(obj);
                    }
                    // Past the interface by OFFSET hit epsilons of depth, not
                    // of length along the ray: at a grazing angle a fixed
                    // length leaves the ray within the hit epsilon of the
                    // surface it crossed, which it then finds again at once.
                    let cos = normals[k].dot(l[i]).abs();
                    k += 1;
                    step[i] = off / cos.max(MIN_COS);
                    origin[i] = (origin[i] + l[i] * t) + l[i] * step[i];
                    left[i] -= t + step[i];
                    if out[i].max_element() > 1e-4 && left[i] > 0.0 {
                        still.push(i);
                    }
                }
            }
            active = still;
        }
        // Rays still crossing interfaces after the last segment (grazing a
        // surface, in and out within the offset) keep what they have.
        (out, evals)
    }

    /// Per ray `group[r]`: whether its origin lies outside every
    /// transparent object (the union of them positive there).
    fn outside_all(&mut self, group: &[usize], origin: &[Vec3], evals: &mut u64) -> Vec<bool> {
        let Some(se) = self.shadow_evals.as_mut() else {
            return vec![false; group.len()];
        };
        let xs: Vec<f32> = group.iter().map(|&i| origin[i].x).collect();
        let ys: Vec<f32> = group.iter().map(|&i| origin[i].y).collect();
        let zs: Vec<f32> = group.iter().map(|&i| origin[i].z).collect();
        let mut d = vec![0.0f32; group.len()];
        se.clear.eval(&xs, &ys, &zs, &mut d);
        *evals += group.len() as u64;
        d.into_iter().map(|d| d > 0.0).collect()
    }

    /// Unit normals of the transparent objects' union at the points (by
    /// the scene's gradient stencil; zero where the gradient vanishes).
    fn clear_normals(&mut self, ctx: &Ctx, pts: &[Vec3], evals: &mut u64) -> Vec<Vec3> {
        let m = pts.len();
        let Some(se) = self.shadow_evals.as_mut().filter(|_| m > 0) else {
            return vec![Vec3::Y; m];
        };
        let xs: Vec<f32> = pts.iter().map(|p| p.x).collect();
        let ys: Vec<f32> = pts.iter().map(|p| p.y).collect();
        let zs: Vec<f32> = pts.iter().map(|p| p.z).collect();
        let (mut gx, mut gy, mut gz) = (vec![0.0f32; m], vec![0.0f32; m], vec![0.0f32; m]);
        se.clear
            .gradients(&xs, &ys, &zs, ctx.gradient, &mut gx, &mut gy, &mut gz);
        *evals += (m * 4) as u64;
        (0..m)
            .map(|q| Vec3::new(gx[q], gy[q], gz[q]).normalize_or_zero())
            .collect()
    }

    /// The next transparent interface along each ray `group[r]` (from
    /// `origin[i]` along `l[i]`, before `left[i]`): its distance and
    /// object, None where there is none. Marched: outside objects the
    /// union of the transparent ones, no further than the box their
    /// surface lies in; inside, the distance to the nearest transparent
    /// surface; the object is the one whose surface is nearest the hit.
    /// None when there are no shadow fields.
    #[allow(clippy::too_many_arguments)]
    fn next_interfaces(
        &mut self,
        ctx: &Ctx,
        inside: bool,
        group: &[usize],
        origin: &[Vec3],
        l: &[Vec3],
        left: &[f32],
        evals: &mut u64,
    ) -> Option<Vec<Option<(f32, usize)>>> {
        let s = &ctx.scene.render;
        let mut rays = Rays::default();
        for &i in group {
            rays.push(origin[i].to_array(), l[i].to_array());
        }
        // No interface counts beyond the light: marching stops there (and,
        // outside the objects, once the ray leaves the box their surface
        // lies in).
        let far: Vec<f32> = group
            .iter()
            .enumerate()
            .map(|(r, &i)| match (&ctx.clear_reach, inside) {
                (Some(reach), false) => left[i].min(reach.far(rays.origin(r), rays.direction(r), left[i])),
                _ => left[i],
            })
            .collect();
        let se = self.shadow_evals.as_mut()?;
        let ev = if inside { &mut se.clear_surfaces } else { &mut se.clear };
        let mut hits: Vec<Hit> = Vec::new();
        *evals += sphere_trace_capped(ev, &rays, s, &mut self.scratch, &mut hits, None, Some(&far));
        let pts: Vec<(usize, Vec3, f32)> = group
            .iter()
            .zip(&hits)
            .filter(|(&i, h)| h.t < left[i])
            .map(|(&i, h)| (i, origin[i] + l[i] * h.t, h.t))
            .collect();
        let objs = self.nearest_objects(ctx, &pts, evals);
        let mut found = vec![None; group.len()];
        let mut k = 0;
        for (r, &i) in group.iter().enumerate() {
            if hits[r].t < left[i] {
                found[r] = Some((pts[k].2, objs[k]));
                k += 1;
            }
        }
        Some(found)
    }

    /// The object whose surface is nearest each point (|d| smallest).
    fn nearest_objects(&mut self, ctx: &Ctx, pts: &[(usize, Vec3, f32)], evals: &mut u64) -> Vec<usize> {
        let m = pts.len();
        let Some(objects) = self.objects.as_mut().filter(|_| m > 0) else {
            return vec![0; m];
        };
        let xs: Vec<f32> = pts.iter().map(|p| p.1.x).collect();
        let ys: Vec<f32> = pts.iter().map(|p| p.1.y).collect();
        let zs: Vec<f32> = pts.iter().map(|p| p.1.z).collect();
        let mut best = vec![(f32::INFINITY, 0usize); m];
        let mut d = vec![0.0f32; m];
        for j in 0..objects.len() {
            if ctx.surfaces[j].transparency <= 0.0 {
                continue;
            }
            objects.field(j).eval(&xs, &ys, &zs, &mut d);
            *evals += m as u64;
            for q in 0..m {
                if d[q].abs() < best[q].0 {
                    best[q] = (d[q].abs(), j);
                }
            }
        }
        best.into_iter().map(|b| b.1).collect()
    }

    /// For each hit, the objects whose surface passes within a few hit
    /// epsilons of it (the nearest always included): touching objects share
    /// an interface, which a ray crosses out of one and into the other at once.
    fn touching(&mut self, ctx: &Ctx, hs: &HitSet, nearest: &[usize], evals: &mut u64) -> Vec<Vec<usize>> {
        let m = hs.idx.len();
        let mut out: Vec<Vec<usize>> = nearest.iter().map(|&o| vec![o]).collect();
        // Only transparent objects can share an interface a ray crosses.
        let clear = ctx.surfaces.iter().filter(|s| s.transparency > 0.0).count();
        let Some(objects) = self.objects.as_mut().filter(|_| clear >= 2 && m > 0) else {
            return out;
        };
        let near = 4.0 * OFFSET * ctx.scene.render.hit_epsilon as f32;
        let mut d = vec![0.0f32; m];
        for j in 0..objects.len() {
            if ctx.surfaces[j].transparency <= 0.0 {
                continue; // only transparent objects are entered
            }
            objects.field(j).eval(&hs.px, &hs.py, &hs.pz, &mut d);
            *evals += m as u64;
            for q in 0..m {
                if d[q].abs() < near && !out[q].contains(&j) {
                    out[q].push(j);
                }
            }
        }
        out
    }
}
