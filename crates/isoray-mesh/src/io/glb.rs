//! glTF 2.0 binary (`.glb`): the JSON through `gltf-json`, the container by
//! hand (12-byte header, JSON chunk padded with spaces, BIN chunk padded
//! with zeros).
//!
//! Written: one mesh with one primitive per material used, all sharing the
//! POSITION (with min/max), NORMAL and TEXCOORD_0 accessors, each with its
//! own u32 indices; one glTF material per mesh material (a default one when
//! the mesh has none). Read back: every primitive of every mesh, merged
//! (primitives sharing vertex accessors share vertices).

use std::collections::{BTreeMap, HashMap};
use std::io::{self, Write};

use gltf_json as json;
use json::accessor::{ComponentType, GenericComponentType, Type};
use json::buffer::Target;
use json::material::{AlphaMode, PbrBaseColorFactor, PbrMetallicRoughness, StrengthFactor};
use json::mesh::{Mode, Primitive, Semantic};
use json::validation::{Checked::Valid, USize64};
use json::{Accessor, Index, Root};

use super::{bad, compact_materials, default_material, material_of, Problem};
use crate::mesh::{Mesh, MeshMaterial};

const MAGIC: &[u8; 4] = b"glTF";
const JSON_CHUNK: &[u8; 4] = b"JSON";
const BIN_CHUNK: &[u8; 4] = b"BIN\0";

pub(super) fn write(w: &mut dyn Write, mesh: &Mesh) -> Result<(), Problem> {
    let (root, bin) = document(mesh);
    let mut json = json::serialize::to_vec(&root).map_err(|e| Problem::Io(io::Error::other(e)))?;
    while json.len() % 4 != 0 {
        json.push(b' ');
    }
    // `bin` holds only 4-byte values, so it needs no padding.
    let mut total = 12 + 8 + json.len() as u64;
    if !bin.is_empty() {
        total += 8 + bin.len() as u64;
    }
    let Ok(total) = u32::try_from(total) else {
        return Err(Problem::Mesh(format!(
            "the glb would take {total} bytes, more than the 4 GiB it can hold"
        )));
    };
    w.write_all(MAGIC)?;
    w.write_all(&2u32.to_le_bytes())?;
    w.write_all(&total.to_le_bytes())?;
    w.write_all(&(json.len() as u32).to_le_bytes())?;
    w.write_all(JSON_CHUNK)?;
    w.write_all(&json)?;
    if !bin.is_empty() {
        w.write_all(&(bin.len() as u32).to_le_bytes())?;
        w.write_all(BIN_CHUNK)?;
        w.write_all(&bin)?;
    }
    Ok(())
}

