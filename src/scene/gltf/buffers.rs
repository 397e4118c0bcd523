//! The file's binary data: the GLB chunk, external files and `data:` URIs.

use std::borrow::Cow;
use std::path::{Path, PathBuf};

use base64::Engine;

use super::Loader;
use crate::error::{Result, shorten};
use crate::util::files::read_bounded;
use crate::util::limits::{MAX_SCENE_BUFFERS, MAX_SCENE_FILE};

impl<'a> Loader<'a> {
    pub(super) fn load_buffers(&mut self, mut blob: Option<Cow<'a, [u8]>>) -> Result<()> {
        let buffers: Vec<_> = self.doc.buffers().collect();
        for buffer in buffers {
            let i = buffer.index();
            let data = match buffer.source() {
                gltf::buffer::Source::Bin => blob.take().ok_or_else(|| {
                    self.err(format!("buffer {i} refers to the GLB's binary chunk, but the file has none"))
                })?,
                gltf::buffer::Source::Uri(uri) => Cow::Owned(self.read_uri(uri, &format!("buffer {i}"))?),
            };
            self.buffer_bytes += data.len() as u64;
            if self.buffer_bytes > MAX_SCENE_BUFFERS {
                return Err(self.err(format!(
                    "buffer {i}: the scene's buffers hold more than the limit of {MAX_SCENE_BUFFERS} bytes"
                )));
            }
            if data.len() < buffer.length() {
                return Err(self.err(format!(
                    "buffer {i} holds {} bytes but declares byteLength {}",
                    data.len(),
                    buffer.length()
                )));
            }
            self.buffers.push(data);
        }
        Ok(())
    }

    /// Reads a `data:` URI or a file relative to the glTF file. Files must be regular files in
    /// the scene file's folder or below it (symlinks resolved), unless the options allow
    /// external files; either way at most `MAX_SCENE_FILE` bytes, and FIFOs or devices are
    /// refused without blocking.
    pub(super) fn read_uri(&self, uri: &str, what: &str) -> Result<Vec<u8>> {
        let budget = MAX_SCENE_BUFFERS.saturating_sub(self.buffer_bytes);
        if let Some(rest) = uri.strip_prefix("data:") {
            let (header, payload) =
                rest.split_once(',').ok_or_else(|| self.err(format!("{what}: malformed data: URI (no comma)")))?;
            if !header.ends_with(";base64") || header.contains(";;") {
                return Err(self.err(format!("{what}: data: URI is not base64 (\"data:{},...\")", shorten(header))));
            }
            let payload = payload.trim();
            if payload.len() as u64 / 4 * 3 > budget {
                return Err(self.err(format!(
                    "{what}: the scene's buffers and images hold more than the limit of {MAX_SCENE_BUFFERS} bytes"
                )));
            }
            return base64::engine::general_purpose::STANDARD
                .decode(payload)
                .map_err(|e| self.err(format!("{what}: data: URI holds invalid base64 ({e})")));
        }
        let shown = shorten(uri);
        if uri.is_empty() || uri.contains("://") || uri.starts_with(':') {
            return Err(
                self.err(format!("{what}: unsupported URI \"{shown}\" (only relative file paths and data: URIs)"))
            );
        }
        let Some(base) = self.base else {
            return Err(
                self.err(format!("{what}: external file \"{shown}\" cannot be read from an in-memory document"))
            );
        };
        let rel = percent_decode(uri);
        let file: PathBuf = base.join(&rel);
        if !self.options.allow_external_files {
            self.check_inside(base, &rel, &file, what, &shown)?;
        }
        read_bounded(&file, MAX_SCENE_FILE.min(budget)).map_err(|m| self.err(format!("{what}: \"{shown}\": {m}")))
    }

    /// Refuses a URI that resolves outside the scene file's folder (README "Security").
    fn check_inside(&self, base: &Path, rel: &str, file: &Path, what: &str, shown: &str) -> Result<()> {
        let outside = |why: &str| {
            self.err(format!(
                "{what}: \"{shown}\" {why}; glTF URIs are relative references inside the scene's folder \
                 (--allow-external-files permits others)"
            ))
        };
        let rel_path = Path::new(rel);
        if rel_path.is_absolute() || rel.starts_with('/') || rel.starts_with('\\') || rel_path.has_root() {
            return Err(outside("is an absolute path"));
        }
        let root = std::fs::canonicalize(if base.as_os_str().is_empty() { Path::new(".") } else { base })
            .map_err(|e| self.err(format!("{what}: cannot resolve the scene's folder: {e}")))?;
        match std::fs::canonicalize(file) {
            Ok(real) if real.starts_with(&root) => Ok(()),
            Ok(_) => Err(outside("resolves outside the scene's folder")),
            // A missing file: refuse `..` components that would leave the folder, else let the
            // read report it.
            Err(_) => {
                let mut depth = 0i64;
                for c in rel_path.components() {
                    match c {
                        std::path::Component::ParentDir => depth -= 1,
                        std::path::Component::Normal(_) => depth += 1,
                        _ => {}
                    }
                    if depth < 0 {
                        return Err(outside("resolves outside the scene's folder"));
                    }
                }
                Ok(())
            }
        }
    }
}

fn percent_decode(s: &str) -> String {
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' && i + 2 < bytes.len() {
            let hex = |b: u8| (b as char).to_digit(16);
            if let (Some(h), Some(l)) = (hex(bytes[i + 1]), hex(bytes[i + 2])) {
                out.push((h * 16 + l) as u8);
                i += 3;
                continue;
            }
        }
        out.push(bytes[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percent_decoding() {
        assert_eq!(percent_decode("my%20file.bin"), "my file.bin");
        assert_eq!(percent_decode("100%"), "100%");
        assert_eq!(percent_decode("a%2"), "a%2");
    }
}
