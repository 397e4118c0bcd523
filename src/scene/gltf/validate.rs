//! What a file may ask for: glTF 2.x, known required extensions, indices the gltf crate's
//! validation would panic on, declared bounds that hold the data.

use std::path::Path;

use glam::Vec3;

use super::{Loader, SUPPORTED_REQUIRED};
use crate::error::{Error, Result};

/// Refuses files that require an extension we cannot render faithfully.
pub(super) fn check_required_extensions(path: &Path, required: &[String]) -> Result<()> {
    let unsupported = |message: String| Error::Unsupported { path: path.to_path_buf(), message };
    for ext in required {
        match ext.as_str() {
            "KHR_draco_mesh_compression" => {
                return Err(unsupported(
                    "Draco-compressed meshes (KHR_draco_mesh_compression); re-export the scene without mesh compression".into(),
                ));
            }
            "EXT_meshopt_compression" => {
                return Err(unsupported(
                    "meshopt-compressed buffers (EXT_meshopt_compression); re-export without compression".into(),
                ));
            }
            e if !SUPPORTED_REQUIRED.contains(&e) => {
                return Err(unsupported(format!("the file requires the extension {e}")));
            }
            _ => {}
        }
    }
    Ok(())
}

/// Index checks the gltf crate's validation would panic on rather than report.
pub(super) fn check_references(path: &Path, root: &gltf::json::Root) -> Result<()> {
    let n = root.accessors.len();
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            for (semantic, acc) in &prim.attributes {
                if acc.value() >= n {
                    return Err(Error::scene(
                        path,
                        format!(
                            "meshes[{m}].primitives[{p}] attribute {semantic:?} refers to accessor {} of {n}",
                            acc.value()
                        ),
                    ));
                }
            }
        }
    }
    Ok(())
}

/// Refuses integers above u32::MAX anywhere in the JSON but `extras` (the user's own data):
/// glTF indices are 32-bit and the gltf crate wraps larger ones (node.mesh 4294967296 became
/// mesh 0), and every byte count or element count above that is beyond our limits anyway.
/// Streams through the JSON without building it. Malformed JSON is left to the gltf crate.
pub(super) fn check_indices(path: &Path, bytes: &[u8], is_glb: bool) -> Result<()> {
    let json = if is_glb {
        let len = bytes.get(12..16).map(|l| u32::from_le_bytes([l[0], l[1], l[2], l[3]]) as usize);
        match (len, bytes.get(16..20)) {
            (Some(len), Some(b"JSON")) => match bytes.get(20..20usize.saturating_add(len)) {
                Some(j) => j,
                None => return Ok(()),
            },
            _ => return Ok(()),
        }
    } else {
        bytes
    };
    let mut found = None;
    let mut at = Vec::new();
    let mut de = serde_json::Deserializer::from_slice(json);
    let walk = Walk { at: &mut at, found: &mut found };
    if serde::de::DeserializeSeed::deserialize(walk, &mut de).is_err() {
        return Ok(());
    }
    match found {
        Some((at, v)) => {
            Err(Error::scene(path, format!("{at}: {v} is not a valid glTF index or count (above 4294967295)")))
        }
        None => Ok(()),
    }
}

/// A JSON walk that records the first integer above u32::MAX and where it is.
struct Walk<'w> {
    at: &'w mut Vec<String>,
    found: &'w mut Option<(String, u64)>,
}

impl<'de> serde::de::DeserializeSeed<'de> for Walk<'_> {
    type Value = ();
    fn deserialize<D: serde::Deserializer<'de>>(self, d: D) -> std::result::Result<(), D::Error> {
        d.deserialize_any(self)
    }
}

