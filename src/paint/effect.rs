//! The `Effect` trait (one painterly effect of the chain) and `EffectParams` (an effect's
//! parameters: whether they turn it on, the effect they make, its cache key).

use serde::Serialize;
use xxhash_rust::xxh3::Xxh3;

use super::context::{Canvas, PaintContext};
use super::{palette, sequence};
use crate::error::Result;

/// One painterly effect. `apply` must be deterministic (no thread-dependent order) and must
/// keep the canvas's alpha conventions (see the module doc).
pub trait Effect: Send + Sync {
    fn name(&self) -> &'static str;
    /// Whether it reads the film's hits (`PaintContext::hits`) besides the regions.
    fn reads_hits(&self) -> bool {
        false
    }
    fn apply(&self, canvas: &mut Canvas<'_>, ctx: &PaintContext) -> Result<()>;
    /// A colour transfer's luminance mapping for this canvas, to hold for a sequence
    /// (`Painter::hold`); None for every other effect.
    fn palette_key(&self, _canvas: &Canvas<'_>, _ctx: &PaintContext) -> Option<palette::PaletteKey> {
        None
    }
    /// The region means this effect reads of this canvas that a sequence holds
    /// (`sequence::Held::means`, `Painter::hold`); None for every effect that reads none.
    fn region_means(&self, _canvas: &Canvas<'_>, _ctx: &PaintContext) -> Option<sequence::RegionMeans> {
        None
    }
}

/// An effect's parameters, a struct in the effect's file holding everything the effect reads
/// (its distances and the `scale` they are converted with, the `seed` if it draws from one,
/// another effect's amount it takes into account). Its cache key is made from all its
/// fields (`Keyed`), so it cannot miss one.
pub trait EffectParams: Keyed + Send + Sync {
    /// Whether these parameters turn the effect on (decided without reading a file).
    fn is_on(&self) -> bool;
    /// The effect they make (reads the palette painting, if any).
    fn build(&self) -> Result<Box<dyn Effect>>;
}

/// A value's cache key: a hash of its type and of every field, floats by their exact value.
/// Two effects whose parameters have the same key paint the same canvas from the same one.
pub trait Keyed {
    fn key(&self) -> u128;
}

impl<T: Serialize> Keyed for T {
    fn key(&self) -> u128 {
        key_of(&(std::any::type_name::<T>(), self))
    }
}

/// The hash of `value`'s JSON form (floats in their shortest form that reads back exactly).
pub fn key_of(value: &impl Serialize) -> u128 {
    struct Hashing(Xxh3);
    impl std::io::Write for Hashing {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            self.0.update(buf);
            Ok(buf.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }
    let mut h = Hashing(Xxh3::new());
    // The writer never fails, and the parameters hold nothing JSON cannot write (no maps, paths
    // as their bytes: `path_bytes`).
    serde_json::to_writer(&mut h, value).expect("effect parameters are serialisable");
    h.0.digest128()
}

/// Serialises a path as its bytes (any path, UTF-8 or not), for `key_of`.
pub fn path_bytes<S: serde::Serializer>(
    path: &Option<std::path::PathBuf>,
    s: S,
) -> std::result::Result<S::Ok, S::Error> {
    match path {
        Some(p) => s.serialize_some(p.as_os_str().as_encoded_bytes()),
        None => s.serialize_none(),
    }
}
