//! The `[[structure]]` tables: a registered family, its traversals by name, and its
//! parameters checked against its own table and expanded into sweeps.

use super::{Ctx, RawStructure, StructureSpec};
use crate::error::HarnessError;
use crate::experiment::params::expand;
use crate::registry::Registry;

/// Resolve one structure table against `registry`.
pub(super) fn check_structure(
    cx: &Ctx,
    s: &RawStructure,
    registry: &Registry,
) -> Result<StructureSpec, HarnessError> {
    let family = registry.find(s.name.get_ref()).ok_or_else(|| {
        let known: Vec<&str> = registry.families().iter().map(|s| s.name).collect();
        cx.err(
            s.name.span(),
            "structure.name",
            format!(
                "unknown structure `{}` (known: {})",
                s.name.get_ref(),
                known.join(", ")
            ),
        )
    })?;
    let infos = (family.traversals)();
    let traversals = match &s.traversals {
        // A table without a list runs every traversal but those run on request.
        None => (0..infos.len()).filter(|&i| !infos[i].on_request).collect(),
        Some(t) => {
            let mut out = Vec::new();
            for n in t.get_ref() {
                let i = infos.iter().position(|ti| ti.name == n).ok_or_else(|| {
                    let known: Vec<&str> = infos.iter().map(|t| t.name).collect();
                    cx.err(
                        t.span(),
                        "structure.traversals",
                        format!(
                            "`{}` has no traversal `{n}` (known: {})",
                            family.name,
                            known.join(", ")
                        ),
                    )
                })?;
                if !out.contains(&i) {
                    out.push(i);
                }
            }
            if out.is_empty() {
                return Err(cx.err(
                    t.span(),
                    "structure.traversals",
                    "needs at least one traversal",
                ));
            }
            out
        }
    };
    let empty = toml::Table::new();
    let (table, span) = match &s.params {
        Some(p) => (p.get_ref(), p.span()),
        None => (&empty, s.name.span()),
    };
    let param_sets = expand(family.params, &(family.defaults)(), table)
        .map_err(|(key, msg)| cx.err(span.clone(), &format!("structure.params.{key}"), msg))?;
    // The family's rules across parameters (e.g. R-tree `m ≤ M/2`), before any work.
    for set in &param_sets {
        (family.rules)(set).map_err(|m| {
            let which = if param_sets.len() > 1 {
                format!(" (in the sweep's combination {set})")
            } else {
                String::new()
            };
            cx.err(
                span.clone(),
                "structure.params",
                format!("{}: {m}{which}", family.name),
            )
        })?;
    }
    Ok(StructureSpec {
        family,
        infos,
        traversals,
        param_sets,
        time_builds: s.time_builds,
    })
}
