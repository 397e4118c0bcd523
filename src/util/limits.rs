//! Every bound on what an input may make the renderer read, allocate or compute, in one place
//! (README "Limits"), so a render farm fed untrusted files knows the worst case. The settings'
//! own bounds (image size, samples, facets) are in `settings::validate`, which may depend on
//! nothing but `error`; the ones that must agree are checked equal where both are known.
//!
//! Each bound is checked before the memory or time is spent: a count against the bytes that
//! must hold it, an image's size before it is decoded, a file's size before it is read.

/// Largest scene file (.gltf or .glb) and largest external buffer, bytes.
pub const MAX_SCENE_FILE: u64 = 2 << 30;
/// Largest total of a scene's binary buffers (GLB chunk, external files, data: URIs), bytes.
pub const MAX_SCENE_BUFFERS: u64 = 2 << 30;
// The largest settings file (`--config`, 16 MiB) is `settings::MAX_CONFIG_FILE`: settings
// depend on nothing but `error`.
/// Largest facet layout file (`--facets`, .json), bytes. A Segment layout of an 8K render is
/// a few megabytes; parsing takes at most about twice the text.
pub const MAX_LAYOUT_FILE: u64 = 256 << 20;
/// Largest image file read whole (`--facet-map`, `--palette-image`), bytes.
pub const MAX_IMAGE_FILE: u64 = 512 << 20;

/// Largest glTF accessor, elements.
pub const MAX_ACCESSOR_ELEMENTS: usize = 1 << 26;
/// Most vertices the meshes of a scene may have together (each skinned or morphed instance
/// counted again): up to 48 bytes each (position, normal, UV, colour), so 3 GiB at most.
pub const MAX_SCENE_VERTICES: usize = 1 << 26;
/// Most placed mesh instances (objects) a scene may have.
pub const MAX_OBJECTS: usize = 1 << 22;
/// Most elements the loader may process besides reading each vertex once: morph-target deltas
/// applied and skin joints composed, each counted per instance (a small file must not make
/// the loader loop for hours).
pub const MAX_LOAD_WORK: usize = 1 << 30;
/// Most lights a scene may hold: every light is evaluated at every sample.
pub const MAX_LIGHTS: usize = 4096;
/// Most light evaluations a render may ask for (lights x primary samples; shadow rays follow
/// them): about 10 minutes on two cores. More is refused before tracing.
pub const MAX_LIGHT_SAMPLES: u64 = 4_000_000_000;

/// Largest image side decoded (textures, facet maps, palette paintings, PNG layouts), pixels.
pub const MAX_IMAGE_SIDE: u32 = 16384;
/// Largest decoded image, pixels: 64 Mpx (8192 x 8192), the largest render.
pub const MAX_IMAGE_PIXELS: u64 = 64 << 20;
/// Most texels all of a scene's textures may hold together (1 GiB as 8-bit RGBA).
pub const MAX_SCENE_TEXELS: u64 = 256 << 20;
/// Bytes a decoder may allocate for one image: its largest pixel format (16-bit RGBA, 8 bytes
/// a pixel) at `MAX_IMAGE_PIXELS`.
pub const MAX_DECODER_ALLOC: u64 = 8 * MAX_IMAGE_PIXELS;

/// Most points a loaded facet layout's polygons may have together.
pub const MAX_LAYOUT_POINTS: usize = 1 << 20;
/// Most polygons a loaded facet layout may have.
pub const MAX_LAYOUT_POLYGONS: usize = 1 << 18;
/// How many times over the polygons of a loaded layout may cover the image (the sum of their
/// bounding boxes' areas, in images): rasterising costs that many passes over the pixels.
pub const MAX_LAYOUT_COVERAGE: f64 = 64.0;
