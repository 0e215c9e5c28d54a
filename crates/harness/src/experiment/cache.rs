//! The build cache: a structure built once is loaded, not built again, by the later processes
//! of a run, the later runs of a `reproduce`, and later runs and reproduces.
//!
//! **Key.** An entry is found by the SHA-256 of what decides the build and nothing else: the
//! cache format, the digest of the running binary (its code, the features it was compiled
//! with, its dependencies: a new build of the binary is a new key), the family's name, its
//! full parameter set (defaults included) and the scene's triangles bit for bit. Never a file
//! name or a time: the same triangles under another name hit, an edited file misses.
//!
//! **Entry.** One file, `<family>-<key>.tbc`: a magic line, the header (key, family,
//! parameters, binary digest, commit, host, when it was made, the build's time and heap
//! figures), the structure's bytes ([`tb_core::persist`]: `serde` and `bincode`) and a SHA-256
//! of all of it. It is written to a temporary file in the same folder and renamed into place,
//! so a reader sees a whole entry or none. A truncated or corrupt entry (checksum), one made
//! by another binary or machine, or one that does not decode or fails
//! [`tb_core::Accel::validate`] is rebuilt with a note, never used.
//!
//! **Place, size.** `TRACE_BENCH_BUILD_CACHE` names the folder (`off`: no cache; `run
//! --no-cache` and `--cache-dir` set it for the run and its processes); by default
//! `target/build-cache` beside a binary that lies in a cargo `target` folder, else the user's
//! cache folder (`$XDG_CACHE_HOME` or `~/.cache`, `trace-bench/builds`). The folder is kept
//! under `TRACE_BENCH_BUILD_CACHE_MB` megabytes (default [`DEFAULT_CAP_MB`]) by removing the
//! entries used longest ago (a hit touches its entry).
//!
//! **Timing.** A loaded structure's build figures (`build_ms`, the heap) are those the build
//! that made the entry measured, on this machine with this binary, plus the auxiliary arrays
//! prepared now; its rows say `build_cached = true`. A config that times its builds
//! (`run.build_repeat` above 1, or `run.time_builds`) builds fresh in every process, as
//! before; the cache still keeps its last build for runs that do not time theirs.
//!
//! **Stages.** A family built over another family's whole structure ([`tb_core::Stage`]:
//! sparse boxes over a kd-tree) finds that first stage here under the base family's own key,
//! so the sparse boxes of every `d_min`, and the kd-tree table over the same tree, build the
//! kd-tree once (`meta.build_cache.stages_loaded`); the build's time is the first stage's,
//! as measured where it was built, plus the second's. Timed builds and runs without the
//! cache build whole, as the family's `build` does.
//!
//! **The oracle's answers.** Brute force's answers for a batch's validated rays are entries
//! of the same kind ([`oracle_key`], [`BuildCache::load_answers`]): the oracle of one scene and
//! ray sample is computed once, not in every process of every run.

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::{Arc, OnceLock};
use std::time::SystemTime;
use tb_core::{Accel, Codec, Family, HitRecord, ParamSet, Query, Ray, Triangle};

/// The environment variable naming the cache folder, or `off`.
pub const ENV: &str = "TRACE_BENCH_BUILD_CACHE";
/// The environment variable capping the folder's size, megabytes.
pub const ENV_MB: &str = "TRACE_BENCH_BUILD_CACHE_MB";
/// The default cap, megabytes.
pub const DEFAULT_CAP_MB: u64 = 8192;
/// The entries' format: part of the key, so that a new format never reads an old entry.
const FORMAT: u32 = 1;
const MAGIC: &[u8; 16] = b"trace-bench-tbc\n";
const EXT: &str = "tbc";

/// A cache folder and its size cap.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BuildCache {
    dir: PathBuf,
    cap_bytes: u64,
}

/// Where a structure's entry is and what it must say.
pub struct Key {
    hex: String,
    family: &'static str,
    params: String,
}

/// What the build that made an entry measured (the structure alone, without the auxiliary
/// arrays of any traversal).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BuildFigures {
    /// Every build's ms (one unless the build was repeated), the structure alone.
    pub runs_ms: Vec<f64>,
    /// The heap of the (last) build, `(peak, kept)` bytes, where it was measured.
    pub heap: Option<(u64, u64)>,
}

#[derive(Serialize, Deserialize)]
struct Header {
    format: u32,
    key: String,
    family: String,
    params: String,
    exe: String,
    commit: String,
    host: String,
    made_unix_s: u64,
    figures: BuildFigures,
}

