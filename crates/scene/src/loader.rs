//! File loaders: Wavefront OBJ (plain or gzip-compressed) and glTF 2.0 (`.gltf`, `.glb`).
//!
//! Only vertex positions are read; trace-bench uses geometric normals, so normals, texture
//! coordinates and materials are ignored. Every loader returns one flat triangle list.
//!
//! - **OBJ** (`.obj`), through `tobj`: polygons are triangulated as fans, all objects and groups
//!   are merged, `.mtl` files are never opened, point and line elements (`p`, `l`, and `f` with
//!   fewer than three vertices) are ignored. Relative (negative) indices are supported.
//! - **gzip-compressed OBJ** (`.obj.gz`): decompressed in memory (flate2, multi-member gzip
//!   accepted), then parsed as above.
//! - **glTF 2.0** (`.gltf` with embedded or external buffers, `.glb`), through the `gltf` crate:
//!   the primitives of every mesh instance reachable from the default scene (the first scene
//!   when none is marked default), with the node transforms of the hierarchy applied. Buffers
//!   are loaded (`gltf::import_buffers`), images are not, so missing textures do not matter.
//!   Primitives in mode `Triangles` are read as they are; `TriangleStrip` and `TriangleFan` are
//!   converted to triangle lists; points and lines (`Points`, `Lines`, `LineLoop`, `LineStrip`)
//!   are an error naming the mesh, the primitive and the mode.
//!
//! Malformed input never panics: every problem is one [`SceneError::File`] with a one-line
//! message naming the file and, for OBJ, the line where it is known (for glTF, the JSON path).
//! What the gltf crate would index or compute unchecked is checked first; a panic of a parser
//! all the same is caught without printing anything and becomes the error.

use crate::error::SceneError;
use crate::scene::Scene;
use std::cell::Cell;
use std::io::{BufRead, Read};
use std::panic::AssertUnwindSafe;
use std::path::{Path, PathBuf};
use std::sync::Once;
use tb_core::{Triangle, Vec3};

/// File name endings [`load_file`] accepts (case-insensitive).
pub const SUPPORTED_EXTENSIONS: &[&str] = &[".obj", ".obj.gz", ".gltf", ".glb"];

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    Obj,
    ObjGz,
    Gltf,
}

fn format_of(path: &Path) -> Option<Format> {
    let name = path.file_name()?.to_string_lossy().to_ascii_lowercase();
    if name.ends_with(".obj.gz") {
        Some(Format::ObjGz)
    } else if name.ends_with(".obj") {
        Some(Format::Obj)
    } else if name.ends_with(".gltf") || name.ends_with(".glb") {
        Some(Format::Gltf)
    } else {
        None
    }
}

/// A [`SceneError::File`]; control characters of the message (from names and text in the file)
/// are escaped, so that it stays one line.
fn file_err(path: &Path, message: impl Into<String>) -> SceneError {
    let message: String = message.into();
    let message = if message.chars().any(char::is_control) {
        message
            .chars()
            .map(|c| {
                if c.is_control() {
                    c.escape_default().to_string()
                } else {
                    c.to_string()
                }
            })
            .collect()
    } else {
        message
    };
    SceneError::File {
        path: path.to_path_buf(),
        message,
    }
}

/// Load `.obj`, `.obj.gz`, `.gltf` or `.glb` (see the module documentation for what is read).
///
/// Errors: [`SceneError::NotFound`] when the file does not exist; [`SceneError::File`] for an
/// unsupported extension, unreadable or malformed content (with the line for OBJ where known),
/// a non-finite vertex, an out-of-range index, or a file without triangles.
pub fn load_file(path: &Path) -> Result<Scene, SceneError> {
    match std::fs::metadata(path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Err(SceneError::NotFound {
                path: path.to_path_buf(),
            })
        }
        Err(e) => return Err(file_err(path, format!("cannot read: {e}"))),
        Ok(m) if m.is_dir() => return Err(file_err(path, "is a directory, not a scene file")),
        Ok(_) => {}
    }
    let format = format_of(path).ok_or_else(|| {
        file_err(
            path,
            format!(
                "unsupported file type (supported: {})",
                SUPPORTED_EXTENSIONS.join(", ")
            ),
        )
    })?;
    let bytes = std::fs::read(path).map_err(|e| match e.kind() {
        std::io::ErrorKind::NotFound => SceneError::NotFound {
            path: path.to_path_buf(),
        },
        _ => file_err(path, format!("cannot read: {e}")),
    })?;
    // The parsers are guarded against hostile input; should one still panic, its message is
    // the error, and nothing else is printed.
    let parsed = quietly(|| match format {
        Format::Obj => obj_triangles(path, bytes),
        Format::ObjGz => {
            let text = gunzip(path, &bytes)?;
            drop(bytes);
            obj_triangles(path, text)
        }
        Format::Gltf => gltf_triangles(path, &bytes).map(|t| (t, Vec::new())),
    });
    let (triangles, notes) = match parsed {
        Ok(result) => result?,
        Err(panic) => {
            let what = match format {
                Format::Obj | Format::ObjGz => "OBJ",
                Format::Gltf => "glTF",
            };
            return Err(file_err(
                path,
                format!("malformed {what} (the parser failed: {panic})"),
            ));
        }
    };
    if triangles.is_empty() {
        return Err(file_err(path, "contains no triangles"));
    }
    let mut scene = Scene::from_triangles(path.display().to_string(), triangles);
    scene.notes = notes;
    Ok(scene)
}