/// The glTF document for `mesh` and its binary buffer.
fn document(mesh: &Mesh) -> (Root, Vec<u8>) {
    let mut root = Root {
        asset: json::Asset {
            generator: Some("isoray".to_string()),
            ..Default::default()
        },
        ..Default::default()
    };
    let defaults = [default_material("default")];
    let materials = if mesh.materials.is_empty() {
        &defaults[..]
    } else {
        &mesh.materials[..]
    };
    for m in materials {
        root.push(json::Material {
            name: Some(m.name.clone()),
            alpha_mode: Valid(if m.base_color[3] < 1.0 {
                AlphaMode::Blend
            } else {
                AlphaMode::Opaque
            }),
            pbr_metallic_roughness: PbrMetallicRoughness {
                base_color_factor: PbrBaseColorFactor(m.base_color),
                metallic_factor: StrengthFactor(0.0),
                roughness_factor: StrengthFactor(0.5),
                ..Default::default()
            },
            ..Default::default()
        });
    }
    let mut bin = Vec::new();
    let mut nodes = Vec::new();
    if !mesh.triangles.is_empty() {
        let buffer = root.push(json::Buffer {
            byte_length: USize64(0),
            name: None,
            uri: None,
            extensions: None,
            extras: Default::default(),
        });
        let view = |root: &mut Root, bin: &mut Vec<u8>, data: Vec<u8>, target: Target| {
            let offset = bin.len();
            bin.extend_from_slice(&data);
            root.push(json::buffer::View {
                buffer,
                byte_length: USize64::from(data.len()),
                byte_offset: Some(USize64::from(offset)),
                byte_stride: None,
                name: None,
                target: Some(Valid(target)),
                extensions: None,
                extras: Default::default(),
            })
        };
        let floats = |v: &mut Vec<u8>, xs: &[f32]| xs.iter().for_each(|x| v.extend_from_slice(&x.to_le_bytes()));

        let n = mesh.positions.len();
        let mut data = Vec::with_capacity(12 * n);
        mesh.positions.iter().for_each(|p| floats(&mut data, p));
        let (mut min, mut max) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for p in &mesh.positions {
            for k in 0..3 {
                min[k] = min[k].min(p[k]);
                max[k] = max[k].max(p[k]);
            }
        }
        let v = view(&mut root, &mut bin, data, Target::ArrayBuffer);
        let bounds = Some((min.to_vec(), max.to_vec()));
        let positions = root.push(accessor(v, n, ComponentType::F32, Type::Vec3, bounds));
        let mut attributes = BTreeMap::from([(Valid(Semantic::Positions), positions)]);
        if !mesh.normals.is_empty() {
            let mut data = Vec::with_capacity(12 * n);
            mesh.normals.iter().for_each(|p| floats(&mut data, p));
            let v = view(&mut root, &mut bin, data, Target::ArrayBuffer);
            let a = root.push(accessor(v, n, ComponentType::F32, Type::Vec3, None));
            attributes.insert(Valid(Semantic::Normals), a);
        }
        if !mesh.uvs.is_empty() {
            let mut data = Vec::with_capacity(8 * n);
            mesh.uvs.iter().for_each(|p| floats(&mut data, p));
            let v = view(&mut root, &mut bin, data, Target::ArrayBuffer);
            let a = root.push(accessor(v, n, ComponentType::F32, Type::Vec2, None));
            attributes.insert(Valid(Semantic::TexCoords(0)), a);
        }
        let mut primitives = Vec::new();
        for m in 0..materials.len() {
            let mut data = Vec::new();
            for (i, t) in mesh.triangles.iter().enumerate() {
                if material_of(mesh, i) as usize == m {
                    t.iter().for_each(|v| data.extend_from_slice(&v.to_le_bytes()));
                }
            }
            if data.is_empty() {
                continue;
            }
            let count = data.len() / 4;
            let v = view(&mut root, &mut bin, data, Target::ElementArrayBuffer);
            let indices = root.push(accessor(v, count, ComponentType::U32, Type::Scalar, None));
            primitives.push(Primitive {
                attributes: attributes.clone(),
                indices: Some(indices),
                material: Some(Index::new(m as u32)),
                mode: Valid(Mode::Triangles),
                targets: None,
                extensions: None,
                extras: Default::default(),
            });
        }
        root.buffers[0].byte_length = USize64::from(bin.len());
        let gltf_mesh = root.push(json::Mesh {
            name: Some("isoray".to_string()),
            primitives,
            weights: None,
            extensions: None,
            extras: Default::default(),
        });
        nodes.push(root.push(json::Node {
            mesh: Some(gltf_mesh),
            ..Default::default()
        }));
    }
    // An empty mesh gets no scene: a scene's node list may not be empty.
    if !nodes.is_empty() {
        let scene = root.push(json::Scene {
            nodes,
            name: None,
            extensions: None,
            extras: Default::default(),
        });
        root.scene = Some(scene);
    }
    (root, bin)
}

fn accessor(
    view: Index<json::buffer::View>,
    count: usize,
    component: ComponentType,
    type_: Type,
    bounds: Option<(Vec<f32>, Vec<f32>)>,
) -> Accessor {
    let (min, max) = bounds.map_or((None, None), |(lo, hi)| (Some(lo.into()), Some(hi.into())));
    Accessor {
        buffer_view: Some(view),
        byte_offset: Some(USize64(0)),
        count: USize64::from(count),
        component_type: Valid(GenericComponentType(component)),
        type_: Valid(type_),
        min,
        max,
        name: None,
        normalized: false,
        sparse: None,
        extensions: None,
        extras: Default::default(),
    }
}

