//! Compiling objects one at a time, with a cache keyed by content.
//!
//! Each object's shape compiles to a [`Fragment`]: a graph of its own, with
//! its placement read from placeholder inputs. A fragment depends only on
//! the shape text, whether the object is placed, the layout of the scene's
//! inputs and the content of the user surfaces the text calls (and on the
//! values of the inputs an exact analysis bound, which are checked). The
//! [`ObjectCache`] keeps fragments by that key, so loading a scene again
//! after an edit (the studio, `isoray set`, a parameter that exact algebra
//! bound) compiles only the objects whose content changed; the others are
//! copied into the scene's graph ([`Builder::import`]).

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use isoray_shape::{Builder, Diagnostic, Library, Node, Shape};

/// Placeholder inputs of a fragment's placement: the seven inputs of
/// [`crate::Transform`] are `FRAGMENT_INPUTS + k` until the fragment is
/// imported into a scene, which renumbers them to the object's inputs.
pub(crate) const FRAGMENT_INPUTS: u32 = 1 << 30;

/// An object's compiled shape, apart from any scene.
#[derive(Debug)]
pub(crate) struct Fragment {
    /// The graph.
    pub(crate) graph: Builder,
    /// The object's signed distance (placement included) in `graph`.
    pub(crate) node: Node,
    /// Inputs that exact algebra bound as constants, sorted.
    pub(crate) bound: Vec<u32>,
    /// The bits of the bound inputs' values when they were bound.
    bound_bits: Vec<u64>,
    /// The functions the shape text calls, in order of first call.
    pub(crate) called: Vec<String>,
    /// Values that must stay positive as the inputs change, with what each
    /// is (see [`isoray_shape::Compiled::guards`]).
    pub(crate) guards: Vec<(Shape, String)>,
    /// The object's own tape, once extracted, for the first input of its
    /// placement it was extracted with.
    shape: Mutex<Option<(Option<u32>, Shape)>>,
}

impl Fragment {
    /// Copies the fragment into `b`; its placement reads the seven inputs
    /// from `first` on.
    pub(crate) fn import(&self, b: &mut Builder, first: Option<u32>) -> Node {
        b.import(&self.graph, self.node, |v| match (v >= FRAGMENT_INPUTS, first) {
            (true, Some(k)) => v - FRAGMENT_INPUTS + k,
            _ => v,
        })
    }

    /// The object's shape with its placement at inputs `first`: made by
    /// `extract` the first time, then kept (a tape depends only on the
    /// graph it is extracted from, and an imported fragment is that graph).
    pub(crate) fn shape(&self, first: Option<u32>, extract: impl FnOnce() -> Shape) -> Shape {
        let mut slot = self.shape.lock().unwrap_or_else(|e| e.into_inner());
        match &*slot {
            Some((at, shape)) if *at == first => shape.clone(),
            _ => {
                let shape = extract();
                *slot = Some((first, shape.clone()));
                shape
            }
        }
    }
}

/// What compiling an object gives, for [`ObjectCache::get_or_compile`].
pub(crate) struct Compiled {
    /// The graph.
    pub(crate) graph: Builder,
    /// The object's distance in it.
    pub(crate) node: Node,
    /// Inputs exact algebra bound, sorted.
    pub(crate) bound: Vec<u32>,
    /// The functions the text calls.
    pub(crate) called: Vec<String>,
    /// Values that must stay positive.
    pub(crate) guards: Vec<(Shape, String)>,
}

/// How many objects a cache compiled and how many it reused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct CacheStats {
    /// Objects compiled (cache misses).
    pub compiled: u64,
    /// Objects taken from the cache.
    pub reused: u64,
}

/// Per key, the fragments compiled at different values of the inputs they
/// bound (most recent last).
#[derive(Debug, Default)]
struct Inner {
    map: HashMap<String, Vec<Arc<Fragment>>>,
    /// The functions each shape text calls.
    called: HashMap<String, Vec<String>>,
    /// Mesh files read, by path, modification time and length.
    meshes: HashMap<MeshKey, Arc<crate::meshes::LoadedMesh>>,
    stats: CacheStats,
}

/// A mesh file as the cache knows it: path, modification time, length.
type MeshKey = (std::path::PathBuf, Option<std::time::SystemTime>, u64);

/// The most mesh files a cache keeps.
const MESH_FILES: usize = 16;

/// The most fragments kept per key (values of bound inputs).
const VARIANTS: usize = 16;

