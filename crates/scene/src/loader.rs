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
//! message naming the file and, for OBJ, the line where it is known.

use crate::error::SceneError;
use crate::scene::Scene;
use std::io::{BufRead, Read};
use std::path::{Path, PathBuf};
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

fn file_err(path: &Path, message: impl Into<String>) -> SceneError {
    SceneError::File {
        path: path.to_path_buf(),
        message: message.into(),
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
    let triangles = match format {
        Format::Obj => obj_triangles(path, bytes)?,
        Format::ObjGz => {
            let text = gunzip(path, &bytes)?;
            drop(bytes);
            obj_triangles(path, text)?
        }
        Format::Gltf => gltf_triangles(path, &bytes)?,
    };
    if triangles.is_empty() {
        return Err(file_err(path, "contains no triangles"));
    }
    Ok(Scene::from_triangles(path.display().to_string(), triangles))
}

// ---------------------------------------------------------------------------------------------
// gzip

/// Decompress a whole gzip file in memory.
fn gunzip(path: &Path, bytes: &[u8]) -> Result<Vec<u8>, SceneError> {
    // The trailer's ISIZE (uncompressed size mod 2^32) is a good capacity hint; clamp it so a
    // corrupt trailer cannot make us reserve absurd amounts.
    let hint = match bytes.len() {
        n if n >= 18 => {
            let t = &bytes[n - 4..];
            u32::from_le_bytes([t[0], t[1], t[2], t[3]]) as usize
        }
        _ => 0,
    };
    let cap = hint.min(bytes.len().saturating_mul(32)).min(1 << 30);
    let mut out = Vec::with_capacity(cap);
    flate2::read::MultiGzDecoder::new(bytes)
        .read_to_end(&mut out)
        .map_err(|e| {
            file_err(
                path,
                format!("cannot decompress gzip data (truncated or corrupt file?): {e}"),
            )
        })?;
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

/// Parse OBJ text (already in memory) into triangles.
fn obj_triangles(path: &Path, mut data: Vec<u8>) -> Result<Vec<Triangle>, SceneError> {
    neutralize_polylines(&mut data);
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
    Ok(tris)
}

// ---------------------------------------------------------------------------------------------
// glTF

fn panic_message(p: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = p.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = p.downcast_ref::<String>() {
        s.clone()
    } else {
        "unknown error".into()
    }
}

fn gltf_triangles(path: &Path, bytes: &[u8]) -> Result<Vec<Triangle>, SceneError> {
    // The gltf crate validates the document, but its accessor readers still assume some
    // invariants (strides, index types); guard against a panic on hostile input.
    let base: Option<PathBuf> = path.parent().map(Path::to_path_buf);
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        gltf_triangles_inner(base.as_deref(), bytes)
    })) {
        Ok(Ok(t)) => Ok(t),
        Ok(Err(message)) => Err(file_err(path, message)),
        Err(p) => Err(file_err(
            path,
            format!("malformed glTF (reader failed: {})", panic_message(&*p)),
        )),
    }
}

fn gltf_triangles_inner(base: Option<&Path>, bytes: &[u8]) -> Result<Vec<Triangle>, String> {
    use gltf::accessor::{DataType, Dimensions};
    use gltf::mesh::Mode;

    let gltf::Gltf { document, blob } =
        gltf::Gltf::from_slice(bytes).map_err(|e| format!("invalid glTF: {e}"))?;
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
            if let Some(view) = acc.view() {
                if view.stride().is_some_and(|s| s < 12) {
                    return Err(format!("{what}: POSITION stride below 12 bytes"));
                }
            }
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
                        if let Some(view) = iacc.view() {
                            if view.stride().is_some_and(|s| s < iacc.size()) {
                                return Err(format!("{what}: index stride too small"));
                            }
                        }
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
    fn formats() {
        assert_eq!(format_of(Path::new("a/B.OBJ.GZ")), Some(Format::ObjGz));
        assert_eq!(format_of(Path::new("x.obj")), Some(Format::Obj));
        assert_eq!(format_of(Path::new("x.glb")), Some(Format::Gltf));
        assert_eq!(format_of(Path::new("x.ply")), None);
    }
}
