//! Stiff and extreme scenes for numerical checks, `builtin:stress/NAME`, each with its own rays.
//!
//! TODO(helper B).

use crate::builtin::{BuiltinInfo, Params};
use crate::{Scene, SceneError};

/// The stress scenes.
pub const LIST: &[BuiltinInfo] = &[];

/// Load stress scene `name` (the part after `stress/`).
pub fn load(name: &str, params: &Params) -> Result<Scene, SceneError> {
    let _ = params;
    Err(SceneError::Builtin {
        spec: format!("stress/{name}"),
        message: format!("unknown stress scene `{name}` (run `trace-bench scenes` for the list)"),
    })
}