pub(super) fn read(bytes: &[u8]) -> Result<Mesh, Problem> {
    let (json_chunk, bin) = chunks(bytes)?;
    let root = Root::from_slice(json_chunk).or_else(|e| bad(format!("bad glTF JSON: {e}")))?;

    for (i, node) in root.nodes.iter().enumerate() {
        let identity = node.matrix.is_none_or(|m| {
            m == [
                1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
            ]
        }) && node.translation.is_none_or(|t| t == [0.0; 3])
            && node.rotation.as_ref().is_none_or(|r| r.0 == [0.0, 0.0, 0.0, 1.0])
            && node.scale.is_none_or(|s| s == [1.0; 3]);
        if !identity {
            return bad(format!(
                "node {i} has a transform, and reading glb node transforms is not supported"
            ));
        }
    }

    let mut mesh = Mesh {
        materials: root
            .materials
            .iter()
            .enumerate()
            .map(|(i, m)| MeshMaterial {
                name: m.name.clone().unwrap_or_else(|| format!("material{i}")),
                base_color: m.pbr_metallic_roughness.base_color_factor.0,
            })
            .collect(),
        ..Mesh::default()
    };
    let primitives: Vec<(usize, usize, &Primitive)> = root
        .meshes
        .iter()
        .enumerate()
        .flat_map(|(i, m)| m.primitives.iter().enumerate().map(move |(j, p)| (i, j, p)))
        .collect();
    let normal_key = Valid(Semantic::Normals);
    let uv_key = Valid(Semantic::TexCoords(0));
    let with_normals = !primitives.is_empty() && primitives.iter().all(|p| p.2.attributes.contains_key(&normal_key));
    let with_uvs = !primitives.is_empty() && primitives.iter().all(|p| p.2.attributes.contains_key(&uv_key));

    let mut bases: HashMap<(usize, usize, usize), (u32, usize)> = HashMap::new();
    let mut per_triangle = Vec::new();
    let mut default_slot = None;
    for (i, j, prim) in primitives {
        let at = |m: String| Problem::Bad(format!("mesh {i}, primitive {j}: {m}"));
        if !matches!(prim.mode, Valid(Mode::Triangles)) {
            return Err(at("only triangle primitives are supported".into()));
        }
        let Some(pos) = prim.attributes.get(&Valid(Semantic::Positions)) else {
            return Err(at("no POSITION attribute".into()));
        };
        let normal = prim.attributes.get(&normal_key).filter(|_| with_normals);
        let uv = prim.attributes.get(&uv_key).filter(|_| with_uvs);
        let key = (
            pos.value(),
            normal.map_or(usize::MAX, Index::value),
            uv.map_or(usize::MAX, Index::value),
        );
        let (base, count) = match bases.get(&key) {
            Some(&b) => b,
            None => {
                let p = floats(&root, bin, pos.value(), Type::Vec3).map_err(|m| at(format!("POSITION: {m}")))?;
                let count = p.len() / 3;
                let base = mesh.positions.len();
                if u32::try_from(base + count).is_err() {
                    return Err(at("more vertices than fit in u32 indices".into()));
                }
                mesh.positions.extend(p.chunks_exact(3).map(|c| [c[0], c[1], c[2]]));
                if let Some(a) = normal {
                    let n = floats(&root, bin, a.value(), Type::Vec3).map_err(|m| at(format!("NORMAL: {m}")))?;
                    if n.len() != 3 * count {
                        return Err(at(format!("{} normals for {count} positions", n.len() / 3)));
                    }
                    mesh.normals.extend(n.chunks_exact(3).map(|c| [c[0], c[1], c[2]]));
                }
                if let Some(a) = uv {
                    let t = floats(&root, bin, a.value(), Type::Vec2).map_err(|m| at(format!("TEXCOORD_0: {m}")))?;
                    if t.len() != 2 * count {
                        return Err(at(format!("{} texture coordinates for {count} positions", t.len() / 2)));
                    }
                    mesh.uvs.extend(t.chunks_exact(2).map(|c| [c[0], c[1]]));
                }
                bases.insert(key, (base as u32, count));
                (base as u32, count)
            }
        };
        let indices = match prim.indices {
            Some(a) => indices(&root, bin, a.value()).map_err(|m| at(format!("indices: {m}")))?,
            None => (0..count as u32).collect(),
        };
        if indices.len() % 3 != 0 {
            return Err(at(format!("{} indices do not make whole triangles", indices.len())));
        }
        if let Some(&v) = indices.iter().find(|&&v| v as usize >= count) {
            return Err(at(format!("index {v} is out of range for {count} vertices")));
        }
        let material = match prim.material {
            Some(m) if m.value() < root.materials.len() => m.value() as u32,
            Some(m) => return Err(at(format!("material {} does not exist", m.value()))),
            None => *default_slot.get_or_insert_with(|| {
                mesh.materials.push(default_material("default"));
                mesh.materials.len() as u32 - 1
            }),
        };
        for t in indices.chunks_exact(3) {
            mesh.triangles.push([base + t[0], base + t[1], base + t[2]]);
            per_triangle.push(material);
        }
    }
    mesh.triangle_materials = compact_materials(per_triangle);
    Ok(mesh)
}

/// The JSON chunk and the BIN chunk (empty when there is none).
fn chunks(bytes: &[u8]) -> Result<(&[u8], &[u8]), Problem> {
    let u32_at = |o: usize| bytes.get(o..o + 4).map(|b| u32::from_le_bytes(b.try_into().unwrap()));
    if bytes.len() < 12 || &bytes[..4] != MAGIC {
        return bad("not a glb file (no \"glTF\" header)");
    }
    if u32_at(4) != Some(2) {
        return bad(format!(
            "glb version {} is not supported (only 2)",
            u32_at(4).unwrap_or(0)
        ));
    }
    let length = u32_at(8).unwrap_or(0) as usize;
    if length > bytes.len() {
        return bad(format!(
            "the glb header says {length} bytes but the file has only {} (truncated?)",
            bytes.len()
        ));
    }
    let bytes = &bytes[..length];
    let mut offset = 12;
    let mut found: Vec<(&[u8], &[u8])> = Vec::new();
    while offset < bytes.len() {
        let (Some(len), Some(kind)) = (u32_at(offset), bytes.get(offset + 4..offset + 8)) else {
            return bad(format!("truncated chunk header at byte {offset}"));
        };
        let start = offset + 8;
        let Some(data) = bytes.get(start..start + len as usize) else {
            return bad(format!(
                "the chunk at byte {offset} claims {len} bytes but the file ends first (truncated?)"
            ));
        };
        found.push((kind, data));
        offset = start + len as usize;
    }
    match found.as_slice() {
        [(kind, json), rest @ ..] if *kind == JSON_CHUNK => {
            let bin = rest.first().filter(|(k, _)| *k == BIN_CHUNK).map_or(&[][..], |c| c.1);
            Ok((json, bin))
        }
        _ => bad("the glb's first chunk is not JSON"),
    }
}

