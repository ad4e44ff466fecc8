//! PLY through `ply-rs-bw`: binary little-endian on write (`x y z`, then
//! `nx ny nz` and `s t` when present; faces as `vertex_indices`); ASCII or
//! binary on read.

use std::io::{Cursor, Write};

use ply_rs_bw::parser::Parser;
use ply_rs_bw::ply::{
    Addable, ElementDef, Encoding, Header, Property, PropertyAccess, PropertyDef, PropertyType, ScalarType,
};
use ply_rs_bw::writer::Writer;

use super::{bad, Problem};
use crate::mesh::Mesh;

/// A vertex as written.
struct VertexOut {
    p: [f32; 3],
    n: [f32; 3],
    uv: [f32; 2],
}

impl PropertyAccess for VertexOut {
    fn new() -> Self {
        VertexOut {
            p: [0.0; 3],
            n: [0.0; 3],
            uv: [0.0; 2],
        }
    }

    fn get_float(&self, name: &str) -> Option<f32> {
        Some(match name {
            "x" => self.p[0],
            "y" => self.p[1],
            "z" => self.p[2],
            "nx" => self.n[0],
            "ny" => self.n[1],
            "nz" => self.n[2],
            "s" => self.uv[0],
            "t" => self.uv[1],
            _ => return None,
        })
    }
}

/// A face as written.
struct FaceOut([u32; 3]);

impl PropertyAccess for FaceOut {
    fn new() -> Self {
        FaceOut([0; 3])
    }

    fn get_list_uint(&self, name: &str) -> Option<&[u32]> {
        (name == "vertex_indices").then_some(&self.0[..])
    }
}

pub(super) fn write(w: &mut dyn Write, mesh: &Mesh) -> Result<(), Problem> {
    let float = || PropertyType::Scalar(ScalarType::Float);
    let mut vertex = ElementDef::new("vertex".to_string());
    vertex.count = mesh.positions.len();
    let mut names = vec!["x", "y", "z"];
    if !mesh.normals.is_empty() {
        names.extend(["nx", "ny", "nz"]);
    }
    if !mesh.uvs.is_empty() {
        names.extend(["s", "t"]);
    }
    for name in names {
        vertex.properties.add(PropertyDef::new(name.to_string(), float()));
    }
    let mut face = ElementDef::new("face".to_string());
    face.count = mesh.triangles.len();
    face.properties.add(PropertyDef::new(
        "vertex_indices".to_string(),
        PropertyType::List(ScalarType::UChar, ScalarType::UInt),
    ));
    let mut header = Header::new();
    header.encoding = Encoding::BinaryLittleEndian;
    header.comments.push("written by isoray".to_string());
    header.elements.add(vertex.clone());
    header.elements.add(face.clone());

    let mut w = w;
    Writer::<VertexOut>::new().write_header(&mut w, &header)?;
    let vertices = Writer::<VertexOut>::new();
    for (i, &p) in mesh.positions.iter().enumerate() {
        let v = VertexOut {
            p,
            n: mesh.normals.get(i).copied().unwrap_or_default(),
            uv: mesh.uvs.get(i).copied().unwrap_or_default(),
        };
        vertices.write_little_endian_element(&mut w, &v, &vertex)?;
    }
    let faces = Writer::<FaceOut>::new();
    for &t in &mesh.triangles {
        faces.write_little_endian_element(&mut w, &FaceOut(t), &face)?;
    }
    Ok(())
}

/// A vertex as read: any numeric property types, widened.
struct VertexIn {
    p: [f64; 3],
    n: [f64; 3],
    uv: [f64; 2],
}

/// Property names read as texture coordinates, as (u, v) pairs.
const UV_NAMES: [(&str, &str); 4] = [
    ("s", "t"),
    ("u", "v"),
    ("texture_u", "texture_v"),
    ("texture_s", "texture_t"),
];

impl PropertyAccess for VertexIn {
    fn new() -> Self {
        VertexIn {
            p: [0.0; 3],
            n: [0.0; 3],
            uv: [0.0; 2],
        }
    }

    fn set_property(&mut self, name: &str, property: Property) {
        let Some(x) = scalar(&property) else { return };
        let slot = match name {
            "x" => &mut self.p[0],
            "y" => &mut self.p[1],
            "z" => &mut self.p[2],
            "nx" => &mut self.n[0],
            "ny" => &mut self.n[1],
            "nz" => &mut self.n[2],
            _ if UV_NAMES.iter().any(|(u, _)| *u == name) => &mut self.uv[0],
            _ if UV_NAMES.iter().any(|(_, v)| *v == name) => &mut self.uv[1],
            _ => return,
        };
        *slot = x;
    }
}

