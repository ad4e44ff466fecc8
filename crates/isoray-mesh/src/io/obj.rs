//! Wavefront OBJ: written as text by hand (floats in shortest round-trip
//! form, so f32 values come back exactly); read with `tobj`, after a scan
//! here that checks every line and index (with line numbers in the
//! messages) and collects the material assignments.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::fs;
use std::io::Write;
use std::path::Path;

use super::{bad, compact_materials, default_material, material_of, Problem};
use crate::mesh::{Mesh, MeshMaterial};

pub(super) fn write(w: &mut dyn Write, mesh: &Mesh, mtllib: Option<&str>) -> Result<(), Problem> {
    writeln!(
        w,
        "# written by isoray: {} vertices, {} triangles",
        mesh.positions.len(),
        mesh.triangles.len()
    )?;
    if let Some(lib) = mtllib {
        writeln!(w, "mtllib {lib}")?;
    }
    for p in &mesh.positions {
        writeln!(w, "v {} {} {}", p[0], p[1], p[2])?;
    }
    for t in &mesh.uvs {
        writeln!(w, "vt {} {}", t[0], t[1])?;
    }
    for n in &mesh.normals {
        writeln!(w, "vn {} {} {}", n[0], n[1], n[2])?;
    }
    let names = material_names(&mesh.materials);
    let (has_uv, has_n) = (!mesh.uvs.is_empty(), !mesh.normals.is_empty());
    let mut current = None;
    for (i, t) in mesh.triangles.iter().enumerate() {
        if !names.is_empty() {
            let m = material_of(mesh, i);
            if current != Some(m) {
                writeln!(w, "usemtl {}", names[m as usize])?;
                current = Some(m);
            }
        }
        w.write_all(b"f")?;
        for &v in t {
            let v = v + 1;
            match (has_uv, has_n) {
                (true, true) => write!(w, " {v}/{v}/{v}")?,
                (true, false) => write!(w, " {v}/{v}")?,
                (false, true) => write!(w, " {v}//{v}")?,
                (false, false) => write!(w, " {v}")?,
            }
        }
        w.write_all(b"\n")?;
    }
    Ok(())
}

/// The material library for [`write`]: `Kd` is the base colour's RGB and `d` its alpha.
pub(super) fn write_mtl(w: &mut dyn Write, mesh: &Mesh) -> Result<(), Problem> {
    writeln!(w, "# written by isoray: {} materials", mesh.materials.len())?;
    for (name, m) in material_names(&mesh.materials).iter().zip(&mesh.materials) {
        let c = m.base_color;
        writeln!(w, "\nnewmtl {name}\nKd {} {} {}\nd {}", c[0], c[1], c[2], c[3])?;
    }
    Ok(())
}

/// Material names as OBJ can carry them: one line, trimmed, non-empty, unique.
fn material_names(materials: &[MeshMaterial]) -> Vec<String> {
    let mut seen = HashMap::new();
    materials
        .iter()
        .enumerate()
        .map(|(i, m)| {
            let clean: String = m.name.chars().map(|c| if c.is_control() { '_' } else { c }).collect();
            let mut name = clean.trim().to_string();
            if name.is_empty() {
                name = format!("material{i}");
            }
            if seen.contains_key(&name) {
                name = format!("{name}_{i}");
            }
            seen.insert(name.clone(), ());
            name
        })
        .collect()
}

/// What a face corner refers to: (singular, plural) for messages.
const VERTEX: (&str, &str) = ("vertex", "vertices");
const TEXCOORD: (&str, &str) = ("texture coordinate", "texture coordinates");
const NORMAL: (&str, &str) = ("normal", "normals");

/// Resolves a 1-based (or negative, relative) OBJ index to a 0-based one.
fn resolve(line: usize, token: &str, before: usize, total: usize, what: (&str, &str)) -> Result<usize, Problem> {
    let Ok(x) = token.parse::<i64>() else {
        return bad(format!("line {line}: cannot read {} index {token:?}", what.0));
    };
    if x > 0 {
        let i = (x - 1) as u64;
        if i >= total as u64 {
            return bad(format!(
                "line {line}: face refers to {} {x} but the file has {total} {}",
                what.0, what.1
            ));
        }
        Ok(i as usize)
    } else if x < 0 {
        let i = before as i64 + x;
        if i < 0 {
            return bad(format!(
                "line {line}: face refers to {} {x} (relative) but only {before} {} precede it",
                what.0, what.1
            ));
        }
        Ok(i as usize)
    } else {
        bad(format!(
            "line {line}: face refers to {} 0 but OBJ indices start at 1",
            what.0
        ))
    }
}

