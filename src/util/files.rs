//! Files in and out, with bounds: every file the renderer reads goes through `read_bounded`
//! (regular files only, size checked before reading, FIFOs and devices refused without
//! blocking, symlinks resolved), every image through `decode_image` (its size checked before
//! decoding), and every output through `Outputs` (all or nothing).
//!
//! Outputs are written to short temporary names in their own directories, then renamed into
//! place together; a failure anywhere leaves nothing new behind. The temporary files are
//! registered, so a SIGINT or SIGTERM (the add-on's cancel) removes them: the binary's signal
//! handler calls `remove_temporary_files`, which waits for a rename in progress to finish.

use std::fs::{File, OpenOptions};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};

use image::{DynamicImage, ImageBuffer, ImageDecoder, ImageFormat, Luma, RgbaImage};

use super::limits::{MAX_DECODER_ALLOC, MAX_IMAGE_FILE, MAX_IMAGE_SIDE};
use crate::error::{Error, Result, short_path};

/// A 16-bit grey image (the `facet-ids` pass, PNG facet layouts).
pub type Gray16 = ImageBuffer<Luma<u16>, Vec<u16>>;
/// A 16-bit RGBA image (the motion pass).
pub type Rgba16 = ImageBuffer<image::Rgba<u16>, Vec<u16>>;

// ---- bounded reads

/// Opens `path` for reading if it is a regular file (symlinks followed) of at most `limit`
/// bytes, and returns it with its size. A FIFO, a device, a socket or a directory is refused
/// without blocking: the file is opened non-blocking and checked on the open handle, so a
/// path swapped for a FIFO after a check cannot block either.
pub fn open_regular(path: &Path, limit: u64) -> std::result::Result<(File, u64), String> {
    let meta = std::fs::metadata(path).map_err(|e| format!("cannot open: {e}"))?;
    if !meta.is_file() {
        return Err(format!("cannot open: {}, not a regular file", kind_of(&meta)));
    }
    let mut options = OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NONBLOCK);
    }
    let file = options.open(path).map_err(|e| format!("cannot open: {e}"))?;
    let meta = file.metadata().map_err(|e| format!("cannot open: {e}"))?;
    if !meta.is_file() {
        return Err(format!("cannot open: {}, not a regular file", kind_of(&meta)));
    }
    if meta.len() > limit {
        return Err(format!("{} bytes is larger than the limit of {limit} bytes", meta.len()));
    }
    Ok((file, meta.len()))
}

fn kind_of(meta: &std::fs::Metadata) -> &'static str {
    let t = meta.file_type();
    if t.is_dir() {
        return "a directory";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return "a FIFO";
        }
        if t.is_char_device() || t.is_block_device() {
            return "a device";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    "a special file"
}

/// Reads a whole regular file of at most `limit` bytes (see `open_regular`). A file that grows
/// past the limit while it is read is refused too. The message says what is wrong, not the path.
pub fn read_bounded(path: &Path, limit: u64) -> std::result::Result<Vec<u8>, String> {
    let (file, len) = open_regular(path, limit)?;
    let mut bytes = Vec::with_capacity(len as usize);
    file.take(limit.saturating_add(1)).read_to_end(&mut bytes).map_err(|e| format!("cannot read: {e}"))?;
    if bytes.len() as u64 > limit {
        return Err(format!("the file grew past the limit of {limit} bytes while it was read"));
    }
    Ok(bytes)
}

/// `read_bounded` as UTF-8 text.
pub fn read_text_bounded(path: &Path, limit: u64) -> std::result::Result<String, String> {
    String::from_utf8(read_bounded(path, limit)?).map_err(|_| "not UTF-8 text".to_string())
}

// ---- bounded image decoding

/// Decodes a PNG or JPEG of at most `max_pixels` pixels and `MAX_IMAGE_SIDE` a side. The size
/// is read from the header and checked before any pixel is decoded, and the decoder's own
/// allocations are capped, so a small file declaring a huge image costs nothing.
pub fn decode_image(bytes: &[u8], max_pixels: u64) -> std::result::Result<DynamicImage, String> {
    let mut reader = image::ImageReader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| format!("cannot read the image: {e}"))?;
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_IMAGE_SIDE);
    limits.max_image_height = Some(MAX_IMAGE_SIDE);
    limits.max_alloc = Some(MAX_DECODER_ALLOC);
    reader.limits(limits);
    let decoder = reader.into_decoder().map_err(|e| image_error(e, max_pixels))?;
    let (w, h) = decoder.dimensions();
    check_image_size(w, h, max_pixels)?;
    DynamicImage::from_decoder(decoder).map_err(|e| image_error(e, max_pixels))
}

