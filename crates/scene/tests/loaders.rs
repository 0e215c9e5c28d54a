//! File loaders (OBJ, OBJ.gz, glTF, GLB) on small fixtures written at test time, the built-in
//! procedural scenes, and the paper scenes under /work/shared/scenes when present.

use std::io::Write;
use std::path::{Path, PathBuf};
use tb_scene::loader::load_file;
use tb_scene::{Scene, SceneError};

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    e.write_all(bytes).unwrap();
    e.finish().unwrap()
}

/// The error message of a load that must fail, checking it names the file.
fn err_of(path: &Path) -> String {
    match load_file(path) {
        Ok(s) => panic!(
            "{} loaded ({} triangles)",
            path.display(),
            s.triangles.len()
        ),
        Err(e) => {
            let m = e.to_string();
            assert!(
                m.contains(&path.display().to_string()),
                "message does not name the file: {m}"
            );
            assert!(!m.contains('\n'), "message is not one line: {m}");
            println!("{m}");
            m
        }
    }
}

// ---------------------------------------------------------------------------------------------
// OBJ

/// A quad (2 triangles) and a pentagon (3), with things the loader must ignore: a material
/// library that does not exist, normals, texture coordinates, a polyline, a point.
const OBJ: &str = "\
# quad and pentagon
mtllib does-not-exist.mtl
o quad
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
vt 0 0
vn 0 0 1
usemtl red
f 1/1/1 2/1/1 3/1/1 4/1/1
g pentagon
v 2 0 0
v 3 0 0
v 3.5 1 0
v 2.5 2 0
v 1.5 1 -1
f -5 -4 -3 -2 -1
l 1 2 3
p 1
";

#[test]
fn obj_polygons_are_triangulated_and_merged() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "shapes.obj", OBJ.as_bytes());
    let s = load_file(&p).unwrap();
    assert_eq!(s.triangles.len(), 5);
    assert_eq!(s.source, p.display().to_string());
    assert!(s.view.is_none());
    assert_eq!(s.bounds.min, glam::Vec3::new(0.0, 0.0, -1.0));
    assert_eq!(s.bounds.max, glam::Vec3::new(3.5, 2.0, 0.0));
    assert_eq!(s.degenerate_count(), 0);
}

#[test]
fn obj_gz_loads_identically() {
    let dir = tempfile::tempdir().unwrap();
    let a = load_file(&write(dir.path(), "a.obj", OBJ.as_bytes())).unwrap();
    let b = load_file(&write(dir.path(), "a.obj.gz", &gzip(OBJ.as_bytes()))).unwrap();
    assert_eq!(a.triangles, b.triangles);
    assert_eq!(a.bounds, b.bounds);
    // Upper-case extensions are accepted too.
    let c = load_file(&write(dir.path(), "B.OBJ.GZ", &gzip(OBJ.as_bytes()))).unwrap();
    assert_eq!(a.triangles, c.triangles);
}

#[test]
fn obj_garbage_face_names_the_line() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "bad.obj",
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n",
    );
    let m = err_of(&p);
    assert!(m.contains("line 4"), "{m}");
    assert!(m.contains("face"), "{m}");
}

#[test]
fn obj_face_index_out_of_range_names_the_line() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "range.obj",
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 7\n",
    );
    let m = err_of(&p);
    assert!(m.contains("line 5") && m.contains("out of range"), "{m}");
    let p = write(
        dir.path(),
        "zero.obj",
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n",
    );
    let m = err_of(&p);
    assert!(m.contains("line 4") && m.contains("out of range"), "{m}");
    let p = write(dir.path(), "neg.obj", b"v 0 0 0\nv 1 0 0\nf -1 -2 -3\n");
    let m = err_of(&p);
    assert!(m.contains("line 3") && m.contains("out of range"), "{m}");
}

#[test]
fn obj_bad_vertex_and_non_finite_vertex() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "short.obj",
        b"v 0 0 0\nv 1 0\nv 0 1 0\nf 1 2 3\n",
    );
    let m = err_of(&p);
    assert!(m.contains("line 2"), "{m}");
    let p = write(
        dir.path(),
        "nan.obj",
        b"v 0 0 0\nv 1 0 0\nv 0 NaN 0\nf 1 2 3\n",
    );
    let m = err_of(&p);
    assert!(m.contains("line 3") && m.contains("non-finite"), "{m}");
    let p = write(
        dir.path(),
        "inf.obj",
        b"v 0 0 0\nv inf 0 0\nv 0 1 0\nf 1 2 3\n",
    );
    let m = err_of(&p);
    assert!(m.contains("line 2"), "{m}");
}

