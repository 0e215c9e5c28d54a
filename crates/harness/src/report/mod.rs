//! What a run draws and tabulates beside its rows, each part with its own config section:
//! heat maps of primary rays ([`images`], `[run] images`), image error against run time
//! ([`convergence`], `[convergence]`) and the dynamic-scene table ([`dynamic`], `[dynamic]`).

pub mod convergence;
pub mod dynamic;
pub mod images;
