// Watertight fallback for adapters without SHADER_F64: the edge functions are recomputed in
// f32, i.e. left as they are. Rays whose f32 edge function is exactly zero may then differ
// from tb-core's f64 fallback (a tie broken differently on a shared edge or vertex).
fn edge_fallback(ax: f32, ay: f32, bx: f32, by: f32, cx: f32, cy: f32) -> vec3<f32> {
    return vec3<f32>(cx * by - cy * bx, ax * cy - ay * cx, bx * ay - by * ax);
}