#[test]
fn obj_without_triangles_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "empty.obj",
        b"# nothing\nv 0 0 0\nv 1 0 0\nf 1 2\n",
    );
    let m = err_of(&p);
    assert!(m.contains("contains no triangles"), "{m}");
    let p = write(dir.path(), "binary.obj", &[0xff, 0xfe, 0x00, 0x80, b'\n']);
    err_of(&p);
}

#[test]
fn truncated_and_corrupt_gzip_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    let big: String = (0..2000)
        .map(|i| format!("v {i} 0 0\n"))
        .collect::<String>()
        + "f 1 2 3\n";
    let gz = gzip(big.as_bytes());
    let p = write(dir.path(), "cut.obj.gz", &gz[..gz.len() / 2]);
    let m = err_of(&p);
    assert!(m.contains("gzip"), "{m}");
    let p = write(dir.path(), "cut-trailer.obj.gz", &gz[..gz.len() - 4]);
    err_of(&p);
    let p = write(dir.path(), "plain.obj.gz", big.as_bytes());
    let m = err_of(&p);
    assert!(m.contains("gzip"), "{m}");
}

#[test]
fn missing_file_and_unknown_extension() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("nope.obj");
    match load_file(&missing) {
        Err(SceneError::NotFound { path }) => assert_eq!(path, missing),
        other => panic!("expected NotFound, got {other:?}"),
    }
    let p = write(dir.path(), "model.ply", b"ply\n");
    let m = err_of(&p);
    assert!(
        m.contains(".obj") && m.contains(".obj.gz") && m.contains(".glb"),
        "{m}"
    );
    // A directory is not a scene.
    err_of(dir.path());
}

#[test]
fn load_resolves_relative_paths_against_the_root() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "rel.obj", OBJ.as_bytes());
    let s = tb_scene::load("rel.obj", dir.path()).unwrap();
    assert_eq!(s.source, "rel.obj");
    assert_eq!(s.triangles.len(), 5);
}

// ---------------------------------------------------------------------------------------------
// glTF

/// Buffer: a unit right triangle (3 x f32 VEC3) and the u16 indices 0 1 2, 44 bytes.
fn triangle_buffer() -> Vec<u8> {
    let mut b = Vec::new();
    for v in [0f32, 0., 0., 1., 0., 0., 0., 1., 0.] {
        b.extend_from_slice(&v.to_le_bytes());
    }
    for i in [0u16, 1, 2] {
        b.extend_from_slice(&i.to_le_bytes());
    }
    b.extend_from_slice(&[0, 0]);
    b
}

/// glTF JSON: node "parent" (translation 10,0,0) with child "child" (translation 0,5,0)
/// holding mesh `mesh_name`, whose primitive has `mode`; `uri` is the buffer's `"uri"` member
/// (with its comma) or empty for GLB.
fn gltf_json(uri: &str, mode: u32, mesh_name: &str) -> String {
    format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  "scene": 0,
  "scenes": [{{"nodes": [0]}}],
  "nodes": [
    {{"name": "parent", "translation": [10, 0, 0], "children": [1]}},
    {{"name": "child", "translation": [0, 5, 0], "mesh": 0}}
  ],
  "meshes": [{{"name": "{mesh_name}", "primitives": [
    {{"attributes": {{"POSITION": 0}}, "indices": 1, "mode": {mode}}},
    {{"attributes": {{"POSITION": 0}}, "mode": {mode}}}
  ]}}],
  "buffers": [{{{uri} "byteLength": 44}}],
  "bufferViews": [
    {{"buffer": 0, "byteOffset": 0, "byteLength": 36, "target": 34962}},
    {{"buffer": 0, "byteOffset": 36, "byteLength": 6, "target": 34963}}
  ],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
      "min": [0, 0, 0], "max": [1, 1, 0]}},
    {{"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}}
  ]
}}"#
    )
}

fn data_uri() -> String {
    format!(
        r#""uri": "data:application/octet-stream;base64,{}","#,
        base64::encode(triangle_buffer())
    )
}

fn glb(json: &str, bin: &[u8]) -> Vec<u8> {
    let mut j = json.as_bytes().to_vec();
    j.resize(j.len().next_multiple_of(4), b' ');
    let mut b = bin.to_vec();
    b.resize(b.len().next_multiple_of(4), 0);
    let total = 12 + 8 + j.len() + 8 + b.len();
    let mut out = Vec::new();
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(j.len() as u32).to_le_bytes());
    out.extend_from_slice(&0x4E4F_534Au32.to_le_bytes());
    out.extend_from_slice(&j);
    out.extend_from_slice(&(b.len() as u32).to_le_bytes());
    out.extend_from_slice(&0x004E_4942u32.to_le_bytes());
    out.extend_from_slice(&b);
    out
}

