//! The frame file names of `-o` with `--frames` (Blender's convention: a run of `#` in the file
//! name becomes the frame number, zero-padded to the run's length). The range itself is a
//! setting (`frames`, `Settings::frame_range`).

use std::path::{Path, PathBuf};

/// The file of frame `n`: the last run of `#` in the file name replaced by `n` zero-padded to
/// the run's length (longer numbers are written in full); without `#`, `_` and four digits are
/// added before the extension (`out.png` -> `out_0001.png`).
pub fn frame_path(pattern: &Path, n: u32) -> PathBuf {
    let name = pattern.file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let name = match name.rfind('#') {
        Some(end) => {
            let start = name[..=end].rfind(|c| c != '#').map_or(0, |i| i + 1);
            let width = end + 1 - start;
            format!("{}{n:0width$}{}", &name[..start], &name[end + 1..])
        }
        None => match name.rsplit_once('.') {
            Some((stem, ext)) => format!("{stem}_{n:04}.{ext}"),
            None => format!("{name}_{n:04}"),
        },
    };
    pattern.with_file_name(name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_names() {
        let p = |s: &str, n| frame_path(Path::new(s), n).to_string_lossy().into_owned();
        assert_eq!(p("frames/cubist_####.png", 7), "frames/cubist_0007.png");
        assert_eq!(p("frames/c_##.png", 123), "frames/c_123.png");
        assert_eq!(p("a#b_###.png", 5), "a#b_005.png");
        assert_eq!(p("out.png", 12), "out_0012.png");
        assert_eq!(p("dir.d/out", 1), "dir.d/out_0001");
    }
}
