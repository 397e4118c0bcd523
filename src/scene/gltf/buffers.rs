//! The file's binary data: the GLB chunk, external files and `data:` URIs.

use std::path::PathBuf;

use base64::Engine;

use super::Loader;
use crate::error::Result;

impl Loader<'_> {
    pub(super) fn load_buffers(&mut self, mut blob: Option<Vec<u8>>) -> Result<()> {
        let buffers: Vec<_> = self.doc.buffers().collect();
        for buffer in buffers {
            let i = buffer.index();
            let data = match buffer.source() {
                gltf::buffer::Source::Bin => blob.take().ok_or_else(|| {
                    self.err(format!("buffer {i} refers to the GLB's binary chunk, but the file has none"))
                })?,
                gltf::buffer::Source::Uri(uri) => self.read_uri(uri, &format!("buffer {i}"))?,
            };
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

    /// Reads a `data:` URI or a file relative to the glTF file.
    pub(super) fn read_uri(&self, uri: &str, what: &str) -> Result<Vec<u8>> {
        if let Some(rest) = uri.strip_prefix("data:") {
            let (header, payload) =
                rest.split_once(',').ok_or_else(|| self.err(format!("{what}: malformed data: URI (no comma)")))?;
            if !header.ends_with(";base64") || header.contains(";;") {
                return Err(self.err(format!("{what}: data: URI is not base64 (\"data:{header},...\")")));
            }
            return base64::engine::general_purpose::STANDARD
                .decode(payload.trim())
                .map_err(|e| self.err(format!("{what}: data: URI holds invalid base64 ({e})")));
        }
        if uri.is_empty() || uri.contains("://") || uri.starts_with(':') {
            return Err(
                self.err(format!("{what}: unsupported URI \"{uri}\" (only relative file paths and data: URIs)"))
            );
        }
        let Some(base) = self.base else {
            return Err(self.err(format!("{what}: external file \"{uri}\" cannot be read from an in-memory document")));
        };
        let rel = percent_decode(uri);
        let file: PathBuf = base.join(&rel);
        std::fs::read(&file).map_err(|e| self.err(format!("{what}: cannot read \"{}\": {e}", file.display())))
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
