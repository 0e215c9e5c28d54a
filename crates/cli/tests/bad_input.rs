//! Fuzz-style end-to-end test: a few hundred truncated and mutated scene files (OBJ, OBJ.gz,
//! glTF, GLB) and configs, each given to the `trace-bench` binary. Whatever the input, the
//! binary either accepts it (exit 0) or refuses it with exactly one `error: …` line (exit 1):
//! never a panic message, a backtrace hint, exit 101 or a signal.
//!
//! The cases are deterministic (a fixed seed): mutations of small files written here (always),
//! of the small shared scenes (Cornell box, teapot; skipped with a notice when absent), and of
//! `configs/*.toml`. Scenes go through `trace-bench info FILE`. Configs go through
//! `trace-bench validate CONFIG` with an empty scenes root (paper scenes: a fast "not found"):
//! a config is refused before any work starts, so once the runner reports its first step (a
//! progress line on stderr) the config has been accepted, and the process is stopped there.

use serde_json::{json, Value};
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_trace-bench");
const SEED: u64 = 0x7b_5eed;
/// A case that neither exits nor reaches the work in this time fails the test.
const CASE_LIMIT: Duration = Duration::from_secs(60);

// ---------------------------------------------------------------------------------------------
// Deterministic randomness (SplitMix64)

struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in `0..n` (`n > 0`).
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
    fn pick<'a, T>(&mut self, items: &'a [T]) -> &'a T {
        &items[self.below(items.len())]
    }
}

// ---------------------------------------------------------------------------------------------
// Mutations of bytes and lines

/// Cut points spread over `data` (start, end and in between), plus `random` random ones.
fn truncations(data: &[u8], rng: &mut Rng, random: usize) -> Vec<(String, Vec<u8>)> {
    let len = data.len();
    let mut cuts = vec![0, 1, len / 4, len / 2, 3 * len / 4, len.saturating_sub(1)];
    cuts.extend((0..random).map(|_| rng.below(len.max(1))));
    cuts.sort_unstable();
    cuts.dedup();
    cuts.into_iter()
        .filter(|&c| c < len)
        .map(|c| (format!("truncated at {c} of {len}"), data[..c].to_vec()))
        .collect()
}

/// `count` random bytes of `data` replaced (a flipped bit, a random byte, or a nasty one).
fn flip(data: &[u8], rng: &mut Rng, count: usize) -> (String, Vec<u8>) {
    let mut d = data.to_vec();
    if d.is_empty() {
        return ("empty".into(), d);
    }
    for _ in 0..count {
        let i = rng.below(d.len());
        d[i] = match rng.below(3) {
            0 => d[i] ^ (1 << rng.below(8)),
            1 => rng.next() as u8,
            _ => *rng.pick(b"\0\n\r\"\\9-.{}[],:#/ \xff\xc3"),
        };
    }
    (format!("{count} bytes changed"), d)
}

fn split_lines(data: &[u8]) -> Vec<Vec<u8>> {
    data.split(|&b| b == b'\n').map(<[u8]>::to_vec).collect()
}

fn join_lines(lines: &[Vec<u8>]) -> Vec<u8> {
    lines.join(&b'\n')
}

/// A line deleted, duplicated, two swapped, or one of `extra` inserted.
fn line_edit(data: &[u8], rng: &mut Rng, extra: &[&str]) -> (String, Vec<u8>) {
    let mut lines = split_lines(data);
    let n = lines.len();
    let i = rng.below(n);
    let what = match rng.below(4) {
        0 => {
            lines.remove(i);
            format!("line {} deleted", i + 1)
        }
        1 => {
            let l = lines[i].clone();
            lines.insert(i, l);
            format!("line {} duplicated", i + 1)
        }
        2 => {
            let j = rng.below(n);
            lines.swap(i, j);
            format!("lines {} and {} swapped", i + 1, j + 1)
        }
        _ => {
            let l = rng.pick(extra);
            lines.insert(i, l.as_bytes().to_vec());
            format!("`{l}` inserted at line {}", i + 1)
        }
    };
    (what, join_lines(&lines))
}

/// Truncations, byte changes and line edits of `data` (the mutations every format gets).
fn generic(
    data: &[u8],
    rng: &mut Rng,
    flips: usize,
    edits: usize,
    extra: &[&str],
) -> Vec<(String, Vec<u8>)> {
    let mut out = truncations(data, rng, 2);
    for k in 0..flips {
        out.push(flip(data, rng, [1, 1, 3, 16][k % 4]));
    }
    for _ in 0..edits {
        out.push(line_edit(data, rng, extra));
    }
    out
}

fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    e.write_all(bytes).unwrap();
    e.finish().unwrap()
}

// ---------------------------------------------------------------------------------------------
// OBJ

/// A cube of quads with everything the OBJ loader meets: texture coordinates, normals,
/// negative indices, groups, a material library that does not exist, a polyline, a point and
/// a hexagon.
const OBJ: &str = "\
# cube
mtllib cube.mtl
o cube
v -1 -1 -1
v 1 -1 -1
v 1 1 -1
v -1 1 -1
v -1 -1 1
v 1 -1 1
v 1 1 1
v -1 1 1
vt 0 0
vt 1 0
vt 1 1
vn 0 0 -1
vn 0 0 1
g back
usemtl red
f 1/1/1 2/2/1 3/3/1 4/1/1
g front
f 5//2 6//2 7//2 8//2
f -8 -7 -3 -4
f 2 3 7 6
s 1
f 4/3 3/2 7/1 8/1
l 1 2 3
p 5
f 1 2 6 5 4 3
";

