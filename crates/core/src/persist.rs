//! Saving a built structure and loading it again, for the harness's build cache.
//!
//! A structure that implements [`Persist`] is written with `serde` and `bincode` (the nodes,
//! references and built figures; not the scene's triangles, which the loader hands back, and
//! not its parameters, which are part of the cache key and handed back too). The family then
//! carries a [`Codec`] ([`crate::Family::with_persist`]), and the harness stores the bytes in
//! a content-addressed file (`tb_harness::experiment::cache`). A loaded structure is checked
//! with [`crate::Accel::validate`] before it is used; the cache's tests compare it with a fresh
//! build, field for field and answer for answer.
//!
//! Auxiliary arrays that traversals build on first use (ropes, boxes, parent links) are not
//! saved: they are rebuilt by [`crate::Accel::prepare`], untimed, as after a build.

use crate::accel::{Accel, Codec, Family, Structure};
use crate::geom::Triangle;
use crate::params::{ParamError, ParamSet, Params};
use serde::de::DeserializeOwned;
use serde::Serialize;
use std::sync::Arc;

/// A structure that can be saved and loaded again.
pub trait Persist: Structure + Serialize + DeserializeOwned {
    /// Give a loaded structure what was not saved: the scene's triangles `tris` (those it was
    /// built on, by the cache key) and its parameters `params` (checked, as at build time).
    fn attach(&mut self, tris: &Arc<[Triangle]>, params: &ParamSet) -> Result<(), ParamError>;
}

fn save<S: Persist>(accel: &dyn Accel) -> Result<Vec<u8>, String> {
    let s = accel
        .as_any()
        .and_then(|a| a.downcast_ref::<S>())
        .ok_or_else(|| format!("not a {} structure", S::NAME))?;
    bincode::serialize(s).map_err(|e| format!("{}: cannot encode: {e}", S::NAME))
}

fn load<S: Persist>(
    bytes: &[u8],
    tris: &Arc<[Triangle]>,
    params: &ParamSet,
) -> Result<Box<dyn Accel>, String> {
    let mut s: S =
        bincode::deserialize(bytes).map_err(|e| format!("{}: cannot decode: {e}", S::NAME))?;
    s.attach(tris, params)
        .map_err(|e| format!("{}: parameters: {e}", S::NAME))?;
    Ok(Box::new(s))
}

/// The codec of structure `S`.
pub const fn codec_of<S: Persist>() -> Codec {
    Codec {
        save: save::<S>,
        load: load::<S>,
    }
}

impl Family {
    /// This family's builds saved to and loaded from the build cache.
    pub const fn with_persist<S: Persist>(mut self) -> Family {
        self.codec = Some(codec_of::<S>());
        self
    }
}

/// The parameters `P` of a checked set (the usual body of [`Persist::attach`]).
pub fn params_from<P: Params>(set: &ParamSet) -> Result<P, ParamError> {
    P::from_set(set)
}

/// `#[serde(with = "tb_core::persist::pod")]`: a `Vec` of plain-old-data values as one byte
/// string (one copy each way, instead of one call per field).
pub mod pod {
    use bytemuck::Pod;
    use serde::{Deserialize, Deserializer, Serializer};

    /// Write `v`'s bytes.
    pub fn serialize<T: Pod, S: Serializer>(v: &[T], s: S) -> Result<S::Ok, S::Error> {
        s.serialize_bytes(bytemuck::cast_slice(v))
    }

    /// Read values written by [`serialize`].
    pub fn deserialize<'de, T: Pod, D: Deserializer<'de>>(d: D) -> Result<Vec<T>, D::Error> {
        let bytes: serde_bytes_buf::Buf = Deserialize::deserialize(d)?;
        from_bytes(&bytes.0).map_err(serde::de::Error::custom)
    }

    /// Values of type `T` from their bytes (any alignment); `Err` where the length does not
    /// divide.
    pub fn from_bytes<T: Pod>(bytes: &[u8]) -> Result<Vec<T>, String> {
        let size = std::mem::size_of::<T>().max(1);
        if !bytes.len().is_multiple_of(size) {
            return Err(format!(
                "{} bytes is not a whole number of {size}-byte values",
                bytes.len()
            ));
        }
        let mut out = vec![T::zeroed(); bytes.len() / size];
        bytemuck::cast_slice_mut::<T, u8>(&mut out).copy_from_slice(bytes);
        Ok(out)
    }

    /// A byte string written as one.
    pub(super) struct Bytes<'a>(pub &'a [u8]);

    impl serde::Serialize for Bytes<'_> {
        fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
            s.serialize_bytes(self.0)
        }
    }

    /// A byte string read as one (serde reads `Vec<u8>` as a sequence otherwise).
    pub(super) mod serde_bytes_buf {
        use serde::de::{Deserialize, Deserializer, Error, SeqAccess, Visitor};
        use std::fmt;

        pub struct Buf(pub Vec<u8>);

        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Buf;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a byte string")
            }
            fn visit_bytes<E: Error>(self, v: &[u8]) -> Result<Buf, E> {
                Ok(Buf(v.to_vec()))
            }
            fn visit_byte_buf<E: Error>(self, v: Vec<u8>) -> Result<Buf, E> {
                Ok(Buf(v))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut a: A) -> Result<Buf, A::Error> {
                let mut v = Vec::with_capacity(a.size_hint().unwrap_or(0));
                while let Some(b) = a.next_element()? {
                    v.push(b);
                }
                Ok(Buf(v))
            }
        }

        impl<'de> Deserialize<'de> for Buf {
            fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                d.deserialize_byte_buf(V)
            }
        }
    }
}