/// An image of `w` x `h` within the limits, or why not.
pub fn check_image_size(w: u32, h: u32, max_pixels: u64) -> std::result::Result<(), String> {
    if w > MAX_IMAGE_SIDE || h > MAX_IMAGE_SIDE || w as u64 * h as u64 > max_pixels {
        return Err(format!(
            "the image is {w}x{h}: larger than the limit of {MAX_IMAGE_SIDE} px a side and {max_pixels} pixels"
        ));
    }
    Ok(())
}

fn image_error(e: image::ImageError, max_pixels: u64) -> String {
    match e {
        image::ImageError::Limits(_) => {
            format!("the image is larger than the limit of {MAX_IMAGE_SIDE} px a side and {max_pixels} pixels ({e})")
        }
        e => format!("not a readable image: {e}"),
    }
}

/// Reads and decodes an image file (PNG or JPEG): at most `MAX_IMAGE_FILE` bytes, decoded
/// within `decode_image`'s limits. Errors name the file.
pub fn read_image(path: &Path, max_pixels: u64) -> Result<DynamicImage> {
    let bytes = read_bounded(path, MAX_IMAGE_FILE).map_err(|m| Error::input(path, m))?;
    decode_image(&bytes, max_pixels).map_err(|m| Error::input(path, m))
}

// ---- outputs: all or nothing

/// Temporary files that exist now (being written, or the old outputs moved aside during a
/// commit), removed by `remove_temporary_files` on a signal. Its lock is held while outputs
/// are renamed into place, so a signal handler waits for a commit to finish or roll back.
struct Registry {
    files: Vec<PathBuf>,
    /// Set by `remove_temporary_files`: the process is exiting, no new temporary file.
    closing: bool,
}

static REGISTRY: Mutex<Registry> = Mutex::new(Registry { files: Vec::new(), closing: false });

fn registry() -> std::sync::MutexGuard<'static, Registry> {
    REGISTRY.lock().unwrap_or_else(|e| e.into_inner())
}

/// Removes every temporary file this process is writing and keeps new ones from being made;
/// called by the binary's SIGINT/SIGTERM handler just before it exits. Waits for an output
/// commit in progress (a few renames) to finish, so the outputs are all new or all old.
pub fn remove_temporary_files() {
    let mut reg = registry();
    reg.closing = true;
    for f in reg.files.drain(..) {
        let _ = std::fs::remove_file(f);
    }
    // Keep the lock until the process exits: no thread may create another temporary file.
    std::mem::forget(reg);
}

/// A fresh, short name in `dir` (`.cubist-<16 hex>.tmp`, 29 bytes: within any file system's
/// name limit whatever the output's name), created exclusively and registered.
fn create_temporary(dir: &Path) -> std::io::Result<(PathBuf, File)> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    for _ in 0..100 {
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_nanos());
        let tag = super::rng::splitmix64((std::process::id() as u64) << 32 ^ n ^ nanos as u64);
        let path = dir.join(format!(".cubist-{tag:016x}.tmp"));
        let mut reg = registry();
        if reg.closing {
            return Err(std::io::Error::other("the process is exiting"));
        }
        match OpenOptions::new().write(true).create_new(true).open(&path) {
            Ok(f) => {
                reg.files.push(path.clone());
                return Ok((path, f));
            }
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(e) => return Err(e),
        }
    }
    Err(std::io::Error::other("cannot find a free temporary name"))
}

/// Removes a temporary file and forgets it.
fn discard(path: &Path) {
    let _ = std::fs::remove_file(path);
    forget(path);
}

fn forget(path: &Path) {
    registry().files.retain(|f| f != path);
}

/// Writes one output's content: to the open temporary file, or by its path.
type Writer<'a> = Box<dyn FnOnce(&Path, &mut std::io::BufWriter<File>) -> std::result::Result<(), String> + 'a>;

/// A set of outputs written all or nothing: `commit` writes every one to a temporary file
/// beside it, then renames them all into place; if any write or rename fails, the temporary
/// files are removed and any output already replaced is put back, so nothing new remains.
#[derive(Default)]
pub struct Outputs<'a> {
    items: Vec<(PathBuf, Writer<'a>)>,
    /// Not flushed to the disk before the rename (`transient`).
    transient: bool,
}

impl<'a> Outputs<'a> {
    pub fn new() -> Self {
        Outputs { items: Vec::new(), transient: false }
    }