/// Lines an edit may insert into an OBJ file.
const OBJ_LINES: &[&str] = &[
    "f 1 2 99",
    "f 0 1 2",
    "f -99 1 2",
    "f 1 2",
    "f 1/9/1 2 3",
    "f 1//9 2 3",
    "f 1/1/1/1 2 3",
    "f a b c",
    "v nan 0 0",
    "v 1e39 0 0",
    "v 1 2",
    "v 1 2 3 0",
    "vt x y",
    "vn",
    "mtllib /dev/null",
    "o",
    "\u{0}\u{1}\u{2}",
];

/// Face and vertex tokens replaced by out-of-range or malformed ones.
fn obj_specific(text: &str, rng: &mut Rng, count: usize) -> Vec<(String, Vec<u8>)> {
    const INDICES: &[&str] = &[
        "0",
        "9",
        "-9",
        "99999999999",
        "-99999999999999999999",
        "4294967297",
        "18446744073709551617",
        "1/99",
        "1//99",
        "1/-99/1",
        "1/2/3/4",
        "x",
        "1.5",
        "+1",
        "//",
    ];
    const COORDS: &[&str] = &["nan", "inf", "-inf", "1e39", "0x10", "", "1,5", "--1"];
    let lines: Vec<&str> = text.split('\n').collect();
    let faces: Vec<usize> = (0..lines.len())
        .filter(|&i| lines[i].starts_with("f "))
        .collect();
    let verts: Vec<usize> = (0..lines.len())
        .filter(|&i| lines[i].starts_with("v "))
        .collect();
    let mut out = Vec::new();
    for k in 0..count {
        let mut l: Vec<String> = lines.iter().map(|s| s.to_string()).collect();
        let (set, tokens) = if k % 3 == 2 && !verts.is_empty() {
            (&verts, COORDS)
        } else if !faces.is_empty() {
            (&faces, INDICES)
        } else {
            continue;
        };
        let i = *rng.pick(set);
        let mut words: Vec<String> = l[i].split_whitespace().map(String::from).collect();
        if words.len() < 2 {
            continue;
        }
        let w = 1 + rng.below(words.len() - 1);
        let t = *rng.pick(tokens);
        words[w] = t.to_string();
        l[i] = words.join(" ");
        out.push((
            format!("line {}: `{}`", i + 1, l[i]),
            l.join("\n").into_bytes(),
        ));
    }
    out
}

// ---------------------------------------------------------------------------------------------
// glTF

/// The buffer of [`gltf_doc`], 200 bytes: 8 cube corners (f32 VEC3, 0..96), 36 u16 indices of
/// its 12 triangles (96..168), 4 u8 strip indices (168..172), and the sparse part of accessor
/// 3: two u16 indices (172..176) and two VEC3 values (176..200).
fn gltf_buffer() -> Vec<u8> {
    let mut b = Vec::new();
    for i in 0..8 {
        for axis in 0..3 {
            let c = if i >> axis & 1 == 1 { 1f32 } else { -1f32 };
            b.extend_from_slice(&c.to_le_bytes());
        }
    }
    let faces: [[u16; 4]; 6] = [
        [0, 1, 3, 2],
        [4, 6, 7, 5],
        [0, 4, 5, 1],
        [2, 3, 7, 6],
        [0, 2, 6, 4],
        [1, 5, 7, 3],
    ];
    for f in faces {
        for i in [f[0], f[1], f[2], f[0], f[2], f[3]] {
            b.extend_from_slice(&i.to_le_bytes());
        }
    }
    b.extend_from_slice(&[0, 1, 2, 3]);
    for i in [1u16, 6] {
        b.extend_from_slice(&i.to_le_bytes());
    }
    for v in [0f32, 2., 0., 3., 3., 3.] {
        b.extend_from_slice(&v.to_le_bytes());
    }
    assert_eq!(b.len(), 200);
    b
}

/// A glTF document over [`gltf_buffer`]: an indexed cube under a translated parent with a
/// scaled and rotated child, a triangle strip with u8 indices over a sparse accessor, and a
/// fan over a sparse accessor without a buffer view (zeros plus two values), placed by a matrix.
/// `uri`: the buffer's URI, or `None` for GLB.
fn gltf_doc(uri: Option<&str>) -> Value {
    let mut buffer = json!({"byteLength": 200});
    if let Some(u) = uri {
        buffer["uri"] = json!(u);
    }
    json!({
        "asset": {"version": "2.0", "generator": "trace-bench bad_input test"},
        "scene": 0,
        "scenes": [{"nodes": [0, 3]}],
        "nodes": [
            {"name": "parent", "translation": [1, 0, 0], "children": [1, 2]},
            {"name": "cube", "mesh": 0, "scale": [2, 2, 2], "rotation": [0, 0, 0.6, 0.8]},
            {"name": "strip", "mesh": 1,
             "matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 5, 0, 1]},
            {"name": "fan", "mesh": 2}
        ],
        "meshes": [
            {"name": "cube", "primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]},
            {"name": "strip", "primitives": [{"attributes": {"POSITION": 3}, "indices": 2, "mode": 5}]},
            {"name": "fan", "primitives": [{"attributes": {"POSITION": 4}, "mode": 6}]}
        ],
        "buffers": [buffer],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 96, "target": 34962},
            {"buffer": 0, "byteOffset": 96, "byteLength": 72, "target": 34963},
            {"buffer": 0, "byteOffset": 168, "byteLength": 4, "target": 34963},
            {"buffer": 0, "byteOffset": 172, "byteLength": 4},
            {"buffer": 0, "byteOffset": 176, "byteLength": 24}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 8, "type": "VEC3",
             "min": [-1, -1, -1], "max": [1, 1, 1]},
            {"bufferView": 1, "componentType": 5123, "count": 36, "type": "SCALAR"},
            {"bufferView": 2, "componentType": 5121, "count": 4, "type": "SCALAR"},
            {"bufferView": 0, "componentType": 5126, "count": 8, "type": "VEC3",
             "min": [-1, -1, -1], "max": [3, 3, 3],
             "sparse": {"count": 2,
                        "indices": {"bufferView": 3, "componentType": 5123},
                        "values": {"bufferView": 4}}},
            {"componentType": 5126, "count": 8, "type": "VEC3",
             "min": [0, 0, 0], "max": [3, 3, 3],
             "sparse": {"count": 2,
                        "indices": {"bufferView": 3, "componentType": 5123},
                        "values": {"bufferView": 4}}}
        ]
    })
}

