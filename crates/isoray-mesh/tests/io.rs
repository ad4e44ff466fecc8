//! Mesh files: round trips through every format, atomic writes, and
//! malformed input turned into errors that name the file.

use std::fs;
use std::path::{Path, PathBuf};

use isoray_mesh::io::{self, Format, MeshIoError, DEFAULT_BASE_COLOR};
use isoray_mesh::{Mesh, MeshMaterial};

/// A fresh, empty directory for one test.
fn scratch(test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("isoray-mesh-io-{}-{test}", std::process::id()));
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir).unwrap();
    dir
}

/// A box with flat-shaded faces: 24 vertices (4 per face, so each corner
/// position appears three times), per-face normals, uvs, and two materials
/// alternating by face. Coordinates are not exactly representable in
/// decimal, to test f32 round trips.
fn cube() -> Mesh {
    let (lo, hi) = ([-0.1f32, 0.2, -0.3], [0.7f32, 1.1, 0.9]);
    let corner = |i: usize| {
        [
            [lo[0], hi[0]][i & 1],
            [lo[1], hi[1]][(i >> 1) & 1],
            [lo[2], hi[2]][(i >> 2) & 1],
        ]
    };
    // Faces as quads wound counter-clockwise from outside, with their normals.
    let quads: [([usize; 4], [f32; 3]); 6] = [
        ([0, 2, 3, 1], [0.0, 0.0, -1.0]),
        ([4, 5, 7, 6], [0.0, 0.0, 1.0]),
        ([0, 1, 5, 4], [0.0, -1.0, 0.0]),
        ([2, 6, 7, 3], [0.0, 1.0, 0.0]),
        ([0, 4, 6, 2], [-1.0, 0.0, 0.0]),
        ([1, 3, 7, 5], [1.0, 0.0, 0.0]),
    ];
    let mut m = Mesh::default();
    for (f, (q, n)) in quads.iter().enumerate() {
        let base = m.positions.len() as u32;
        for (k, &c) in q.iter().enumerate() {
            m.positions.push(corner(c));
            m.normals.push(*n);
            m.uvs
                .push([(k == 1 || k == 2) as u8 as f32 / 3.0, (k >= 2) as u8 as f32 * 0.7]);
        }
        m.triangles.push([base, base + 1, base + 2]);
        m.triangles.push([base, base + 2, base + 3]);
        m.triangle_materials.extend([(f % 2) as u32; 2]);
    }
    m.materials = vec![
        MeshMaterial {
            name: "red paint".into(),
            base_color: [0.9, 0.1, 0.05, 1.0],
        },
        MeshMaterial {
            name: "glass".into(),
            base_color: [0.2, 0.3, 0.9, 0.25],
        },
    ];
    m
}

/// The bits of an f32 array, for exact comparisons.
fn bits<const N: usize>(v: [f32; N]) -> [u32; N] {
    v.map(f32::to_bits)
}

/// Every triangle as its corner positions (bits), in order.
fn triangle_positions(m: &Mesh) -> Vec<[[u32; 3]; 3]> {
    m.triangles
        .iter()
        .map(|t| t.map(|v| bits(m.positions[v as usize])))
        .collect()
}

/// The material index of each triangle.
fn materials_per_triangle(m: &Mesh) -> Vec<u32> {
    (0..m.triangles.len())
        .map(|i| m.triangle_materials.get(i).copied().unwrap_or(0))
        .collect()
}

/// Asserts `b` is `a` exactly: positions, normals and uvs bit for bit,
/// triangles, materials and their assignment.
fn assert_same(a: &Mesh, b: &Mesh) {
    assert_eq!(
        a.positions.iter().map(|p| bits(*p)).collect::<Vec<_>>(),
        b.positions.iter().map(|p| bits(*p)).collect::<Vec<_>>()
    );
    assert_eq!(
        a.normals.iter().map(|p| bits(*p)).collect::<Vec<_>>(),
        b.normals.iter().map(|p| bits(*p)).collect::<Vec<_>>()
    );
    assert_eq!(
        a.uvs.iter().map(|p| bits(*p)).collect::<Vec<_>>(),
        b.uvs.iter().map(|p| bits(*p)).collect::<Vec<_>>()
    );
    assert_eq!(a.triangles, b.triangles);
    assert_eq!(a.materials, b.materials);
    assert_eq!(materials_per_triangle(a), materials_per_triangle(b));
}

