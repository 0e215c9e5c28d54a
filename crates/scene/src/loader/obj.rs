//! Wavefront OBJ (plain or gzip-compressed, see [`super`]): tobj's parser on the text in
//! memory, with the checks that name the line of a bad index, a non-finite vertex or a short
//! face, and polylines turned into comments.

use super::*;

// ---------------------------------------------------------------------------------------------
// OBJ

/// An in-memory `BufRead` that remembers how far the parser got, for error line numbers.
pub(super) struct SliceReader<'a> {
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
pub(super) fn line_at(data: &[u8], pos: usize) -> usize {
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
pub(super) fn neutralize_polylines(data: &mut [u8]) {
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
pub(super) fn numbered_lines(data: &[u8]) -> impl Iterator<Item = (usize, &[u8])> {
    data.split(|&b| b == b'\n')
        .enumerate()
        .map(|(i, l)| (i + 1, l))
}

pub(super) fn words(line: &[u8]) -> impl Iterator<Item = &str> {
    line.split(|b| b.is_ascii_whitespace())
        .filter(|w| !w.is_empty())
        .map(|w| std::str::from_utf8(w).unwrap_or("\u{fffd}"))
}

/// Find the first face line with a vertex, texture or normal index out of range (checked
/// against the elements defined before that line), for the error message.
pub(super) fn find_bad_face_index(data: &[u8]) -> Option<String> {
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
pub(super) fn find_non_finite_vertex(data: &[u8]) -> Option<String> {
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

pub(super) fn obj_error(path: &Path, data: &[u8], pos: usize, e: tobj::LoadError) -> SceneError {
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
pub(super) fn short_faces(path: &Path, data: &[u8]) -> Option<String> {
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
pub(super) fn obj_triangles(
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