fn scalar(p: &Property) -> Option<f64> {
    Some(match *p {
        Property::Char(x) => x.into(),
        Property::UChar(x) => x.into(),
        Property::Short(x) => x.into(),
        Property::UShort(x) => x.into(),
        Property::Int(x) => x.into(),
        Property::UInt(x) => x.into(),
        Property::Float(x) => x.into(),
        Property::Double(x) => x,
        _ => return None,
    })
}

/// A face as read: its vertex indices, whatever their integer type.
struct FaceIn(Vec<i64>);

/// Names of the face element's index list.
const INDEX_NAMES: [&str; 2] = ["vertex_indices", "vertex_index"];

impl PropertyAccess for FaceIn {
    fn new() -> Self {
        FaceIn(Vec::new())
    }

    fn set_property(&mut self, name: &str, property: Property) {
        if !INDEX_NAMES.contains(&name) {
            return;
        }
        self.0 = match property {
            Property::ListChar(l) => l.into_iter().map(i64::from).collect(),
            Property::ListUChar(l) => l.into_iter().map(i64::from).collect(),
            Property::ListShort(l) => l.into_iter().map(i64::from).collect(),
            Property::ListUShort(l) => l.into_iter().map(i64::from).collect(),
            Property::ListInt(l) => l.into_iter().map(i64::from).collect(),
            Property::ListUInt(l) => l.into_iter().map(i64::from).collect(),
            _ => return,
        };
    }
}

/// Any other element, read and dropped.
struct Skip;

impl PropertyAccess for Skip {
    fn new() -> Self {
        Skip
    }
}

pub(super) fn read(bytes: &[u8]) -> Result<Mesh, Problem> {
    let mut reader = Cursor::new(bytes);
    let header = Parser::<Skip>::new()
        .read_header(&mut reader)
        .or_else(|e| bad(format!("bad PLY header: {e}")))?;

    let Some(vertex) = header.elements.get("vertex") else {
        return bad("bad PLY header: no \"vertex\" element");
    };
    let has = |def: &ElementDef, name: &str| matches!(def.properties.get(name), Some(p) if matches!(p.data_type, PropertyType::Scalar(_)));
    if let Some(missing) = ["x", "y", "z"].into_iter().find(|n| !has(vertex, n)) {
        return bad(format!(
            "bad PLY header: the vertex element has no scalar property {missing:?}"
        ));
    }
    let has_normals = ["nx", "ny", "nz"].iter().all(|n| has(vertex, n));
    let has_uvs = UV_NAMES.iter().any(|(u, v)| has(vertex, u) && has(vertex, v));
    if let Some(face) = header.elements.get("face") {
        let list = INDEX_NAMES.iter().find_map(|n| face.properties.get(*n));
        let ok = matches!(list, Some(p) if matches!(
            p.data_type,
            PropertyType::List(_, ScalarType::Char | ScalarType::UChar | ScalarType::Short | ScalarType::UShort | ScalarType::Int | ScalarType::UInt)
        ));
        if !ok {
            return bad("bad PLY header: the face element has no integer list property \"vertex_indices\"");
        }
    }

    let mut vertices = Vec::new();
    let mut faces = Vec::new();
    for (name, def) in &header.elements {
        let failed = |e: std::io::Error| Problem::Bad(format!("cannot read the {name:?} elements: {e}"));
        match name.as_str() {
            "vertex" => {
                vertices = Parser::<VertexIn>::new()
                    .read_payload_for_element(&mut reader, def, &header)
                    .map_err(failed)?
            }
            "face" => {
                faces = Parser::<FaceIn>::new()
                    .read_payload_for_element(&mut reader, def, &header)
                    .map_err(failed)?
            }
            _ => {
                Parser::<Skip>::new()
                    .read_payload_for_element(&mut reader, def, &header)
                    .map_err(failed)?;
            }
        }
    }

    let n = vertices.len();
    if u32::try_from(n).is_err() {
        return bad(format!("{n} vertices are more than fit in u32 indices"));
    }
    let mut mesh = Mesh::default();
    for (i, v) in vertices.iter().enumerate() {
        let p = v.p.map(|c| c as f32);
        if !p.iter().all(|c| c.is_finite()) {
            return bad(format!("vertex {i} has a non-finite position {:?}", v.p));
        }
        mesh.positions.push(p);
    }
    if has_normals {
        mesh.normals = vertices.iter().map(|v| v.n.map(|c| c as f32)).collect();
    }
    if has_uvs {
        mesh.uvs = vertices.iter().map(|v| v.uv.map(|c| c as f32)).collect();
    }
    for (i, FaceIn(f)) in faces.iter().enumerate() {
        if let Some(&v) = f.iter().find(|&&v| v < 0 || v as u64 >= n as u64) {
            return bad(format!("face {i} refers to vertex {v} but the file has {n} vertices"));
        }
        // Points and edges (fewer than three corners) carry no triangles.
        for k in 2..f.len() {
            mesh.triangles.push([f[0] as u32, f[k - 1] as u32, f[k] as u32]);
        }
    }
    Ok(mesh)
}