fn glb(json: &[u8], bin: Option<&[u8]>) -> Vec<u8> {
    let mut j = json.to_vec();
    j.resize(j.len().next_multiple_of(4), b' ');
    let mut out = Vec::new();
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&0u32.to_le_bytes()); // total, below
    out.extend_from_slice(&(j.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&j);
    if let Some(bin) = bin {
        let mut b = bin.to_vec();
        b.resize(b.len().next_multiple_of(4), 0);
        out.extend_from_slice(&(b.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&b);
    }
    let total = out.len() as u32;
    out[8..12].copy_from_slice(&total.to_le_bytes());
    out
}

/// Set (`Some`) or remove (`None`) the member at JSON pointer `ptr`, creating it in its parent.
fn edit(doc: &mut Value, ptr: &str, value: Option<Value>) {
    let (parent, key) = ptr.rsplit_once('/').unwrap();
    let Some(p) = doc.pointer_mut(parent) else {
        return;
    };
    match (p, value) {
        (Value::Object(m), Some(v)) => {
            m.insert(key.to_string(), v);
        }
        (Value::Object(m), None) => {
            m.remove(key);
        }
        (Value::Array(a), v) => {
            if let Ok(i) = key.parse::<usize>() {
                match v {
                    Some(v) if i < a.len() => a[i] = v,
                    Some(v) => a.push(v),
                    None if i < a.len() => {
                        a.remove(i);
                    }
                    None => {}
                }
            }
        }
        _ => {}
    }
}

/// Targeted edits: every reference out of range, wrong component types and element types,
/// counts, offsets and strides that do not fit, bad URIs, cycles, removed members.
fn gltf_edits() -> Vec<(String, Option<Value>)> {
    let big = json!(1u64 << 40);
    let huge = json!(u64::MAX);
    let mut e: Vec<(&str, Option<Value>)> = vec![
        // The reported case and its relatives: references to nothing.
        ("/meshes/0/primitives/0/attributes/POSITION", Some(json!(7))),
        (
            "/meshes/0/primitives/0/attributes/POSITION",
            Some(json!(-1)),
        ),
        (
            "/meshes/0/primitives/0/attributes/POSITION",
            Some(json!(4_294_967_296u64)),
        ),
        (
            "/meshes/0/primitives/0/attributes/POSITION",
            Some(json!("0")),
        ),
        ("/meshes/2/primitives/0/attributes/POSITION", Some(json!(5))),
        ("/meshes/0/primitives/0/attributes/NORMAL", Some(json!(99))),
        (
            "/meshes/0/primitives/0/attributes/TEXCOORD_0",
            Some(json!(5)),
        ),
        (
            "/meshes/0/primitives/0/attributes/_CUSTOM\n",
            Some(json!(99)),
        ),
        ("/meshes/0/primitives/0/indices", Some(json!(99))),
        (
            "/meshes/0/primitives/0/targets",
            Some(json!([{"POSITION": 42}])),
        ),
        ("/meshes/0/primitives/0/material", Some(json!(3))),
        ("/accessors/0/bufferView", Some(json!(99))),
        ("/accessors/1/bufferView", Some(json!(5))),
        ("/accessors/3/sparse/indices/bufferView", Some(json!(99))),
        ("/accessors/3/sparse/values/bufferView", Some(json!(5))),
        ("/bufferViews/0/buffer", Some(json!(1))),
        ("/bufferViews/1/buffer", Some(json!(99))),
        ("/nodes/0/mesh", Some(json!(3))),
        ("/nodes/0/children", Some(json!([99]))),
        ("/nodes/0/camera", Some(json!(0))),
        ("/nodes/0/skin", Some(json!(0))),
        ("/scenes/0/nodes", Some(json!([99]))),
        ("/scene", Some(json!(5))),
        ("/scene", Some(json!(-1))),
        ("/scenes", Some(json!([]))),
        // The wrong kind of data.
        ("/meshes/0/primitives/0/indices", Some(json!(0))),
        ("/meshes/0/primitives/0/attributes/POSITION", Some(json!(1))),
        ("/accessors/0/componentType", Some(json!(5125))),
        ("/accessors/0/componentType", Some(json!(1))),
        ("/accessors/0/componentType", Some(json!("FLOAT"))),
        ("/accessors/0/type", Some(json!("VEC2"))),
        ("/accessors/0/type", Some(json!("MAT4"))),
        ("/accessors/0/type", Some(json!("VEC7"))),
        ("/accessors/1/componentType", Some(json!(5126))),
        ("/accessors/1/componentType", Some(json!(5122))),
        ("/accessors/1/type", Some(json!("VEC3"))),
        ("/accessors/2/componentType", Some(json!(5125))),
        (
            "/accessors/3/sparse/indices/componentType",
            Some(json!(5126)),
        ),
        ("/meshes/0/primitives/0/mode", Some(json!(0))),
        ("/meshes/0/primitives/0/mode", Some(json!(1))),
        ("/meshes/0/primitives/0/mode", Some(json!(3))),
        ("/meshes/0/primitives/0/mode", Some(json!(99))),
        ("/meshes/1/primitives/0/mode", Some(json!(4))),
        ("/meshes/2/primitives/0/mode", Some(json!(2))),
        // Counts, offsets and strides that do not fit.
        ("/accessors/0/count", Some(json!(9))),
        ("/accessors/0/count", Some(json!(0))),
        ("/accessors/0/count", Some(json!(1_000_000))),
        ("/accessors/0/count", Some(big.clone())),
        ("/accessors/0/count", Some(huge.clone())),
        ("/accessors/0/count", Some(json!(-1))),
        ("/accessors/1/count", Some(json!(37))),
        ("/accessors/1/count", Some(json!(35))),
        ("/accessors/1/count", Some(big.clone())),
        ("/accessors/2/count", Some(json!(2))),
        ("/accessors/0/byteOffset", Some(json!(4))),
        ("/accessors/0/byteOffset", Some(json!(1u64 << 62))),
        ("/accessors/0/byteOffset", Some(huge.clone())),
        ("/accessors/1/byteOffset", Some(json!(1))),
        ("/accessors/3/count", Some(json!(9))),
        ("/accessors/3/sparse/count", Some(json!(0))),
        ("/accessors/3/sparse/count", Some(json!(9))),
        ("/accessors/3/sparse/count", Some(big.clone())),
        (
            "/accessors/3/sparse/indices/byteOffset",
            Some(json!(1u64 << 62)),
        ),
        ("/accessors/3/sparse/values/byteOffset", Some(huge.clone())),
        ("/accessors/4/count", Some(big.clone())),
        ("/accessors/4/count", Some(json!(100_000_000))),
        ("/bufferViews/0/byteOffset", Some(json!(190))),
        ("/bufferViews/0/byteOffset", Some(json!(1u64 << 62))),
        ("/bufferViews/0/byteLength", Some(json!(11))),
        ("/bufferViews/0/byteLength", Some(big.clone())),
        ("/bufferViews/0/byteLength", Some(huge.clone())),
        ("/bufferViews/0/byteStride", Some(json!(0))),
        ("/bufferViews/0/byteStride", Some(json!(1))),
        ("/bufferViews/0/byteStride", Some(json!(4))),
        ("/bufferViews/0/byteStride", Some(json!(11))),
        ("/bufferViews/0/byteStride", Some(json!(16))),
        ("/bufferViews/0/byteStride", Some(json!(255))),
        ("/bufferViews/0/byteStride", Some(big.clone())),
        ("/bufferViews/1/byteStride", Some(json!(4))),
        ("/bufferViews/3/byteStride", Some(json!(1))),
        ("/bufferViews/4/byteStride", Some(json!(4))),
        ("/buffers/0/byteLength", Some(big.clone())),
        ("/buffers/0/byteLength", Some(json!(0))),
        ("/buffers/0/byteLength", Some(json!(199))),
        // URIs that do not decode or name no file.
        ("/buffers/0/uri", Some(json!("%FF%FE.bin"))),
        ("/buffers/0/uri", Some(json!("%"))),
        ("/buffers/0/uri", Some(json!("missing.bin"))),
        ("/buffers/0/uri", Some(json!("."))),
        ("/buffers/0/uri", Some(json!("file:///dev/zero"))),
        (
            "/buffers/0/uri",
            Some(json!("data:application/octet-stream;base64,!!!")),
        ),
        ("/buffers/0/uri", Some(json!("data:,"))),
        ("/buffers/0/uri", Some(json!("http://example.com/x.bin"))),
        // Scene graphs that are not trees, transforms that are not.
        ("/nodes/0/children", Some(json!([0]))),
        ("/nodes/1/children", Some(json!([0]))),
        ("/nodes/0/children", Some(json!([1, 1]))),
        ("/scenes/0/nodes", Some(json!([0, 0]))),
        ("/scenes/0/nodes", Some(json!([]))),
        ("/nodes/1/matrix", Some(json!([1, 2, 3]))),
        (
            "/nodes/2/matrix",
            Some(json!([
                1e38, 0, 0, 0, 0, 1e38, 0, 0, 0, 0, 1e38, 0, 0, 0, 0, 1e38
            ])),
        ),
        ("/nodes/1/scale", Some(json!([1e38, 1e38, 1e38]))),
        ("/nodes/1/translation", Some(json!([1e39, 0, 0]))),
        ("/nodes/1/rotation", Some(json!([0, 0, 0, 0]))),
        ("/nodes/1/rotation", Some(json!([1, 2]))),
        // Other parts of the document.
        ("/asset/version", Some(json!("1.0"))),
        ("/asset/version", Some(json!(2))),
        (
            "/extensionsRequired",
            Some(json!(["KHR_draco_mesh_compression"])),
        ),
        ("/meshes/0/name", Some(json!("two\nlines \u{1b}[31m"))),
        ("/meshes/0/primitives/0/attributes", Some(json!({}))),
        ("/meshes/0/primitives", Some(json!([]))),
        (
            "/animations",
            Some(
                json!([{"channels": [{"sampler": 5, "target": {"node": 99, "path": "translation"}}], "samplers": []}]),
            ),
        ),
        (
            "/skins",
            Some(json!([{"joints": [99], "inverseBindMatrices": 99}])),
        ),
        (
            "/materials",
            Some(json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 9}}}])),
        ),
        ("/textures", Some(json!([{"source": 9, "sampler": 9}]))),
    ];
    let removed = [
        "/asset",
        "/accessors",
        "/bufferViews",
        "/buffers",
        "/meshes",
        "/nodes",
        "/scenes",
        "/accessors/0/bufferView",
        "/accessors/0/componentType",
        "/accessors/0/count",
        "/accessors/3/sparse/indices",
        "/bufferViews/0/byteLength",
        "/buffers/0/uri",
    ];
    e.extend(removed.map(|p| (p, None)));
    e.into_iter().map(|(p, v)| (p.to_string(), v)).collect()
}

