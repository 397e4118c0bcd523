//! The frame range of `frames` (`--frames A-B`): frames A to B of the scene's animation, or
//! one frame N, rendered in one process.

use super::Settings;
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

impl Settings {
    /// The first and last frame of `frames` (None: a still).
    pub fn frame_range(&self) -> Result<Option<(u32, u32)>> {
        self.frames.as_deref().map(parse_range).transpose()
    }
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
}