/// A plain-old-data slot of an array whose slots are mostly one empty value (the R-tree's
/// complete level-order layout: Feldmann section 4 keeps a slot for every child a node could
/// have), saved by [`sparse_pod`].
pub trait Slot: bytemuck::Pod {
    /// The empty slot, compared byte for byte.
    const EMPTY: Self;
}

/// `#[serde(with = "tb_core::persist::sparse_pod")]`: a `Vec` of [`Slot`]s saved as its length,
/// a bitmap of the slots that are not [`Slot::EMPTY`] (byte for byte) and those slots' bytes;
/// loaded bit for bit as it was. Conference's R-tree with `M = 4` is 695 MiB of slots, nearly
/// all empty: saved whole, its cache entry took seconds to check and read.
pub mod sparse_pod {
    use super::pod::{from_bytes, serde_bytes_buf::Buf, Bytes};
    use super::Slot;
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    fn is_empty<T: Slot>(v: &T) -> bool {
        bytemuck::bytes_of(v) == bytemuck::bytes_of(&T::EMPTY)
    }

    /// Write `v` as its length, the bitmap of its full slots and their bytes.
    pub fn serialize<T: Slot, S: Serializer>(v: &[T], s: S) -> Result<S::Ok, S::Error> {
        let mut bits = vec![0u8; v.len().div_ceil(8)];
        let mut full = Vec::new();
        for (i, x) in v.iter().enumerate() {
            if !is_empty(x) {
                bits[i / 8] |= 1 << (i % 8);
                full.push(*x);
            }
        }
        let bytes: &[u8] = bytemuck::cast_slice(&full);
        (v.len() as u64, Bytes(&bits), Bytes(bytes)).serialize(s)
    }

    /// Read values written by [`serialize`].
    pub fn deserialize<'de, T: Slot, D: Deserializer<'de>>(d: D) -> Result<Vec<T>, D::Error> {
        let (len, bits, bytes): (u64, Buf, Buf) = Deserialize::deserialize(d)?;
        expand(len, &bits.0, &bytes.0).map_err(serde::de::Error::custom)
    }

    /// The slots of a saved length, bitmap and full slots' bytes; `Err` where they disagree.
    pub fn expand<T: Slot>(len: u64, bits: &[u8], bytes: &[u8]) -> Result<Vec<T>, String> {
        let len = usize::try_from(len).map_err(|_| format!("{len} slots is too many"))?;
        if bits.len() != len.div_ceil(8) {
            return Err(format!("a bitmap of {} bytes for {len} slots", bits.len()));
        }
        let full: Vec<T> = from_bytes(bytes)?;
        let set: usize = bits.iter().map(|b| b.count_ones() as usize).sum();
        if set != full.len() || (len % 8 != 0 && bits[len / 8] >> (len % 8) != 0) {
            return Err(format!(
                "{set} full slots marked, {} saved, of {len}",
                full.len()
            ));
        }
        let mut out = vec![T::EMPTY; len];
        let mut next = full.into_iter();
        for (i, slot) in out.iter_mut().enumerate() {
            if bits[i / 8] >> (i % 8) & 1 == 1 {
                *slot = next.next().expect("counted");
            }
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::{sparse_pod, Slot};
    use serde::{Deserialize, Serialize};

    #[repr(C)]
    #[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
    struct S {
        a: f32,
        b: u32,
    }

    impl Slot for S {
        const EMPTY: S = S {
            a: f32::INFINITY,
            b: 0,
        };
    }

    #[derive(Serialize, Deserialize, Debug, PartialEq)]
    struct Holder(#[serde(with = "sparse_pod")] Vec<S>);

    /// Sparse slots come back bit for bit (a NaN and a negative zero among them), and the
    /// saved form holds the full slots only.
    #[test]
    fn sparse_slots_round_trip_bit_for_bit() {
        let mut v = vec![S::EMPTY; 1001];
        v[0] = S { a: -0.0, b: 1 };
        v[7] = S { a: f32::NAN, b: 2 };
        v[8] = S { a: 1.5, b: 0 };
        v[1000] = S { a: 2.0, b: 3 };
        let bytes = bincode::serialize(&Holder(v.clone())).unwrap();
        assert!(bytes.len() < 1001 / 8 + 4 * 8 + 64, "{} bytes", bytes.len());
        let back: Holder = bincode::deserialize(&bytes).unwrap();
        let raw = |v: &[S]| bytemuck::cast_slice::<S, u8>(v).to_vec();
        assert_eq!(raw(&back.0), raw(&v));
        let empty: Holder =
            bincode::deserialize(&bincode::serialize(&Holder(vec![])).unwrap()).unwrap();
        assert!(empty.0.is_empty());
    }

    /// A length, bitmap and slots that disagree are refused, not filled in.
    #[test]
    fn inconsistent_sparse_slots_are_refused() {
        let one = bytemuck::bytes_of(&S { a: 1.0, b: 1 }).to_vec();
        assert!(sparse_pod::expand::<S>(9, &[1, 0], &one).is_ok());
        assert!(sparse_pod::expand::<S>(9, &[1], &one)
            .unwrap_err()
            .contains("bitmap"));
        assert!(sparse_pod::expand::<S>(9, &[3, 0], &one)
            .unwrap_err()
            .contains("marked"));
        // A bit past the end.
        assert!(sparse_pod::expand::<S>(9, &[0, 2], &one).is_err());
        assert!(sparse_pod::expand::<S>(9, &[1, 0], &one[..5]).is_err());
    }
}