/// A loaded entry.
pub struct Hit {
    /// The structure, loaded and attached to the scene's triangles.
    pub accel: Box<dyn Accel>,
    /// What the build that made the entry measured.
    pub figures: BuildFigures,
}

/// What a look-up found.
pub enum Lookup {
    /// A usable entry, loaded.
    Hit(Hit),
    /// No entry for the key.
    Miss,
    /// An entry that cannot be used (the reason, with its file): rebuilt, with a note.
    Refused(String),
}

impl BuildCache {
    /// The cache in `dir` under `cap_mb` megabytes.
    pub fn new(dir: PathBuf, cap_mb: u64) -> BuildCache {
        BuildCache {
            dir,
            cap_bytes: cap_mb.saturating_mul(1 << 20),
        }
    }

    /// The cache the environment asks for: `None` where [`ENV`] is `off`, else its folder
    /// (default [`BuildCache::default_dir`]) under [`ENV_MB`] (default [`DEFAULT_CAP_MB`]).
    /// Values are checked by the binary before any work; here a bad cap is the default.
    pub fn from_env() -> Option<BuildCache> {
        let dir = match std::env::var_os(ENV) {
            Some(v) if v == "off" => return None,
            Some(v) if !v.is_empty() => PathBuf::from(v),
            _ => Self::default_dir()?,
        };
        let mb = std::env::var(ENV_MB)
            .ok()
            .and_then(|v| v.trim().parse::<u64>().ok())
            .filter(|&n| n >= 1)
            .unwrap_or(DEFAULT_CAP_MB);
        Some(BuildCache::new(dir, mb))
    }

    /// `target/build-cache` when the running binary lies in a folder named `target` (a cargo
    /// build), else `trace-bench/builds` in the user's cache folder; `None` where neither is
    /// known.
    pub fn default_dir() -> Option<PathBuf> {
        let exe = std::env::current_exe().ok()?;
        if let Some(t) = exe
            .ancestors()
            .find(|a| a.file_name() == Some("target".as_ref()))
        {
            return Some(t.join("build-cache"));
        }
        let base = std::env::var_os("XDG_CACHE_HOME")
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
            .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache")))?;
        Some(base.join("trace-bench").join("builds"))
    }

