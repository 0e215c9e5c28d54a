//! The rule deciding whether a structure's answer matches the oracle's.
//!
//! Closest-hit: a ray matches when both miss, or both hit and either the primitive is the same
//! or the distances agree within
//!
//! `|t − t_ref| ≤ T_REL_TOL · |t_ref| + T_ULPS · 2^-24 · max(‖o‖∞, ‖o + t_ref·d‖∞) / ‖d‖₂`
//!
//! (another primitive at the same distance: a shared edge or vertex, or coplanar duplicates,
//! where the order of tests decides which is reported). The second term admits distances that
//! differ by less than a few ulps of the coordinates at the ray origin and hit point: two
//! coplanar triangles hit at `t ≈ 1e-4` from an origin at magnitude 3 get distances differing
//! by ~1e-7 (half an ulp of 3), which `f32` cannot order, and a structure that culls by boxes
//! may legitimately find either. Any other outcome is a mismatch: hit/miss disagreement, or
//! another primitive at another distance. Any-hit: a ray matches when both agree on
//! "occluded or not".
//!
//! With the watertight test both sides run the same arithmetic on the same triangle, so `t` of
//! the same primitive is bit-identical; the tolerance only admits ties between primitives.

use crate::accel::Query;
use crate::geom::{HitRecord, Ray};
use serde::Serialize;

/// Relative tolerance on `t` for hits on different primitives (see module doc).
pub const T_REL_TOL: f32 = 1e-4;

/// Ulps of the coordinate magnitude at origin and hit admitted as a tie (see module doc).
pub const T_ULPS: f32 = 8.0;

/// The distance tolerance for a hit at `t_ref` along `ray` (see module doc).
pub fn t_tolerance(ray: &Ray, t_ref: f32) -> f32 {
    let p = ray.origin + t_ref * ray.dir;
    let mag = ray.origin.abs().max_element().max(p.abs().max_element());
    let len = ray.dir.length();
    let coord = if len > 0.0 {
        T_ULPS * f32::EPSILON * 0.5 * mag / len
    } else {
        0.0
    };
    T_REL_TOL * t_ref.abs() + coord
}

/// How an answer differs from the oracle's.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum MismatchKind {
    /// The oracle hits, the structure misses.
    MissedHit,
    /// The oracle misses, the structure hits.
    FalseHit,
    /// Both hit, but another primitive at a distance outside the tolerance.
    OtherPrimitive,
}

/// One ray whose answer differs from the oracle's.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Mismatch {
    /// Index of the ray in its batch.
    pub index: usize,
    /// The ray as it was traced.
    pub ray: Ray,
    /// The oracle's answer.
    pub expected: HitRecord,
    /// The structure's answer.
    pub got: HitRecord,
    /// How the two answers differ.
    pub kind: MismatchKind,
}

/// Compare one answer with the oracle's, by query.
pub fn compare(
    query: Query,
    ray: &Ray,
    expected: &HitRecord,
    got: &HitRecord,
) -> Option<MismatchKind> {
    match query {
        Query::Closest => compare_closest(ray, expected, got),
        Query::Any => compare_any(expected, got),
    }
}

/// Compare one closest-hit answer for `ray` with the oracle's.
pub fn compare_closest(ray: &Ray, expected: &HitRecord, got: &HitRecord) -> Option<MismatchKind> {
    match (expected.is_hit(), got.is_hit()) {
        (false, false) => None,
        (true, false) => Some(MismatchKind::MissedHit),
        (false, true) => Some(MismatchKind::FalseHit),
        (true, true) => {
            if expected.prim == got.prim
                || (got.t - expected.t).abs() <= t_tolerance(ray, expected.t)
            {
                None
            } else {
                Some(MismatchKind::OtherPrimitive)
            }
        }
    }
}

/// Compare one any-hit answer with the oracle's.
pub fn compare_any(expected: &HitRecord, got: &HitRecord) -> Option<MismatchKind> {
    match (expected.is_hit(), got.is_hit()) {
        (true, false) => Some(MismatchKind::MissedHit),
        (false, true) => Some(MismatchKind::FalseHit),
        _ => None,
    }
}

/// Format an `f32` as an exact hexadecimal float (`0x1.8p+1`), so a mismatching ray can be
/// reproduced bit for bit.
pub fn hex_f32(x: f32) -> String {
    if x.is_nan() {
        return "nan".into();
    }
    if x.is_infinite() {
        return if x > 0.0 { "inf".into() } else { "-inf".into() };
    }
    let bits = x.to_bits();
    let sign = if bits >> 31 != 0 { "-" } else { "" };
    let exp = ((bits >> 23) & 0xff) as i32;
    let mant = bits & 0x7f_ffff;
    if exp == 0 && mant == 0 {
        return format!("{sign}0x0p+0");
    }
    // Mantissa as 6 hex digits (23 bits shifted left by one to fill 24 bits).
    let (lead, e) = if exp == 0 { (0, -126) } else { (1, exp - 127) };
    let frac = format!("{:06x}", mant << 1);
    let frac = frac.trim_end_matches('0');
    if frac.is_empty() {
        format!("{sign}0x{lead}p{e:+}")
    } else {
        format!("{sign}0x{lead}.{frac}p{e:+}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::Vec3;

    #[test]
    fn tie_on_other_primitive_is_a_match() {
        let r = Ray::new(Vec3::ZERO, Vec3::X);
        let a = HitRecord {
            t: 2.0,
            prim: 1,
            u: 0.0,
            v: 0.0,
        };
        let b = HitRecord {
            t: 2.0001,
            prim: 7,
            u: 0.0,
            v: 0.0,
        };
        assert_eq!(compare_closest(&r, &a, &b), None);
        let c = HitRecord {
            t: 2.1,
            prim: 7,
            u: 0.0,
            v: 0.0,
        };
        assert_eq!(
            compare_closest(&r, &a, &c),
            Some(MismatchKind::OtherPrimitive)
        );
        assert_eq!(
            compare_closest(&r, &a, &HitRecord::MISS),
            Some(MismatchKind::MissedHit)
        );
        assert_eq!(
            compare_closest(&r, &HitRecord::MISS, &a),
            Some(MismatchKind::FalseHit)
        );
        assert_eq!(compare_any(&a, &c), None);
        // Far from the origin, distances within a few ulps of the coordinates are ties ...
        let far = Ray::new(Vec3::new(3.0, 0.0, 0.0), Vec3::X);
        let e = HitRecord {
            t: 7.877_908e-5,
            prim: 218,
            u: 0.0,
            v: 0.0,
        };
        let g = HitRecord {
            t: 7.884_985e-5,
            prim: 297,
            u: 0.0,
            v: 0.0,
        };
        assert_eq!(compare_closest(&far, &e, &g), None);
        // ... but not at the origin, where the same distances are resolvable.
        assert_eq!(
            compare_closest(&r, &e, &g),
            Some(MismatchKind::OtherPrimitive)
        );
    }

    #[test]
    fn hex_floats_are_exact() {
        assert_eq!(hex_f32(1.0), "0x1p+0");
        assert_eq!(hex_f32(3.0), "0x1.8p+1");
        assert_eq!(hex_f32(-0.75), "-0x1.8p-1");
        assert_eq!(hex_f32(0.1), "0x1.99999ap-4");
        assert_eq!(hex_f32(0.0), "0x0p+0");
    }
}