// ---------------------------------------------------------------------------------------------
// gzip

/// The most bytes a gzip scene may decompress to (4 GiB, an OBJ of some 50M triangles), unless
/// `TRACE_BENCH_MAX_GUNZIP` (bytes) says otherwise: a corrupt or hostile file (a "gzip bomb"
/// expands a thousandfold) ends in a clear error instead of exhausting memory.
pub fn gunzip_limit() -> u64 {
    std::env::var("TRACE_BENCH_MAX_GUNZIP")
        .ok()
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or(4 << 30)
}

/// Decompress a whole gzip file in memory, at most [`gunzip_limit`] bytes.
fn gunzip(path: &Path, bytes: &[u8]) -> Result<Vec<u8>, SceneError> {
    gunzip_at_most(path, bytes, gunzip_limit())
}

fn gunzip_at_most(path: &Path, bytes: &[u8], limit: u64) -> Result<Vec<u8>, SceneError> {
    // The trailer's ISIZE (uncompressed size mod 2^32) is a good capacity hint; clamp it so a
    // corrupt trailer cannot make us reserve absurd amounts.
    let hint = match bytes.len() {
        n if n >= 18 => {
            let t = &bytes[n - 4..];
            u32::from_le_bytes([t[0], t[1], t[2], t[3]]) as usize
        }
        _ => 0,
    };
    let cap = hint
        .min(bytes.len().saturating_mul(32))
        .min(1 << 30)
        .min(usize::try_from(limit).unwrap_or(usize::MAX));
    let mut out = Vec::with_capacity(cap);
    flate2::read::MultiGzDecoder::new(bytes)
        .take(limit.saturating_add(1))
        .read_to_end(&mut out)
        .map_err(|e| {
            file_err(
                path,
                format!("cannot decompress gzip data (truncated or corrupt file?): {e}"),
            )
        })?;
    if out.len() as u64 > limit {
        return Err(file_err(
            path,
            format!(
                "decompresses to more than {limit} bytes (the limit; set TRACE_BENCH_MAX_GUNZIP \
                 to a larger byte count if the file is genuine)"
            ),
        ));
    }
    Ok(out)
}

// ---------------------------------------------------------------------------------------------
// OBJ

/// An in-memory `BufRead` that remembers how far the parser got, for error line numbers.
struct SliceReader<'a> {
    data: &'a [u8],
    pos: usize,
}

impl Read for SliceReader<'_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let rest = &self.data[self.pos..];
        let n = rest.len().min(buf.len());
        buf[..n].copy_from_slice(&rest[..n]);
        self.pos += n;
        Ok(n)
    }
}

impl BufRead for SliceReader<'_> {
    fn fill_buf(&mut self) -> std::io::Result<&[u8]> {
        Ok(&self.data[self.pos..])
    }
    fn consume(&mut self, amt: usize) {
        self.pos = (self.pos + amt).min(self.data.len());
    }
}

/// 1-based number of the line the parser read last, given the bytes it consumed.
fn line_at(data: &[u8], pos: usize) -> usize {
    let consumed = &data[..pos.min(data.len())];
    let newlines = consumed.iter().filter(|&&b| b == b'\n').count();
    if consumed.last() == Some(&b'\n') {
        newlines
    } else {
        newlines + 1
    }
}

/// Turn OBJ polyline elements (`l …`) into comments: tobj would read a polyline of three or
/// more vertices as a polygon, but a line is not a surface.
fn neutralize_polylines(data: &mut [u8]) {
    for line in data.split_mut(|&b| b == b'\n') {
        let start = line
            .iter()
            .position(|&b| b != b' ' && b != b'\t')
            .unwrap_or(line.len());
        if line.get(start) == Some(&b'l')
            && matches!(line.get(start + 1), None | Some(b' ' | b'\t' | b'\r'))
        {
            line[start] = b'#';
        }
    }
}

/// Iterate over `(1-based line number, line)` of a text buffer.
fn numbered_lines(data: &[u8]) -> impl Iterator<Item = (usize, &[u8])> {
    data.split(|&b| b == b'\n')
        .enumerate()
        .map(|(i, l)| (i + 1, l))
}

