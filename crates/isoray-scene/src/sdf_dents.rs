//! Dents as geometry (`dents = "sdf"`): each impact is a CSG edit of the
//! struck object, the object minus the impactor at its pushed pose,
//! d′ = max(d, −d_B), or with a soft rim of width k the smooth maximum
//! max(d, −d_B) + max(k − |d + d_B|, 0)²/(4k), which rounds the crater's
//! edge. Both are valid distance bounds when d and d_B are, so sphere
//! tracing stays safe; silhouettes, shadows, AO, reflections and
//! `isoray mesh` all see the dents.
//!
//! Each edit is written in the scene file as an `[[object.sdf_dent]]`
//! table: the impactor's shape text, its placement in the struck object's
//! own coordinates (so the dent moves with the object), the rim, and a
//! bounding sphere of the dent (where the impactor overlaps the object).
//! Outside its sphere an edit changes nothing the tracer needs, and the
//! tape skips it: the spheres form a tree (each node behind a lazy select
//! that skips its whole subtree), so a point far from every dent pays for
//! one sphere test and a thousand dents cost about what ten do.

use isoray_shape::{Builder, Node};
use toml_edit::{value, Array, ArrayOfTables, DocumentMut, Item, Table};

use crate::doc::Located;
use crate::error::{SceneError, Sources};
use crate::physics::Placement;
use crate::reader::Reader;
use crate::schema::{key, key_without_default, num, KeySpec, Kind, Range};

type Result<T> = std::result::Result<T, SceneError>;

/// One dent cut into an object's geometry (`[[object.sdf_dent]]`).
#[derive(Debug, Clone, PartialEq)]
pub struct SdfDent {
    /// The impactor's shape text, in its own coordinates.
    pub shape: String,
    /// The impactor's placement at its pushed pose, in the struck object's
    /// own coordinates.
    pub placement: Placement,
    /// Width of the soft rim, object units (0: a sharp edge).
    pub rim: f64,
    /// A sphere (centre, radius; object coordinates) that holds the part
    /// of the impactor inside the object, and the rim.
    pub bound: [f64; 4],
}

/// The keys of an `[[object.sdf_dent]]` table.
pub fn sdf_dent_keys() -> &'static [KeySpec] {
    static KEYS: std::sync::LazyLock<Vec<KeySpec>> = std::sync::LazyLock::new(|| {
        vec![
            key_without_default(
                "shape",
                Kind::Str,
                "required",
                "the impactor's shape text in its own coordinates (`isoray simulate` writes the impactor object's `shape`)",
            ),
            key(
                "position",
                Kind::Vector,
                "[0.0, 0.0, 0.0]",
                "where the impactor's origin was, at its pushed pose, in the dented object's own coordinates",
            ),
            key(
                "rotation",
                Kind::Vector,
                "[0.0, 0.0, 0.0]",
                "its rotation there, degrees about x, then y, then z (as an object's `rotation`)",
            ),
            key(
                "scale",
                num(Range::POSITIVE),
                "1.0",
                "its scale relative to the dented object's",
            ),
            key(
                "rim",
                num(Range::NON_NEGATIVE),
                "0.0",
                "width of the soft rim: the crater's edge is rounded over this width (object units; 0 = sharp)",
            ),
            key_without_default(
                "bound",
                Kind::Text("[x, y, z, r]"),
                "required",
                "a sphere in the object's coordinates holding the part of the impactor inside the object, and the rim: outside it the dent is skipped",
            ),
        ]
    });
    &KEYS
}

/// Reads the `sdf_dent` tables of an object (`ctx`: `object.N`), with the
/// place of each one's shape text.
pub(crate) fn read<'a>(src: &'a Sources, r: &mut Reader<'a>, ctx: &str) -> Result<Vec<(SdfDent, &'a Located)>> {
    let Some(v) = r.get("sdf_dent") else {
        return Ok(Vec::new());
    };
    let items = crate::read::array_of_tables(src, v, &format!("{ctx}.sdf_dent"), true)?;
    let mut out = Vec::with_capacity(items.len());
    for (k, item) in items.into_iter().enumerate() {
        let here = format!("{ctx}.sdf_dent.{k}");
        let mut t = Reader::new(src, item, &here)?;
        let keys = sdf_dent_keys();
        let Some((shape, loc)) = t.string("shape")? else {
            return Err(src
                .error(
                    item.origin,
                    format!("`{here}` needs a `shape`: the impactor's shape text"),
                    Some("add shape = \"length(p) - 0.25\""),
                    &[],
                )
                .with_key(format!("{here}.shape")));
        };
        let placement = Placement {
            position: t.vec3("position", [0.0; 3])?,
            rotation: t.vec3("rotation", [0.0; 3])?,
            scale: t.num_key(crate::schema::spec(keys, "scale"))?,
        };
        let rim = t.num_key(crate::schema::spec(keys, "rim"))?;
        let bound = read_bound(src, &mut t, item, &here)?;
        t.finish_keys(keys)?;
        out.push((
            SdfDent {
                shape: shape.to_string(),
                placement,
                rim,
                bound,
            },
            loc,
        ));
    }
    Ok(out)
}

