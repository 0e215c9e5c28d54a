//! Built-in procedural scenes, addressed as `builtin:NAME?param=value&…`.
//!
//! TODO(helper A): the procedural generators (cornell, sphereflake, mount, tetra, soup,
//! teapot-stadium). Stress scenes (`builtin:stress/NAME`) live in [`crate::stress`].

use crate::{Scene, SceneError};
use std::collections::BTreeMap;

/// One built-in scene as listed by `trace-bench scenes`.
#[derive(Clone, Copy, Debug)]
pub struct BuiltinInfo {
    /// Name after `builtin:` (e.g. `sphereflake`, `stress/axis-planes`).
    pub name: &'static str,
    /// One line: what it is and where it comes from.
    pub doc: &'static str,
    /// Parameters as `name=default: meaning`, one per entry.
    pub params: &'static [&'static str],
}

/// The `?k=v&k=v` part of a builtin source, with typed getters. Every key must be consumed:
/// [`Params::finish`] reports the first unknown one.
#[derive(Clone, Debug)]
pub struct Params {
    spec: String,
    values: BTreeMap<String, String>,
    used: std::cell::RefCell<Vec<String>>,
}

impl Params {
    /// Split `NAME?k=v&k=v` into the name and its parameters.
    pub fn parse(spec: &str) -> Result<(String, Params), SceneError> {
        let (name, query) = match spec.split_once('?') {
            Some((n, q)) => (n, q),
            None => (spec, ""),
        };
        let mut values = BTreeMap::new();
        for kv in query.split('&').filter(|s| !s.is_empty()) {
            let Some((k, v)) = kv.split_once('=') else {
                return Err(SceneError::Builtin {
                    spec: spec.into(),
                    message: format!("parameter `{kv}` is not of the form key=value"),
                });
            };
            values.insert(k.trim().to_string(), v.trim().to_string());
        }
        Ok((
            name.to_string(),
            Params {
                spec: spec.into(),
                values,
                used: Default::default(),
            },
        ))
    }

    fn err(&self, message: String) -> SceneError {
        SceneError::Builtin {
            spec: self.spec.clone(),
            message,
        }
    }

    fn get<T: std::str::FromStr>(&self, key: &str, default: T) -> Result<T, SceneError> {
        self.used.borrow_mut().push(key.to_string());
        match self.values.get(key) {
            None => Ok(default),
            Some(v) => v.parse().map_err(|_| {
                self.err(format!(
                    "parameter `{key}`: cannot parse `{v}` as {}",
                    std::any::type_name::<T>()
                ))
            }),
        }
    }

    pub fn f32(&self, key: &str, default: f32) -> Result<f32, SceneError> {
        let v = self.get(key, default)?;
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.err(format!("parameter `{key}` must be finite")))
        }
    }

    pub fn u32(&self, key: &str, default: u32) -> Result<u32, SceneError> {
        self.get(key, default)
    }

    pub fn u64(&self, key: &str, default: u64) -> Result<u64, SceneError> {
        self.get(key, default)
    }

    /// Error on a key no getter asked for (call after reading all parameters).
    pub fn finish(&self) -> Result<(), SceneError> {
        let used = self.used.borrow();
        match self.values.keys().find(|k| !used.contains(k)) {
            Some(k) => Err(self.err(format!("unknown parameter `{k}`"))),
            None => Ok(()),
        }
    }

    /// A range check with a clear message.
    pub fn check(&self, ok: bool, message: &str) -> Result<(), SceneError> {
        if ok {
            Ok(())
        } else {
            Err(self.err(message.to_string()))
        }
    }
}

/// All built-in scenes, procedural then stress.
pub fn list() -> Vec<BuiltinInfo> {
    let mut v: Vec<BuiltinInfo> = PROCEDURAL.to_vec();
    v.extend_from_slice(crate::stress::LIST);
    v
}

/// The procedural scenes (helper A fills this table).
pub const PROCEDURAL: &[BuiltinInfo] = &[];

/// Load `NAME?params` (the part after `builtin:`).
pub fn load(spec: &str) -> Result<Scene, SceneError> {
    let (name, params) = Params::parse(spec)?;
    let mut scene = if let Some(stress) = name.strip_prefix("stress/") {
        crate::stress::load(stress, &params)?
    } else {
        load_procedural(&name, &params)?
    };
    params.finish()?;
    scene.source = format!("builtin:{spec}");
    Ok(scene)
}

fn load_procedural(name: &str, params: &Params) -> Result<Scene, SceneError> {
    let _ = params;
    Err(SceneError::Builtin {
        spec: name.into(),
        message: format!("unknown built-in scene `{name}` (run `trace-bench scenes` for the list)"),
    })
}