fn words(line: &[u8]) -> impl Iterator<Item = &str> {
    line.split(|b| b.is_ascii_whitespace())
        .filter(|w| !w.is_empty())
        .map(|w| std::str::from_utf8(w).unwrap_or("\u{fffd}"))
}

/// Find the first face line with a vertex, texture or normal index out of range (checked
/// against the elements defined before that line), for the error message.
fn find_bad_face_index(data: &[u8]) -> Option<String> {
    let mut counts = [0usize; 3]; // v, vt, vn
    const WHAT: [&str; 3] = ["vertex", "texture coordinate", "normal"];
    const PLURAL: [&str; 3] = ["vertices", "texture coordinates", "normals"];
    for (no, line) in numbered_lines(data) {
        let mut w = words(line);
        match w.next() {
            Some("v") => counts[0] += 1,
            Some("vt") => counts[1] += 1,
            Some("vn") => counts[2] += 1,
            Some("f") => {
                for token in w {
                    for (k, part) in token.split('/').enumerate().take(3) {
                        if part.is_empty() {
                            continue;
                        }
                        let Ok(i) = part.parse::<i64>() else {
                            continue;
                        };
                        let n = counts[k] as i64;
                        let ok = if i > 0 { i <= n } else { i < 0 && -i <= n };
                        if !ok {
                            return Some(format!(
                                "line {no}: face {} index {i} out of range ({} {} defined before this line)",
                                WHAT[k],
                                counts[k],
                                PLURAL[k],
                            ));
                        }
                    }
                }
            }
            _ => {}
        }
    }
    None
}

/// Find the first `v` line with a non-finite coordinate.
fn find_non_finite_vertex(data: &[u8]) -> Option<String> {
    for (no, line) in numbered_lines(data) {
        let mut w = words(line);
        if w.next() == Some("v") {
            let vals: Vec<f32> = w.take(4).filter_map(|s| s.parse().ok()).collect();
            let mut p: Vec<f32> = vals.iter().take(3).copied().collect();
            if vals.len() == 4 {
                p.iter_mut().for_each(|c| *c /= vals[3]);
            }
            if p.iter().any(|c| !c.is_finite()) {
                return Some(format!(
                    "line {no}: vertex with a non-finite coordinate: {}",
                    String::from_utf8_lossy(line).trim()
                ));
            }
        }
    }
    None
}

fn obj_error(path: &Path, data: &[u8], pos: usize, e: tobj::LoadError) -> SceneError {
    use tobj::LoadError as E;
    let message = match e {
        E::FaceVertexOutOfBounds
        | E::FaceTexCoordOutOfBounds
        | E::FaceNormalOutOfBounds
        | E::FaceColorOutOfBounds
        | E::InvalidPolygon => find_bad_face_index(data)
            .unwrap_or_else(|| format!("invalid OBJ: {e} (a face refers to a missing element)")),
        E::ReadError => format!(
            "line {}: invalid OBJ: cannot read the line (not UTF-8 text?)",
            line_at(data, pos)
        ),
        _ => {
            let no = line_at(data, pos);
            let text: String = numbered_lines(data)
                .nth(no - 1)
                .map(|(_, l)| String::from_utf8_lossy(l).trim().chars().take(80).collect())
                .unwrap_or_default();
            format!("line {no}: invalid OBJ: {e}: `{text}`")
        }
    };
    file_err(path, message)
}

/// Faces (`f`) of fewer than three vertices, which tobj drops: how many, and the first's
/// line, as a note naming the file (`None` when there are none).
fn short_faces(path: &Path, data: &[u8]) -> Option<String> {
    let mut count = 0usize;
    let mut first = 0usize;
    for (no, line) in numbered_lines(data) {
        let mut w = words(line);
        if w.next() == Some("f") && w.count() < 3 {
            count += 1;
            if first == 0 {
                first = no;
            }
        }
    }
    (count > 0).then(|| {
        format!(
            "{}: {count} face{} of fewer than three vertices left out (not a surface; the \
             first at line {first})",
            path.display(),
            if count == 1 { "" } else { "s" }
        )
    })
}