fn read_bound(src: &Sources, t: &mut Reader, item: &Located, here: &str) -> Result<[f64; 4]> {
    let expected = "[x, y, z, r]: four numbers, r positive";
    let Some(v) = t.get("bound") else {
        return Err(src
            .error(
                item.origin,
                format!("`{here}` needs a `bound`: {expected}, a sphere holding the dent"),
                Some("add bound = [x, y, z, r]"),
                &[],
            )
            .with_key(format!("{here}.bound")));
    };
    let nums: Option<Vec<f64>> = match &v.item {
        crate::doc::Item::Array(xs) => xs
            .iter()
            .map(|x| match x.item {
                crate::doc::Item::Num(n, _) if n.is_finite() => Some(n),
                _ => None,
            })
            .collect(),
        _ => None,
    };
    match nums {
        Some(n) if n.len() == 4 && n[3] > 0.0 => Ok([n[0], n[1], n[2], n[3]]),
        _ => Err(t.err(v, "bound", expected)),
    }
}

/// Text that identifies a list of dents, for the object cache's key.
pub(crate) fn cache_key(dents: &[SdfDent]) -> String {
    let mut s = String::new();
    for d in dents {
        let p = d.placement;
        s.push_str(&format!(
            "\u{1}{}\u{2}{:?}{:?}{:?}{:?}{:?}",
            d.shape, p.position, p.rotation, p.scale, d.rim, d.bound
        ));
    }
    s
}

/// A bounding sphere.
#[derive(Debug, Clone, Copy)]
struct Ball {
    c: [f64; 3],
    r: f64,
}

/// A tree of bounding spheres over the dents.
enum Tree {
    Leaf(usize),
    Node(Ball, Box<Tree>, Box<Tree>),
}

/// The smallest sphere centred at the middle of the spheres' box that holds them.
fn enclose(balls: &[Ball], items: &[usize]) -> Ball {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for &i in items {
        for k in 0..3 {
            lo[k] = lo[k].min(balls[i].c[k] - balls[i].r);
            hi[k] = hi[k].max(balls[i].c[k] + balls[i].r);
        }
    }
    let c: [f64; 3] = std::array::from_fn(|k| 0.5 * (lo[k] + hi[k]));
    let r = items
        .iter()
        .map(|&i| {
            let b = balls[i];
            let d = ((b.c[0] - c[0]).powi(2) + (b.c[1] - c[1]).powi(2) + (b.c[2] - c[2]).powi(2)).sqrt();
            d + b.r
        })
        .fold(0.0, f64::max);
    Ball { c, r }
}

/// Splits the dents at the median of their centres along the widest axis.
fn build(balls: &[Ball], items: &mut [usize]) -> Tree {
    if items.len() == 1 {
        return Tree::Leaf(items[0]);
    }
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for &i in items.iter() {
        for k in 0..3 {
            lo[k] = lo[k].min(balls[i].c[k]);
            hi[k] = hi[k].max(balls[i].c[k]);
        }
    }
    let axis = (0..3)
        .max_by(|&a, &b| (hi[a] - lo[a]).total_cmp(&(hi[b] - lo[b])))
        .unwrap_or(0);
    // Stable order (ties by index) keeps the tape the same for the same dents.
    items.sort_by(|&a, &b| balls[a].c[axis].total_cmp(&balls[b].c[axis]).then(a.cmp(&b)));
    let ball = enclose(balls, items);
    let (l, r) = items.split_at_mut(items.len() / 2);
    Tree::Node(ball, Box::new(build(balls, l)), Box::new(build(balls, r)))
}

/// Lowers dent k's impactor distance at its own point q′ (`impactor(b, k, q′)`).
pub(crate) type LowerImpactor<'a, E> = dyn FnMut(&mut Builder, usize, [Node; 3]) -> std::result::Result<Node, E> + 'a;