    /// The folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    fn path(&self, key: &Key) -> PathBuf {
        self.dir
            .join(format!("{}-{}.{EXT}", key.family, &key.hex[..16]))
    }

    /// The entry of `key`, loaded with `codec` over `tris` and `params`.
    pub fn load(
        &self,
        key: &Key,
        codec: &Codec,
        tris: &Arc<[Triangle]>,
        params: &ParamSet,
    ) -> Lookup {
        self.load_with(key, |payload| (codec.load)(payload, tris, params))
            .map_or(Lookup::Miss, |r| match r {
                Ok((accel, figures)) => Lookup::Hit(Hit { accel, figures }),
                Err(why) => Lookup::Refused(why),
            })
    }

    /// The payload of `key`'s entry decoded by `decode`, with the figures of the work that
    /// made it: `None` without an entry, `Err` (naming the file) for one that cannot be used.
    fn load_with<T>(
        &self,
        key: &Key,
        decode: impl FnOnce(&[u8]) -> Result<T, String>,
    ) -> Option<Result<(T, BuildFigures), String>> {
        let path = self.path(key);
        let bytes = match std::fs::read(&path) {
            Ok(b) => b,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return None,
            Err(e) => return Some(Err(format!("{}: {e}", path.display()))),
        };
        let decoded = split(&bytes).and_then(|(header, payload)| {
            header_matches(&header, key)?;
            Ok((decode(payload)?, header.figures))
        });
        if decoded.is_ok() {
            touch(&path);
        }
        Some(decoded.map_err(|why| format!("{}: {why}", path.display())))
    }

    /// The brute-force oracle's answers of `key` ([`oracle_key`]), `n` of them: `None`
    /// without an entry, `Err` for one that cannot be used (it is then made again).
    pub fn load_answers(&self, key: &Key, n: usize) -> Option<Result<Vec<HitRecord>, String>> {
        self.load_with(key, |payload| {
            let v: Vec<HitRecord> = bincode::deserialize(payload).map_err(|e| e.to_string())?;
            if v.len() != n {
                return Err(format!("{} answers for {n} rays", v.len()));
            }
            Ok(v)
        })
        .map(|r| r.map(|(v, _)| v))
    }

    /// Save the oracle's `answers` under `key`, made in `ms`.
    pub fn store_answers(&self, key: &Key, answers: &[HitRecord], ms: f64) -> Result<(), String> {
        let payload = bincode::serialize(answers).map_err(|e| e.to_string())?;
        let figures = BuildFigures {
            runs_ms: vec![ms],
            heap: None,
        };
        self.store_bytes(key, payload, figures)
    }

    /// Save `accel` under `key` with its build's `figures` (written whole or not at all), then
    /// keep the folder under its cap. `Err` says what failed; nothing is lost but the entry.
    pub fn store(
        &self,
        key: &Key,
        codec: &Codec,
        accel: &dyn Accel,
        figures: BuildFigures,
    ) -> Result<(), String> {
        self.store_bytes(key, (codec.save)(accel)?, figures)
    }

    /// Save `payload` under `key` with `figures`, whole or not at all, then keep the folder
    /// under its cap.
    fn store_bytes(
        &self,
        key: &Key,
        payload: Vec<u8>,
        figures: BuildFigures,
    ) -> Result<(), String> {
        let header = Header {
            format: FORMAT,
            key: key.hex.clone(),
            family: key.family.into(),
            params: key.params.clone(),
            exe: exe_digest().to_string(),
            commit: tb_results::meta::commit(),
            host: host().to_string(),
            made_unix_s: SystemTime::now()
                .duration_since(SystemTime::UNIX_EPOCH)
                .map_or(0, |d| d.as_secs()),
            figures,
        };
        let head = bincode::serialize(&header).map_err(|e| e.to_string())?;
        let mut out = Vec::with_capacity(MAGIC.len() + 8 + head.len() + payload.len() + 32);
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&(head.len() as u64).to_le_bytes());
        out.extend_from_slice(&head);
        out.extend_from_slice(&payload);
        let sum = Sha256::digest(&out);
        out.extend_from_slice(&sum);
        let dir = &self.dir;
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        let path = self.path(key);
        let tmp = dir.join(format!(
            ".{}.{}.tmp",
            path.file_name().and_then(|n| n.to_str()).unwrap_or("entry"),
            std::process::id()
        ));
        let written = std::fs::File::create(&tmp)
            .and_then(|mut f| f.write_all(&out).and_then(|_| f.sync_all()))
            .and_then(|_| std::fs::rename(&tmp, &path));
        if let Err(e) = written {
            let _ = std::fs::remove_file(&tmp);
            return Err(format!("{}: {e}", path.display()));
        }
        self.evict(&path);
        Ok(())
    }

    /// Remove the entries used longest ago until the folder is under its cap (never `keep`).
    fn evict(&self, keep: &Path) {
        let Ok(rd) = std::fs::read_dir(&self.dir) else {
            return;
        };
        let mut entries: Vec<(SystemTime, u64, PathBuf)> = rd
            .flatten()
            .filter(|e| e.path().extension().is_some_and(|x| x == EXT))
            .filter_map(|e| {
                let m = e.metadata().ok()?;
                Some((m.modified().ok()?, m.len(), e.path()))
            })
            .collect();
        let mut total: u64 = entries.iter().map(|e| e.1).sum();
        entries.sort();
        for (_, len, path) in entries {
            if total <= self.cap_bytes {
                break;
            }
            if path != keep && std::fs::remove_file(&path).is_ok() {
                total -= len;
            }
        }
    }
}

/// The key of `family` built with `params` over `tris` by this binary.
pub fn key(family: &'static Family, params: &ParamSet, tris: &[Triangle]) -> Key {
    let params = params.to_string();
    let mut h = key_hasher(family.name, &params);
    hash_triangles(&mut h, tris);
    Key {
        hex: hex(&h.finalize()),
        family: family.name,
        params,
    }
}

/// The key of the brute-force oracle's answers to `query` for `rays` over `tris` (watertight
/// test), by this binary: the oracle of one scene and ray sample is computed once, by the
/// first process of the first run that validates them, and read by the others (entries
/// `oracle-<key>.tbc` beside the builds, checked as builds are).
pub fn oracle_key(query: Query, tris: &[Triangle], rays: &[Ray]) -> Key {
    let params = format!("query={query:?};rays={}", rays.len());
    let mut h = key_hasher("oracle", &params);
    hash_triangles(&mut h, tris);
    hash_floats(
        &mut h,
        rays.iter().flat_map(|r| {
            let (o, d) = (r.origin.to_array(), r.dir.to_array());
            [o[0], o[1], o[2], d[0], d[1], d[2], r.tmin, r.tmax]
        }),
    );
    Key {
        hex: hex(&h.finalize()),
        family: "oracle",
        params,
    }
}