/// An accessor's bytes: (element data, stride, element size, count, component type).
fn accessor_data<'a>(
    root: &Root,
    bin: &'a [u8],
    i: usize,
) -> Result<(&'a [u8], usize, ComponentType, Type, usize), String> {
    let a = root.accessors.get(i).ok_or(format!("accessor {i} does not exist"))?;
    if a.sparse.is_some() {
        return Err(format!("accessor {i} is sparse, which is not supported"));
    }
    let (Valid(GenericComponentType(component)), Valid(type_)) = (a.component_type, a.type_) else {
        return Err(format!("accessor {i} has an invalid component type or type"));
    };
    let view_index = a.buffer_view.ok_or(format!("accessor {i} has no buffer view"))?.value();
    let view = root
        .buffer_views
        .get(view_index)
        .ok_or(format!("buffer view {view_index} does not exist"))?;
    let buffer = root
        .buffers
        .get(view.buffer.value())
        .ok_or(format!("buffer {} does not exist", view.buffer.value()))?;
    if view.buffer.value() != 0 || buffer.uri.is_some() {
        return Err("only data in the glb's own BIN chunk is supported".to_string());
    }
    let start = view.byte_offset.map_or(0, |o| o.0) as usize;
    let data = bin
        .get(start..start.saturating_add(view.byte_length.0 as usize))
        .ok_or(format!("buffer view {view_index} lies outside the BIN chunk"))?;
    let data = data
        .get(a.byte_offset.map_or(0, |o| o.0) as usize..)
        .ok_or(format!("accessor {i} starts outside its view"))?;
    let size = component_size(component) * type_.multiplicity();
    let stride = view.byte_stride.map_or(size, |s| s.0);
    let count = a.count.0 as usize;
    if stride < size {
        return Err(format!(
            "accessor {i}: stride {stride} is less than the element size {size}"
        ));
    }
    let needed = if count == 0 {
        0
    } else {
        (count - 1).saturating_mul(stride).saturating_add(size)
    };
    if needed > data.len() {
        return Err(format!(
            "accessor {i}: {count} elements need {needed} bytes but its view has {}",
            data.len()
        ));
    }
    Ok((data, stride, component, type_, count))
}

fn component_size(c: ComponentType) -> usize {
    match c {
        ComponentType::I8 | ComponentType::U8 => 1,
        ComponentType::I16 | ComponentType::U16 => 2,
        ComponentType::U32 | ComponentType::F32 => 4,
    }
}

/// An f32 accessor of type `want`, flattened.
fn floats(root: &Root, bin: &[u8], i: usize, want: Type) -> Result<Vec<f32>, String> {
    let (data, stride, component, type_, count) = accessor_data(root, bin, i)?;
    if component != ComponentType::F32 || type_ != want {
        return Err(format!("accessor {i} is {component:?} {type_:?}, not F32 {want:?}"));
    }
    let k = want.multiplicity();
    let mut out = Vec::with_capacity(count * k);
    for e in 0..count {
        for c in 0..k {
            let o = e * stride + 4 * c;
            out.push(f32::from_le_bytes(data[o..o + 4].try_into().unwrap()));
        }
    }
    Ok(out)
}

/// A scalar unsigned-integer accessor, widened to u32.
fn indices(root: &Root, bin: &[u8], i: usize) -> Result<Vec<u32>, String> {
    let (data, stride, component, type_, count) = accessor_data(root, bin, i)?;
    if type_ != Type::Scalar {
        return Err(format!("accessor {i} is {type_:?}, not Scalar"));
    }
    let read: fn(&[u8]) -> u32 = match component {
        ComponentType::U8 => |b| u32::from(b[0]),
        ComponentType::U16 => |b| u32::from(u16::from_le_bytes([b[0], b[1]])),
        ComponentType::U32 => |b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
        other => return Err(format!("accessor {i} has {other:?} components, not unsigned integers")),
    };
    Ok((0..count).map(|e| read(&data[e * stride..])).collect())
}