fn check_translated_triangles(s: &Scene) {
    // Two primitives (indexed and not) of one triangle each, moved by (10, 5, 0).
    assert_eq!(s.triangles.len(), 2);
    assert_eq!(s.bounds.min, glam::Vec3::new(10.0, 5.0, 0.0));
    assert_eq!(s.bounds.max, glam::Vec3::new(11.0, 6.0, 0.0));
    assert_eq!(s.triangles[0], s.triangles[1]);
}

#[test]
fn gltf_with_data_uri_applies_node_transforms() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "tri.gltf",
        gltf_json(&data_uri(), 4, "Tri").as_bytes(),
    );
    check_translated_triangles(&load_file(&p).unwrap());
}

#[test]
fn gltf_with_external_buffer_and_glb() {
    let dir = tempfile::tempdir().unwrap();
    write(dir.path(), "tri.bin", &triangle_buffer());
    let p = write(
        dir.path(),
        "ext.gltf",
        gltf_json(r#""uri": "tri.bin","#, 4, "Tri").as_bytes(),
    );
    check_translated_triangles(&load_file(&p).unwrap());
    let p = write(
        dir.path(),
        "tri.glb",
        &glb(&gltf_json("", 4, "Tri"), &triangle_buffer()),
    );
    check_translated_triangles(&load_file(&p).unwrap());
}

#[test]
fn gltf_strips_and_fans_are_converted() {
    let dir = tempfile::tempdir().unwrap();
    for mode in [5, 6] {
        let p = write(
            dir.path(),
            &format!("m{mode}.gltf"),
            gltf_json(&data_uri(), mode, "Tri").as_bytes(),
        );
        check_translated_triangles(&load_file(&p).unwrap());
    }
}

#[test]
fn gltf_lines_and_points_are_errors_naming_the_mesh() {
    let dir = tempfile::tempdir().unwrap();
    for (mode, name) in [
        (0, "Points"),
        (1, "Lines"),
        (2, "LineLoop"),
        (3, "LineStrip"),
    ] {
        let p = write(
            dir.path(),
            &format!("l{mode}.gltf"),
            gltf_json(&data_uri(), mode, "Wire").as_bytes(),
        );
        let m = err_of(&p);
        assert!(
            m.contains("mesh 'Wire' primitive 0") && m.contains(name),
            "{m}"
        );
    }
}

#[test]
fn malformed_gltf_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "bad.gltf", b"{ this is not json");
    let m = err_of(&p);
    assert!(m.contains("glTF"), "{m}");
    // Valid JSON, but the accessor points past the end of its buffer view.
    let bad = gltf_json(&data_uri(), 4, "Tri").replace(
        "\"count\": 3, \"type\": \"VEC3\"",
        "\"count\": 30, \"type\": \"VEC3\"",
    );
    err_of(&write(dir.path(), "range.gltf", bad.as_bytes()));
    // Missing external buffer.
    let p = write(
        dir.path(),
        "nobuf.gltf",
        gltf_json(r#""uri": "missing.bin","#, 4, "Tri").as_bytes(),
    );
    err_of(&p);
    // Truncated binary.
    let g = glb(&gltf_json("", 4, "Tri"), &triangle_buffer());
    err_of(&write(dir.path(), "cut.glb", &g[..g.len() - 20]));
    err_of(&write(dir.path(), "tiny.glb", b"glTF\x02\x00"));
    // Index out of range.
    let mut buf = triangle_buffer();
    buf[40] = 9;
    let uri = format!(
        r#""uri": "data:application/octet-stream;base64,{}","#,
        base64::encode(buf)
    );
    let m = err_of(&write(
        dir.path(),
        "index.gltf",
        gltf_json(&uri, 4, "Tri").as_bytes(),
    ));
    assert!(m.contains("out of range"), "{m}");
}

// ---------------------------------------------------------------------------------------------
// Built-in procedural scenes

fn builtin(spec: &str) -> Result<Scene, SceneError> {
    tb_scene::load(&format!("builtin:{spec}"), Path::new("."))
}

