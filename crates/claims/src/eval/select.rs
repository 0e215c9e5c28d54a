//! Which rows a claim takes: the columns of a build and of a row's context, selectors and
//! filters matched against rows, and the key of a row's group.

use super::*;

/// Columns that are properties of a build (one value per scene table x structure x params).
pub(super) const BUILD_COLS: &[&str] = &[
    "memory_bytes",
    "structure_bytes",
    "nodes",
    "prim_refs",
    "node_bytes",
    "sah_cost",
    "build_heap_peak_bytes",
    "build_heap_kept_bytes",
];

pub(super) fn default_pool(t: &Term) -> Pool {
    match t {
        Term::Col(c) if c.ends_with("_per_ray") || c == "hit_rate" => Pool::Rays,
        Term::Col(c) if c.ends_with("_max") => Pool::Max,
        Term::Col(c)
            if matches!(
                c.as_str(),
                "capped_rays" | "mismatches" | "validated_rays" | "rays"
            ) =>
        {
            Pool::Sum
        }
        _ => Pool::Mean,
    }
}

pub(super) fn per_build(t: &Term) -> bool {
    match t {
        Term::Col(c) => BUILD_COLS.contains(&c.as_str()),
        Term::Build(_) | Term::HeapRatio | Term::BuildTime => true,
        Term::Time | Term::Mrays => false,
    }
}

/// Columns that tell one measurement context (the same rays) from another.
pub(super) const CONTEXT: &[&str] = &[
    "file",
    "scene",
    "ray_kind",
    "device",
    "triangle_test",
    "threads",
    "budget_ms",
    "frame",
    "table",
    "heuristic",
    "beta",
    "patch",
    "axis",
    "integrator",
    "pass",
];
/// Columns that tell the variants compared (a selector must pick one per context).
pub(super) const VARIANT: &[&str] = &["structure", "params", "traversal"];

/// A GPU row from a software rasterizer: `adapter_type = software`, or (rows written before
/// that column) an adapter name of one.
pub(super) fn software_adapter(r: &Row) -> bool {
    const NAMES: [&str; 4] = ["llvmpipe", "lavapipe", "swiftshader", "softpipe"];
    r.get("device") == Some("gpu")
        && (r.get("adapter_type") == Some("software")
            || r.get("adapter").is_some_and(|a| {
                let a = a.to_ascii_lowercase();
                NAMES.iter().any(|s| a.contains(s))
            }))
}

pub(crate) fn glob(pat: &str, s: &str) -> bool {
    // `*` matches any run; iterative with backtracking to the last star.
    let (p, t): (Vec<char>, Vec<char>) = (pat.chars().collect(), s.chars().collect());
    let (mut i, mut j, mut star, mut mark) = (0, 0, None, 0);
    while j < t.len() {
        if i < p.len() && p[i] != '*' && p[i] == t[j] {
            i += 1;
            j += 1;
        } else if i < p.len() && p[i] == '*' {
            star = Some(i);
            mark = j;
            i += 1;
        } else if let Some(s) = star {
            i = s + 1;
            mark += 1;
            j = mark;
        } else {
            return false;
        }
    }
    p[i..].iter().all(|&c| c == '*')
}

pub(super) fn cell_matches(v: &toml::Value, cell: &str) -> bool {
    match v {
        toml::Value::String(p) => glob(p, cell),
        toml::Value::Integer(i) => cell.trim().parse::<f64>().is_ok_and(|x| x == *i as f64),
        toml::Value::Float(f) => cell
            .trim()
            .parse::<f64>()
            .is_ok_and(|x| x == *f || (x - f).abs() <= 1e-9 * f.abs().max(x.abs())),
        toml::Value::Boolean(b) => cell.trim() == if *b { "true" } else { "false" },
        toml::Value::Array(a) => a.iter().any(|x| cell_matches(x, cell)),
        _ => false,
    }
}

pub(super) fn selector_matches(s: &Selector, r: &Row) -> bool {
    s.0.iter().all(|(k, v)| match k.as_str() {
        crate::pick::KEY | crate::schema::MEASURE_KEY => true,
        "scene" => r.table().is_some_and(|c| cell_matches(v, c)),
        "view" => r.get("scene").is_some_and(|c| cell_matches(v, c)),
        "params" => {
            let toml::Value::Table(t) = v else {
                return false;
            };
            let p = r.params();
            t.iter()
                .all(|(pk, pv)| p.get(pk.as_str()).is_some_and(|c| cell_matches(pv, c)))
        }
        col => r.get(col).is_some_and(|c| cell_matches(v, c)),
    })
}

/// The claim's filter on `device`, with the defaults: `file = "results"`,
/// `triangle_test = "watertight"` and the device, each unless the filter names it and each
/// only where the row has the column.
pub(super) fn filter_matches(c: &Claim, device: &str, r: &Row) -> bool {
    let f = &c.filter.0;
    let default =
        |col: &str, want: &str| f.contains_key(col) || r.get(col).is_none_or(|x| x == want);
    default("file", "results")
        && default("triangle_test", "watertight")
        && default("device", device)
        && selector_matches(&c.filter, r)
}

pub(super) fn group_key(per: &[String], r: &Row) -> String {
    per.iter()
        .map(|k| match k.as_str() {
            "scene" => r.table().unwrap_or("").to_owned(),
            "view" => r.get("scene").unwrap_or("").to_owned(),
            k if k.starts_with("param:") => r.params().get(&k[6..]).copied().unwrap_or("").into(),
            k => r.get(k).unwrap_or("").to_owned(),
        })
        .collect::<Vec<_>>()
        .join(" · ")
}

pub(super) fn joined(r: &Row, cols: &[&str]) -> String {
    cols.iter()
        .map(|c| r.get(c).unwrap_or(""))
        .collect::<Vec<_>>()
        .join("|")
}