/// A hasher with the format, the binary, `name` and `params` in it.
fn key_hasher(name: &str, params: &str) -> Sha256 {
    let mut h = Sha256::new();
    h.update(FORMAT.to_le_bytes());
    h.update(exe_digest().as_bytes());
    for s in [name, params] {
        h.update((s.len() as u64).to_le_bytes());
        h.update(s.as_bytes());
    }
    h
}

/// Hash the vertices of `tris` bit for bit ([`hash_floats`]).
fn hash_triangles(h: &mut Sha256, tris: &[Triangle]) {
    hash_floats(
        h,
        tris.iter()
            .flat_map(|t| [t.v0, t.v1, t.v2])
            .flat_map(|v| v.to_array()),
    );
}

/// Hash `values` bit for bit, with their count after them.
fn hash_floats(h: &mut Sha256, values: impl Iterator<Item = f32>) {
    let mut buf = Vec::with_capacity(36 * 1024);
    let mut n = 0u64;
    for c in values {
        buf.extend_from_slice(&c.to_bits().to_le_bytes());
        n += 1;
        if buf.len() >= 32 * 1024 {
            h.update(&buf);
            buf.clear();
        }
    }
    h.update(&buf);
    h.update(n.to_le_bytes());
}

/// The header and the structure's bytes of entry `bytes`, checked (magic, length, checksum).
fn split(bytes: &[u8]) -> Result<(Header, &[u8]), String> {
    let min = MAGIC.len() + 8 + 32;
    if bytes.len() < min || &bytes[..MAGIC.len()] != MAGIC {
        return Err("not a build-cache entry (truncated or another file)".into());
    }
    let (body, sum) = bytes.split_at(bytes.len() - 32);
    if Sha256::digest(body).as_slice() != sum {
        return Err("checksum mismatch (truncated or corrupt)".into());
    }
    let len = u64::from_le_bytes(body[MAGIC.len()..MAGIC.len() + 8].try_into().expect("8"));
    let start = MAGIC.len() + 8;
    let end = usize::try_from(len)
        .ok()
        .and_then(|l| start.checked_add(l))
        .filter(|&e| e <= body.len())
        .ok_or("header length out of range")?;
    let header: Header =
        bincode::deserialize(&body[start..end]).map_err(|e| format!("header: {e}"))?;
    Ok((header, &body[end..]))
}

/// Whether `h` is the entry of `key`, made by this binary on this machine; `Err` says how not.
fn header_matches(h: &Header, key: &Key) -> Result<(), String> {
    let foreign = |what: &str, theirs: &str, ours: &str| {
        Err(format!(
            "made with another {what} ({theirs}, this run: {ours})"
        ))
    };
    if h.format != FORMAT {
        return foreign("format", &h.format.to_string(), &FORMAT.to_string());
    }
    if h.key != key.hex || h.family != key.family || h.params != key.params {
        return Err(format!(
            "holds another build ({} [{}]) than its name says",
            h.family, h.params
        ));
    }
    if h.exe != exe_digest() {
        return foreign("binary", &h.exe[..h.exe.len().min(12)], &exe_digest()[..12]);
    }
    if h.host != host() {
        return foreign("machine", &h.host, host());
    }
    Ok(())
}

/// The SHA-256 of the running binary (hex), read once; "unknown" where it cannot be read
/// (then every key of the process is its own: no entry of another binary matches).
/// The SHA-256 of the running binary, hex (part of every key; `meta.binary_digest`).
pub fn exe_digest() -> &'static str {
    static D: OnceLock<String> = OnceLock::new();
    D.get_or_init(|| {
        let read = std::env::current_exe().and_then(std::fs::read);
        match read {
            Ok(b) => hex(&Sha256::digest(&b)),
            Err(_) => format!("unknown-{}", std::process::id()),
        }
    })
}

fn host() -> &'static str {
    static H: OnceLock<String> = OnceLock::new();
    H.get_or_init(tb_results::meta::host_name)
}

fn hex(b: &[u8]) -> String {
    b.iter().map(|x| format!("{x:02x}")).collect()
}

/// Mark `path` used now (eviction removes the entries used longest ago).
fn touch(path: &Path) {
    if let Ok(f) = std::fs::File::options().append(true).open(path) {
        let _ = f.set_modified(SystemTime::now());
    }
}