/// Checks that `words` holds at least `n` finite numbers.
fn numbers(line: usize, words: &[&str], n: usize, what: &str) -> Result<(), Problem> {
    let ok = words.len() >= n && words[..n].iter().all(|w| w.parse::<f32>().is_ok_and(f32::is_finite));
    if ok {
        Ok(())
    } else {
        bad(format!(
            "line {line}: {what} needs {n} finite numbers, got {:?}",
            words.join(" ")
        ))
    }
}

/// The text after a line's first word, trimmed.
fn rest(line: &str) -> &str {
    let line = line.trim_start();
    line.find(char::is_whitespace).map_or("", |i| line[i..].trim())
}

pub(super) fn read(bytes: &[u8], path: &Path) -> Result<Mesh, Problem> {
    let text = String::from_utf8_lossy(bytes);
    let (mut nv, mut nvt, mut nvn, mut has_usemtl) = (0usize, 0usize, 0usize, false);
    for line in text.lines() {
        match line.split_whitespace().next() {
            Some("v") => nv += 1,
            Some("vt") => nvt += 1,
            Some("vn") => nvn += 1,
            Some("usemtl") => has_usemtl = true,
            _ => {}
        }
    }
    if u32::try_from(nv).is_err() {
        return bad(format!("{nv} vertices are more than fit in u32 indices"));
    }

    // Check every line and collect the lines tobj is to read. Its first face
    // uses every vertex in order, so that tobj numbers them as the file does.
    let mut input = String::with_capacity(text.len() + 8 * nv);
    if nv > 0 {
        input.push('f');
        for i in 1..=nv {
            write!(input, " {i}").expect("writing to a String");
        }
        input.push('\n');
    }
    let (mut cv, mut cvt, mut cvn) = (0usize, 0usize, 0usize);
    let (mut all_vt, mut all_vn) = (true, true);
    let mut keys: Vec<String> = Vec::new();
    let mut key_index: HashMap<String, u32> = HashMap::new();
    let mut current: Option<u32> = None;
    let mut face_keys: Vec<Option<u32>> = Vec::new();
    let mut mtllibs: Vec<String> = Vec::new();
    let mut key = |name: &str, keys: &mut Vec<String>| {
        *key_index.entry(name.to_string()).or_insert_with(|| {
            keys.push(name.to_string());
            keys.len() as u32 - 1
        })
    };
    // Appends "head a b c ..." to the input.
    let push = |input: &mut String, head: &str, words: &[&str]| {
        input.push_str(head);
        for w in words {
            input.push(' ');
            input.push_str(w);
        }
        input.push('\n');
    };
    let mut words: Vec<&str> = Vec::new();
    for (l, line) in text.lines().enumerate() {
        let l = l + 1;
        words.clear();
        words.extend(line.split_whitespace());
        let Some((&head, args)) = words.split_first() else {
            continue;
        };
        match head {
            "v" => {
                numbers(l, args, 3, "a vertex")?;
                // Vertex colours are dropped (tobj wants them on every vertex or none).
                match args.len() {
                    3 | 6 => push(&mut input, "v", &args[..3]),
                    4 if args[3].parse::<f32>().is_ok_and(|w| w.is_finite() && w != 0.0) => push(&mut input, "v", args),
                    _ => {
                        return bad(format!(
                            "line {l}: a vertex needs x y z [w] or x y z r g b, got {:?}",
                            args.join(" ")
                        ))
                    }
                }
                cv += 1;
            }
            "vt" => {
                numbers(l, args, 1, "a texture coordinate")?;
                let v = args
                    .get(1)
                    .filter(|v| v.parse::<f32>().is_ok_and(f32::is_finite))
                    .unwrap_or(&"0");
                push(&mut input, "vt", &[args[0], v]);
                cvt += 1;
            }
            "vn" => {
                numbers(l, args, 3, "a normal")?;
                push(&mut input, "vn", &args[..3]);
                cvn += 1;
            }
            "f" => {
                for corner in args {
                    let mut parts = corner.split('/');
                    let (v, t, n) = (parts.next().unwrap_or(""), parts.next(), parts.next());
                    if v.is_empty() || parts.next().is_some() {
                        return bad(format!("line {l}: cannot read face corner {corner:?}"));
                    }
                    resolve(l, v, cv, nv, VERTEX)?;
                    match t {
                        Some(t) if !t.is_empty() => {
                            resolve(l, t, cvt, nvt, TEXCOORD)?;
                        }
                        _ => all_vt &= args.len() < 3,
                    }
                    match n {
                        Some(n) if !n.is_empty() => {
                            resolve(l, n, cvn, nvn, NORMAL)?;
                        }
                        _ => all_vn &= args.len() < 3,
                    }
                }
                face_keys.push(current);
                push(&mut input, "f", args);
            }
            "usemtl" => {
                let name = rest(line);
                if name.is_empty() {
                    return bad(format!("line {l}: usemtl names no material"));
                }
                current = Some(key(name, &mut keys));
            }
            "g" | "o" if !has_usemtl => {
                let name = rest(line);
                current = Some(key(if name.is_empty() { "default" } else { name }, &mut keys));
            }
            "mtllib" => mtllibs.push(rest(line).to_string()),
            _ => {}
        }
    }
    let use_uvs = nvt > 0 && all_vt;
    let use_normals = nvn > 0 && all_vn;

    // The defaults: no triangulation (face_arities tells the polygons), one
    // index list each for positions, texture coordinates and normals.
    let options = tobj::LoadOptions::default();
    let (models, _) = tobj::load_obj_buf(&mut input.as_bytes(), &options, |_| Ok(Default::default()))
        .or_else(|e| bad(format!("tobj: {e}")))?;
    let empty = tobj::Mesh::default();
    let m = models.first().map_or(&empty, |model| &model.mesh);
    if m.positions.len() != 3 * nv {
        return bad(format!("tobj read {} coordinates for {nv} vertices", m.positions.len()));
    }

    let mut mesh = Mesh {
        positions: m.positions.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect(),
        ..Mesh::default()
    };
    let missing = || Problem::Bad("tobj's face data do not match the file's faces".to_string());
    let uv_of = |j: usize| -> Result<[f32; 2], Problem> {
        if !use_uvs {
            return Ok([0.0; 2]);
        }
        let t = *m.texcoord_indices.get(j).ok_or_else(missing)? as usize;
        let c = m.texcoords.get(2 * t..2 * t + 2).ok_or_else(missing)?;
        Ok([c[0], c[1]])
    };
    let normal_of = |j: usize| -> Result<[f32; 3], Problem> {
        if !use_normals {
            return Ok([0.0; 3]);
        }
        let t = *m.normal_indices.get(j).ok_or_else(missing)? as usize;
        let c = m.normals.get(3 * t..3 * t + 3).ok_or_else(missing)?;
        Ok([c[0], c[1], c[2]])
    };

    // Each position takes the attributes of its first corner; a corner with
    // other ones gets a copy of the position, appended.
    let mut attrs: Vec<Option<([f32; 2], [f32; 3])>> = vec![None; nv];
    let mut copies: HashMap<(u32, [u32; 2], [u32; 3]), u32> = HashMap::new();
    let mut uvs = Vec::new();
    let mut normals = Vec::new();
    let arities: Vec<usize> = if m.face_arities.is_empty() {
        vec![3; m.indices.len() / 3]
    } else {
        m.face_arities.iter().map(|&a| a as usize).collect()
    };
    let skip = usize::from(nv > 0);
    if arities.len() != skip + face_keys.len() {
        return Err(missing());
    }
    let mut j = arities.first().filter(|_| nv > 0).copied().unwrap_or(0);
    let mut tri_keys = Vec::new();
    let mut corners = Vec::new();
    for (&a, &face_key) in arities[skip..].iter().zip(&face_keys) {
        corners.clear();
        for _ in 0..a {
            let v = *m.indices.get(j).ok_or_else(missing)?;
            let (uv, n) = (uv_of(j)?, normal_of(j)?);
            j += 1;
            let slot = attrs.get_mut(v as usize).ok_or_else(missing)?;
            let bits = (uv.map(f32::to_bits), n.map(f32::to_bits));
            let index = match slot {
                None => {
                    *slot = Some((uv, n));
                    v
                }
                Some((u0, n0)) if (u0.map(f32::to_bits), n0.map(f32::to_bits)) == bits => v,
                Some(_) => *copies.entry((v, bits.0, bits.1)).or_insert_with(|| {
                    mesh.positions.push(mesh.positions[v as usize]);
                    uvs.push(uv);
                    normals.push(n);
                    mesh.positions.len() as u32 - 1
                }),
            };
            corners.push(index);
        }
        for k in 2..corners.len() {
            mesh.triangles.push([corners[0], corners[k - 1], corners[k]]);
            tri_keys.push(face_key);
        }
    }
    if u32::try_from(mesh.positions.len()).is_err() {
        return bad("too many vertices after splitting those with several normals or texture coordinates");
    }
    let first_attrs = attrs.iter().map(|a| a.unwrap_or_default());
    if use_uvs {
        mesh.uvs = first_attrs.clone().map(|a| a.0).chain(uvs).collect();
    }
    if use_normals {
        mesh.normals = first_attrs.map(|a| a.1).chain(normals).collect();
    }

    // Materials: with any face assigned, every key (and, for usemtl, every
    // material in the libraries), coloured from the libraries.
    if tri_keys.iter().any(Option::is_some) {
        let library = if has_usemtl {
            load_libraries(path, &mtllibs)
        } else {
            Vec::new()
        };
        let mut index: HashMap<String, u32> = HashMap::new();
        for mat in library {
            if !index.contains_key(&mat.name) {
                index.insert(mat.name.clone(), mesh.materials.len() as u32);
                mesh.materials.push(mat);
            }
        }
        let default_key = tri_keys.iter().any(Option::is_none).then(|| key("default", &mut keys));
        let mut slot = |name: &str, materials: &mut Vec<MeshMaterial>| {
            *index.entry(name.to_string()).or_insert_with(|| {
                materials.push(default_material(name));
                materials.len() as u32 - 1
            })
        };
        let key_material: Vec<u32> = keys.iter().map(|k| slot(k, &mut mesh.materials)).collect();
        let per_triangle = tri_keys
            .iter()
            .map(|k| key_material[k.or(default_key).unwrap_or(0) as usize])
            .collect();
        mesh.triangle_materials = compact_materials(per_triangle);
    }
    Ok(mesh)
}