/// The error's message, asserted to name `path`'s file.
fn message_naming(err: MeshIoError, path: &Path) -> String {
    let msg = err.to_string();
    let name = path.file_name().unwrap().to_str().unwrap();
    assert!(msg.contains(name), "{msg:?} does not name {name}");
    msg
}

/// Files in `dir` whose names mark them as temporaries.
fn temporaries(dir: &Path) -> Vec<String> {
    fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".tmp-"))
        .collect()
}

#[test]
fn formats_come_from_extensions_in_any_case() {
    assert_eq!(Format::from_path(Path::new("a/b.STL")).unwrap(), Format::Stl);
    assert_eq!(Format::from_path(Path::new("m.obj")).unwrap(), Format::Obj);
    assert_eq!(Format::from_path(Path::new("m.Ply")).unwrap(), Format::Ply);
    assert_eq!(Format::from_path(Path::new("scene.glb")).unwrap(), Format::Glb);
    for bad in ["mesh.gltf", "mesh", "mesh.stl.bak"] {
        let msg = Format::from_path(Path::new(bad)).unwrap_err().to_string();
        assert!(msg.contains(bad) && msg.contains(".stl, .obj, .ply, .glb"), "{msg}");
    }
    let msg = io::read(Path::new("nowhere/thing.xyz")).unwrap_err().to_string();
    assert!(msg.contains("thing.xyz"), "{msg}");
}

#[test]
fn stl_round_trip_welds_by_exact_position() {
    let dir = scratch("stl");
    let path = dir.join("cube.stl");
    let m = cube();
    io::write(&path, &m).unwrap();
    assert_eq!(fs::metadata(&path).unwrap().len(), 84 + 50 * 12);
    let back = io::read(&path).unwrap();
    // STL keeps triangles (in order) but not vertex identity: the 24
    // vertices weld to the box's 8 corners.
    assert_eq!(back.positions.len(), 8);
    assert_eq!(triangle_positions(&back), triangle_positions(&m));
    assert!(back.normals.is_empty() && back.uvs.is_empty() && back.materials.is_empty());
    assert!(back.topology().is_closed_manifold());
    assert!((back.volume() - m.volume()).abs() < 1e-9);

    // The same through write_to, and the face normals stl_io wrote.
    let mut bytes = Vec::new();
    io::write_to(Format::Stl, &mut bytes, &m).unwrap();
    assert_eq!(bytes, fs::read(&path).unwrap());
    let first_normal: Vec<f32> = bytes[84..96]
        .chunks(4)
        .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
        .collect();
    assert_eq!(first_normal, [0.0, 0.0, -1.0]);
    fs::remove_dir_all(dir).unwrap();
}

#[test]
fn ascii_stl_is_read_and_welded() {
    let dir = scratch("stl-ascii");
    // A bare "solid" line, as many exporters write; two triangles sharing an edge.
    let text = "solid\n\
        facet normal 0 0 1\n outer loop\n  vertex 0 0 0\n  vertex 1 0 0\n  vertex 1 1 0\n endloop\nendfacet\n\
        facet normal 0 0 1\n outer loop\n  vertex 0 0 0\n  vertex 1 1 0\n  vertex 0 1 0.5e-1\n endloop\nendfacet\n\
        endsolid\n";
    let path = dir.join("quad.STL");
    fs::write(&path, text).unwrap();
    let m = io::read(&path).unwrap();
    assert_eq!(
        m.positions,
        vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.05]]
    );
    assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    fs::remove_dir_all(dir).unwrap();
}

#[test]
fn obj_round_trip_keeps_indices_normals_uvs_and_material_colours() {
    let dir = scratch("obj");
    let path = dir.join("cube.obj");
    let m = cube();
    io::write(&path, &m).unwrap();
    let text = fs::read_to_string(&path).unwrap();
    assert!(text.contains("mtllib cube.mtl\n"), "{text}");
    assert!(
        text.contains("usemtl red paint\n") && text.contains("f 1/1/1 2/2/2 3/3/3\n"),
        "{text}"
    );
    assert!(dir.join("cube.mtl").exists());
    let back = io::read(&path).unwrap();
    assert_same(&m, &back);
    assert!(temporaries(&dir).is_empty());
    fs::remove_dir_all(dir).unwrap();
}

