//! Fold cells: which objects can change each field's fold where, so that
//! the tracer evaluates those alone (the CPU's object-level cells,
//! [`isoray_shape::fold`], made ahead of the frame instead of as points
//! arrive).
//!
//! The scene's distance is the fold, in file order, of its objects'
//! distances by smooth union of width `render.blend` (`min` at 0); so is
//! each field the tracer marches (all objects; those not in closed form;
//! the opaque ones; the transparent ones). Over a box, interval bounds of
//! each object's tape (closed-form bounds for spheres) show which objects
//! cannot change the fold there and which restart it
//! ([`isoray_shape::fold::cull`]): the fold of the rest is the whole
//! fold's value bit for bit at every point of the box, and the material
//! blend's too (the scene field's lists use the material blend's width).
//!
//! The boxes are the cells of an octree over the cube every traced point
//! lies in (the CPU tracer's domain: the camera's reach), split breadth
//! first while a list is long, to [`MAX_DEPTH`] levels and [`MAX_NODES`]
//! cells. Each cell's midpoints are `(lo + hi) * 0.5` in f32, as the
//! shader computes them, so a point goes down to a cell that holds it.
//!
//! The buffer (`cells` in `fold.wgsl`): [`HEADER`] words — the root box
//! (lo x, y, z, hi x, y, z as f32 bits), the number of cells (0: no cells,
//! every evaluation folds every object), one unused word — then
//! [`NODE_WORDS`] words per cell: its first child's index (0 for a leaf;
//! the eight children are consecutive, octant bit 0 for x ≥ mid, 1 for y,
//! 2 for z), then per field [`SLOTS`] (word offset, length) of its list of
//! objects; then the lists, each stored once however many cells share it.

use std::collections::HashMap;

use isoray_scene::analytic::Analytic;
use isoray_scene::Scene;
use isoray_shade::MaterialSample;
use isoray_shape::fold::{cull, sphere_bound};
use isoray_shape::interval::{Interval, IntervalEvaluator};

use crate::pack::Words;

/// The fields that have lists: the scene (all objects, and the material
/// blend), the objects not in closed form (`min`), the opaque objects and
/// the transparent ones.
pub(crate) const SLOTS: usize = 4;
/// Words before the first cell.
pub(crate) const HEADER: usize = 8;
/// Words of one cell.
pub(crate) const NODE_WORDS: usize = 1 + 2 * SLOTS;
/// Levels below the root at most.
pub(crate) const MAX_DEPTH: u32 = 12;
/// Cells at most.
pub(crate) const MAX_NODES: usize = 1 << 16;
/// Lists no longer than this are not split further.
const LEAF: usize = 1;
/// A cell is split only where a fold may come within this many cell
/// diagonals (and the blend's width) of its surface.
const NEAR: f64 = 1.0;
/// Levels in a row without a shorter list after which a cell is a leaf.
const PATIENCE: u32 = 2;
/// Only cells whose lists are all this short run out of patience: longer
/// lists are split while they are near a surface.
const SHORT_LIST: usize = 4;

/// What the cells hold, for reports and tests.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CellStats {
    /// Cells in all (0: none were made).
    pub cells: usize,
    /// Leaves.
    pub leaves: usize,
    /// Deepest level reached.
    pub depth: u32,
    /// The longest list of the scene field in a leaf.
    pub longest: usize,
    /// The time it took to make them.
    pub build: std::time::Duration,
}

struct Node {
    lo: [f32; 3],
    hi: [f32; 3],
    depth: u32,
    lists: [Vec<u32>; SLOTS],
    /// Whether a field's surface may lie within about the cell's size of
    /// it: only such cells are split (elsewhere rays cross a cell in a
    /// step or two).
    near: bool,
    /// Levels in a row whose split shortened no list: past [`PATIENCE`]
    /// the cell is not split again (two objects blending along a seam
    /// stay together however small the cells).
    stale: u32,
    child: u32,
}

/// Each object's bound over a box: closed form for spheres, else interval
/// arithmetic on its tape.
struct Bounds<'s> {
    evals: Vec<IntervalEvaluator<'s>>,
    tapes: Vec<&'s isoray_shape::Tape>,
    spheres: Vec<Option<([f64; 3], f64)>>,
}