    /// Outputs read back at once and then dropped (a `cubist serve` frame for the viewport):
    /// still all or nothing and renamed into place, so a reader never sees half a file, but
    /// not `fsync`ed first. The sync only guards against an operating-system crash between
    /// the rename and the disk's write-back, which matters for a farm's frames, not for a
    /// frame the client reads within milliseconds; it cost 14-18 ms of a 4 MB raw frame's
    /// request on a loaded machine.
    pub fn transient() -> Self {
        Outputs { items: Vec::new(), transient: true }
    }

    /// Adds a file whose content `write` produces.
    pub fn add(
        &mut self,
        path: &Path,
        write: impl FnOnce(&mut std::io::BufWriter<File>) -> std::result::Result<(), String> + 'a,
    ) -> Result<()> {
        self.push(path, Box::new(move |_, f| write(f)))
    }

    /// Adds a file that `write` fills by its (temporary) path.
    pub fn add_by_path(
        &mut self,
        path: &Path,
        write: impl FnOnce(&Path) -> std::result::Result<(), String> + 'a,
    ) -> Result<()> {
        self.push(path, Box::new(move |tmp, _| write(tmp)))
    }

    fn push(&mut self, path: &Path, write: Writer<'a>) -> Result<()> {
        if self.items.iter().any(|(p, _)| p == path) {
            return Err(Error::output(path, "two outputs of this render would have this name"));
        }
        self.items.push((path.to_path_buf(), write));
        Ok(())
    }

    /// Adds a PNG (the path must end in .png).
    pub fn png(&mut self, path: &Path, img: &'a RgbaImage) -> Result<()> {
        check_png_path(path)?;
        self.add(path, move |f| img.write_to(f, ImageFormat::Png).map_err(|e| e.to_string()))
    }

    /// Adds a 16-bit grey PNG (facet ids).
    pub fn png16(&mut self, path: &Path, img: &'a Gray16) -> Result<()> {
        check_png_path(path)?;
        self.add(path, move |f| img.write_to(f, ImageFormat::Png).map_err(|e| e.to_string()))
    }

    /// Adds a 16-bit RGBA PNG (the motion pass, written with every frame): compressed fast,
    /// each row against the one above (a motion field changes slowly down the picture); the
    /// default's adaptive filters and compression took about a third of the pass's cost.
    pub fn png_rgba16(&mut self, path: &Path, img: &'a Rgba16) -> Result<()> {
        use image::codecs::png::{CompressionType, FilterType, PngEncoder};
        check_png_path(path)?;
        self.add(path, move |f| {
            img.write_with_encoder(PngEncoder::new_with_quality(f, CompressionType::Fast, FilterType::Up))
                .map_err(|e| e.to_string())
        })
    }

    /// Adds a text file (JSON).
    pub fn text(&mut self, path: &Path, text: String) -> Result<()> {
        self.add(path, move |f| f.write_all(text.as_bytes()).map_err(|e| e.to_string()))
    }

    /// The paths added so far, in order.
    pub fn paths(&self) -> impl Iterator<Item = &Path> {
        self.items.iter().map(|(p, _)| p.as_path())
    }