#[test]
fn obj_without_its_library_gets_default_colours() {
    let dir = scratch("obj-no-mtl");
    let mut m = cube();
    m.normals.clear();
    let mut bytes = Vec::new();
    io::write_to(Format::Obj, &mut bytes, &m).unwrap();
    let text = String::from_utf8(bytes).unwrap();
    assert!(!text.contains("mtllib") && text.contains("f 1/1 2/2 3/3\n"), "{text}");
    let path = dir.join("cube.obj");
    fs::write(&path, text).unwrap();
    let back = io::read(&path).unwrap();
    let names: Vec<&str> = back.materials.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["red paint", "glass"]);
    assert!(back.materials.iter().all(|m| m.base_color == DEFAULT_BASE_COLOR));
    assert!(back.normals.is_empty());
    assert_eq!(materials_per_triangle(&back), materials_per_triangle(&m));
    assert_eq!(back.positions, m.positions);
    assert_eq!(back.uvs, m.uvs);
    assert_eq!(back.triangles, m.triangles);
    fs::remove_dir_all(dir).unwrap();
}

#[test]
fn obj_polygons_fan_relative_indices_resolve_and_shared_positions_split() {
    let dir = scratch("obj-polygons");
    let path = dir.join("shapes.obj");
    // A pentagon fan, then a triangle using relative indices whose corner 1
    // has a different normal than in the pentagon (so it is split), a line
    // and a point (ignored), and an unused vertex (kept).
    let text = "# test\n\
        o shapes\n\
        v 0 0 0\nv 1 0 0\nv 1.5 1 0\nv 0.5 2 0\nv -0.5 1 0\nv 9 9 9\n\
        vn 0 0 1\nvn 0 1 0\n\
        f 1//1 2//1 3//1 4//1 5//1\n\
        f -6//-1 -5//-1 -2//-1\n\
        l 1 2\nf 1 2\n";
    fs::write(&path, text).unwrap();
    let m = io::read(&path).unwrap();
    assert_eq!(m.positions.len(), 6 + 3);
    assert_eq!(
        &m.positions[..6],
        &[
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.5, 1.0, 0.0],
            [0.5, 2.0, 0.0],
            [-0.5, 1.0, 0.0],
            [9.0, 9.0, 9.0]
        ]
    );
    assert_eq!(&m.triangles[..3], &[[0, 1, 2], [0, 2, 3], [0, 3, 4]]);
    assert_eq!(m.triangles[3], [6, 7, 8]);
    assert_eq!(&m.positions[6..], &[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [-0.5, 1.0, 0.0]]);
    assert_eq!(m.normals[0], [0.0, 0.0, 1.0]);
    assert_eq!(m.normals[7], [0.0, 1.0, 0.0]);
    // One object, no usemtl: the object's name is the single material.
    assert_eq!(
        m.materials,
        vec![MeshMaterial {
            name: "shapes".into(),
            base_color: DEFAULT_BASE_COLOR
        }]
    );
    assert!(m.triangle_materials.is_empty());
    fs::remove_dir_all(dir).unwrap();
}

#[test]
fn ply_round_trip_is_exact() {
    let dir = scratch("ply");
    let path = dir.join("cube.ply");
    let mut m = cube();
    io::write(&path, &m).unwrap();
    let bytes = fs::read(&path).unwrap();
    let header_end = bytes.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
    let header = std::str::from_utf8(&bytes[..header_end]).unwrap();
    assert!(header.contains("format binary_little_endian 1.0"), "{header}");
    assert!(
        header.contains("property float nx") && header.contains("property float t"),
        "{header}"
    );
    assert!(header.contains("property list uchar uint vertex_indices"), "{header}");
    assert_eq!(bytes.len() - header_end, 24 * 8 * 4 + 12 * (1 + 12));
    let back = io::read(&path).unwrap();
    // PLY carries no materials.
    m.materials.clear();
    m.triangle_materials.clear();
    assert_same(&m, &back);

    // Without normals and uvs the properties are left out.
    m.normals.clear();
    m.uvs.clear();
    io::write(&path, &m).unwrap();
    let back = io::read(&path).unwrap();
    assert_same(&m, &back);
    fs::remove_dir_all(dir).unwrap();
}