/// A numeric member somewhere in the document replaced by a random unfit value.
fn gltf_random_edit(doc: &Value, rng: &mut Rng) -> (String, Value) {
    fn numbers(v: &Value, at: String, out: &mut Vec<String>) {
        match v {
            Value::Number(_) => out.push(at),
            Value::Array(a) => a
                .iter()
                .enumerate()
                .for_each(|(i, x)| numbers(x, format!("{at}/{i}"), out)),
            Value::Object(m) => m
                .iter()
                .for_each(|(k, x)| numbers(x, format!("{at}/{k}"), out)),
            _ => {}
        }
    }
    let mut all = Vec::new();
    numbers(doc, String::new(), &mut all);
    let at = rng.pick(&all).clone();
    let values = [
        json!(-1),
        json!(0),
        json!(1),
        json!(3),
        json!(255),
        json!(65_536),
        json!(u32::MAX),
        json!(1u64 << 33),
        json!(u64::MAX),
        json!(0.5),
        json!(-1e30),
        json!("7"),
        json!(null),
        json!([]),
        json!({}),
    ];
    let v = rng.pick(&values).clone();
    let mut d = doc.clone();
    edit(&mut d, &at, Some(v.clone()));
    (format!("{at} = {v}"), d)
}

// ---------------------------------------------------------------------------------------------
// TOML configs

