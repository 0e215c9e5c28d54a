//! trace-bench rendering: what the numbers look like.
//!
//! - [`colormap`]: the false-colour maps of heat maps (dark blue at 0 to dark red at the
//!   scale's top, as in the sparse-boxes paper's Figure 5) and of difference maps;
//! - [`heatmap`]: per-pixel counter images with a labelled colour bar, difference maps;
//! - [`image`]: the EXR (raw `f32` channels, `exr` crate) and PNG (8-bit, `png` crate) writers
//!   and the EXR reader;
//! - [`shade`]: the simple shading of primary hits (`|n·d|` grey);
//! - [`trace`]: [`Tracer`], "something that traces a batch of rays", so an integrator runs on
//!   any structure and any device;
//! - [`integrate`]: progressive ambient-occlusion and diffuse path-tracing integrators;
//! - [`metrics`]: RMSE and relative MSE against a reference;
//! - [`cache`]: the content-hashed cache of reference images.

#![deny(missing_docs)]

pub mod cache;
pub mod colormap;
pub mod error;
pub mod heatmap;
pub mod image;
pub mod integrate;
pub mod metrics;
pub mod shade;
pub mod trace;

pub use error::RenderError;
pub use image::{Channels, Rgb8};
pub use integrate::{Integrator, Progressive};
pub use trace::{AccelTracer, Tracer};