#[test]
fn ascii_ply_with_polygons_and_extra_elements_is_read() {
    let dir = scratch("ply-ascii");
    let path = dir.join("square.ply");
    let text = "ply\nformat ascii 1.0\ncomment made by hand\n\
        element vertex 4\nproperty double x\nproperty double y\nproperty double z\nproperty uchar red\n\
        property float u\nproperty float v\n\
        element face 1\nproperty list uchar int vertex_index\n\
        element edge 1\nproperty int vertex1\nproperty int vertex2\n\
        end_header\n\
        0 0 0 255 0 0\n1 0 0 255 1 0\n1 1 0 255 1 1\n0 1 0 255 0 1\n\
        4 0 1 2 3\n\
        0 1\n";
    fs::write(&path, text).unwrap();
    let m = io::read(&path).unwrap();
    assert_eq!(
        m.positions,
        vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]]
    );
    assert_eq!(m.uvs, vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]);
    assert!(m.normals.is_empty());
    assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    fs::remove_dir_all(dir).unwrap();
}

#[test]
fn glb_round_trip_checked_by_the_gltf_crate() {
    let dir = scratch("glb");
    let path = dir.join("cube.glb");
    let m = cube();
    io::write(&path, &m).unwrap();
    let bytes = fs::read(&path).unwrap();
    assert_eq!(&bytes[..4], b"glTF");
    assert_eq!(
        u32::from_le_bytes(bytes[8..12].try_into().unwrap()) as usize,
        bytes.len()
    );
    assert_eq!(bytes.len() % 4, 0);

    // Parsed (and validated) independently.
    let gltf = gltf::Gltf::from_slice(&bytes).unwrap();
    let blob = gltf.blob.clone().unwrap();
    let doc = &gltf.document;
    assert_eq!(doc.meshes().count(), 1);
    let colours: Vec<[f32; 4]> = doc
        .materials()
        .map(|mat| mat.pbr_metallic_roughness().base_color_factor())
        .collect();
    assert_eq!(colours, vec![m.materials[0].base_color, m.materials[1].base_color]);
    let names: Vec<_> = doc.materials().map(|mat| mat.name().unwrap().to_string()).collect();
    assert_eq!(names, ["red paint", "glass"]);
    let mesh = doc.meshes().next().unwrap();
    assert_eq!(mesh.primitives().count(), 2);
    for (k, prim) in mesh.primitives().enumerate() {
        assert_eq!(prim.mode(), gltf::mesh::Mode::Triangles);
        assert_eq!(prim.material().index(), Some(k));
        let pos = prim.get(&gltf::Semantic::Positions).unwrap();
        assert_eq!(pos.count(), 24);
        assert_eq!(pos.min().unwrap(), serde_json_value([-0.1, 0.2, -0.3]));
        assert_eq!(pos.max().unwrap(), serde_json_value([0.7, 1.1, 0.9]));
        assert_eq!(prim.get(&gltf::Semantic::Normals).unwrap().count(), 24);
        assert_eq!(prim.get(&gltf::Semantic::TexCoords(0)).unwrap().count(), 24);
        let indices = prim.indices().unwrap();
        assert_eq!(indices.data_type(), gltf::accessor::DataType::U32);
        assert_eq!(indices.count(), 18);

        let reader = prim.reader(|b| (b.index() == 0).then_some(&blob[..]));
        let positions: Vec<[f32; 3]> = reader.read_positions().unwrap().collect();
        assert_eq!(positions, m.positions);
        let normals: Vec<[f32; 3]> = reader.read_normals().unwrap().collect();
        assert_eq!(normals, m.normals);
        let uvs: Vec<[f32; 2]> = reader.read_tex_coords(0).unwrap().into_f32().collect();
        assert_eq!(uvs, m.uvs);
        let idx: Vec<u32> = reader.read_indices().unwrap().into_u32().collect();
        let expected: Vec<u32> = (0..12)
            .filter(|&i| m.triangle_materials[i] == k as u32)
            .flat_map(|i| m.triangles[i])
            .collect();
        assert_eq!(idx, expected);
    }

    // Our own reader gives the mesh back (triangles grouped by material).
    let back = io::read(&path).unwrap();
    let mut grouped = m.clone();
    let mut order: Vec<usize> = (0..12).collect();
    order.sort_by_key(|&i| m.triangle_materials[i]);
    grouped.triangles = order.iter().map(|&i| m.triangles[i]).collect();
    grouped.triangle_materials = order.iter().map(|&i| m.triangle_materials[i]).collect();
    assert_same(&grouped, &back);
    fs::remove_dir_all(dir).unwrap();
}