/// Values of the wrong type or out of range for any key.
const TOML_VALUES: &[&str] = &[
    "\"five\"",
    "-1",
    "0",
    "1e400",
    "nan",
    "inf",
    "true",
    "[]",
    "{}",
    "[1, \"a\"]",
    "99999999999999999999",
    "\"\"",
    "\"builtin:nope\"",
    "{ eye = \"x\" }",
    "1979-05-27T07:32:00Z",
];

/// A `key = value` line given a value of the wrong type, or a key no table knows.
fn toml_specific(text: &str, rng: &mut Rng) -> Vec<(String, Vec<u8>)> {
    let lines: Vec<&str> = text.split('\n').collect();
    let assignments: Vec<usize> = (0..lines.len())
        .filter(|&i| {
            let t = lines[i].trim_start();
            !t.starts_with('#') && t.contains('=')
        })
        .collect();
    let tables: Vec<usize> = (0..lines.len())
        .filter(|&i| lines[i].trim_start().starts_with('['))
        .collect();
    let mut out = Vec::new();
    for _ in 0..2 {
        if assignments.is_empty() {
            break;
        }
        let i = *rng.pick(&assignments);
        let key = lines[i].split('=').next().unwrap().trim_end();
        let v = *rng.pick(TOML_VALUES);
        let mut l: Vec<String> = lines.iter().map(|s| s.to_string()).collect();
        l[i] = format!("{key} = {v}");
        out.push((
            format!("line {}: `{}`", i + 1, l[i]),
            l.join("\n").into_bytes(),
        ));
    }
    let at = if tables.is_empty() {
        0
    } else {
        *rng.pick(&tables) + 1
    };
    let mut l: Vec<String> = lines.iter().map(|s| s.to_string()).collect();
    l.insert(at, "bogus_key = 1".into());
    out.push((
        format!("unknown key at line {}", at + 1),
        l.join("\n").into_bytes(),
    ));
    out
}

// ---------------------------------------------------------------------------------------------
// Cases and their runs

#[derive(Clone, Copy, PartialEq, Eq)]
enum Kind {
    Scene,
    Config,
}

struct Case {
    what: String,
    file: PathBuf,
    kind: Kind,
    /// A seed as written: it must be accepted, or the mutations of it test little.
    must_load: bool,
}

struct Cases {
    dir: PathBuf,
    list: Vec<Case>,
}

impl Cases {
    /// Write `bytes` as the input of a new case (`ext`: the file name's ending).
    fn add(&mut self, kind: Kind, what: String, ext: &str, bytes: &[u8]) -> PathBuf {
        let file = self.dir.join(format!("c{:04}{ext}", self.list.len()));
        std::fs::write(&file, bytes).unwrap();
        self.list.push(Case {
            what,
            file: file.clone(),
            kind,
            must_load: false,
        });
        file
    }
    fn scene(&mut self, what: String, ext: &str, bytes: &[u8]) {
        self.add(Kind::Scene, what, ext, bytes);
    }
    /// A scene file that must load.
    fn valid(&mut self, what: &str, ext: &str, bytes: &[u8]) {
        self.scene(format!("{what} as written"), ext, bytes);
        self.list.last_mut().unwrap().must_load = true;
    }
}

enum Verdict {
    Accepted,
    Refused(String),
}

/// Check one case's exit status and stderr; `Ok` with the verdict, or `Err` with why the
/// case fails the test.
fn judge(code: Option<i32>, stderr: &str, kind: Kind) -> Result<Verdict, String> {
    if stderr.contains("panicked") || stderr.contains("RUST_BACKTRACE") {
        return Err(format!("a panic message on stderr:\n{stderr}"));
    }
    // Config loading reports the scenes it loads, and a loader notes what it left out of a
    // scene it accepts (`note: `, e.g. a face of two vertices); everything else on stderr is
    // the error.
    let lines: Vec<&str> = stderr
        .lines()
        .filter(|l| !(kind == Kind::Config && l.starts_with("loading ")))
        .filter(|l| !l.starts_with("note: "))
        .collect();
    match code {
        Some(0) if lines.is_empty() => Ok(Verdict::Accepted),
        Some(0) => Err(format!("exit 0, but stderr has:\n{stderr}")),
        Some(1) if lines.len() == 1 && lines[0].starts_with("error: ") => {
            Ok(Verdict::Refused(lines[0].to_string()))
        }
        Some(1) => Err(format!(
            "exit 1, but the error is not one `error: ` line:\n{stderr}"
        )),
        Some(c) => Err(format!("exit {c}:\n{stderr}")),
        None => Err(format!("killed by a signal:\n{stderr}")),
    }
}

