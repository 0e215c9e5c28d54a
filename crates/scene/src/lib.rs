//! trace-bench scenes and rays.
//!
//! - [`load`]: a scene from a source string: `builtin:NAME?param=value&…` (see [`builtin`] and
//!   [`stress`]) or a file path (`.obj`, `.obj.gz`, `.gltf`, `.glb`) relative to the scenes root;
//! - [`camera`]: the pinhole camera of the configs, row or Morton pixel order;
//! - [`rays`]: the ray batches every structure traces (primary, shadow, ao, path bounces,
//!   random), generated once per scene and kind with fixed seeds;
//! - [`conformance`]: the shared oracle suite every structure x traversal must pass.

#![deny(missing_docs)]

pub mod builtin;
pub mod camera;
pub mod conformance;
pub mod error;
pub mod loader;
pub mod procedural;
pub mod rays;
pub mod scene;
pub mod source;
pub mod stress;

pub use camera::{Camera, PixelOrder};
pub use error::SceneError;
pub use scene::{Scene, View};
pub use source::load;
