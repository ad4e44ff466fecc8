//! STL through `stl_io`: binary on write; binary or ASCII on read, welded by
//! exact position.

use std::collections::HashMap;
use std::io::{Cursor, Write};

use stl_io::{Normal, Triangle, Vertex};

use super::{bad, face_normal, Problem};
use crate::mesh::Mesh;

/// Binary STL: 80-byte header, u32 triangle count, 50 bytes per triangle.
const HEADER: usize = 84;
const RECORD: u64 = 50;

pub(super) fn write(w: &mut dyn Write, mesh: &Mesh) -> Result<(), Problem> {
    if u32::try_from(mesh.triangles.len()).is_err() {
        return Err(Problem::Mesh(format!(
            "{} triangles are more than a binary STL can hold",
            mesh.triangles.len()
        )));
    }
    let triangles = mesh.triangles.iter().map(|t| {
        let p = t.map(|v| mesh.positions[v as usize]);
        Triangle {
            normal: Normal::new(face_normal(p)),
            vertices: p.map(Vertex::new),
        }
    });
    let mut w = w;
    stl_io::write_stl(&mut w, triangles)?;
    Ok(())
}

pub(super) fn read(bytes: &[u8]) -> Result<Mesh, Problem> {
    // stl_io decides by a leading "solid ", which some binary files have too
    // and some ASCII files lack (a bare "solid" line): decide here, by size.
    let ascii = if is_binary(bytes)? {
        None
    } else {
        // ASCII: make sure the first line reads "solid <name>" for stl_io.
        let start = bytes
            .iter()
            .position(|b| !b.is_ascii_whitespace())
            .unwrap_or(bytes.len());
        let end = bytes[start..]
            .iter()
            .position(|&b| b == b'\n')
            .map_or(bytes.len(), |e| start + e);
        let mut text = b"solid \n".to_vec();
        if end < bytes.len() {
            text.extend_from_slice(&bytes[end + 1..]);
        }
        Some(text)
    };
    let mut binary_copy;
    let mut cursor = match &ascii {
        Some(text) => Cursor::new(text.as_slice()),
        None if bytes.starts_with(b"solid ") => {
            // The header is free text; blank it so stl_io reads binary.
            binary_copy = bytes.to_vec();
            binary_copy[..5].fill(b' ');
            Cursor::new(binary_copy.as_slice())
        }
        None => Cursor::new(bytes),
    };
    let kind = if ascii.is_some() { "ASCII STL" } else { "binary STL" };
    let reader = stl_io::create_stl_reader(&mut cursor).or_else(|e| bad(format!("{kind}: {e}")))?;

    let mut mesh = Mesh::default();
    let mut index: HashMap<[u32; 3], u32> = HashMap::new();
    for (i, t) in reader.enumerate() {
        let t = t.or_else(|e| bad(format!("{kind}: triangle {i}: {e}")))?;
        let mut tri = [0u32; 3];
        for (k, v) in t.vertices.iter().enumerate() {
            let p = v.0;
            if !p.iter().all(|c| c.is_finite()) {
                return bad(format!("{kind}: triangle {i} has a non-finite vertex {p:?}"));
            }
            // Weld by exact position, with -0 and +0 the same.
            let key = p.map(|c| (c + 0.0).to_bits());
            let next = mesh.positions.len();
            tri[k] = *index.entry(key).or_insert_with(|| {
                mesh.positions.push(p);
                next as u32
            });
        }
        mesh.triangles.push(tri);
    }
    if u32::try_from(mesh.positions.len()).is_err() {
        return bad("the file has more distinct vertices than fit in u32 indices");
    }
    Ok(mesh)
}

/// Whether `bytes` is a binary STL: its size matches the triangle count in
/// its header, or it does not start like an ASCII one. A binary file too
/// short for its count is reported as truncated.
fn is_binary(bytes: &[u8]) -> Result<bool, Problem> {
    let count = (bytes.len() >= HEADER).then(|| u32::from_le_bytes(bytes[80..84].try_into().unwrap()));
    let expected = count.map(|n| HEADER as u64 + RECORD * u64::from(n));
    if expected == Some(bytes.len() as u64) {
        return Ok(true);
    }
    let text = bytes.trim_ascii_start();
    if text.starts_with(b"solid") && text.get(5).is_none_or(|b| b.is_ascii_whitespace()) {
        return Ok(false);
    }
    match (count, expected) {
        (Some(n), Some(e)) if (bytes.len() as u64) < e => bad(format!(
            "binary STL header promises {n} triangles ({e} bytes) but the file has only {} bytes (truncated?)",
            bytes.len()
        )),
        (Some(_), _) => Ok(true),
        (None, _) => bad(format!(
            "{} bytes are too few for a binary STL (at least {HEADER}) and the file does not start with \"solid\"",
            bytes.len()
        )),
    }
}
