//! From buffers to files: the film's colour as an sRGB image (`encode`), the extra passes
//! (`passes`), and atomic writes (`write`) so a failed render never leaves a partial file.

pub mod encode;
pub mod passes;
pub mod write;

use image::{ImageBuffer, Luma};

pub use encode::encode;
pub use passes::Pass;
pub use write::{check_png_path, pass_path, write_atomic, write_png, write_png16, write_text};

/// A 16-bit grey image (the `facet-ids` pass).
pub type Gray16 = ImageBuffer<Luma<u16>, Vec<u16>>;
