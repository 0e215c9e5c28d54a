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

    /// A byte string read as one (serde reads `Vec<u8>` as a sequence otherwise).
    mod serde_bytes_buf {
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