impl Bounds<'_> {
    fn of(&mut self, j: u32, bx: [Interval; 3]) -> Interval {
        let j = j as usize;
        match self.spheres[j] {
            Some((c, r)) => sphere_bound(c, r, bx),
            None => self.evals[j].eval(self.tapes[j], bx, None),
        }
    }
}

/// No cells: every evaluation folds every object.
pub(crate) fn none() -> (Words, CellStats) {
    (Words(vec![0u32; HEADER]), CellStats::default())
}

/// The cells of the scene at its current inputs over `domain`, the cube
/// (centre, half size) every traced point lies in ([`isoray_render::Reaches`]'
/// domain: the camera's reach, then shadow rays' and AO samples'); see the
/// module docs. A header saying there are none for a single object, no
/// domain (`render.prune` off) or one that is not finite.
pub(crate) fn build(scene: &Scene, domain: Option<([f64; 3], f64)>) -> (Words, CellStats) {
    let n = scene.objects.len();
    let Some((center, half)) = domain else {
        return none();
    };
    if n < 2 || !(half.is_finite() && half > 0.0) || center.iter().any(|c| !c.is_finite()) {
        return none();
    }
    let vars = &scene.inputs;
    let mut bounds = Bounds {
        evals: scene
            .objects
            .iter()
            .map(|o| IntervalEvaluator::new(o.shape.tape(), vars))
            .collect(),
        tapes: scene.objects.iter().map(|o| o.shape.tape()).collect(),
        spheres: scene
            .objects
            .iter()
            .map(|o| match o.closed_form(vars) {
                Some(Analytic::Sphere { c, r }) => Some((c, r)),
                _ => None,
            })
            .collect(),
    };
    let r = &scene.render;
    let k = r.blend.max(0.0);
    let km = k * r.material_blend;
    let analytic = &scene.derived().analytic;
    let clear: Vec<bool> = scene
        .objects
        .iter()
        .map(|o| MaterialSample::from(&scene.materials[o.material]).transparency > 0.0)
        .collect();
    // Per slot: its objects, its width and the material width.
    let all: Vec<u32> = (0..n as u32).collect();
    let pick = |f: &dyn Fn(usize) -> bool| all.iter().copied().filter(|&j| f(j as usize)).collect::<Vec<u32>>();
    let roots: [Vec<u32>; SLOTS] = [
        all.clone(),
        pick(&|j| analytic.get(j).is_none_or(|a| a.is_none())),
        pick(&|j| !clear[j]),
        pick(&|j| clear[j]),
    ];
    let widths: [(f64, f64); SLOTS] = [(k, k.max(km)), (0.0, 0.0), (k, k), (k, k)];
    let lo = center.map(|c| (c - half) as f32);
    let hi = center.map(|c| (c + half) as f32);
    let mut nodes = vec![Node {
        lo,
        hi,
        depth: 0,
        lists: roots,
        near: true,
        stale: 0,
        child: 0,
    }];
    let mut level = vec![0usize];
    let mut depth = 0;
    while !level.is_empty() && depth < MAX_DEPTH {
        let mut split: Vec<usize> = level
            .iter()
            .copied()
            .filter(|&i| nodes[i].near && nodes[i].stale < PATIENCE && nodes[i].lists.iter().any(|l| l.len() > LEAF))
            .collect();
        // The longest lists first when the budget runs out.
        let room = (MAX_NODES - nodes.len()) / 8;
        if split.len() > room {
            split.sort_by_key(|&i| std::cmp::Reverse(nodes[i].lists[0].len()));
            split.truncate(room);
        }
        if split.is_empty() {
            break;
        }
        let mut next = Vec::with_capacity(8 * split.len());
        for i in split {
            let (plo, phi) = (nodes[i].lo, nodes[i].hi);
            let mid: [f32; 3] = std::array::from_fn(|a| (plo[a] + phi[a]) * 0.5);
            let first = nodes.len() as u32;
            nodes[i].child = first;
            for oct in 0..8 {
                let mut clo = plo;
                let mut chi = phi;
                for a in 0..3 {
                    if oct >> a & 1 == 1 {
                        clo[a] = mid[a];
                    } else {
                        chi[a] = mid[a];
                    }
                }
                let bx: [Interval; 3] = std::array::from_fn(|a| Interval::new(clo[a] as f64, chi[a] as f64));
                let scale = (0..3).fold(0.0f64, |s, a| s.max(bx[a].lo.abs()).max(bx[a].hi.abs()));
                // One bound per object for all the slots.
                let mut memo: HashMap<u32, Interval> = HashMap::new();
                let diag = (0..3).map(|a| (bx[a].hi - bx[a].lo).powi(2)).sum::<f64>().sqrt();
                let mut near = false;
                let lists: [Vec<u32>; SLOTS] = std::array::from_fn(|s| {
                    let parent = &nodes[i].lists[s];
                    if parent.len() <= 1 {
                        return parent.clone();
                    }
                    let (k, width) = widths[s];
                    let (kept, fold) = cull(parent, k, width, scale, |j| {
                        *memo.entry(j).or_insert_with(|| bounds.of(j, bx))
                    });
                    near |= fold.lo < NEAR * diag + k;
                    kept
                });
                let shorter = (0..SLOTS).any(|s| lists[s].len() < nodes[i].lists[s].len());
                let short = lists.iter().all(|l| l.len() <= SHORT_LIST);
                let stale = if shorter || !short { 0 } else { nodes[i].stale + 1 };
                next.push(nodes.len());
                nodes.push(Node {
                    lo: clo,
                    hi: chi,
                    depth: depth + 1,
                    lists,
                    near,
                    stale,
                    child: 0,
                });
            }
        }
        level = next;
        depth += 1;
    }
    // Lay out: the cells, then each distinct list once.
    let mut words = vec![0u32; HEADER + NODE_WORDS * nodes.len()];
    for a in 0..3 {
        words[a] = lo[a].to_bits();
        words[3 + a] = hi[a].to_bits();
    }
    words[6] = nodes.len() as u32;
    let mut stored: HashMap<Vec<u32>, u32> = HashMap::new();
    let mut stats = CellStats {
        cells: nodes.len(),
        ..CellStats::default()
    };
    for (i, node) in nodes.iter().enumerate() {
        let b = HEADER + NODE_WORDS * i;
        words[b] = node.child;
        if node.child == 0 {
            stats.leaves += 1;
            stats.depth = stats.depth.max(node.depth);
            stats.longest = stats.longest.max(node.lists[0].len());
        }
        for (s, list) in node.lists.iter().enumerate() {
            let at = match stored.get(list) {
                Some(&at) => at,
                None => {
                    let at = words.len() as u32;
                    words.extend_from_slice(list);
                    stored.insert(list.clone(), at);
                    at
                }
            };
            words[b + 1 + 2 * s] = at;
            words[b + 2 + 2 * s] = list.len() as u32;
        }
    }
    (Words(words), stats)
}