/// Compiled objects keyed by their content, shared by the loads that are
/// given it (clones share one cache). Never keyed by name or position:
/// reordering objects, renaming them or editing another object reuses them.
///
/// The cache holds at most [`ObjectCache::CAPACITY`] keys, each with up to
/// 16 compilations at different values of the inputs exact algebra bound
/// (so a slider moving a bound parameter back and forth stops compiling);
/// a key past 16 forgets its oldest compilation, and a cache past its
/// capacity starts again empty.
#[derive(Debug, Clone, Default)]
pub struct ObjectCache(Arc<Mutex<Inner>>);

impl ObjectCache {
    /// The most objects a cache keeps.
    pub const CAPACITY: usize = 4096;

    /// An empty cache.
    pub fn new() -> Self {
        Self::default()
    }

    /// Objects compiled and reused since the cache was made.
    pub fn stats(&self) -> CacheStats {
        self.0.lock().map(|m| m.stats).unwrap_or_default()
    }

    /// Number of compiled objects kept.
    pub fn len(&self) -> usize {
        self.0.lock().map(|m| m.map.values().map(Vec::len).sum()).unwrap_or(0)
    }

    /// True when nothing is kept.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The functions `text` calls, if the cache has seen it.
    pub(crate) fn called(&self, text: &str) -> Option<Vec<String>> {
        self.0.lock().ok()?.called.get(text).cloned()
    }

    /// The mesh file at `path` with its hierarchy, read by `read` unless
    /// the cache holds it unchanged (same modification time and length).
    pub(crate) fn mesh(
        &self,
        path: &std::path::Path,
        read: impl FnOnce() -> Result<crate::meshes::LoadedMesh, String>,
    ) -> Result<Arc<crate::meshes::LoadedMesh>, String> {
        let meta = std::fs::metadata(path).ok();
        let key: MeshKey = (
            path.to_path_buf(),
            meta.as_ref().and_then(|m| m.modified().ok()),
            meta.as_ref().map_or(0, |m| m.len()),
        );
        if let Some(hit) = self.0.lock().ok().and_then(|m| m.meshes.get(&key).cloned()) {
            return Ok(hit);
        }
        let loaded = Arc::new(read()?);
        if let Ok(mut m) = self.0.lock() {
            if m.meshes.len() >= MESH_FILES {
                m.meshes.clear();
            }
            m.meshes.insert(key, loaded.clone());
        }
        Ok(loaded)
    }

    /// Remembers the functions `text` calls.
    pub(crate) fn remember_called(&self, text: &str, called: Vec<String>) {
        if let Ok(mut m) = self.0.lock() {
            if m.called.len() >= Self::CAPACITY {
                m.called.clear();
            }
            m.called.insert(text.to_string(), called);
        }
    }

    /// The fragment for `key`, compiled by `compile` unless the cache has
    /// one whose bound inputs have the values `inputs` gives them now.
    /// Errors are not cached.
    pub(crate) fn get_or_compile(
        &self,
        key: String,
        inputs: &[f64],
        compile: impl FnOnce() -> Result<Compiled, Diagnostic>,
    ) -> Result<Arc<Fragment>, Diagnostic> {
        let bits = |bound: &[u32]| -> Vec<u64> {
            bound
                .iter()
                .map(|&k| inputs.get(k as usize).copied().unwrap_or(f64::NAN).to_bits())
                .collect()
        };
        if let Ok(mut m) = self.0.lock() {
            let hit = m
                .map
                .get(&key)
                .and_then(|variants| variants.iter().find(|f| f.bound_bits == bits(&f.bound)).cloned());
            if let Some(f) = hit {
                m.stats.reused += 1;
                return Ok(f);
            }
        }
        let Compiled {
            graph,
            node,
            bound,
            called,
            guards,
        } = compile()?;
        let fragment = Arc::new(Fragment {
            bound_bits: bits(&bound),
            graph,
            node,
            bound,
            called,
            guards,
            shape: Mutex::new(None),
        });
        if let Ok(mut m) = self.0.lock() {
            if m.map.len() >= Self::CAPACITY {
                m.map.clear();
            }
            let variants = m.map.entry(key).or_default();
            if variants.len() >= VARIANTS {
                variants.remove(0);
            }
            variants.push(fragment.clone());
            m.stats.compiled += 1;
        }
        Ok(fragment)
    }
}

/// The cache key of an object: its shape text, whether it is placed, and
/// what the library contributes (see [`Library::content_key`]).
pub(crate) fn object_key(lib: &Library, text: &str, placed: bool, called: &[String]) -> String {
    format!("{placed}\u{0}{text}\u{0}{}", lib.content_key(called))
}
