//! The frame range of `--frames` and the frame file names of `-o` (Blender's convention: a run
//! of `#` in the file name becomes the frame number, zero-padded to the run's length).

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};

/// `A-B` (inclusive) or a single frame `N`.
pub fn parse_range(s: &str) -> Result<(u32, u32)> {
    let bad = || Error::setting("frames", format!("`{s}` is not a frame range: A-B (e.g. 1-120) or one frame N"));
    let num = |t: &str| t.trim().parse::<u32>().map_err(|_| bad());
    match s.split_once('-') {
        Some((a, b)) => {
            let (a, b) = (num(a)?, num(b)?);
            if a > b {
                return Err(Error::setting("frames", format!("`{s}`: the first frame is after the last")));
            }
            Ok((a, b))
        }
        None => {
            let n = num(s)?;
            Ok((n, n))
        }
    }
}

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
    fn ranges() {
        assert_eq!(parse_range("1-120").unwrap(), (1, 120));
        assert_eq!(parse_range("61 - 120").unwrap(), (61, 120));
        assert_eq!(parse_range("7").unwrap(), (7, 7));
        for bad in ["", "a-b", "3-1", "-5", "1-", "1-2-3"] {
            assert!(parse_range(bad).is_err(), "{bad}");
        }
    }

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
