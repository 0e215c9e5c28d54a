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

mod gltf_file;
mod obj;
use gltf_file::*;
use obj::*;

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