    /// Writes every output, all or nothing (see the type's doc). The error names the output
    /// at fault.
    pub fn commit(self) -> Result<()> {
        for (path, _) in &self.items {
            check_target(path)?;
        }
        // 1. Every content into its own temporary file (the slow part: encoding).
        let mut staged: Vec<(PathBuf, PathBuf)> = Vec::new();
        let abandon = |staged: &[(PathBuf, PathBuf)]| staged.iter().for_each(|(_, t)| discard(t));
        for (path, write) in self.items {
            let dir = parent_dir(&path);
            let (tmp, file) = match create_temporary(&dir) {
                Ok(x) => x,
                Err(e) => {
                    abandon(&staged);
                    return Err(Error::output(&path, format!("cannot create a file in {}: {e}", short_path(&dir))));
                }
            };
            staged.push((path.clone(), tmp.clone()));
            let mut out = std::io::BufWriter::new(file);
            let transient = self.transient;
            let written = write(&tmp, &mut out).and_then(|()| {
                let file = out.into_inner().map_err(|e| e.error().to_string())?;
                if transient { Ok(()) } else { file.sync_all().map_err(|e| e.to_string()) }
            });
            if let Err(e) = written {
                abandon(&staged);
                return Err(Error::output(&path, e));
            }
        }
        // 2. Every rename, holding the registry's lock: a signal handler waits until all the
        // outputs are in place or all are back as they were.
        let mut reg = registry();
        if reg.closing {
            drop(reg);
            abandon(&staged);
            return Err(Error::Cancelled);
        }
        let mut done: Vec<(PathBuf, Option<PathBuf>)> = Vec::new();
        let mut failure = None;
        for (path, tmp) in &staged {
            // An existing output is moved aside first, to be put back if a later one fails.
            let backup = if std::fs::symlink_metadata(path).is_ok() {
                let b = parent_dir(path).join(format!(
                    ".cubist-{:016x}.old",
                    super::rng::splitmix64(done.len() as u64 ^ std::process::id() as u64)
                ));
                if let Err(e) = std::fs::rename(path, &b) {
                    failure = Some(Error::output(path, e));
                    break;
                }
                reg.files.push(b.clone());
                Some(b)
            } else {
                None
            };
            if let Err(e) = std::fs::rename(tmp, path) {
                if let Some(b) = &backup {
                    let _ = std::fs::rename(b, path);
                }
                failure = Some(Error::output(path, e));
                break;
            }
            done.push((path.clone(), backup));
        }
        if let Some(e) = failure {
            for (path, backup) in done.iter().rev() {
                match backup {
                    Some(b) => {
                        let _ = std::fs::rename(b, path);
                    }
                    None => {
                        let _ = std::fs::remove_file(path);
                    }
                }
            }
            for (_, tmp) in &staged {
                let _ = std::fs::remove_file(tmp);
            }
            let olds: Vec<PathBuf> = done.iter().filter_map(|(_, b)| b.clone()).collect();
            reg.files.retain(|f| !staged.iter().any(|(_, t)| t == f) && !olds.contains(f));
            return Err(e);
        }
        for (_, backup) in &done {
            if let Some(b) = backup {
                let _ = std::fs::remove_file(b);
            }
        }
        reg.files.retain(|f| !staged.iter().any(|(_, t)| t == f) && !done.iter().any(|(_, b)| b.as_ref() == Some(f)));
        Ok(())
    }
}

