// Watertight fallback of Woop et al. 2013 (Listing 1) for an edge function that is exactly
// zero in f32: recompute the three in f64 (products of f32 are exact in f64), as tb-core does.
fn edge_fallback(ax: f32, ay: f32, bx: f32, by: f32, cx: f32, cy: f32) -> vec3<f32> {
    return vec3<f32>(
        f32(f64(cx) * f64(by) - f64(cy) * f64(bx)),
        f32(f64(ax) * f64(cy) - f64(ay) * f64(cx)),
        f32(f64(bx) * f64(ay) - f64(by) * f64(ax)),
    );
}