/// A JSON array of f32 values, as gltf gives accessor bounds.
fn serde_json_value(v: [f32; 3]) -> gltf::json::Value {
    gltf::json::Value::from(v.to_vec())
}

#[test]
fn glb_of_a_mesh_without_materials_has_a_default_one() {
    let dir = scratch("glb-default");
    let path = dir.join("plain.glb");
    let mut m = cube();
    m.materials.clear();
    m.triangle_materials.clear();
    m.normals.clear();
    m.uvs.clear();
    io::write(&path, &m).unwrap();
    let gltf = gltf::Gltf::from_slice(&fs::read(&path).unwrap()).unwrap();
    let mat = gltf.document.materials().next().unwrap();
    assert_eq!(gltf.document.materials().count(), 1);
    assert_eq!(mat.pbr_metallic_roughness().base_color_factor(), DEFAULT_BASE_COLOR);
    let prim = gltf.document.meshes().next().unwrap().primitives().next().unwrap();
    assert!(prim.get(&gltf::Semantic::Normals).is_none() && prim.get(&gltf::Semantic::TexCoords(0)).is_none());
    let back = io::read(&path).unwrap();
    assert_eq!(back.positions, m.positions);
    assert_eq!(back.triangles, m.triangles);
    assert_eq!(back.materials.len(), 1);

    // An empty mesh still makes a valid file.
    io::write(&path, &Mesh::default()).unwrap();
    gltf::Gltf::from_slice(&fs::read(&path).unwrap()).unwrap();
    assert!(io::read(&path).unwrap().triangles.is_empty());
    fs::remove_dir_all(dir).unwrap();
}

#[test]
fn failed_writes_leave_the_existing_file_untouched() {
    let dir = scratch("atomic");
    for format in Format::ALL {
        let path = dir.join(format!("target.{}", format.extension()));
        let original = b"precious old contents".to_vec();
        fs::write(&path, &original).unwrap();

        let mut bad_index = cube();
        bad_index.triangles[5][1] = 24;
        let msg = message_naming(io::write(&path, &bad_index).unwrap_err(), &path);
        assert!(
            msg.contains("triangle 5 refers to vertex 24 but the mesh has 24 vertices"),
            "{msg}"
        );

        let mut bad_normals = cube();
        bad_normals.normals.pop();
        let msg = message_naming(io::write(&path, &bad_normals).unwrap_err(), &path);
        assert!(msg.contains("24 positions but 23 normals"), "{msg}");

        let mut bad_uvs = cube();
        bad_uvs.uvs.push([0.0; 2]);
        assert!(io::write(&path, &bad_uvs).is_err());

        let mut bad_material = cube();
        bad_material.triangle_materials[3] = 2;
        let msg = message_naming(io::write(&path, &bad_material).unwrap_err(), &path);
        assert!(
            msg.contains("triangle 3 uses material 2 but the mesh has 2 materials"),
            "{msg}"
        );

        let mut short_materials = cube();
        short_materials.triangle_materials.pop();
        assert!(io::write(&path, &short_materials).is_err());

        let mut nan = cube();
        nan.positions[7][2] = f32::NAN;
        let msg = message_naming(io::write(&path, &nan).unwrap_err(), &path);
        assert!(msg.contains("vertex 7"), "{msg}");

        assert_eq!(fs::read(&path).unwrap(), original, "{format}");

        // A target in a directory that does not exist.
        let nowhere = dir.join("missing").join(format!("mesh.{}", format.extension()));
        let err = io::write(&nowhere, &cube()).unwrap_err();
        assert!(matches!(err, MeshIoError::Io { .. }), "{err}");
        message_naming(err, &nowhere);

        // A good write replaces it.
        io::write(&path, &cube()).unwrap();
        assert_ne!(fs::read(&path).unwrap(), original);
    }
    // A target that is a directory: the rename fails, the temporary goes.
    let blocker = dir.join("blocker.ply");
    fs::create_dir(&blocker).unwrap();
    fs::write(blocker.join("inside"), b"x").unwrap();
    assert!(io::write(&blocker, &cube()).is_err());
    assert!(blocker.join("inside").exists());
    assert_eq!(temporaries(&dir), Vec::<String>::new());
    fs::remove_dir_all(dir).unwrap();
}