/// Lowers the dents onto the object's own distance `d` at its own point
/// `q`; `impactor(b, k, q′)` lowers dent k's impactor distance at q′.
pub(crate) fn lower<E>(
    b: &mut Builder,
    q: [Node; 3],
    d: Node,
    dents: &[SdfDent],
    impactor: &mut LowerImpactor<E>,
) -> std::result::Result<Node, E> {
    if dents.is_empty() {
        return Ok(d);
    }
    let balls: Vec<Ball> = dents
        .iter()
        .map(|x| Ball {
            c: [x.bound[0], x.bound[1], x.bound[2]],
            r: x.bound[3],
        })
        .collect();
    let mut items: Vec<usize> = (0..dents.len()).collect();
    let tree = build(&balls, &mut items);
    lower_tree(b, q, d, dents, &balls, &tree, impactor)
}

/// `d` where the point is farther from `ball` than from the object's
/// surface (outside the object: anywhere outside the ball), else `inner(d)`.
fn guarded<E>(
    b: &mut Builder,
    q: [Node; 3],
    d: Node,
    ball: Ball,
    inner: impl FnOnce(&mut Builder) -> std::result::Result<Node, E>,
) -> std::result::Result<Node, E> {
    let mut s = b.constant(0.0);
    for (&qk, &ck) in q.iter().zip(&ball.c) {
        let e = b.add_c(qk, -ck);
        let e2 = b.square(e);
        s = b.add(s, e2);
    }
    let dist = b.sqrt(s);
    let zero = b.constant(0.0);
    let inside = b.min(d, zero);
    let gap = b.add(dist, inside);
    // A relative margin keeps rounding on the safe side.
    let far = b.add_c(gap, -(ball.r * (1.0 + 1e-9) + 1e-12));
    let e = inner(b)?;
    Ok(b.lazy_select(far, d, e))
}

fn lower_tree<E>(
    b: &mut Builder,
    q: [Node; 3],
    d: Node,
    dents: &[SdfDent],
    balls: &[Ball],
    tree: &Tree,
    impactor: &mut LowerImpactor<E>,
) -> std::result::Result<Node, E> {
    match tree {
        Tree::Leaf(k) => guarded(b, q, d, balls[*k], |b| {
            let dent = &dents[*k];
            let qk = to_impactor(b, q, &dent.placement);
            let db = impactor(b, *k, qk)?;
            let db = b.mul_c(db, dent.placement.scale);
            let cut = b.neg(db);
            Ok(smooth_max(b, d, cut, dent.rim))
        }),
        Tree::Node(ball, l, r) => guarded(b, q, d, *ball, |b| {
            let d = lower_tree(b, q, d, dents, balls, l, impactor)?;
            lower_tree(b, q, d, dents, balls, r, impactor)
        }),
    }
}

/// The impactor's own point for the object's point q: P⁻¹(q).
fn to_impactor(b: &mut Builder, q: [Node; 3], p: &Placement) -> [Node; 3] {
    // Columns of R⁻¹/s: the local images of the axes.
    let cols: [[f64; 3]; 3] = std::array::from_fn(|k| {
        let mut e = [0.0; 3];
        e[k] = 1.0;
        p.dir_to_local(e).map(|c| c / p.scale)
    });
    let rel: [Node; 3] = std::array::from_fn(|k| b.add_c(q[k], -p.position[k]));
    std::array::from_fn(|i| {
        let mut acc: Option<Node> = None;
        for (k, &r) in rel.iter().enumerate() {
            let m = cols[k][i];
            if m == 0.0 {
                continue;
            }
            let t = b.mul_c(r, m);
            acc = Some(match acc {
                None => t,
                Some(a) => b.add(a, t),
            });
        }
        acc.unwrap_or_else(|| b.constant(0.0))
    })
}

/// max(a, c) + max(k − |a − c|, 0)²/(4k), the smooth union's mirror; max(a, c) when k = 0.
fn smooth_max(b: &mut Builder, a: Node, c: Node, k: f64) -> Node {
    if k <= 0.0 {
        return b.max(a, c);
    }
    let (na, nc) = (b.neg(a), b.neg(c));
    let u = b.smooth_union(na, nc, k);
    b.neg(u)
}

