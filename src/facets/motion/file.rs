//! The follow data saved beside a facet layout (`<layout>.follow`), so that frames rendered by
//! other processes (the Blender add-on renders each frame in its own, a farm splits them across
//! machines) carry facets from the same key frame: its camera, its geometry and, per pixel,
//! the triangle and depth its centre ray hit.
//!
//! Layout: `MAGIC`, a u32 LE header length, a JSON header (format, version, size, triangle
//! count, camera), then little-endian arrays: triangle corners (f32 x 9 per triangle), pixel
//! triangles (u32), pixel depths (f32). The file's length must be exactly what the header
//! announces, checked before anything is allocated, so a small hostile file cannot ask for
//! gigabytes; every value is range-checked.

use std::path::{Path, PathBuf};

use glam::Vec3;
use serde::{Deserialize, Serialize};

use super::Key;
use crate::camera::CameraModel;
use crate::error::{Error, Result};
use crate::facets::{FacetMap, MAX_BASE_PIXELS};
use crate::film::NO_HIT;
use crate::util::files::write_atomic;

const MAGIC: &[u8; 8] = b"CUBFOLW1";
const FORMAT: &str = "cubist-follow";
const VERSION: u32 = 1;
/// Largest JSON header (a camera is a few hundred bytes).
const MAX_HEADER: u32 = 1 << 16;
/// Most triangles a key may hold: the loader's bound on a scene.
pub const MAX_KEY_TRIANGLES: u64 = 50_000_000;

/// A key frame as plain owned data (`Key` borrows it).
#[derive(Clone, Debug, PartialEq)]
pub struct KeyData {
    pub width: u32,
    pub height: u32,
    pub tri: Vec<u32>,
    pub depth: Vec<f32>,
    pub positions: Vec<[Vec3; 3]>,
    pub camera: CameraModel,
}

impl KeyData {
    pub fn key<'a>(&'a self, map: &'a FacetMap) -> Key<'a> {
        Key { map, tri: &self.tri, depth: &self.depth, positions: &self.positions, camera: &self.camera }
    }
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Header {
    format: String,
    version: u32,
    width: u32,
    height: u32,
    triangles: u64,
    camera: CameraModel,
}

/// The follow data's path for a layout file: `<layout file name>.follow` beside it.
pub fn path_for(layout: &Path) -> PathBuf {
    let mut name = layout.file_name().map(|n| n.to_os_string()).unwrap_or_default();
    name.push(".follow");
    layout.with_file_name(name)
}

/// Writes `key` to `path` atomically.
pub fn save(path: &Path, key: &KeyData) -> Result<()> {
    let header = Header {
        format: FORMAT.into(),
        version: VERSION,
        width: key.width,
        height: key.height,
        triangles: key.positions.len() as u64,
        camera: key.camera.clone(),
    };
    let json = serde_json::to_vec(&header).map_err(|e| Error::output(path, e))?;
    let mut bytes = Vec::with_capacity(12 + json.len() + key.positions.len() * 36 + key.tri.len() * 8);
    bytes.extend_from_slice(MAGIC);
    bytes.extend_from_slice(&(json.len() as u32).to_le_bytes());
    bytes.extend_from_slice(&json);
    for t in &key.positions {
        for c in t.iter().flat_map(|p| p.to_array()) {
            bytes.extend_from_slice(&c.to_le_bytes());
        }
    }
    key.tri.iter().for_each(|t| bytes.extend_from_slice(&t.to_le_bytes()));
    key.depth.iter().for_each(|d| bytes.extend_from_slice(&d.to_le_bytes()));
    write_atomic(path, |tmp| std::fs::write(tmp, &bytes).map_err(|e| e.to_string()))
}

/// Reads follow data written by `save`; any inconsistency is an error naming the file.
pub fn load(path: &Path) -> Result<KeyData> {
    let bad = |m: String| Error::setting("facets", format!("follow data {}: {m}", path.display()));
    let len = std::fs::metadata(path)
        .map_err(|e| bad(format!("cannot read it ({e}); a layout saved with --facet-motion follow has one")))?
        .len();
    let mut f = std::fs::File::open(path).map_err(|e| bad(format!("cannot read it ({e})")))?;
    use std::io::Read;
    let mut head = [0u8; 12];
    f.read_exact(&mut head).map_err(|_| bad("too short to be follow data".into()))?;
    if &head[..8] != MAGIC {
        return Err(bad("not cubist follow data".into()));
    }
    let hlen = u32::from_le_bytes([head[8], head[9], head[10], head[11]]);
    if hlen > MAX_HEADER {
        return Err(bad(format!("a {hlen}-byte header is too large")));
    }
    let mut json = vec![0u8; hlen as usize];
    f.read_exact(&mut json).map_err(|_| bad("truncated header".into()))?;
    let h: Header = serde_json::from_slice(&json).map_err(|e| bad(format!("bad header: {e}")))?;
    if h.format != FORMAT || h.version != VERSION {
        return Err(bad(format!("format {} version {}, expected {FORMAT} version {VERSION}", h.format, h.version)));
    }
    let pixels = h.width as u64 * h.height as u64;
    if pixels == 0 || pixels > MAX_BASE_PIXELS || h.triangles > MAX_KEY_TRIANGLES {
        return Err(bad(format!("{}x{} pixels and {} triangles are out of bounds", h.width, h.height, h.triangles)));
    }
    let expected = 12 + hlen as u64 + h.triangles * 36 + pixels * 8;
    if len != expected {
        return Err(bad(format!("{len} bytes where its header announces {expected}")));
    }
    let mut body = Vec::with_capacity((expected - 12 - hlen as u64) as usize);
    f.read_to_end(&mut body).map_err(|e| bad(format!("cannot read it ({e})")))?;
    let word = |k: usize| [body[4 * k], body[4 * k + 1], body[4 * k + 2], body[4 * k + 3]];
    let tris = h.triangles as usize;
    let positions: Vec<[Vec3; 3]> = (0..tris)
        .map(|t| {
            std::array::from_fn(|c| {
                Vec3::from_array(std::array::from_fn(|k| f32::from_le_bytes(word(t * 9 + c * 3 + k))))
            })
        })
        .collect();
    let base = tris * 9;
    let n = pixels as usize;
    let tri: Vec<u32> = (0..n).map(|i| u32::from_le_bytes(word(base + i))).collect();
    let depth: Vec<f32> = (0..n).map(|i| f32::from_le_bytes(word(base + n + i))).collect();
    if let Some(i) = tri.iter().position(|&t| t != NO_HIT && t as u64 >= h.triangles) {
        return Err(bad(format!("pixel {i} names triangle {} of {}", tri[i], h.triangles)));
    }
    if let Some(i) = depth.iter().position(|d| d.is_nan() || *d < 0.0) {
        return Err(bad(format!("pixel {i} has depth {}", depth[i])));
    }
    Ok(KeyData { width: h.width, height: h.height, tri, depth, positions, camera: h.camera })
}

#[cfg(test)]
mod tests {
    use glam::{DVec3, Vec3};