#[test]
fn malformed_files_are_errors_that_name_the_file() {
    let dir = scratch("malformed");
    let m = cube();
    let expect = |name: &str, contents: &[u8], needle: &str| {
        let path = dir.join(name);
        fs::write(&path, contents).unwrap();
        let msg = message_naming(io::read(&path).unwrap_err(), &path);
        assert!(msg.contains(needle), "{name}: {msg:?} lacks {needle:?}");
    };

    let mut stl = Vec::new();
    io::write_to(Format::Stl, &mut stl, &m).unwrap();
    expect(
        "truncated.stl",
        &stl[..stl.len() - 7],
        "promises 12 triangles (684 bytes) but the file has only 677",
    );
    expect("tiny.stl", &stl[..40], "too few for a binary STL");
    let mut nan_stl = stl.clone();
    nan_stl[84 + 12..84 + 16].copy_from_slice(&f32::NAN.to_le_bytes());
    expect("nan.stl", &nan_stl, "triangle 0 has a non-finite vertex");
    expect(
        "broken-ascii.stl",
        b"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0\n",
        "ASCII STL",
    );

    expect(
        "range.obj",
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n",
        "line 4: face refers to vertex 4 but the file has 3 vertices",
    );
    expect(
        "zero.obj",
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n",
        "OBJ indices start at 1",
    );
    expect(
        "relative.obj",
        b"v 0 0 0\nf -1 -2 -3\n",
        "line 2: face refers to vertex -2 (relative)",
    );
    expect(
        "uv-range.obj",
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/2 3/1\n",
        "texture coordinate 2",
    );
    expect("nan.obj", b"v 0 nan 0\n", "line 1: a vertex needs 3 finite numbers");
    expect("short.obj", b"v 0 0\n", "line 1");
    expect(
        "corner.obj",
        b"v 0 0 0\nf 1/1/1/1 1 1\n",
        "line 2: cannot read face corner",
    );

    expect(
        "header.ply",
        b"ply\nformat ascii 1.0\nelement vertex three\nend_header\n",
        "bad PLY header",
    );
    expect("magic.ply", b"plx\n", "bad PLY header");
    expect(
        "noxyz.ply",
        b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n0\n",
        "no scalar property \"y\"",
    );
    expect(
        "face.ply",
        b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
          element face 2\nproperty list uchar int vertex_indices\nend_header\n\
          0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 900\n",
        "face 1 refers to vertex 900 but the file has 3 vertices",
    );
    let mut ply = Vec::new();
    io::write_to(Format::Ply, &mut ply, &m).unwrap();
    expect(
        "truncated.ply",
        &ply[..ply.len() - 10],
        "cannot read the \"face\" elements",
    );
    let mut nan_ply = ply.clone();
    let payload = nan_ply.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
    nan_ply[payload + 4..payload + 8].copy_from_slice(&f32::INFINITY.to_le_bytes());
    expect("nan.ply", &nan_ply, "vertex 0 has a non-finite position");

    let mut glb = Vec::new();
    io::write_to(Format::Glb, &mut glb, &m).unwrap();
    expect("truncated.glb", &glb[..glb.len() - 100], "truncated");
    expect("text.glb", b"{\"asset\":{\"version\":\"2.0\"}}", "not a glb file");

    let missing = dir.join("absent.obj");
    let err = io::read(&missing).unwrap_err();
    assert!(matches!(err, MeshIoError::Io { .. }));
    message_naming(err, &missing);
    fs::remove_dir_all(dir).unwrap();
}

#[test]
fn damaged_files_never_panic() {
    let dir = scratch("fuzz");
    let m = cube();
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut next = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed
    };
    for format in Format::ALL {
        let mut good = Vec::new();
        io::write_to(format, &mut good, &m).unwrap();
        let path = dir.join(format!("damaged.{}", format.extension()));
        for round in 0..60 {
            let mut bytes = good.clone();
            if round % 2 == 0 {
                bytes.truncate(next() as usize % good.len());
            }
            for _ in 0..1 + round % 4 {
                let i = next() as usize % bytes.len().max(1);
                if let Some(b) = bytes.get_mut(i) {
                    *b = next() as u8;
                }
            }
            fs::write(&path, &bytes).unwrap();
            // Ok or Err, but no panic; what is read is consistent.
            if let Ok(read) = io::read(&path) {
                let n = read.positions.len() as u32;
                assert!(
                    read.triangles.iter().flatten().all(|&v| v < n),
                    "{format} round {round}"
                );
            }
        }
    }
    fs::remove_dir_all(dir).unwrap();
}