/// The directory an output goes to ("." for a bare file name).
fn parent_dir(path: &Path) -> PathBuf {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// An output path must name a file in an existing directory, and not a directory itself.
fn check_target(path: &Path) -> Result<()> {
    if path.file_name().is_none() {
        return Err(Error::output(path, "not a file name"));
    }
    let dir = parent_dir(path);
    if !dir.is_dir() {
        return Err(Error::output(path, format!("directory {} does not exist", short_path(&dir))));
    }
    if path.is_dir() {
        return Err(Error::output(path, "is a directory"));
    }
    Ok(())
}

/// Writes one file atomically: `write` fills the temporary file whose path it is given.
pub fn write_atomic(path: &Path, write: impl FnOnce(&Path) -> std::result::Result<(), String>) -> Result<()> {
    let mut outputs = Outputs::new();
    outputs.add_by_path(path, write)?;
    outputs.commit()
}

/// Writes a PNG atomically. Only .png output is supported (lossless, alpha).
pub fn write_png(path: &Path, img: &RgbaImage) -> Result<()> {
    let mut o = Outputs::new();
    o.png(path, img)?;
    o.commit()
}

/// Writes 16-bit grey PNGs (facet ids) atomically.
pub fn write_png16(path: &Path, img: &Gray16) -> Result<()> {
    let mut o = Outputs::new();
    o.png16(path, img)?;
    o.commit()
}

/// Writes text (JSON) atomically.
pub fn write_text(path: &Path, text: &str) -> Result<()> {
    let mut o = Outputs::new();
    o.text(path, text.to_string())?;
    o.commit()
}

pub fn check_png_path(path: &Path) -> Result<()> {
    match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase) {
        Some(e) if e == "png" => Ok(()),
        _ => {
            Err(Error::Setting { key: "output", message: format!("{}: output images must be .png", short_path(path)) })
        }
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

    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> =
            std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        v.sort();
        v
    }

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
    fn a_failed_output_leaves_nothing_new_and_restores_the_old_files() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b, c) = (dir.path().join("a.txt"), dir.path().join("b.txt"), dir.path().join("c.txt"));
        std::fs::write(&b, "old b").unwrap();
        // The third output fails while its content is written.
        let mut o = Outputs::new();
        o.text(&a, "new a".into()).unwrap();
        o.text(&b, "new b".into()).unwrap();
        o.add(&c, |_| Err("disk full".into())).unwrap();
        let e = o.commit().unwrap_err().to_string();
        assert!(e.contains("c.txt") && e.contains("disk full"), "{e}");
        assert_eq!(names(dir.path()), ["b.txt"]);
        assert_eq!(std::fs::read_to_string(&b).unwrap(), "old b");
        // A target that is a directory: refused before anything is written.
        std::fs::create_dir(&c).unwrap();
        std::fs::write(c.join("keep"), "").unwrap();
        let mut o = Outputs::new();
        o.text(&a, "new a".into()).unwrap();
        o.text(&b, "new b".into()).unwrap();
        o.text(&c, "new c".into()).unwrap();
        assert!(o.commit().is_err());
        assert_eq!(names(dir.path()), ["b.txt", "c.txt"]);
        assert_eq!(std::fs::read_to_string(&b).unwrap(), "old b");
        // All succeed: every file new, no temporary left.
        std::fs::remove_dir_all(&c).unwrap();
        let mut o = Outputs::new();
        o.text(&a, "new a".into()).unwrap();
        o.text(&b, "new b".into()).unwrap();
        o.commit().unwrap();
        assert_eq!(names(dir.path()), ["a.txt", "b.txt"]);
        assert_eq!(std::fs::read_to_string(&b).unwrap(), "new b");
        // Its own temporaries only: other tests of this process write files concurrently.
        assert!(!registry().files.iter().any(|f| f.starts_with(dir.path())));
    }

    #[test]
    fn transient_outputs_are_still_all_or_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("a.rgba"), dir.path().join("b.png"));
        std::fs::write(&a, "old a").unwrap();
        let mut o = Outputs::transient();
        o.add(&a, |f| f.write_all(b"new a").map_err(|e| e.to_string())).unwrap();
        o.add(&b, |_| Err("disk full".into())).unwrap();
        assert!(o.commit().is_err());
        assert_eq!(names(dir.path()), ["a.rgba"]);
        assert_eq!(std::fs::read_to_string(&a).unwrap(), "old a");
        let img = RgbaImage::new(2, 2);
        let mut o = Outputs::transient();
        o.add(&a, |f| f.write_all(b"new a").map_err(|e| e.to_string())).unwrap();
        o.png(&b, &img).unwrap();
        o.commit().unwrap();
        assert_eq!(names(dir.path()), ["a.rgba", "b.png"]);
        assert_eq!(std::fs::read_to_string(&a).unwrap(), "new a");
    }

    #[test]
    fn two_outputs_of_one_name_are_refused() {
        let mut o = Outputs::new();
        o.text(Path::new("x.json"), String::new()).unwrap();
        assert!(o.text(Path::new("x.json"), String::new()).is_err());
    }

    #[test]
    fn a_legal_long_file_name_works() {
        // 250 bytes: legal on every common file system; the temporary name stays short.
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join(format!("{}.png", "n".repeat(246)));
        write_png(&out, &RgbaImage::new(2, 2)).unwrap();
        assert_eq!(names(dir.path()).len(), 1);
    }

    #[cfg(unix)]
    #[test]
    fn special_files_are_refused_without_blocking() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("fifo");
        let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        let link = dir.path().join("zero");
        std::os::unix::fs::symlink("/dev/zero", &link).unwrap();
        for (p, want) in [(&fifo, "FIFO"), (&link, "device"), (&dir.path().to_path_buf(), "directory")] {
            let e = read_bounded(p, 1 << 20).unwrap_err();
            assert!(e.contains(want), "{e}");
        }
        let big = dir.path().join("big");
        std::fs::write(&big, vec![0u8; 1001]).unwrap();
        assert!(read_bounded(&big, 1000).unwrap_err().contains("limit of 1000 bytes"));
        assert_eq!(read_bounded(&big, 1001).unwrap().len(), 1001);
    }

    #[test]
    fn image_sizes_are_checked_before_decoding() {
        // A 1-bit PNG of 20000 x 20000 compresses to a few kilobytes.
        let mut png = Vec::new();
        {
            let mut enc = png::Encoder::new(&mut png, 20000, 20000);
            enc.set_color(png::ColorType::Grayscale);
            enc.set_depth(png::BitDepth::One);
            let mut w = enc.write_header().unwrap();
            w.write_image_data(&vec![0u8; 2500 * 20000]).unwrap();
        }
        assert!(png.len() < 200_000, "{}", png.len());
        let e = decode_image(&png, 64 << 20).unwrap_err();
        assert!(e.contains("20000x20000") || e.contains("limit"), "{e}");
        let small = decode_image(&png, 1 << 30);
        assert!(small.is_err(), "16384 px a side at most");
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
