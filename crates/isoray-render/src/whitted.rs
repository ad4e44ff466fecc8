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

use crate::optics::{fresnel, reflect, refract, split};
use crate::shade::Surface;
use crate::trace::Rays;
use crate::{Ctx, HitSet, Worker};

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
    fn is_inside(&self) -> bool {
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
}

impl Packet {
    fn push(&mut self, o: Vec3, d: Vec3, sample: u32, weight: Vec3, media: Media) {
        self.rays.push(o.to_array(), d.to_array());
        self.sample.push(sample);
        self.weight.push(weight);
        self.media.push(media);
    }
}

/// Secondary rays start this many hit epsilons off the surface, on the side
/// they travel into, so they do not find their own surface again.
const OFFSET: f32 = 10.0;

impl Worker<'_> {
    /// Shades the primary hits `hs` of `self.rays` and follows reflected and
    /// refracted rays to `render.max_depth`, accumulating into `samples`.
    /// Returns the evaluations spent.
    pub(crate) fn trace_paths(&mut self, ctx: &Ctx, hs: HitSet, samples: &mut [Vec3]) -> u64 {
        let s = &ctx.scene.render;
        let background = Vec3::from(s.background.map(|c| c as f32));
        let n = self.rays.len();
        samples.iter_mut().for_each(|x| *x = Vec3::ZERO);
        let mut evals = 0;
        let primary = Packet {
            rays: std::mem::take(&mut self.rays),
            sample: (0..n as u32).collect(),
            weight: vec![Vec3::ONE; n],
            media: vec![Media::default(); n],
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
                let hs = match traced {
                    Some(hs) => hs,
                    None => {
                        let (hs, e) = self.trace_and_normals(ctx, inside);
                        evals += e;
                        hs
                    }
                };
                // Beer–Lambert over the segment just travelled inside an object.
                let (surfaces, objects) = self.materials(ctx, &hs, &mut evals, inside);
                if inside {
                    for &i in &hs.idx {
                        if let Some(o) = packet.media[i].top() {
                            let sigma = ctx.surfaces[o].absorption;
                            packet.weight[i] *= (-sigma * self.hits[i].t).exp();
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
                        samples[packet.sample[i] as usize] += packet.weight[i] * background;
                    }
                }
                // The Fresnel split at each hit, and the rays it spawns.
                let m = hs.idx.len();
                let mut local = vec![Vec3::ONE; m];
                for k in 0..m {
                    let i = hs.idx[k];
                    let surf: &Surface = &surfaces[k];
                    if !surf.is_optical() {
                        continue;
                    }
                    let d = Vec3::new(self.rays.dx[i], self.rays.dy[i], self.rays.dz[i]);
                    let nrm = Vec3::new(hs.nx[k], hs.ny[k], hs.nz[k]);
                    let p = Vec3::new(hs.px[k], hs.py[k], hs.pz[k]);
                    let media = packet.media[i];
                    let o = objects[k];
                    let n1 = media.top().map_or(1.0, |t| ctx.surfaces[t].ior);
                    let mut after = media;
                    let n2 = if media.contains(o) {
                        after.remove(o);
                        after.top().map_or(1.0, |t| ctx.surfaces[t].ior)
                    } else {
                        after.push(o);
                        surf.ior
                    };
                    let cos1 = -nrm.dot(d);
                    let transmitted = if surf.transparency > 0.0 {
                        refract(d, nrm, n1 / n2)
                    } else {
                        None
                    };
                    let f = fresnel(surf.fresnel, cos1, n1, n2);
                    let sp = split(
                        surf.reflectivity,
                        surf.transparency,
                        f,
                        surf.transparency > 0.0 && transmitted.is_none(),
                    );
                    local[k] = sp.local;
                    if depth == s.max_depth {
                        continue;
                    }
                    let w = packet.weight[i];
                    let off = OFFSET * eps;
                    let wr = w * sp.reflect;
                    if wr.max_element() >= s.min_weight as f32 {
                        let target = if media.is_inside() { &mut next_in } else { &mut next_out };
                        target.push(p + nrm * off, reflect(d, nrm), packet.sample[i], wr, media);
                    }
                    if let Some(t) = transmitted {
                        let wt = w * sp.transmit;
                        if wt.max_element() >= s.min_weight as f32 {
                            let target = if after.is_inside() { &mut next_in } else { &mut next_out };
                            target.push(p - nrm * off, t, packet.sample[i], wt, after);
                        }
                    }
                }
                let colors = self.shade(ctx, &hs, &surfaces, &local, &mut evals);
                for (k, &i) in hs.idx.iter().enumerate() {
                    samples[packet.sample[i] as usize] += packet.weight[i] * colors[k];
                }
            }
            generation.push((next_out, None));
            generation.push((next_in, None));
        }
        evals
    }
}
