//! On-disk cache of per-mesh saliency, one file per content key, so animation frames rendered by
//! separate processes (the Blender add-on runs the binary once per frame) compute a mesh once.
//!
//! A file is `MAGIC`, the vertex count (u64 LE) and one f32 LE per vertex; it is written
//! atomically, and any unreadable, truncated or mismatched file is ignored and rewritten.

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::util::files::write_atomic;

const MAGIC: &[u8; 8] = b"CUBSAL1\n";

/// The file holding `key`'s values in `dir`.
pub fn entry_path(dir: &Path, key: u128) -> PathBuf {
    dir.join(format!("{key:032x}.saliency"))
}

/// The cached values of `key`, if a valid entry for `vertices` vertices exists.
pub fn load(dir: &Path, key: u128, vertices: usize) -> Option<Vec<f32>> {
    // A regular file of the size this entry must have (a symlink to /dev/zero or a huge file
    // is ignored and rewritten, never read whole).
    let bytes = crate::util::files::read_bounded(&entry_path(dir, key), 16 + 4 * vertices as u64).ok()?;
    let body = bytes.strip_prefix(MAGIC.as_slice())?;
    let (count, values) = body.split_first_chunk::<8>()?;
    if u64::from_le_bytes(*count) != vertices as u64 || values.len() != vertices * 4 {
        return None;
    }
    let out: Vec<f32> = values.chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
    out.iter().all(|v| (0.0..=1.0).contains(v)).then_some(out)
}

/// Stores `values` under `key` in `dir` (created if missing), atomically.
pub fn store(dir: &Path, key: u128, values: &[f32]) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::output(dir, format!("saliency cache: {e}")))?;
    let mut bytes = Vec::with_capacity(16 + values.len() * 4);
    bytes.extend_from_slice(MAGIC);
    bytes.extend_from_slice(&(values.len() as u64).to_le_bytes());
    for v in values {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    write_atomic(&entry_path(dir, key), |tmp| std::fs::write(tmp, &bytes).map_err(|e| e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_rejects_mismatches() {
        let dir = tempfile::tempdir().unwrap();
        let v = vec![0.0f32, 0.25, 1.0];
        store(dir.path(), 42, &v).unwrap();
        assert_eq!(load(dir.path(), 42, 3), Some(v.clone()));
        assert_eq!(load(dir.path(), 42, 4), None);
        assert_eq!(load(dir.path(), 43, 3), None);
        // A truncated or foreign file is ignored.
        let p = entry_path(dir.path(), 42);
        let bytes = std::fs::read(&p).unwrap();
        std::fs::write(&p, &bytes[..bytes.len() - 1]).unwrap();
        assert_eq!(load(dir.path(), 42, 3), None);
        std::fs::write(&p, b"not a cache file").unwrap();
        assert_eq!(load(dir.path(), 42, 3), None);
        // Nothing but the entry is left behind.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    /// The key of a mesh is the digest of its numbers one by one (as the entries on disk were
    /// made), however `content_key` feeds them; and a mesh of over 64 KiB of numbers crosses
    /// its blocks.
    #[test]
    fn content_key_is_the_per_number_digest() {
        use crate::saliency::{SaliencyMethod, content_key};
        let n = 7000u32;
        let positions: Vec<glam::Vec3> =
            (0..n).map(|i| glam::Vec3::new(i as f32 * 0.5, (i as f32).sin(), -(i as f32))).collect();
        let triangles: Vec<[u32; 3]> = (0..n - 2).map(|i| [i, i + 1, i + 2]).collect();
        let mesh = crate::scene::Mesh {
            name: "m".into(),
            normals: vec![glam::Vec3::Z; positions.len()],
            positions,
            uvs: None,
            colors: None,
            triangles,
            material: None,
        };
        let method = SaliencyMethod::Auto;
        let mut h = xxhash_rust::xxh3::Xxh3::new();
        h.update(b"cubist-saliency");
        h.update(&crate::saliency::ALGORITHM_VERSION.to_le_bytes());
        h.update(method.as_str().as_bytes());
        h.update(&(mesh.positions.len() as u64).to_le_bytes());
        for p in &mesh.positions {
            for c in p.to_array() {
                h.update(&c.to_bits().to_le_bytes());
            }
        }
        h.update(&(mesh.triangles.len() as u64).to_le_bytes());
        for t in &mesh.triangles {
            for c in t {
                h.update(&c.to_le_bytes());
            }
        }
        assert_eq!(content_key(&mesh, method), h.digest128());
    }

    #[test]
    fn creates_its_directory_and_reports_failures() {
        let dir = tempfile::tempdir().unwrap();
        let sub = dir.path().join("a/b");
        store(&sub, 1, &[0.5]).unwrap();
        assert_eq!(load(&sub, 1, 1), Some(vec![0.5]));
        let file = dir.path().join("f");
        std::fs::write(&file, b"x").unwrap();
        let err = store(&file.join("c"), 1, &[0.5]).unwrap_err().to_string();
        assert!(err.contains("saliency cache"), "{err}");
    }
}