#[test]
fn procedural_scenes_load_with_defaults() {
    let expected = [
        ("cornell", 32),
        ("sphereflake", 65_602),
        ("mount", 8_192),
        ("tetra", 4_096),
        ("soup", 10_000),
        ("teapot", 16_256),
        ("teapot-stadium", 16_386),
        ("arena", 1_399_314),
        ("city", 759_258),
        ("hairball", 2_880_000),
        ("crown", 3_512_832),
        ("explode", 253_512),
        ("deform", 1_637_120),
    ];
    let names: Vec<&str> = tb_scene::builtin::PROCEDURAL
        .iter()
        .map(|b| b.name)
        .collect();
    assert_eq!(names, expected.map(|e| e.0));
    for (name, count) in expected {
        let info = tb_scene::builtin::PROCEDURAL
            .iter()
            .find(|b| b.name == name)
            .unwrap();
        assert!(!info.doc.is_empty());
        let a = builtin(name).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(a.triangles.len(), count, "{name}");
        assert_eq!(a.source, format!("builtin:{name}"));
        assert!(!a.bounds.is_empty(), "{name}");
        assert!(
            a.bounds.min.is_finite() && a.bounds.max.is_finite(),
            "{name}"
        );
        let view = a.view.as_ref().expect("a view");
        view.camera
            .check()
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!((view.camera.width, view.camera.height), (256, 256));
        let light = view.light.expect("a light");
        assert!(light.is_finite());
        let diag = a.bounds.diagonal();
        assert!(
            (view.ao_distance - 0.04 * diag).abs() <= 1e-4 * diag,
            "{name}"
        );
        assert!(
            a.triangles.iter().all(|t| !t.is_degenerate()),
            "{name} has degenerate triangles"
        );
        // Deterministic.
        let b = builtin(name).unwrap();
        assert_eq!(a.triangles, b.triangles, "{name}");
        assert_eq!(a.view, b.view, "{name}");
        // The camera looks at the scene: the centre ray's target lies inside the bounds.
        let t = view.camera.target;
        let slack = 1e-3 * diag;
        assert!(
            (a.bounds.min - slack).cmple(t).all() && t.cmple(a.bounds.max + slack).all(),
            "{name}: target {t} outside {:?}",
            a.bounds
        );
    }
}

#[test]
fn size_parameters_scale_as_documented() {
    let cases = [
        ("cornell?scale=2", 32),
        ("sphereflake?size=0&tess=0", 22),
        ("sphereflake?size=1&tess=0", 10 * 20 + 2),
        ("sphereflake?size=2&tess=2", 91 * 320 + 2),
        ("mount?size=0", 2),
        ("mount?size=3", 128),
        ("mount?size=8&seed=7", 2 * 65_536),
        ("tetra?size=0", 4),
        ("tetra?size=2", 64),
        ("soup?count=1", 1),
        ("soup?count=7&size=1&seed=3", 7),
        ("teapot?tess=1", 56),
        ("teapot?tess=2", 240),
        ("teapot-stadium?teapot_tess=1&segments=5", 56 + 2 + 20),
        ("teapot-stadium?stadium=10&segments=3", 16_256 + 2 + 12),
        ("hairball?strands=3&segments=5&sides=4", 2 * 4 * 5 * 3),
        (
            "crown?tess=1&gems=2&points=3&gem_tess=0",
            16_384 + 512 + 20 * 5,
        ),
        (
            "crown?tess=2&gems=0&points=4&gem_tess=1",
            16_384 * 4 + 1024 + 80 * 4,
        ),
        ("explode?tess=2&frame=59", 240),
        ("deform?tess=2&frames=10&frame=9", 240),
    ];
    for (spec, n) in cases {
        let s = builtin(spec).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(s.triangles.len(), n, "{spec}");
        assert!(s.view.unwrap().camera.check().is_ok(), "{spec}");
    }
    // Scale multiplies the Cornell box.
    let a = builtin("cornell").unwrap();
    let b = builtin("cornell?scale=2").unwrap();
    assert_eq!(b.bounds.max, a.bounds.max * 2.0);
    // The soup stays in the unit cube, and seeds change it.
    let s = builtin("soup?count=1000&size=0.2").unwrap();
    assert!(
        s.bounds.min.cmpge(glam::Vec3::ZERO).all() && s.bounds.max.cmple(glam::Vec3::ONE).all()
    );
    let t = builtin("soup?count=1000&size=0.2&seed=2").unwrap();
    assert_ne!(s.triangles, t.triangles);
    // Different mountain seeds differ.
    assert_ne!(
        builtin("mount?seed=1").unwrap().triangles,
        builtin("mount?seed=2").unwrap().triangles
    );
    // The explosion starts from the intact teapot and scatters it; frames differ; the hairball
    // stays near its unit ball.
    let intact = builtin("explode?tess=3&frame=0").unwrap();
    assert_eq!(
        intact.triangles,
        builtin("teapot?tess=3").unwrap().triangles
    );
    let late = builtin("explode?tess=3&frame=50").unwrap();
    assert!(late.bounds.diagonal() > 2.0 * intact.bounds.diagonal());
    assert_ne!(
        builtin("deform?tess=3&frame=1").unwrap().triangles,
        builtin("deform?tess=3&frame=2").unwrap().triangles
    );
    let h = builtin("hairball?strands=50&segments=40").unwrap();
    assert!(h.bounds.max.max_element() < 1.6 && h.bounds.min.min_element() > -1.6);
    // The stadium is huge next to the teapot.
    let st = builtin("teapot-stadium").unwrap();
    let tp = builtin("teapot").unwrap();
    assert!(st.bounds.diagonal() > 1000.0 * tp.bounds.diagonal());
}

