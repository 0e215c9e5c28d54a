// Watertight fallbacks on adapters without SHADER_F64.
//
// The exact-zero edge fallback: the edge functions are recomputed in f32, i.e. left as they
// are. Rays whose f32 edge function is exactly zero may then differ from tb-core's f64
// fallback (a tie broken differently on a shared edge or vertex).
fn edge_fallback(ax: f32, ay: f32, bx: f32, by: f32, cx: f32, cy: f32) -> vec3<f32> {
    return vec3<f32>(cx * by - cy * bx, ax * cy - ay * cx, bx * ay - by * ax);
}

// Where f32's products leave its range even after `finish` scaled the sheared vertices (a
// triangle under 2^-32 of its distance from the origin across), tb-core finishes in f64
// (tb_core::tri::Sheared::in_f64); without f64 such a ray misses the triangle.
fn watertight_f64(p: Pre, r: Ray, s: Sheared, tmax: f32) -> vec4<f32> {
    return vec4<f32>(0.0);
}