/// `trace-bench info FILE` (1 GiB of address space at most).
fn run_scene(file: &Path) -> Result<Verdict, String> {
    // Under a memory limit where there is a shell: a loader that regressed into allocating
    // what a count in the file asks for, or reading an endless device, fails alone and fast
    // instead of taking the machine's memory.
    let mut cmd = if cfg!(unix) {
        let mut c = Command::new("sh");
        c.args([
            "-c",
            "ulimit -v 1048576 2>/dev/null; exec \"$0\" \"$@\"",
            BIN,
        ]);
        c
    } else {
        Command::new(BIN)
    };
    let out = cmd
        .arg("info")
        .arg(file)
        .env_remove("RUST_BACKTRACE")
        .stdin(Stdio::null())
        .output()
        .map_err(|e| format!("cannot run {BIN}: {e}"))?;
    judge(
        out.status.code(),
        &String::from_utf8_lossy(&out.stderr),
        Kind::Scene,
    )
}

/// `trace-bench validate CONFIG`, stopped once the runner reports its first step (a progress
/// line, two spaces in: every check passed, the config is accepted).
fn run_config(file: &Path, scenes_root: &Path) -> Result<Verdict, String> {
    let mut child = Command::new(BIN)
        .arg("validate")
        .arg(file)
        .env_remove("RUST_BACKTRACE")
        .env("TRACE_BENCH_SCENES", scenes_root)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| format!("cannot run {BIN}: {e}"))?;
    let stderr = child.stderr.take().unwrap();
    let (tx, rx) = mpsc::channel();
    let reader = std::thread::spawn(move || {
        for line in BufReader::new(stderr).lines() {
            let Ok(line) = line else { break };
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    let start = Instant::now();
    let mut text = String::new();
    let mut working = false;
    loop {
        let left = CASE_LIMIT.saturating_sub(start.elapsed());
        match rx.recv_timeout(left) {
            Ok(line) => {
                if line.starts_with("  ") {
                    working = true;
                    break;
                }
                text.push_str(&line);
                text.push('\n');
            }
            Err(mpsc::RecvTimeoutError::Disconnected) => break,
            Err(mpsc::RecvTimeoutError::Timeout) => {
                let _ = child.kill();
                let _ = child.wait();
                return Err(format!(
                    "neither refused nor working after {CASE_LIMIT:?}; stderr:\n{text}"
                ));
            }
        }
    }
    if working {
        let _ = child.kill();
        let _ = child.wait();
        drop(rx);
        let _ = reader.join();
        judge(Some(0), &text, Kind::Config)
    } else {
        let status = child.wait().map_err(|e| e.to_string())?;
        let _ = reader.join();
        judge(status.code(), &text, Kind::Config)
    }
}

fn shared_scenes() -> PathBuf {
    std::env::var_os("TRACE_BENCH_SCENES")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/scenes"))
}

/// Build every case.
fn cases(dir: &Path) -> Cases {
    let mut rng = Rng(SEED);
    let mut c = Cases {
        dir: dir.to_path_buf(),
        list: Vec::new(),
    };

    // OBJ and OBJ.gz of our own.
    let obj = OBJ.as_bytes();
    c.valid("cube OBJ", ".obj", obj);
    for (what, d) in generic(obj, &mut rng, 8, 8, OBJ_LINES) {
        c.scene(format!("cube OBJ {what}"), ".obj", &d);
    }
    let mut obj_mutants = obj_specific(OBJ, &mut rng, 24);
    for (what, d) in &obj_mutants {
        c.scene(format!("cube OBJ {what}"), ".obj", d);
    }
    let gz = gzip(obj);
    c.valid("cube OBJ.gz", ".obj.gz", &gz);
    for (what, d) in truncations(&gz, &mut rng, 2)
        .into_iter()
        .chain((0..6).map(|k| flip(&gz, &mut rng, 1 + k % 3)))
    {
        c.scene(
            format!("cube OBJ.gz, compressed data {what}"),
            ".obj.gz",
            &d,
        );
    }
    let mut two = gz.clone();
    two.extend_from_slice(&gzip(b"v 5 5 5\nv 6 5 5\nv 5 6 5\nf -1 -2 -3\n"));
    c.scene("cube OBJ.gz, two gzip members".into(), ".obj.gz", &two);
    c.scene("OBJ.gz of nothing".into(), ".obj.gz", &gzip(b""));
    c.scene("OBJ.gz that is plain text".into(), ".obj.gz", obj);
    obj_mutants.truncate(6);
    for (what, d) in obj_mutants {
        c.scene(format!("cube OBJ.gz of {what}"), ".obj.gz", &gzip(&d));
    }
    c.scene("empty OBJ".into(), ".obj", b"");
    c.scene(
        "binary garbage as OBJ".into(),
        ".obj",
        &(0..=255u8).cycle().take(1000).collect::<Vec<_>>(),
    );

    // glTF and GLB of our own: the document as written, targeted edits, random edits, bytes.
    let bin = gltf_buffer();
    let data_uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::encode(&bin)
    );
    let text = |d: &Value| serde_json::to_vec_pretty(d).unwrap();
    let doc = gltf_doc(Some(&data_uri));
    let glb_doc = gltf_doc(None);
    c.valid("glTF", ".gltf", &text(&doc));
    c.valid(
        "GLB",
        ".glb",
        &glb(&serde_json::to_vec(&glb_doc).unwrap(), Some(&bin)),
    );
    for (ptr, v) in gltf_edits() {
        let what = match &v {
            Some(v) => format!("{ptr} = {v}"),
            None => format!("{ptr} removed"),
        };
        let mut d = doc.clone();
        edit(&mut d, &ptr, v.clone());
        c.scene(format!("glTF {what}"), ".gltf", &text(&d));
        let mut d = glb_doc.clone();
        edit(&mut d, &ptr, v);
        c.scene(
            format!("GLB {what}"),
            ".glb",
            &glb(&serde_json::to_vec(&d).unwrap(), Some(&bin)),
        );
    }
    for _ in 0..20 {
        let (what, d) = gltf_random_edit(&doc, &mut rng);
        c.scene(format!("glTF {what}"), ".gltf", &text(&d));
        let (what, d) = gltf_random_edit(&glb_doc, &mut rng);
        let bytes = glb(&serde_json::to_vec(&d).unwrap(), Some(&bin));
        c.scene(format!("GLB {what}"), ".glb", &bytes);
    }
    const JSON_LINES: &[&str] = &[
        "{",
        "}",
        "]",
        "\"count\": 1e9,",
        "\"bufferView\": 9,",
        "null",
        "\"\\ud800\"",
    ];
    for (what, d) in generic(&text(&doc), &mut rng, 8, 8, JSON_LINES) {
        c.scene(format!("glTF text {what}"), ".gltf", &d);
    }
    let good_glb = glb(&serde_json::to_vec(&glb_doc).unwrap(), Some(&bin));
    for (what, d) in truncations(&good_glb, &mut rng, 4)
        .into_iter()
        .chain((0..8).map(|k| flip(&good_glb, &mut rng, [1, 2, 8][k % 3])))
    {
        c.scene(format!("GLB bytes {what}"), ".glb", &d);
    }
    let header_edits: &[(&str, usize, u32)] = &[
        ("version 1", 4, 1),
        ("version 3", 4, 3),
        ("total length 0", 8, 0),
        ("total length 5", 8, 5),
        ("total length 12", 8, 12),
        ("total length 2^32-1", 8, u32::MAX),
        ("JSON chunk length 2^32-1", 12, u32::MAX),
        ("JSON chunk length 0", 12, 0),
        ("JSON chunk type BIN", 16, 0x004E_4942),
    ];
    for &(what, at, v) in header_edits {
        let mut d = good_glb.clone();
        d[at..at + 4].copy_from_slice(&v.to_le_bytes());
        c.scene(format!("GLB header {what}"), ".glb", &d);
    }
    let json_len = u32::from_le_bytes(good_glb[12..16].try_into().unwrap()) as usize;
    let bin_at = 20 + json_len;
    for (what, v) in [
        ("BIN chunk length 2^32-1", u32::MAX),
        ("BIN chunk length 4", 4),
    ] {
        let mut d = good_glb.clone();
        d[bin_at..bin_at + 4].copy_from_slice(&v.to_le_bytes());
        c.scene(format!("GLB {what}"), ".glb", &d);
    }
    c.scene(
        "GLB without its BIN chunk".into(),
        ".glb",
        &glb(&serde_json::to_vec(&glb_doc).unwrap(), None),
    );
    c.scene("GLB of 6 bytes".into(), ".glb", b"glTF\x02\x00");
    c.scene("GLB of text".into(), ".glb", &text(&doc));
    // An external buffer next to the file: whole, then short.
    for len in [200, 199, 0] {
        let name = format!("b{:04}.bin", c.list.len());
        std::fs::write(dir.join(&name), &bin[..len]).unwrap();
        let json = text(&gltf_doc(Some(&name)));
        match len {
            200 => c.valid("glTF with an external buffer", ".gltf", &json),
            _ => c.scene(
                format!("glTF with an external buffer of {len} bytes"),
                ".gltf",
                &json,
            ),
        }
    }

    // Stacked random mutations: two to four of any kind on one input. `BAD_INPUT_EXTRA=N`
    // asks for N of them (default 120) for a longer run by hand.
    let extra = std::env::var("BAD_INPUT_EXTRA")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(120);
    for k in 0..extra {
        let mut whats = Vec::new();
        let steps = 2 + rng.below(3);
        match k % 4 {
            0 => {
                let mut d = obj.to_vec();
                for _ in 0..steps {
                    let (w, next) = match rng.below(3) {
                        0 => flip(&d, &mut rng, 1),
                        1 => line_edit(&d, &mut rng, OBJ_LINES),
                        _ => obj_specific(&String::from_utf8_lossy(&d), &mut rng, 1)
                            .pop()
                            .unwrap_or_else(|| ("nothing".into(), d.clone())),
                    };
                    whats.push(w);
                    d = next;
                }
                let (ext, d) = match rng.below(2) {
                    0 => (".obj", d),
                    _ => (".obj.gz", gzip(&d)),
                };
                c.scene(format!("cube OBJ {}", whats.join("; ")), ext, &d);
            }
            1 | 2 => {
                let mut d = if k % 4 == 1 {
                    doc.clone()
                } else {
                    glb_doc.clone()
                };
                for _ in 0..steps {
                    let (w, next) = gltf_random_edit(&d, &mut rng);
                    whats.push(w);
                    d = next;
                }
                let mut bytes = if k % 4 == 1 {
                    text(&d)
                } else {
                    glb(&serde_json::to_vec(&d).unwrap(), Some(&bin))
                };
                if rng.below(4) == 0 {
                    let (w, next) = flip(&bytes, &mut rng, 1);
                    whats.push(w);
                    bytes = next;
                }
                let ext = if k % 4 == 1 { ".gltf" } else { ".glb" };
                c.scene(format!("{ext} {}", whats.join("; ")), ext, &bytes);
            }
            _ => {
                let mut d = text(&doc);
                for _ in 0..steps {
                    let (w, next) = match rng.below(2) {
                        0 => flip(&d, &mut rng, 1),
                        _ => line_edit(&d, &mut rng, JSON_LINES),
                    };
                    whats.push(w);
                    d = next;
                }
                c.scene(format!("glTF text {}", whats.join("; ")), ".gltf", &d);
            }
        }
    }

    // The shared scenes (small ones only).
    let root = shared_scenes();
    let shared = [
        ("cornell-box/CornellBox-Original.obj", 6, 6),
        ("cornell-box/CornellBox-Sphere.obj", 2, 2),
        ("utah-teapot/teapot.newell.obj", 2, 2),
    ];
    let mut missing = Vec::new();
    for (name, flips, edits) in shared {
        let Ok(data) = std::fs::read(root.join(name)) else {
            missing.push(name);
            continue;
        };
        for (what, d) in generic(&data, &mut rng, flips, edits, OBJ_LINES) {
            c.scene(format!("{name} {what}"), ".obj", &d);
        }
        for (what, d) in obj_specific(&String::from_utf8_lossy(&data), &mut rng, 3) {
            c.scene(format!("{name} {what}"), ".obj", &d);
        }
        if name.contains("Original") {
            let gz = gzip(&data);
            for (what, d) in truncations(&gz, &mut rng, 0)
                .into_iter()
                .chain((0..3).map(|_| flip(&gz, &mut rng, 2)))
            {
                c.scene(format!("{name}.gz, compressed data {what}"), ".obj.gz", &d);
            }
        }
    }
    if !missing.is_empty() {
        println!(
            "skipped (shared scenes not found under {}; set TRACE_BENCH_SCENES): {}",
            root.display(),
            missing.join(", ")
        );
    }

    // Configs.
    let configs = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../configs");
    let mut names: Vec<PathBuf> = std::fs::read_dir(&configs)
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    names.sort();
    assert!(!names.is_empty(), "no configs in {}", configs.display());
    // The configs' named views, beside the mutated copies as beside the configs.
    std::fs::copy(configs.join("views.toml"), c.dir.join("views.toml")).unwrap();
    const TOML_LINES: &[&str] = &[
        "[run]",
        "[[scene]]",
        "[[structure]]",
        "name = 1",
        "= 2",
        "[run",
        "x = [",
        "threads = [1, 0, -1]",
    ];
    for p in &names {
        let name = p.file_name().unwrap().to_string_lossy().to_string();
        let data = std::fs::read(p).unwrap();
        // Two cut points per config (the middle and a random one), byte changes, line edits,
        // wrong types, an unknown key.
        let mut m: Vec<(String, Vec<u8>)> = [data.len() / 2, rng.below(data.len())]
            .iter()
            .map(|&k| {
                (
                    format!("truncated at {k} of {}", data.len()),
                    data[..k].to_vec(),
                )
            })
            .collect();
        m.push(flip(&data, &mut rng, 1));
        m.push(flip(&data, &mut rng, 3));
        m.push(line_edit(&data, &mut rng, TOML_LINES));
        m.push(line_edit(&data, &mut rng, TOML_LINES));
        m.extend(toml_specific(&String::from_utf8_lossy(&data), &mut rng));
        for (what, d) in m {
            c.add(Kind::Config, format!("{name} {what}"), ".toml", &d);
        }
    }
    // Configs naming broken scene files: the scene's error becomes the config's one line.
    let bad_gltf = c.add(
        Kind::Scene,
        "the reported case: POSITION names accessor 7 of none".into(),
        ".gltf",
        br#"{"asset": {"version": "2.0"}, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 7}}]}]}"#,
    );
    let bad_obj = c.add(
        Kind::Scene,
        "OBJ face index 4 of 3 vertices".into(),
        ".obj",
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n",
    );
    for (what, file) in [("glTF", &bad_gltf), ("OBJ", &bad_obj)] {
        let config = format!(
            "[run]\nthreads = 1\n\n[[scene]]\nsource = {:?}\n\n[[structure]]\nname = \"bvh\"\n",
            file.display().to_string()
        );
        c.add(
            Kind::Config,
            format!("config naming the broken {what} scene"),
            ".toml",
            config.as_bytes(),
        );
    }
    c
}

#[test]
fn bad_input_never_panics() {
    let dir = tempfile::tempdir().unwrap();
    let empty_root = tempfile::tempdir().unwrap();
    let start = Instant::now();
    let cases = cases(dir.path());
    let n = cases.list.len();
    // Two workers: one per core of the smallest machine we test on.
    let next = std::sync::atomic::AtomicUsize::new(0);
    let results: Vec<(usize, Result<Verdict, String>)> = std::thread::scope(|s| {
        let workers: Vec<_> = (0..2)
            .map(|_| {
                s.spawn(|| {
                    let mut out = Vec::new();
                    loop {
                        let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                        let Some(case) = cases.list.get(i) else { break };
                        let r = match case.kind {
                            Kind::Scene => run_scene(&case.file),
                            Kind::Config => run_config(&case.file, empty_root.path()),
                        };
                        out.push((i, r));
                    }
                    out
                })
            })
            .collect();
        workers
            .into_iter()
            .flat_map(|w| w.join().unwrap())
            .collect()
    });
    let mut failures = Vec::new();
    let mut counts = [[0usize; 2]; 2]; // [scene, config] x [accepted, refused]
    for (i, r) in results {
        let case = &cases.list[i];
        let k = (case.kind == Kind::Config) as usize;
        match r {
            Ok(Verdict::Refused(line)) if case.must_load => {
                failures.push(format!("{} was refused: {line}", case.what));
            }
            Ok(Verdict::Accepted) => counts[k][0] += 1,
            Ok(Verdict::Refused(line)) => {
                counts[k][1] += 1;
                if std::env::var_os("BAD_INPUT_VERBOSE").is_some() {
                    println!("{}: {line}", case.what.escape_debug());
                }
            }
            Err(why) => failures.push(format!(
                "{} ({}): {why}",
                case.what.escape_debug(),
                case.file.display()
            )),
        }
    }
    println!(
        "{n} cases in {:.1} s: scenes {} accepted, {} refused; configs {} accepted, {} refused",
        start.elapsed().as_secs_f64(),
        counts[0][0],
        counts[0][1],
        counts[1][0],
        counts[1][1]
    );
    if !failures.is_empty() {
        // Keep the inputs for a look.
        let kept = dir.keep();
        panic!(
            "{} of {n} cases failed (inputs kept in {}):\n{}",
            failures.len(),
            kept.display(),
            failures.join("\n")
        );
    }
    assert!(n >= 300, "only {n} cases");
}