/// Parse OBJ text (already in memory) into triangles, and the notes of what was left out.
fn obj_triangles(
    path: &Path,
    mut data: Vec<u8>,
) -> Result<(Vec<Triangle>, Vec<String>), SceneError> {
    neutralize_polylines(&mut data);
    let notes: Vec<String> = short_faces(path, &data).into_iter().collect();
    // `..Default::default()` covers the fields of optional tobj features.
    #[allow(clippy::needless_update)]
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
        ..Default::default()
    };
    let mut reader = SliceReader {
        data: &data,
        pos: 0,
    };
    // Materials are never loaded: the loader answers every `mtllib` with an empty library.
    let result = tobj::load_obj_buf(&mut reader, &options, |_| Ok(Default::default()));
    let pos = reader.pos;
    let models = match result {
        Ok((models, _materials)) => models,
        Err(e) => return Err(obj_error(path, &data, pos, e)),
    };

    let count: usize = models.iter().map(|m| m.mesh.indices.len() / 3).sum();
    let mut tris = Vec::with_capacity(count);
    for model in &models {
        let mesh = &model.mesh;
        let positions: Vec<Vec3> = mesh
            .positions
            .chunks_exact(3)
            .map(|c| Vec3::new(c[0], c[1], c[2]))
            .collect();
        if positions.iter().any(|p| !p.is_finite()) {
            let message = find_non_finite_vertex(&data)
                .unwrap_or_else(|| "a vertex has a non-finite coordinate".into());
            return Err(file_err(path, message));
        }
        for f in mesh.indices.chunks_exact(3) {
            let get = |i: u32| positions.get(i as usize).copied();
            match (get(f[0]), get(f[1]), get(f[2])) {
                (Some(a), Some(b), Some(c)) => tris.push(Triangle::new(a, b, c)),
                _ => {
                    let message = find_bad_face_index(&data).unwrap_or_else(|| {
                        format!("object `{}`: face index out of range", model.name)
                    });
                    return Err(file_err(path, message));
                }
            }
        }
    }
    Ok((tris, notes))
}

// ---------------------------------------------------------------------------------------------
// Panics of the parsers

thread_local! {
    /// Set while [`quietly`] runs a parser on this thread.
    static QUIET: Cell<bool> = const { Cell::new(false) };
}

/// Installs the panic hook of [`quietly`], once.
static QUIET_HOOK: Once = Once::new();

fn panic_message(p: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = p.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = p.downcast_ref::<String>() {
        s.clone()
    } else {
        "unknown error".into()
    }
}

/// Run a parser, catching a panic of it (a dependency's on input we did not foresee) as its
/// message, and printing nothing: no `thread … panicked at` line, no backtrace.
///
/// The first call installs a process-wide panic hook that stays silent on a thread inside
/// `quietly` and hands every other panic to the hook that was there before, so panics of other
/// threads, and of this thread outside the call, are reported as they were.
fn quietly<R>(f: impl FnOnce() -> R) -> Result<R, String> {
    QUIET_HOOK.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if !QUIET.with(Cell::get) {
                previous(info);
            }
        }));
    });
    let outer = QUIET.with(|q| q.replace(true));
    let result = std::panic::catch_unwind(AssertUnwindSafe(f));
    QUIET.with(|q| q.set(outer));
    result.map_err(|p| panic_message(&*p))
}

// ---------------------------------------------------------------------------------------------
// glTF
//
// The gltf crate trusts parts of its input: its validation indexes the POSITION accessor before
// it checks indices (gltf-json 1.4: a panic when it does not exist), the GLB reader subtracts
// the header size from the header's length unchecked, buffer URIs are percent-decoded with an
// `unwrap`, and the accessor reader computes byte ranges without overflow checks and panics
// on strides below the element size. Everything it would trip over is checked here first, so
// that the error names the file and the problem; [`quietly`] is only the last line of defence.

/// The most elements an accessor without a buffer view (zeros plus sparse values) may have:
/// its elements are allocated, not read, so a count is all it takes to exhaust memory.
const MAX_ZERO_FILLED: usize = 1 << 24;

fn gltf_triangles(path: &Path, bytes: &[u8]) -> Result<Vec<Triangle>, SceneError> {
    gltf_triangles_inner(path.parent(), bytes).map_err(|m| file_err(path, m))
}

/// Check the 12-byte GLB header (magic `glTF`, version, total length) of a binary glTF.
fn check_glb_header(bytes: &[u8]) -> Result<(), String> {
    if !bytes.starts_with(b"glTF") {
        return Ok(());
    }
    let word = |i: usize| {
        bytes
            .get(i..i + 4)
            .map(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]]))
    };
    let (Some(version), Some(length)) = (word(4), word(8)) else {
        return Err(format!(
            "invalid GLB: {} bytes, shorter than the 12-byte header (truncated file?)",
            bytes.len()
        ));
    };
    if version != 2 {
        return Err(format!(
            "invalid GLB: version {version} (only glTF 2.0 is supported)"
        ));
    }
    if length < 12 {
        return Err(format!(
            "invalid GLB: the header gives a total length of {length} bytes, less than the header"
        ));
    }
    if length as usize > bytes.len() {
        return Err(format!(
            "invalid GLB: the header gives a total length of {length} bytes, the file has {} (truncated file?)",
            bytes.len()
        ));
    }
    Ok(())
}

/// `Err` naming `at` when `index` is not below `len` (`what`: singular and plural).
fn exists(
    at: &dyn Fn() -> String,
    what: (&str, &str),
    index: usize,
    len: usize,
) -> Result<(), String> {
    if index < len {
        return Ok(());
    }
    let have = match len {
        0 => format!("the file has no {}", what.1),
        1 => format!("the file has 1 {}", what.0),
        n => format!("the file has {n} {}", what.1),
    };
    Err(format!(
        "{}: {} {index} does not exist ({have})",
        at(),
        what.0
    ))
}