#[cfg(test)]
mod tests {
    use super::*;
    use isoray_shape::eval::PointEvaluator;

    /// A row of blended spheres and boxes, some overlapping.
    const SCENE: &str = r#"
[camera]
position = [0.0, 2.0, 6.0]
target = [0.0, 0.0, 0.0]
[render]
blend = 0.3
max_distance = 20.0
shadow_max_distance = 5.0
[[object]]
shape = "sphere(p - vec3(-3.0, 0.0, 0.0), 0.6)"
[[object]]
shape = "box(p - vec3(-2.2, 0.1, 0.0), vec3(0.4, 0.5, 0.3))"
[[object]]
shape = "sphere(p - vec3(-1.0, 0.0, 0.2), 0.5)"
[[object]]
shape = "torus(p, 0.6, 0.2)"
[[object]]
shape = "sphere(p - vec3(1.1, 0.3, 0.0), 0.45)"
[[object]]
shape = "box(p - vec3(2.0, 0.0, -0.3), vec3(0.3, 0.6, 0.3))"
[[object]]
shape = "sphere(p - vec3(3.0, 0.0, 0.0), 0.7)"
[[object]]
shape = "sphere(p - vec3(0.0, -1.5, 0.0), 0.4)"
"#;

    /// The renderer's domain for the scene.
    fn domain(scene: &Scene) -> Option<([f64; 3], f64)> {
        isoray_render::reaches(scene, scene.camera.position, Some(1)).domain
    }

