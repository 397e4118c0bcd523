//! What a long-lived render keeps between runs, and the one rule for reusing it. Each stage
//! output is kept in a `Slot` with the key of exactly what its stage read; a `Run` reuses the
//! output while the key is the same and runs the stage otherwise. Every output gets a
//! generation number (`Gen`), and a later stage's key holds the generations of the outputs
//! it read, so a change invalidates exactly the stages downstream of it.
//!
//! The `Policy` says whether a run keeps its outputs for the next: a session (`cubist serve`)
//! does; a one-off render (`cubist render`) does not, so its stages work in place without the
//! copies keeping would need.

use std::path::Path;

use xxhash_rust::xxh3::Xxh3;

use super::Timings;
use crate::error::Result;
use crate::progress::Progress;

/// Names one stage output (unique within a session; 0: none).
pub type Gen = u64;

/// Whether a run keeps its outputs for a later run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Policy {
    /// Kept (a session): stages that work in place keep what they changed apart, so the next
    /// run can reuse every output whose key still holds.
    Kept,
    /// One-off (a single render): stages work in place and nothing is copied to be kept.
    OneOff,
}

/// A kept output, the key of what made it, and its generation.
pub struct Entry<K, V> {
    pub key: K,
    pub id: Gen,
    pub value: V,
}

/// Where one stage's output is kept.
pub struct Slot<K, V>(Option<Entry<K, V>>);

impl<K, V> Default for Slot<K, V> {
    fn default() -> Self {
        Slot(None)
    }
}

impl<K, V> Slot<K, V> {
    /// Whether the slot holds the output made with `key`.
    pub fn hit(&self, key: &K) -> bool
    where
        K: PartialEq,
    {
        self.0.as_ref().is_some_and(|e| e.key == *key)
    }

    /// The generation of the output held (0: none).
    pub fn id(&self) -> Gen {
        self.0.as_ref().map_or(0, |e| e.id)
    }

    pub fn is_some(&self) -> bool {
        self.0.is_some()
    }

    pub fn entry(&self) -> Option<&Entry<K, V>> {
        self.0.as_ref()
    }

    pub fn get(&self) -> Option<&V> {
        self.0.as_ref().map(|e| &e.value)
    }

    pub fn get_mut(&mut self) -> Option<&mut V> {
        self.0.as_mut().map(|e| &mut e.value)
    }

    pub fn take(&mut self) -> Option<Entry<K, V>> {
        self.0.take()
    }

    pub fn put(&mut self, entry: Entry<K, V>) {
        self.0 = Some(entry);
    }

    pub fn clear(&mut self) {
        self.0 = None;
    }

    /// The output held, which the caller has just made or found (an internal error else).
    pub fn made(&self) -> &V {
        self.get().expect("a stage's output is made before it is read")
    }
}

/// One run of the stages: its policy, the session's generation counter, the steps it timed
/// and the outputs it reused.
pub struct Run<'a> {
    pub policy: Policy,
    gens: &'a mut Gen,
    pub progress: &'a Progress,
    pub timings: Timings,
    /// The steps whose output was kept from an earlier run, in order.
    pub reused: Vec<&'static str>,
}

impl<'a> Run<'a> {
    pub fn new(policy: Policy, gens: &'a mut Gen, progress: &'a Progress) -> Run<'a> {
        Run { policy, gens, progress, timings: Timings::default(), reused: Vec::new() }
    }

    pub fn keeps(&self) -> bool {
        self.policy == Policy::Kept
    }

    /// A new generation number.
    pub fn new_gen(&mut self) -> Gen {
        *self.gens += 1;
        *self.gens
    }

    /// The keep/reuse rule: `slot`'s output stays when it was made with `key` (listed as
    /// reused under `name`, if given); otherwise `make`, given the old entry (to reuse parts
    /// of, or drop before working), makes the new output, which the slot keeps under `key`
    /// with a new generation, or the old one when `make` says the output is the same
    /// (`Made::Same`). Returns whether the stage ran. A cancelled run keeps nothing new.
    pub fn step<K: PartialEq, V>(
        &mut self,
        slot: &mut Slot<K, V>,
        key: K,
        name: Option<&'static str>,
        make: impl FnOnce(&mut Self, Option<Entry<K, V>>) -> Result<Made<V>>,
    ) -> Result<bool> {
        if slot.hit(&key) {
            self.reused.extend(name);
            return Ok(false);
        }
        let old = slot.take();
        let made = make(self, old)?;
        self.progress.check()?;
        let (value, id) = match made {
            Made::New(v) => (v, self.new_gen()),
            Made::Same(v, id) => (v, id),
        };
        slot.put(Entry { key, id, value });
        Ok(true)
    }
}

/// What a stage made: a new output, or one equal to the output kept before (which keeps its
/// generation, so the stages after it stay valid).
pub enum Made<V> {
    New(V),
    Same(V, Gen),
}

/// Hash of a file's bytes (None when it cannot be read: the stage reading it reports why).
pub fn file_key(path: Option<&Path>) -> Option<u128> {
    path.and_then(|p| hash_file(p, |_| {})).map(|h| h.digest128())
}

/// Streams a regular file's bytes into a hash, `each` seeing every chunk. None for a file that
/// cannot be read or is not a regular file: a FIFO or a device is refused without blocking
/// (`open_regular`), and its reader then says why.
pub fn hash_file(path: &Path, mut each: impl FnMut(&[u8])) -> Option<Xxh3> {
    use std::io::Read;
    let (mut f, _) = crate::util::files::open_regular(path, u64::MAX).ok()?;
    let mut hasher = Xxh3::new();
    let mut buf = vec![0u8; 1 << 20];
    loop {
        let n = f.read(&mut buf).ok()?;
        if n == 0 {
            return Some(hasher);
        }
        each(&buf[..n]);
        hasher.update(&buf[..n]);
    }
}