#[test]
fn bad_parameters_are_errors() {
    let m = builtin("tetra?bogus=1").unwrap_err().to_string();
    assert!(m.contains("bogus"), "{m}");
    let m = builtin("cornell?size=2").unwrap_err().to_string();
    assert!(m.contains("size"), "{m}");
    for spec in [
        "soup?count=0",
        "soup?count=60000000",
        "soup?size=0",
        "soup?size=2",
        "soup?count=abc",
        "sphereflake?size=7",
        "sphereflake?size=99",
        "sphereflake?tess=11",
        "mount?size=13",
        "tetra?size=12",
        "teapot?tess=0",
        "teapot?tess=100000",
        "teapot-stadium?stadium=0",
        "teapot-stadium?stadium=-5",
        "teapot-stadium?segments=2",
        "cornell?scale=0",
        "hairball?sides=2",
        "hairball?radius=0",
        "hairball?strands=0",
        "crown?tess=0",
        "crown?gem_tess=9",
        "explode?frame=60",
        "explode?frame=5&frames=5",
        "deform?frames=0",
        "cornell?scale=nan",
        "no-such-scene",
    ] {
        let e = builtin(spec).expect_err(spec);
        let m = e.to_string();
        assert!(m.starts_with("builtin:"), "{spec}: {m}");
    }
    let m = builtin("soup?count=60000000").unwrap_err().to_string();
    assert!(m.contains("limit"), "{m}");
}

#[test]
fn every_builtin_is_listed_with_params() {
    for b in tb_scene::builtin::PROCEDURAL {
        for p in b.params {
            let (key, rest) = p.split_once('=').expect("name=default: meaning");
            assert!(rest.contains(": "), "{}: {p}", b.name);
            // The documented default is accepted.
            let default = rest.split(':').next().unwrap();
            builtin(&format!("{}?{key}={default}", b.name))
                .unwrap_or_else(|e| panic!("{}: {e}", b.name));
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Paper scenes

fn paper_scenes() -> Option<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/scenes");
    if root.is_dir() {
        Some(root)
    } else {
        println!("skipping: paper scenes not found at {}", root.display());
        None
    }
}

#[test]
fn paper_scenes_bunny_and_cornell() {
    let Some(root) = paper_scenes() else { return };
    for (file, n) in [
        ("stanford-bunny/stanford-bunny.obj.gz", 69_451),
        ("cornell-box/CornellBox-Original.obj", 36),
    ] {
        let s = tb_scene::load(file, &root).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(s.triangles.len(), n, "{file}");
        assert!(s.bounds.min.is_finite() && s.bounds.max.is_finite());
    }
}

/// All paper scenes with their load times; slow in debug builds, so run it with
/// `cargo test --release -p tb-scene --test loaders -- --ignored --nocapture`.
#[test]
#[ignore]
fn paper_scenes_all_timed() {
    let Some(root) = paper_scenes() else { return };
    for (file, n) in [
        ("stanford-bunny/stanford-bunny.obj.gz", 69_451),
        ("sibenik/sibenik.obj.gz", 75_284),
        ("conference/conference.obj.gz", 331_179),
        ("dabrovic-sponza/sponza.obj.gz", 66_450),
        ("cornell-box/CornellBox-Original.obj", 36),
        ("cornell-box/CornellBox-Sphere.obj", 2_188),
        ("utah-teapot/teapot.newell.obj", 6_320),
        ("utah-teapot/teapot.mcguire.obj", 15_704),
    ] {
        let t = std::time::Instant::now();
        let s = tb_scene::load(file, &root).unwrap_or_else(|e| panic!("{e}"));
        println!(
            "{file}: {} triangles in {:.3} s",
            s.triangles.len(),
            t.elapsed().as_secs_f64()
        );
        assert_eq!(s.triangles.len(), n, "{file}");
    }
}