/// Check every reference between the scene graph, meshes, accessors, buffer views and buffers
/// (JSON paths in the messages). The gltf crate's validation checks the rest of the document,
/// but it must not see these unchecked (see above).
fn check_references(root: &gltf::json::Root) -> Result<(), String> {
    const SCENE: (&str, &str) = ("scene", "scenes");
    const NODE: (&str, &str) = ("node", "nodes");
    const MESH: (&str, &str) = ("mesh", "meshes");
    const ACCESSOR: (&str, &str) = ("accessor", "accessors");
    const VIEW: (&str, &str) = ("bufferView", "bufferViews");
    const BUFFER: (&str, &str) = ("buffer", "buffers");
    let (scenes, nodes, meshes) = (root.scenes.len(), root.nodes.len(), root.meshes.len());
    let (accessors, views, buffers) = (
        root.accessors.len(),
        root.buffer_views.len(),
        root.buffers.len(),
    );
    if let Some(s) = root.scene {
        exists(&|| "scene".into(), SCENE, s.value(), scenes)?;
    }
    for (si, scene) in root.scenes.iter().enumerate() {
        for (k, n) in scene.nodes.iter().enumerate() {
            exists(
                &|| format!("scenes[{si}].nodes[{k}]"),
                NODE,
                n.value(),
                nodes,
            )?;
        }
    }
    for (ni, node) in root.nodes.iter().enumerate() {
        for (k, c) in node.children.iter().flatten().enumerate() {
            exists(
                &|| format!("nodes[{ni}].children[{k}]"),
                NODE,
                c.value(),
                nodes,
            )?;
        }
        if let Some(m) = node.mesh {
            exists(&|| format!("nodes[{ni}].mesh"), MESH, m.value(), meshes)?;
        }
    }
    for (mi, mesh) in root.meshes.iter().enumerate() {
        for (pi, prim) in mesh.primitives.iter().enumerate() {
            let at = |what: &str| format!("meshes[{mi}].primitives[{pi}].{what}");
            for (semantic, a) in &prim.attributes {
                let name = match semantic {
                    gltf::json::validation::Checked::Valid(s) => s.to_string(),
                    gltf::json::validation::Checked::Invalid => "?".into(),
                };
                exists(
                    &|| at(&format!("attributes.{name}")),
                    ACCESSOR,
                    a.value(),
                    accessors,
                )?;
            }
            if let Some(a) = prim.indices {
                exists(&|| at("indices"), ACCESSOR, a.value(), accessors)?;
            }
            for (ti, target) in prim.targets.iter().flatten().enumerate() {
                let morph = [
                    ("POSITION", target.positions),
                    ("NORMAL", target.normals),
                    ("TANGENT", target.tangents),
                ];
                for (name, a) in morph {
                    if let Some(a) = a {
                        let at = || at(&format!("targets[{ti}].{name}"));
                        exists(&at, ACCESSOR, a.value(), accessors)?;
                    }
                }
            }
        }
    }
    for (ai, acc) in root.accessors.iter().enumerate() {
        if let Some(v) = acc.buffer_view {
            exists(
                &|| format!("accessors[{ai}].bufferView"),
                VIEW,
                v.value(),
                views,
            )?;
        }
        if let Some(sparse) = &acc.sparse {
            let at = || format!("accessors[{ai}].sparse.indices.bufferView");
            exists(&at, VIEW, sparse.indices.buffer_view.value(), views)?;
            let at = || format!("accessors[{ai}].sparse.values.bufferView");
            exists(&at, VIEW, sparse.values.buffer_view.value(), views)?;
        }
    }
    for (vi, view) in root.buffer_views.iter().enumerate() {
        exists(
            &|| format!("bufferViews[{vi}].buffer"),
            BUFFER,
            view.buffer.value(),
            buffers,
        )?;
    }
    Ok(())
}

/// Percent-decode a relative URI as the gltf crate does (`%XX` with two hex digits; anything
/// else kept as it is); `None` when the result is not UTF-8.
fn percent_decode(uri: &str) -> Option<String> {
    let b = uri.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let hex = |k: usize| b.get(k).and_then(|&c| (c as char).to_digit(16));
        match (b[i], hex(i + 1), hex(i + 2)) {
            (b'%', Some(h), Some(l)) => {
                out.push((h * 16 + l) as u8);
                i += 3;
            }
            (c, _, _) => {
                out.push(c);
                i += 1;
            }
        }
    }
    String::from_utf8(out).ok()
}

