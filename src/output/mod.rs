//! The render's images: the film's colour as an sRGB image (`encode`) and the extra passes
//! (`passes`). Files are written atomically by `util::files` (re-exported here for front ends),
//! so a failed render never leaves a partial file.

pub mod encode;
pub mod passes;

pub use crate::util::files::{
    Gray16, Outputs, check_png_path, pass_path, write_atomic, write_png, write_png16, write_text,
};
pub use encode::encode;
pub use passes::Pass;