/// The scene text `text` with `dents` appended to object `object`'s
/// `[[object.sdf_dent]]` tables; comments and formatting are kept.
pub fn append_to_text(text: &str, name: &str, object: usize, dents: &[SdfDent]) -> Result<String> {
    let mut doc: DocumentMut = text
        .parse()
        .map_err(|e: toml_edit::TomlError| SceneError::usage(format!("`{name}` is not valid TOML: {}", e.message())))?;
    let no_object = || SceneError::usage(format!("`{name}` has no [[object]] number {object}"));
    let table: &mut Table = match doc.get_mut("object") {
        Some(Item::ArrayOfTables(a)) => a.get_mut(object).ok_or_else(no_object)?,
        _ => return Err(no_object()),
    };
    let list = table
        .entry("sdf_dent")
        .or_insert_with(|| Item::ArrayOfTables(ArrayOfTables::new()));
    let Item::ArrayOfTables(list) = list else {
        return Err(SceneError::usage(format!(
            "`{name}`: object {object}'s `sdf_dent` is not written as [[object.sdf_dent]] tables; cannot add to it"
        )));
    };
    let arr = |v: &[f64]| {
        let mut a = Array::new();
        for &x in v {
            a.push(x);
        }
        value(a)
    };
    for d in dents {
        let mut t = Table::new();
        t.insert("shape", value(d.shape.as_str()));
        t.insert("position", arr(&d.placement.position));
        if d.placement.rotation != [0.0; 3] {
            t.insert("rotation", arr(&d.placement.rotation));
        }
        if d.placement.scale != 1.0 {
            t.insert("scale", value(d.placement.scale));
        }
        if d.rim > 0.0 {
            t.insert("rim", value(d.rim));
        }
        t.insert("bound", arr(&d.bound));
        list.push(t);
    }
    Ok(doc.to_string())
}

impl crate::Scene {
    /// Cuts `dents` into object `object`'s geometry: they are added to the
    /// scene's text as `[[object.sdf_dent]]` tables ([`Scene::source_text`])
    /// and the scene is compiled again, the other objects coming from the
    /// object cache. The time, parameters, placements (those the
    /// simulation set too), dent maps and dent modes stay as they were. On an error
    /// the scene is unchanged.
    ///
    /// [`Scene::source_text`]: crate::Scene::source_text
    pub fn add_sdf_dents(&mut self, object: usize, dents: &[SdfDent]) -> Result<()> {
        if dents.is_empty() {
            return Ok(());
        }
        let mut sources = self.origin.sources.clone();
        sources.text = append_to_text(&sources.text, &sources.path, object, dents)?;
        let placements: Vec<(usize, Placement)> = (0..self.objects.len())
            .filter(|&i| self.objects[i].transform.is_some())
            .map(|i| (i, self.placement(i)))
            .collect();
        // What runs change in memory: the maps, and `dents` (`--dents`).
        let kept: Vec<_> = self
            .objects
            .iter()
            .map(|o| (o.physics.maps.clone(), o.physics.dents))
            .collect();
        let mut fresh = self.clone();
        fresh.recompile_from(sources)?;
        for (i, p) in placements {
            if fresh.objects.get(i).is_some_and(|o| o.transform.is_some()) && fresh.placement(i) != p {
                fresh.set_placement(i, p)?;
            }
        }
        for (o, (maps, dents)) in fresh.objects.iter_mut().zip(kept) {
            o.physics.maps = maps;
            o.physics.dents = dents;
        }
        *self = fresh;
        Ok(())
    }

    /// The scene's text as it stands: the file as loaded, with the dents
    /// [`Scene::add_sdf_dents`] cut since (`--set` overrides not applied).
    ///
    /// [`Scene::add_sdf_dents`]: crate::Scene::add_sdf_dents
    pub fn source_text(&self) -> &str {
        &self.origin.sources.text
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn appended_dents_read_back_as_written() {
        let text = "# a plate\n[[object]]\nname = \"plate\"   # kept\nshape = \"p.y\"\n\n[[object]]\nshape = \"length(p) - 1.0\"\n";
        let d = SdfDent {
            shape: "length(p) - 0.25".into(),
            placement: Placement {
                position: [0.1, 0.2, -0.3],
                rotation: [10.0, 0.0, 5.0],
                scale: 0.5,
            },
            rim: 0.01,
            bound: [0.1, 0.0, -0.3, 0.2],
        };
        let out = append_to_text(text, "t.toml", 0, &[d.clone(), d.clone()]).unwrap();
        assert!(out.starts_with("# a plate\n[[object]]\nname = \"plate\"   # kept\n"));
        assert_eq!(out.matches("[[object.sdf_dent]]").count(), 2, "{out}");
        let scene = crate::load_str(&out, "t.toml", &[]).unwrap();
        assert_eq!(scene.objects[0].physics.sdf_dents, vec![d.clone(), d]);
        assert!(scene.objects[1].physics.sdf_dents.is_empty());
        assert!(append_to_text(text, "t.toml", 2, &[]).is_err());
    }
}
