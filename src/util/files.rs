//! Writing files atomically: a temporary file in the same directory, renamed over the target
//! once complete, so a failed or cancelled render never leaves a partial output.

use std::io::Write;
use std::path::{Path, PathBuf};

use image::{ImageFormat, RgbaImage};

use image::{ImageBuffer, Luma};

use crate::error::{Error, Result};

/// A 16-bit grey image (the `facet-ids` pass, PNG facet layouts).
pub type Gray16 = ImageBuffer<Luma<u16>, Vec<u16>>;

/// A sibling temporary path for atomic writes.
fn temp_path(path: &Path) -> PathBuf {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "output".into());
    path.with_file_name(format!(".{name}.{}.tmp", std::process::id()))
}

/// Writes `bytes` to `path` atomically.
pub fn write_atomic(path: &Path, write: impl FnOnce(&Path) -> std::result::Result<(), String>) -> Result<()> {
    if path.file_name().is_none() {
        return Err(Error::output(path, "not a file name"));
    }
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty())
        && !dir.is_dir()
    {
        return Err(Error::output(path, format!("directory {} does not exist", dir.display())));
    }
    let tmp = temp_path(path);
    match write(&tmp) {
        Ok(()) => std::fs::rename(&tmp, path).map_err(|e| {
            let _ = std::fs::remove_file(&tmp);
            Error::output(path, e)
        }),
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(Error::output(path, e))
        }
    }
}

/// Writes a PNG atomically. Only .png output is supported (lossless, alpha).
pub fn write_png(path: &Path, img: &RgbaImage) -> Result<()> {
    check_png_path(path)?;
    write_atomic(path, |tmp| img.save_with_format(tmp, ImageFormat::Png).map_err(|e| e.to_string()))
}

/// Writes 16-bit grey PNGs (facet ids) atomically.
pub fn write_png16(path: &Path, img: &Gray16) -> Result<()> {
    check_png_path(path)?;
    write_atomic(path, |tmp| img.save_with_format(tmp, ImageFormat::Png).map_err(|e| e.to_string()))
}

/// Writes text (JSON) atomically.
pub fn write_text(path: &Path, text: &str) -> Result<()> {
    write_atomic(path, |tmp| {
        let mut f = std::fs::File::create(tmp).map_err(|e| e.to_string())?;
        f.write_all(text.as_bytes()).map_err(|e| e.to_string())?;
        f.sync_all().map_err(|e| e.to_string())
    })
}

pub fn check_png_path(path: &Path) -> Result<()> {
    match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase) {
        Some(e) if e == "png" => Ok(()),
        _ => Err(Error::Setting { key: "output", message: format!("{}: output images must be .png", path.display()) }),
    }
}

/// `dir/stem.png` -> `dir/stem.<pass>.png`.
pub fn pass_path(output: &Path, pass: &str) -> PathBuf {
    let stem = output.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "cubist".into());
    output.with_file_name(format!("{stem}.{pass}.png"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn failed_write_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("x.png");
        let r = write_atomic(&out, |tmp| {
            std::fs::write(tmp, b"partial").unwrap();
            Err("boom".into())
        });
        assert!(r.is_err());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }

    #[test]
    fn pass_paths_sit_beside_the_output() {
        assert_eq!(pass_path(Path::new("a/b/out.png"), "saliency"), Path::new("a/b/out.saliency.png"));
    }

    #[test]
    fn only_png_outputs() {
        assert!(check_png_path(Path::new("a.png")).is_ok());
        assert!(check_png_path(Path::new("a.PNG")).is_ok());
        assert!(check_png_path(Path::new("a.jpg")).is_err());
        assert!(check_png_path(Path::new("a")).is_err());
    }
}