/// The materials of the `.mtl` libraries that can be read (with tobj, after
/// keeping only well-formed `newmtl`, `Kd` and `d` lines); the others are
/// skipped, leaving their materials the default colour.
fn load_libraries(obj: &Path, libs: &[String]) -> Vec<MeshMaterial> {
    let dir = obj.parent().unwrap_or(Path::new(""));
    let mut out = Vec::new();
    for lib in libs {
        let Ok(bytes) = fs::read(dir.join(lib)) else { continue };
        let text = String::from_utf8_lossy(&bytes);
        let mut clean = String::new();
        for line in text.lines() {
            let words: Vec<&str> = line.split_whitespace().collect();
            let finite = |w: &&str| w.parse::<f32>().is_ok_and(f32::is_finite);
            match words.split_first() {
                Some((&"newmtl", _)) if !rest(line).is_empty() => clean.push_str(&format!("newmtl {}\n", rest(line))),
                Some((&"Kd", c)) if c.len() >= 3 && c[..3].iter().all(finite) => {
                    clean.push_str(&format!("Kd {} {} {}\n", c[0], c[1], c[2]))
                }
                Some((&"d", a)) if !a.is_empty() && finite(&a[0]) => clean.push_str(&format!("d {}\n", a[0])),
                _ => {}
            }
        }
        let Ok((materials, _)) = tobj::load_mtl_buf(&mut clean.as_bytes()) else {
            continue;
        };
        out.extend(materials.into_iter().map(|m| {
            let [r, g, b] = m.diffuse.unwrap_or([
                super::DEFAULT_BASE_COLOR[0],
                super::DEFAULT_BASE_COLOR[1],
                super::DEFAULT_BASE_COLOR[2],
            ]);
            MeshMaterial {
                name: m.name,
                base_color: [r, g, b, m.dissolve.unwrap_or(1.0)],
            }
        }));
    }
    out
}
