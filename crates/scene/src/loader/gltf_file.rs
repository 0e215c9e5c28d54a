//! glTF 2.0 (`.gltf`, `.glb`, see [`super`]) through the gltf crate, with what it would index
//! or compute unchecked checked first.

use super::*;

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
pub(super) const MAX_ZERO_FILLED: usize = 1 << 24;

pub(super) fn gltf_triangles(path: &Path, bytes: &[u8]) -> Result<Vec<Triangle>, SceneError> {
    gltf_triangles_inner(path.parent(), bytes).map_err(|m| file_err(path, m))
}

/// Check the 12-byte GLB header (magic `glTF`, version, total length) of a binary glTF.
pub(super) fn check_glb_header(bytes: &[u8]) -> Result<(), String> {
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
pub(super) fn exists(
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
pub(super) fn check_references(root: &gltf::json::Root) -> Result<(), String> {
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
pub(super) fn percent_decode(uri: &str) -> Option<String> {
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
pub(super) fn check_buffer_uris(
    document: &gltf::Document,
    base: Option<&Path>,
) -> Result<(), String> {
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
pub(super) fn check_elements(
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
pub(super) fn check_accessor(
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

/// The triangles of a glTF document (`bytes`; external buffers relative to `base`): every
/// mesh reached from the default scene (or the first), in world coordinates, depth first.
pub(super) fn gltf_triangles_inner(
    base: Option<&Path>,
    bytes: &[u8],
) -> Result<Vec<Triangle>, String> {
    let (document, buffers) = gltf_document(base, bytes)?;
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
            primitive_triangles(&prim, &what, world, &buffers, &mut tris)?;
        }
    }
    Ok(tris)
}

/// Parse and check the document (header, references, validation, buffer URIs) and load its
/// buffers.
fn gltf_document(
    base: Option<&Path>,
    bytes: &[u8],
) -> Result<(gltf::Document, Vec<gltf::buffer::Data>), String> {
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
    Ok((document, buffers))
}

/// Append the triangles of primitive `prim` (named `what` in errors), its positions moved by
/// `world`.
fn primitive_triangles(
    prim: &gltf::Primitive,
    what: &str,
    world: glam::Mat4,
    buffers: &[gltf::buffer::Data],
    tris: &mut Vec<Triangle>,
) -> Result<(), String> {
    use gltf::mesh::Mode;
    let mode = prim.mode();
    if !matches!(
        mode,
        Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
    ) {
        return Err(format!(
            "{what}: mode {mode:?} is not supported (only Triangles, TriangleStrip, TriangleFan)"
        ));
    }
    let Some(positions) = primitive_positions(prim, what, world, buffers)? else {
        return Ok(());
    };
    let indices = primitive_indices(prim, what, positions.len(), buffers)?;
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
    Ok(())
}

/// The primitive's POSITION data moved by `world`, checked (float VEC3, inside its buffer,
/// finite); `None` when it has no elements.
fn primitive_positions(
    prim: &gltf::Primitive,
    what: &str,
    world: glam::Mat4,
    buffers: &[gltf::buffer::Data],
) -> Result<Option<Vec<Vec3>>, String> {
    use gltf::accessor::{DataType, Dimensions};
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
        return Ok(None);
    }
    check_accessor(&acc, buffers, 12).map_err(|e| format!("{what}: POSITION {e}"))?;
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
    Ok(Some(positions))
}

/// The primitive's indices, checked (unsigned integer scalars inside their buffer), or
/// `0..vertices` when it has none.
fn primitive_indices(
    prim: &gltf::Primitive,
    what: &str,
    vertices: usize,
    buffers: &[gltf::buffer::Data],
) -> Result<Vec<u32>, String> {
    use gltf::accessor::{DataType, Dimensions};
    let Some(iacc) = prim.indices() else {
        return Ok((0..vertices as u32).collect());
    };
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
        return Ok(Vec::new());
    }
    check_accessor(&iacc, buffers, iacc.size()).map_err(|e| format!("{what}: indices {e}"))?;
    let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
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
    Ok(v)
}