    /// The leaf holding p, as `find_cell` in fold.wgsl descends.
    fn leaf(words: &[u32], p: [f32; 3]) -> Option<usize> {
        let f = |i: usize| f32::from_bits(words[i]);
        let (mut lo, mut hi) = ([f(0), f(1), f(2)], [f(3), f(4), f(5)]);
        if (0..3).any(|a| p[a] < lo[a] || p[a] > hi[a]) {
            return None;
        }
        let mut node = 0usize;
        loop {
            let child = words[HEADER + NODE_WORDS * node] as usize;
            if child == 0 {
                return Some(node);
            }
            let mut oct = 0;
            for a in 0..3 {
                let mid = (lo[a] + hi[a]) * 0.5;
                if p[a] >= mid {
                    oct |= 1 << a;
                    lo[a] = mid;
                } else {
                    hi[a] = mid;
                }
            }
            node = child + oct;
        }
    }

    /// The tracer's smooth union in f32 (fold.wgsl's `smooth_union`).
    fn smooth_union(x: f32, y: f32, k: f32, quarter: f32) -> f32 {
        if k <= 0.0 {
            return x.min(y);
        }
        let h = (k - (x - y).abs()).max(0.0);
        x.min(y) - (h * h) * quarter
    }

    #[test]
    fn a_cells_list_folds_to_the_whole_folds_value_bit_for_bit() {
        let scene = isoray_scene::load_str(SCENE, "cells.toml", &[]).unwrap();
        let (Words(words), stats) = build(&scene, domain(&scene));
        assert!(stats.cells > 1 && stats.leaves > 1, "{stats:?}");
        let k = scene.render.blend as f32;
        let quarter = (0.25 / scene.render.blend) as f32;
        let mut evals: Vec<PointEvaluator<f32>> = scene
            .objects
            .iter()
            .map(|o| PointEvaluator::new(o.shape.tape()))
            .collect();
        let vars = scene.inputs.clone();
        let mut dist = |j: usize, p: [f32; 3]| evals[j].eval(&vars, p[0], p[1], p[2]);
        let mut state = 7u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        let (mut checked, mut shorter) = (0, 0);
        for _ in 0..20000 {
            // Around the objects, where the lists differ most.
            let p = [next() * 8.0 - 4.0, next() * 4.0 - 2.0, next() * 3.0 - 1.5];
            let Some(node) = leaf(&words, p) else { continue };
            for slot in [0usize, 2] {
                let b = HEADER + NODE_WORDS * node;
                let (at, len) = (words[b + 1 + 2 * slot] as usize, words[b + 2 + 2 * slot] as usize);
                let list = &words[at..at + len];
                let fold = |ids: &mut dyn Iterator<Item = usize>, dist: &mut dyn FnMut(usize, [f32; 3]) -> f32| {
                    ids.map(|j| dist(j, p))
                        .reduce(|a, b| smooth_union(a, b, k, quarter))
                        .unwrap_or(f32::INFINITY)
                };
                let whole = fold(&mut (0..scene.objects.len()), &mut dist);
                let part = fold(&mut list.iter().map(|&j| j as usize), &mut dist);
                assert_eq!(
                    part.to_bits(),
                    whole.to_bits(),
                    "at {p:?} (cell {node}, field {slot}, objects {list:?}): {part} against {whole}"
                );
                checked += 1;
                shorter += (len < scene.objects.len()) as usize;
            }
        }
        assert!(
            checked > 10000 && shorter > checked / 2,
            "{checked} points, {shorter} with shorter lists"
        );
    }

    #[test]
    fn one_object_needs_no_cells() {
        let scene = isoray_scene::load_str("[[object]]\nshape = \"sphere(p, 1.0)\"\n", "one.toml", &[]).unwrap();
        let (Words(words), stats) = build(&scene, domain(&scene));
        assert_eq!(stats.cells, 0);
        assert_eq!(words[6], 0);
    }
}
