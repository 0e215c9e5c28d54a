// Watertight fallbacks on adapters with SHADER_F64, as tb-core computes them.
//
// Woop et al. 2013 (Listing 1) for an edge function that is exactly zero in f32: recompute the
// three in f64 (products of f32 are exact in f64), as tb-core does.
fn edge_fallback(ax: f32, ay: f32, bx: f32, by: f32, cx: f32, cy: f32) -> vec3<f32> {
    return vec3<f32>(
        f32(f64(cx) * f64(by) - f64(cy) * f64(bx)),
        f32(f64(ax) * f64(cy) - f64(ay) * f64(cx)),
        f32(f64(bx) * f64(ay) - f64(by) * f64(ax)),
    );
}

// The rest of the test where f32's products leave its range even after `finish` scaled the
// sheared vertices (a triangle under 2^-32 of its distance from the origin across), from the
// f32 sheared vertices, in f64: tb_core::tri::Sheared::in_f64 operation for operation.
fn watertight_f64(p: Pre, r: Ray, s: Sheared, tmax: f32) -> vec4<f32> {
    let none = vec4<f32>(0.0);
    let ax = f64(s.a.x);
    let ay = f64(s.a.y);
    let bx = f64(s.b.x);
    let by = f64(s.b.y);
    let cx = f64(s.c.x);
    let cy = f64(s.c.y);
    let u = cx * by - cy * bx;
    let v = ax * cy - ay * cx;
    let w = bx * ay - by * ax;
    if (u < f64(0.0) || v < f64(0.0) || w < f64(0.0)) && (u > f64(0.0) || v > f64(0.0) || w > f64(0.0)) {
        return none;
    }
    let det = u + v + w;
    // |det| is finite and nonzero: below f64's largest (f32 products cannot overflow f64).
    if !(abs(det) > f64(0.0) && abs(det) <= f64(1.0e300)) {
        return none;
    }
    let sz = f64(p.s.z);
    let az = sz * f64(s.a.z);
    let bz = sz * f64(s.b.z);
    let cz = sz * f64(s.c.z);
    let inv = f64(1.0) / det;
    let t = ((u * az + v * bz) + w * cz) * inv;
    let max_x = max(max(abs(ax), abs(bx)), abs(cx));
    let max_y = max(max(abs(ay), abs(by)), abs(cy));
    let max_z = max(max(abs(az), abs(bz)), abs(cz));
    let delta_z = f64(GAMMA3) * max_z;
    let delta_x = f64(GAMMA5) * (max_x + max_z);
    let delta_y = f64(GAMMA5) * (max_y + max_z);
    let delta_e = f64(2.0) * ((f64(GAMMA2) * max_x * max_y + delta_y * max_x) + delta_x * max_y);
    let max_e = max(max(abs(u), abs(v)), abs(w));
    let bound = f64(3.0) * ((f64(GAMMA3) * max_e * max_z + delta_e * max_z) + delta_z * max_e) * abs(inv);
    let t32 = f32(t);
    if t <= bound || !(t32 >= r.tmin && t32 < tmax) {
        return none;
    }
    return vec4<f32>(t32, f32(v * inv), f32(w * inv), 1.0);
}