impl<'de> serde::de::Visitor<'de> for Walk<'_> {
    type Value = ();
    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("JSON")
    }
    fn visit_u64<E>(self, v: u64) -> std::result::Result<(), E> {
        if v > u32::MAX as u64 && self.found.is_none() {
            let mut at = String::new();
            for part in self.at.iter() {
                if !part.starts_with('[') && !at.is_empty() {
                    at.push('.');
                }
                at.push_str(part);
            }
            *self.found = Some((crate::error::shorten(&at), v));
        }
        Ok(())
    }
    fn visit_i64<E>(self, _: i64) -> std::result::Result<(), E> {
        Ok(())
    }
    fn visit_f64<E>(self, _: f64) -> std::result::Result<(), E> {
        Ok(())
    }
    fn visit_bool<E>(self, _: bool) -> std::result::Result<(), E> {
        Ok(())
    }
    fn visit_str<E>(self, _: &str) -> std::result::Result<(), E> {
        Ok(())
    }
    fn visit_unit<E>(self) -> std::result::Result<(), E> {
        Ok(())
    }
    fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> std::result::Result<(), A::Error> {
        let mut i = 0usize;
        loop {
            self.at.push(format!("[{i}]"));
            let more = seq.next_element_seed(Walk { at: self.at, found: self.found })?;
            self.at.pop();
            if more.is_none() {
                return Ok(());
            }
            i += 1;
        }
    }
    fn visit_map<A: serde::de::MapAccess<'de>>(self, mut map: A) -> std::result::Result<(), A::Error> {
        while let Some(key) = map.next_key::<std::borrow::Cow<'de, str>>()? {
            if key == "extras" {
                map.next_value::<serde::de::IgnoredAny>()?;
                continue;
            }
            self.at.push(key.into_owned());
            map.next_value_seed(Walk { at: self.at, found: self.found })?;
            self.at.pop();
        }
        Ok(())
    }
}

pub(super) fn describe_gltf_error(e: gltf::Error) -> String {
    match e {
        gltf::Error::Validation(list) => {
            let first = list
                .first()
                .map(|(p, err)| format!("{}: {err}", p.as_str()))
                .unwrap_or_else(|| "unknown problem".into());
            if list.len() > 1 {
                format!("invalid glTF: {first} (and {} more)", list.len() - 1)
            } else {
                format!("invalid glTF: {first}")
            }
        }
        gltf::Error::Binary(b) => format!("malformed GLB container: {b:?}"),
        gltf::Error::Deserialize(d) => format!("not valid glTF JSON: {d}"),
        other => format!("{other}"),
    }
}

impl Loader<'_> {
    pub(super) fn check_asset(&mut self) -> Result<()> {
        let version = self.doc.as_json().asset.version.clone();
        let major = version.split('.').next().unwrap_or("");
        if major != "2" {
            return Err(self.err(format!("asset.version is \"{version}\": only glTF 2.x is supported")));
        }
        if self.doc.animations().len() > 0 {
            self.warn(format!(
                "{} animation(s) ignored: the scene renders in its rest pose (animate in Blender and render frames instead)",
                self.doc.animations().len()
            ));
        }
        Ok(())
    }

    /// Declared POSITION bounds must hold the data (the validator's ACCESSOR_MIN/MAX checks).
    pub(super) fn check_bounds(&self, acc: &gltf::Accessor, positions: &[Vec3], what: &str) -> Result<()> {
        let as_vec = |v: Option<gltf::json::Value>| -> Option<Vec3> {
            let arr = v?.as_array()?.iter().map(|x| x.as_f64()).collect::<Option<Vec<f64>>>()?;
            (arr.len() == 3).then(|| Vec3::new(arr[0] as f32, arr[1] as f32, arr[2] as f32))
        };
        let (min, max) = (as_vec(acc.min()), as_vec(acc.max()));
        let Some((lo, hi)) = positions
            .iter()
            .fold(None, |acc: Option<(Vec3, Vec3)>, p| Some(acc.map_or((*p, *p), |(lo, hi)| (lo.min(*p), hi.max(*p)))))
        else {
            return Ok(());
        };
        let tol = |v: Vec3| v.abs() * 1e-5 + Vec3::splat(1e-6);
        if let Some(min) = min
            && (lo + tol(lo)).cmplt(min).any()
        {
            return Err(self.err(format!("{what}: data reach {lo:?}, below the declared min {min:?}")));
        }
        if let Some(max) = max
            && (hi - tol(hi)).cmpgt(max).any()
        {
            return Err(self.err(format!("{what}: data reach {hi:?}, above the declared max {max:?}")));
        }
        Ok(())
    }
}