/// Check the external buffers before the gltf crate reads them: a relative URI must decode to
/// UTF-8, and what it (or a `file:` URI) names must be a regular file, not a directory or a
/// device that never ends.
fn check_buffer_uris(document: &gltf::Document, base: Option<&Path>) -> Result<(), String> {
    let Some(base) = base else { return Ok(()) };
    for buffer in document.buffers() {
        let gltf::buffer::Source::Uri(uri) = buffer.source() else {
            continue;
        };
        let at = || format!("buffers[{}].uri", buffer.index());
        let file: PathBuf = if uri.contains(':') {
            match uri
                .strip_prefix("file://")
                .or_else(|| uri.strip_prefix("file:"))
            {
                Some(p) => PathBuf::from(p),
                None => continue, // `data:` (decoded by the crate) or an unsupported scheme
            }
        } else {
            let decoded = percent_decode(uri)
                .ok_or_else(|| format!("{}: `{uri}` is not UTF-8 once percent-decoded", at()))?;
            base.join(decoded)
        };
        match std::fs::metadata(&file) {
            Ok(m) if m.is_file() => {}
            Ok(_) => return Err(format!("{}: {} is not a file", at(), file.display())),
            Err(e) => return Err(format!("{}: cannot read {}: {e}", at(), file.display())),
        }
    }
    Ok(())
}

/// Check that `count` elements of `elem` bytes from byte `offset` of `view` (at its stride)
/// lie inside the view, and the view inside its buffer, with checked arithmetic.
fn check_elements(
    at: &str,
    view: &gltf::buffer::View,
    buffers: &[gltf::buffer::Data],
    offset: usize,
    count: usize,
    elem: usize,
) -> Result<(), String> {
    let vi = view.index();
    let stride = view.stride().unwrap_or(elem);
    if stride < elem {
        return Err(format!(
            "{at}: bufferViews[{vi}].byteStride {stride} is less than the element size ({elem} bytes)"
        ));
    }
    let bi = view.buffer().index();
    let buffer_len = buffers.get(bi).map_or(0, |d| d.len());
    let view_end = view.offset().checked_add(view.length());
    if !matches!(view_end, Some(end) if end <= buffer_len) {
        return Err(format!(
            "bufferViews[{vi}]: {} bytes from byte {} lie outside buffer {bi} ({buffer_len} bytes)",
            view.length(),
            view.offset()
        ));
    }
    let end = stride
        .checked_mul(count.saturating_sub(1))
        .and_then(|n| n.checked_add(elem))
        .and_then(|n| n.checked_add(offset));
    if !matches!(end, Some(end) if end <= view.length()) {
        return Err(format!(
            "{at}: {count} elements of {elem} bytes (stride {stride}) from byte {offset} do not fit in bufferViews[{vi}] ({} bytes)",
            view.length()
        ));
    }
    Ok(())
}

/// Check the data of an accessor the loader reads (elements of `elem` bytes), sparse parts
/// included, before the gltf crate's reader computes its ranges.
fn check_accessor(
    acc: &gltf::Accessor,
    buffers: &[gltf::buffer::Data],
    elem: usize,
) -> Result<(), String> {
    let at = format!("accessors[{}]", acc.index());
    let count = acc.count();
    if count == 0 {
        return Ok(());
    }
    match acc.view() {
        Some(view) => check_elements(&at, &view, buffers, acc.offset(), count, elem)?,
        None if acc.sparse().is_none() => {
            return Err(format!("{at}: neither a bufferView nor sparse data"))
        }
        None if count > MAX_ZERO_FILLED => {
            return Err(format!(
                "{at}: {count} elements without a bufferView (more than {MAX_ZERO_FILLED} are not supported)"
            ))
        }
        None => {}
    }
    if let Some(sparse) = acc.sparse() {
        let n = sparse.count();
        if n == 0 || n > count {
            return Err(format!(
                "{at}.sparse.count: {n} is out of range 1..={count}"
            ));
        }
        let indices = sparse.indices();
        let size = indices.index_type().size();
        let at_i = format!("{at}.sparse.indices");
        check_elements(&at_i, &indices.view(), buffers, indices.offset(), n, size)?;
        let values = sparse.values();
        let at_v = format!("{at}.sparse.values");
        check_elements(&at_v, &values.view(), buffers, values.offset(), n, elem)?;
    }
    Ok(())
}