    use super::*;
    use crate::camera::{CameraFrame, Orthographic};

    fn key() -> KeyData {
        let frame = CameraFrame::new(DVec3::new(0.0, 0.0, 3.0), DVec3::NEG_Z, DVec3::Y).unwrap().0;
        KeyData {
            width: 2,
            height: 1,
            tri: vec![0, NO_HIT],
            depth: vec![2.5, f32::INFINITY],
            positions: vec![[Vec3::ZERO, Vec3::X, Vec3::new(0.1, 0.7, -0.2)]],
            camera: CameraModel::Orthographic(Orthographic {
                frame,
                height: 2.0,
                aspect: 2.0,
                focus: 3.0,
                clip_radius: 1.0,
            }),
        }
    }

    #[test]
    fn round_trips_bit_for_bit() {
        let dir = tempfile::tempdir().unwrap();
        let p = path_for(&dir.path().join("layout.json"));
        assert!(p.ends_with("layout.json.follow"));
        save(&p, &key()).unwrap();
        assert_eq!(load(&p).unwrap(), key());
    }

    #[test]
    fn damaged_files_are_refused_with_a_reason() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("k.follow");
        save(&p, &key()).unwrap();
        let good = std::fs::read(&p).unwrap();
        let check = |bytes: &[u8], needle: &str| {
            std::fs::write(&p, bytes).unwrap();
            let e = load(&p).unwrap_err().to_string();
            assert!(e.contains(needle), "{e}");
        };
        check(&good[..good.len() - 1], "bytes where its header announces");
        check(b"CUBFOLW1", "too short");
        check(b"something else entirely", "not cubist follow data");
        // A header announcing forty million triangles in a tiny file: refused before allocating.
        let k = key();
        let header = Header {
            format: FORMAT.into(),
            version: VERSION,
            width: k.width,
            height: k.height,
            triangles: 40_000_000,
            camera: k.camera,
        };
        let json = serde_json::to_vec(&header).unwrap();
        let mut forged = MAGIC.to_vec();
        forged.extend_from_slice(&(json.len() as u32).to_le_bytes());
        forged.extend_from_slice(&json);
        check(&forged, "header announces 1440000");
        // A pixel naming a triangle that does not exist.
        let mut bad = key();
        bad.tri[0] = 7;
        save(&p, &bad).unwrap();
        assert!(load(&p).unwrap_err().to_string().contains("names triangle 7"));
        assert!(load(&dir.path().join("missing.follow")).unwrap_err().to_string().contains("cannot read"));
    }
}
