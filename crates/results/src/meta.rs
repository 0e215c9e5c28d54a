//! Run metadata for results.json: what the binary is (baked in at build time by `build.rs`:
//! commit, dirty flag, features, peer and wgpu crate versions, rustc), where it ran (host, OS,
//! CPU model, cores, memory, frequency governor, via `sysinfo`), when (start, end, duration),
//! and what it ran (threads, adapter, the effective config).

use serde_json::{json, Map, Value};
use std::time::SystemTime;

/// A value baked in by vergen, `None` where it could not be determined (outside a git
/// checkout, vergen emits a placeholder).
fn baked(v: Option<&'static str>) -> Option<&'static str> {
    v.filter(|s| !s.is_empty() && !s.starts_with("VERGEN_"))
}

/// The commit the binary was built from (12 hex digits), or "unknown".
pub fn commit() -> String {
    baked(option_env!("VERGEN_GIT_SHA"))
        .map(|s| s.chars().take(12).collect())
        .unwrap_or_else(|| "unknown".into())
}

/// Whether the checkout had uncommitted changes when the binary was built (`None`: unknown).
pub fn dirty() -> Option<bool> {
    baked(option_env!("VERGEN_GIT_DIRTY")).and_then(|s| s.parse().ok())
}

/// The build: commit, dirty flag, enabled harness features, crate versions of the peers and
/// wgpu, optimisation level, target and compiler.
pub fn build_info() -> Value {
    let list = |v: Option<&'static str>| -> Vec<&'static str> {
        baked(v)
            .map(|s| {
                s.split(',')
                    .map(str::trim)
                    .filter(|s| !s.is_empty())
                    .collect()
            })
            .unwrap_or_default()
    };
    let mut deps = Map::new();
    for d in list(option_env!("TB_CRATE_VERSIONS")) {
        if let Some((name, version)) = d.split_once(' ') {
            deps.insert(name.into(), Value::from(version));
        }
    }
    json!({
        "version": env!("CARGO_PKG_VERSION"),
        "commit": commit(),
        "dirty": dirty(),
        "commit_date": baked(option_env!("VERGEN_GIT_COMMIT_TIMESTAMP")),
        "features": list(option_env!("VERGEN_CARGO_FEATURES"))
            .into_iter()
            .filter(|f| *f != "default")
            .collect::<Vec<_>>(),
        "crates": deps,
        "profile": if cfg!(debug_assertions) { "debug" } else { "release" },
        "opt_level": baked(option_env!("VERGEN_CARGO_OPT_LEVEL")),
        "target": baked(option_env!("VERGEN_CARGO_TARGET_TRIPLE")),
        "rustc": baked(option_env!("VERGEN_RUSTC_SEMVER")),
        "llvm": baked(option_env!("VERGEN_RUSTC_LLVM_VERSION")),
    })
}

/// The machine's host name (the `host` column of every row), or "unknown".
pub fn host_name() -> String {
    sysinfo::System::host_name().unwrap_or_else(|| "unknown".into())
}

/// The CPU frequency governor of CPU 0 (`performance`, `powersave`, …), `None` where the
/// kernel does not expose one (virtual machines, macOS).
pub fn governor() -> Option<String> {
    std::fs::read_to_string("/sys/devices/system/cpu/cpu0/cpufreq/scaling_governor")
        .ok()
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty())
}

/// The host: name, OS, kernel, CPU model, logical and physical cores, memory, governor.
pub fn host_info() -> Value {
    let mut sys = sysinfo::System::new();
    sys.refresh_cpu_list(sysinfo::CpuRefreshKind::nothing());
    sys.refresh_memory();
    let cpu = sys
        .cpus()
        .first()
        .map(|c| c.brand().trim().to_string())
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "unknown".into());
    json!({
        "name": host_name(),
        "os": sysinfo::System::long_os_version(),
        "kernel": sysinfo::System::kernel_version(),
        "cpu": cpu,
        "cores": std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1),
        "physical_cores": sysinfo::System::physical_core_count(),
        "memory_gib": (sys.total_memory() as f64 / (1u64 << 30) as f64 * 10.0).round() / 10.0,
        "governor": governor(),
    })
}

/// UTC time as RFC 3339 to the second (`2026-11-21T19:30:00Z`).
pub fn now_rfc3339() -> String {
    humantime::format_rfc3339_seconds(SystemTime::now()).to_string()
}

/// The metadata object of a run, `status` "running" until [`finish`].
pub fn collect(config_file: &str, config_text: &str, threads: &[usize]) -> Value {
    json!({
        "tool": "trace-bench",
        "build": build_info(),
        "host": host_info(),
        "threads": threads,
        "start": now_rfc3339(),
        "end": Value::Null,
        "duration_s": Value::Null,
        "adapter": Value::Null,
        "config_file": config_file,
        "config": config_text,
        "status": "running",
    })
}

/// Record the end of the run: `status`, `end` and `duration_s` (from `start`, this
/// session's: a resumed run keeps its first start and adds `resumed`).
pub fn finish(meta: &mut Value, status: &str, started: SystemTime) {
    if let Some(m) = meta.as_object_mut() {
        let secs = started.elapsed().map(|d| d.as_secs_f64()).unwrap_or(0.0);
        let total = m.get("duration_s").and_then(Value::as_f64).unwrap_or(0.0);
        m.insert("status".into(), Value::from(status));
        m.insert("end".into(), Value::from(now_rfc3339()));
        let ms = ((total + secs) * 1e3).round();
        m.insert("duration_s".into(), Value::from(ms / 1e3));
    }
}
