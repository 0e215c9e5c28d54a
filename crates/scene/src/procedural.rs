//! Vocabulary shared by the generated scenes, built-in procedural ([`crate::builtin`]) and
//! stress ([`crate::stress`]): the listing entry ([`BuiltinInfo`]), the `?k=v&…` parameters of
//! a `builtin:NAME?k=v&…` source ([`Params`]), and the icosahedron both sphere generators
//! subdivide (SPD's sphereflake and the stress scenes' icosphere).
//!
//! The dependencies go one way: [`crate::builtin`] uses this module and dispatches
//! `builtin:stress/NAME` to [`crate::stress`], which uses this module too.

use crate::error::SceneError;
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

    /// Parameter `key` as a finite `f32`, `default` when absent.
    pub fn f32(&self, key: &str, default: f32) -> Result<f32, SceneError> {
        let v = self.get(key, default)?;
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.err(format!("parameter `{key}` must be finite")))
        }
    }

    /// Parameter `key` as a `u32`, `default` when absent.
    pub fn u32(&self, key: &str, default: u32) -> Result<u32, SceneError> {
        self.get(key, default)
    }

    /// Parameter `key` as a `u64`, `default` when absent.
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

/// The 12 vertices of the unit icosahedron (normalised), shared by every sphere generator
/// (SPD sphereflake, the stress icosphere).
pub(crate) fn icosahedron_vertices() -> [glam::DVec3; 12] {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .map(|(x, y, z)| glam::DVec3::new(x, y, z).normalize())
}

/// The 20 faces of the icosahedron over [`icosahedron_vertices`], counter-clockwise outside.
pub(crate) const ICOSAHEDRON_FACES: [[usize; 3]; 20] = [
    [0, 11, 5],
    [0, 5, 1],
    [0, 1, 7],
    [0, 7, 10],
    [0, 10, 11],
    [1, 5, 9],
    [5, 11, 4],
    [11, 10, 2],
    [10, 7, 6],
    [7, 1, 8],
    [3, 9, 4],
    [3, 4, 2],
    [3, 2, 6],
    [3, 6, 8],
    [3, 8, 9],
    [4, 9, 5],
    [2, 4, 11],
    [6, 2, 10],
    [8, 6, 7],
    [9, 8, 1],
];