fn gltf_triangles_inner(base: Option<&Path>, bytes: &[u8]) -> Result<Vec<Triangle>, String> {
    use gltf::accessor::{DataType, Dimensions};
    use gltf::mesh::Mode;

    check_glb_header(bytes)?;
    let gltf::Gltf { document, blob } = gltf::Gltf::from_slice_without_validation(bytes)
        .map_err(|e| format!("invalid glTF: {e}"))?;
    let root = document.into_json();
    check_references(&root)?;
    // (Its message lists every problem, each ending in `;`.)
    let document = gltf::Document::from_json(root)
        .map_err(|e| e.to_string().trim_end_matches(';').to_string())?;
    check_buffer_uris(&document, base)?;
    let buffers = gltf::import_buffers(&document, base, blob)
        .map_err(|e| format!("invalid glTF: cannot load buffers: {e}"))?;
    let scene = document
        .default_scene()
        .or_else(|| document.scenes().next())
        .ok_or("glTF file has no scene")?;

    let mut tris = Vec::new();
    let mut visited = vec![false; document.nodes().len()];
    let mut stack: Vec<(gltf::Node, glam::Mat4)> =
        scene.nodes().map(|n| (n, glam::Mat4::IDENTITY)).collect();
    stack.reverse();
    while let Some((node, parent)) = stack.pop() {
        let seen = visited
            .get_mut(node.index())
            .ok_or_else(|| format!("node {} does not exist", node.index()))?;
        if *seen {
            return Err(format!(
                "node {} is reached twice in the scene graph (cycle or shared child)",
                node.index()
            ));
        }
        *seen = true;
        let local = glam::Mat4::from_cols_array_2d(&node.transform().matrix());
        let world = parent * local;
        let mut children: Vec<_> = node.children().map(|c| (c, world)).collect();
        children.reverse();
        stack.extend(children);

        let Some(mesh) = node.mesh() else { continue };
        let mesh_name = match mesh.name() {
            Some(n) => format!("mesh '{n}'"),
            None => format!("mesh {}", mesh.index()),
        };
        for (pi, prim) in mesh.primitives().enumerate() {
            let what = format!("{mesh_name} primitive {pi}");
            let mode = prim.mode();
            if !matches!(
                mode,
                Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
            ) {
                return Err(format!(
                    "{what}: mode {mode:?} is not supported (only Triangles, TriangleStrip, TriangleFan)"
                ));
            }
            let acc = prim
                .get(&gltf::Semantic::Positions)
                .ok_or_else(|| format!("{what}: no POSITION attribute"))?;
            if acc.data_type() != DataType::F32 || acc.dimensions() != Dimensions::Vec3 {
                return Err(format!(
                    "{what}: POSITION must be float VEC3, is {:?} {:?}",
                    acc.data_type(),
                    acc.dimensions()
                ));
            }
            if acc.count() == 0 {
                continue;
            }
            check_accessor(&acc, &buffers, 12).map_err(|e| format!("{what}: POSITION {e}"))?;
            let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
            let positions: Vec<Vec3> = reader
                .read_positions()
                .ok_or_else(|| format!("{what}: POSITION data lies outside its buffer"))?
                .map(|p| world.transform_point3(Vec3::from(p)))
                .collect();
            if positions.len() != acc.count() {
                return Err(format!(
                    "{what}: POSITION has {} of {} elements in its buffer",
                    positions.len(),
                    acc.count()
                ));
            }
            if let Some(bad) = positions.iter().position(|p| !p.is_finite()) {
                return Err(format!(
                    "{what}: vertex {bad} is not finite (after the node transform)"
                ));
            }
            let indices: Vec<u32> = match prim.indices() {
                None => (0..positions.len() as u32).collect(),
                Some(iacc) => {
                    if !matches!(
                        iacc.data_type(),
                        DataType::U8 | DataType::U16 | DataType::U32
                    ) || iacc.dimensions() != Dimensions::Scalar
                    {
                        return Err(format!(
                            "{what}: indices must be unsigned integer scalars, are {:?} {:?}",
                            iacc.data_type(),
                            iacc.dimensions()
                        ));
                    }
                    if iacc.count() == 0 {
                        Vec::new()
                    } else {
                        check_accessor(&iacc, &buffers, iacc.size())
                            .map_err(|e| format!("{what}: indices {e}"))?;
                        let v: Vec<u32> = reader
                            .read_indices()
                            .ok_or_else(|| format!("{what}: index data lies outside its buffer"))?
                            .into_u32()
                            .collect();
                        if v.len() != iacc.count() {
                            return Err(format!(
                                "{what}: indices have {} of {} elements in their buffer",
                                v.len(),
                                iacc.count()
                            ));
                        }
                        v
                    }
                }
            };
            if let Some(&bad) = indices.iter().find(|&&i| i as usize >= positions.len()) {
                return Err(format!(
                    "{what}: index {bad} out of range ({} vertices)",
                    positions.len()
                ));
            }
            let p = |i: u32| positions[i as usize];
            match mode {
                Mode::Triangles => {
                    let faces = indices.chunks_exact(3);
                    if !faces.remainder().is_empty() {
                        return Err(format!(
                            "{what}: {} vertices/indices is not a multiple of 3",
                            indices.len()
                        ));
                    }
                    tris.extend(faces.map(|f| Triangle::new(p(f[0]), p(f[1]), p(f[2]))));
                }
                Mode::TriangleStrip => {
                    for k in 0..indices.len().saturating_sub(2) {
                        let (a, b, c) = (indices[k], indices[k + 1], indices[k + 2]);
                        // Every other triangle is flipped to keep a consistent winding.
                        tris.push(if k & 1 == 0 {
                            Triangle::new(p(a), p(b), p(c))
                        } else {
                            Triangle::new(p(b), p(a), p(c))
                        });
                    }
                }
                _ => {
                    // TriangleFan
                    for k in 1..indices.len().saturating_sub(1) {
                        tris.push(Triangle::new(
                            p(indices[0]),
                            p(indices[k]),
                            p(indices[k + 1]),
                        ));
                    }
                }
            }
        }
    }
    Ok(tris)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gzip_output_is_capped() {
        use std::io::Write;
        // 1 MiB of zeros compresses to about a kilobyte: a small bomb.
        let mut z = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::best());
        z.write_all(&vec![0u8; 1 << 20]).unwrap();
        let gz = z.finish().unwrap();
        assert!(gz.len() < 4096);
        let p = Path::new("bomb.obj.gz");
        assert_eq!(gunzip_at_most(p, &gz, 1 << 20).unwrap().len(), 1 << 20);
        let e = gunzip_at_most(p, &gz, (1 << 20) - 1)
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("bomb.obj.gz: decompresses to more than"),
            "{e}"
        );
        assert!(
            e.contains("TRACE_BENCH_MAX_GUNZIP") && !e.contains('\n'),
            "{e}"
        );
    }

    /// A face of two vertices beside good faces is left out and said so, with its line.
    #[test]
    fn short_faces_are_noted_with_their_line() {
        let dir = std::env::temp_dir().join(format!("tb-short-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("two.obj");
        std::fs::write(
            &p,
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2\nf 2 3 1\nf 3\n",
        )
        .unwrap();
        let scene = load_file(&p).unwrap();
        assert_eq!(scene.triangles.len(), 2);
        assert_eq!(
            scene.notes,
            [format!(
                "{}: 2 faces of fewer than three vertices left out (not a surface; the first at \
                 line 5)",
                p.display()
            )]
        );
        std::fs::write(&p, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        assert!(load_file(&p).unwrap().notes.is_empty());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn line_numbers() {
        let d = b"a\nb\nc";
        assert_eq!(line_at(d, 2), 1);
        assert_eq!(line_at(d, 4), 2);
        assert_eq!(line_at(d, 5), 3);
    }

    #[test]
    fn polylines_become_comments() {
        let mut d = b"v 0 0 0\n  l 1 2 3\nlx\nl\n".to_vec();
        neutralize_polylines(&mut d);
        assert_eq!(&d[..], b"v 0 0 0\n  # 1 2 3\nlx\n#\n");
    }

    #[test]
    fn quietly_catches_a_panic_without_a_word_and_leaves_other_panics_alone() {
        use std::sync::atomic::{AtomicUsize, Ordering};
        static SEEN: AtomicUsize = AtomicUsize::new(0);
        // A hook under ours that counts what reaches it (and prints as before). Only valid if
        // no other test of this crate installed ours first, which none does.
        if QUIET_HOOK.is_completed() {
            return;
        }
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            SEEN.fetch_add(1, Ordering::SeqCst);
            previous(info);
        }));
        let r =
            quietly(|| -> u32 { panic!("index out of bounds: the len is 0 but the index is 7") });
        assert_eq!(
            r,
            Err("index out of bounds: the len is 0 but the index is 7".to_string())
        );
        assert_eq!(
            SEEN.load(Ordering::SeqCst),
            0,
            "the hook saw a silenced panic"
        );
        assert_eq!(quietly(|| 5), Ok(5));
        // Outside `quietly`, and on other threads while it runs, panics reach the hook.
        let _ = std::panic::catch_unwind(|| panic!("loud"));
        assert_eq!(SEEN.load(Ordering::SeqCst), 1);
        let r = quietly(|| std::thread::spawn(|| panic!("loud too")).join().is_err());
        assert_eq!(r, Ok(true));
        assert_eq!(SEEN.load(Ordering::SeqCst), 2);
    }

    #[test]
    fn malformed_messages_stay_on_one_line() {
        let e = file_err(Path::new("x.gltf"), "mesh 'a\nb\u{1b}[31m': bad");
        assert_eq!(e.to_string(), "x.gltf: mesh 'a\\nb\\u{1b}[31m': bad");
    }

    #[test]
    fn formats() {
        assert_eq!(format_of(Path::new("a/B.OBJ.GZ")), Some(Format::ObjGz));
        assert_eq!(format_of(Path::new("x.obj")), Some(Format::Obj));
        assert_eq!(format_of(Path::new("x.glb")), Some(Format::Gltf));
        assert_eq!(format_of(Path::new("x.ply")), None);
    }
}
