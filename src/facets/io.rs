//! Saving and loading facet layouts (`--save-facets`, `--facets`), so an animation or a render
//! farm computes the layout once and every frame, on any machine, uses the same facets.
//!
//! - `.json`: the full resolution-independent layout (normalised sites and polygons, the base
//!   label image run-length encoded), with a format name and version.
//! - `.png`: the layout rasterised at the render's size as 16-bit grey facet ids (lossless).
//!   Loaded back, a 16-bit grey PNG's values are the facet ids; any other PNG is read like a
//!   constant facet map (one facet per distinct colour). Either way it becomes the base label
//!   image, scaled nearest-neighbour to the output.

use std::path::Path;

use image::{ImageBuffer, Luma};
use serde::{Deserialize, Serialize};

use super::constant::{labels_from_image, read_image};
use super::{FacetLayout, FacetMap, FacetPolygon, LabelImage};
use crate::error::short_path;
use crate::error::{Error, Result};
use crate::util::files::{Outputs, read_text_bounded};
use crate::util::limits::{MAX_LAYOUT_COVERAGE, MAX_LAYOUT_FILE, MAX_LAYOUT_POINTS, MAX_LAYOUT_POLYGONS};

/// Names our JSON layouts, so another JSON file given by mistake gets a clear error.
pub const FORMAT: &str = "cubist-facet-layout";
/// Bumped when the JSON layout changes incompatibly.
pub const VERSION: u32 = 1;

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct LayoutFile {
    format: String,
    version: u32,
    facet_count: u32,
    base: Option<RleLabels>,
    sites: Vec<[f64; 2]>,
    polygons: Vec<FacetPolygon>,
}

/// A label image as runs of (label, length), row-major.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RleLabels {
    width: u32,
    height: u32,
    runs: Vec<[u32; 2]>,
}

fn encode_runs(labels: &[u32]) -> Vec<[u32; 2]> {
    let mut runs: Vec<[u32; 2]> = Vec::new();
    for &l in labels {
        match runs.last_mut() {
            Some(r) if r[0] == l => r[1] += 1,
            _ => runs.push([l, 1]),
        }
    }
    runs
}

fn decode_runs(rle: &RleLabels) -> std::result::Result<LabelImage, String> {
    let n = rle.width as u64 * rle.height as u64;
    if n == 0 || n > super::MAX_BASE_PIXELS {
        return Err(format!("base label image {}x{} is empty or too large", rle.width, rle.height));
    }
    let total: u64 = rle.runs.iter().map(|r| r[1] as u64).sum();
    if total != n {
        return Err(format!("base runs cover {total} pixels, the image has {n}"));
    }
    let mut labels = Vec::with_capacity(n as usize);
    for r in &rle.runs {
        labels.extend(std::iter::repeat_n(r[0], r[1] as usize));
    }
    Ok(LabelImage { width: rle.width, height: rle.height, labels })
}

/// The layout as JSON text.
pub fn to_json(layout: &FacetLayout) -> String {
    let file = LayoutFile {
        format: FORMAT.into(),
        version: VERSION,
        facet_count: layout.facet_count,
        base: layout.base.as_ref().map(|b| RleLabels {
            width: b.width,
            height: b.height,
            runs: encode_runs(&b.labels),
        }),
        sites: layout.sites.clone(),
        polygons: layout.polygons.clone(),
    };
    serde_json::to_string(&file).expect("a layout always serialises")
}

/// Parses JSON text written by `to_json`; the error says what is wrong (not the path).
pub fn from_json(text: &str) -> std::result::Result<FacetLayout, String> {
    // The header first, skipping the rest without building it (a generic JSON tree of a big
    // layout takes ten times its size), then the typed layout.
    #[derive(Deserialize)]
    struct Header {
        format: Option<serde::de::IgnoredAny>,
        version: Option<serde_json::Number>,
    }
    #[derive(Deserialize)]
    struct Format {
        format: Option<String>,
    }
    let header: Header = serde_json::from_str(text).map_err(|e| format!("not valid JSON: {e}"))?;
    let format = header.format.and_then(|_| serde_json::from_str::<Format>(text).ok()).and_then(|f| f.format);
    if format.as_deref() != Some(FORMAT) {
        return Err(format!("not a facet layout (no \"format\": \"{FORMAT}\")"));
    }
    match header.version.as_ref().map(|v| v.as_u64()) {
        Some(Some(v)) if v == VERSION as u64 => {}
        Some(_) => {
            return Err(format!(
                "layout format version {}; this cubist reads version {VERSION}",
                crate::error::shorten(&header.version.map(|v| v.to_string()).unwrap_or_default())
            ));
        }
        None => return Err("layout has no format version".into()),
    }
    let file: LayoutFile = serde_json::from_str(text).map_err(|e| format!("malformed layout: {e}"))?;
    check_work(&file)?;
    let base = file.base.as_ref().map(decode_runs).transpose()?;
    let layout = FacetLayout { facet_count: file.facet_count, base, sites: file.sites, polygons: file.polygons };
    layout.validate()?;
    Ok(layout)
}

/// The bounds on a loaded layout's work: rasterising costs each polygon's rows times its
/// points plus its area, and Voronoi sites must lie in the image (`MAX_LAYOUT_*`). Layouts
/// the renderer makes stay far inside them.
fn check_work(file: &LayoutFile) -> std::result::Result<(), String> {
    if file.polygons.len() > MAX_LAYOUT_POLYGONS {
        return Err(format!("{} polygons: at most {MAX_LAYOUT_POLYGONS}", file.polygons.len()));
    }
    let points: usize = file.polygons.iter().map(|p| p.points.len()).sum();
    if points > MAX_LAYOUT_POINTS {
        return Err(format!("{points} polygon points: at most {MAX_LAYOUT_POINTS}"));
    }
    let mut coverage = 0.0;
    let mut row_work = 0.0;
    for p in &file.polygons {
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for q in &p.points {
            for k in 0..2 {
                let v = q[k].clamp(0.0, 1.0);
                (lo[k], hi[k]) = (lo[k].min(v), hi[k].max(v));
            }
        }
        if lo[0] <= hi[0] {
            coverage += (hi[0] - lo[0]) * (hi[1] - lo[1]);
            row_work += (hi[1] - lo[1]) * p.points.len() as f64;
        }
    }
    if !(coverage <= MAX_LAYOUT_COVERAGE) || !(row_work <= MAX_LAYOUT_POINTS as f64 / 16.0) {
        return Err(format!(
            "the polygons cover the image {coverage:.1} times over (at most {MAX_LAYOUT_COVERAGE}) with {points} points: too much work to rasterise"
        ));
    }
    if let Some(s) = file.sites.iter().find(|s| !(0.0..=1.0).contains(&s[0]) || !(0.0..=1.0).contains(&s[1])) {
        return Err(format!("Voronoi site ({:?}, {:?}) lies outside the image ([0, 1] x [0, 1])", s[0], s[1]));
    }
    Ok(())
}

/// A layout from a decoded PNG: 16-bit grey values are facet ids, any other image a facet map
/// (one facet per distinct colour). Errors name `path`.
pub fn from_image(img: &image::DynamicImage, path: &Path) -> Result<FacetLayout> {
    let base = match img {
        image::DynamicImage::ImageLuma16(g) => {
            LabelImage { width: g.width(), height: g.height(), labels: g.pixels().map(|p| p.0[0] as u32).collect() }
        }
        _ => labels_from_image(img, path)?,
    };
    if base.width == 0 || base.height == 0 {
        return Err(Error::input(path, "the facet layout image is empty"));
    }
    let facet_count = base.labels.iter().max().map_or(1, |m| m + 1);
    let layout = FacetLayout { facet_count, base: Some(base), sites: Vec::new(), polygons: Vec::new() };
    layout.validate().map_err(|m| Error::input(path, format!("bad facet layout: {m}")))?;
    Ok(layout)
}

fn extension(path: &Path) -> Option<String> {
    path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase)
}

/// Saves `layout` to `path` (.json: the layout; .png: `map`, its rasterisation at the render's
/// size), atomically.
pub fn save(path: &Path, layout: &FacetLayout, map: &FacetMap) -> Result<()> {
    let mut outputs = Outputs::new();
    add_to(&mut outputs, path, layout, map)?;
    outputs.commit()
}

/// Adds the saved layout to a set of outputs written together (all or nothing).
pub fn add_to(outputs: &mut Outputs, path: &Path, layout: &FacetLayout, map: &FacetMap) -> Result<()> {
    match extension(path).as_deref() {
        Some("json") => outputs.text(path, to_json(layout)),
        Some("png") => {
            let img: ImageBuffer<Luma<u16>, Vec<u16>> = ImageBuffer::from_fn(map.width, map.height, |x, y| {
                Luma([map.ids[(y * map.width + x) as usize] as u16])
            });
            outputs.add(path, move |f| img.write_to(f, image::ImageFormat::Png).map_err(|e| e.to_string()))
        }
        _ => Err(Error::setting(
            "save_facets",
            format!("{}: a facet layout is saved as .json or .png", short_path(path)),
        )),
    }
}

/// Loads a layout saved by `save` (or any facet map PNG); errors name the file.
pub fn load(path: &Path) -> Result<FacetLayout> {
    match extension(path).as_deref() {
        Some("json") => {
            let text = read_text_bounded(path, MAX_LAYOUT_FILE)
                .map_err(|e| Error::input(path, format!("cannot read facet layout: {e}")))?;
            from_json(&text).map_err(|m| Error::input(path, format!("bad facet layout: {m}")))
        }
        Some("png") => from_image(&read_image(path)?, path),
        _ => Err(Error::setting("facets", format!("{}: a facet layout is a .json or .png file", short_path(path)))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::facets::{patch, voronoi};

    fn layouts() -> Vec<FacetLayout> {
        vec![
            FacetLayout::single(),
            voronoi::layout(40, 6, 1.3, 5),
            patch::layout(20, 3.0, 0.8, 2).unwrap(),
            FacetLayout {
                facet_count: 3,
                base: Some(LabelImage { width: 3, height: 2, labels: vec![0, 0, 1, 2, 2, 2] }),
                sites: vec![],
                polygons: vec![FacetPolygon { facet: 1, points: vec![[0.1, 0.1], [0.9, 0.2], [0.5, 0.8]] }],
            },
        ]
    }

    #[test]
    fn json_round_trip_is_exact() {
        for l in layouts() {
            assert_eq!(from_json(&to_json(&l)).unwrap(), l);
        }
    }

    #[test]
    fn files_round_trip_at_any_size() {
        let dir = tempfile::tempdir().unwrap();
        for (k, l) in layouts().into_iter().enumerate() {
            let map = l.rasterize(37, 23);
            let json = dir.path().join(format!("l{k}.json"));
            let png = dir.path().join(format!("l{k}.png"));
            save(&json, &l, &map).unwrap();
            save(&png, &l, &map).unwrap();
            assert_eq!(load(&json).unwrap(), l);
            // The PNG holds the ids at 37x23: identical there, nearest-neighbour elsewhere.
            let from_png = load(&png).unwrap();
            assert_eq!(from_png.rasterize(37, 23).ids, map.ids);
            assert_eq!(from_png.rasterize(74, 46).ids[0], map.ids[0]);
        }
    }

    #[test]
    fn bad_files_give_one_line_errors_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = |n: &str| dir.path().join(n);
        let cases: Vec<(&str, &[u8], &str)> = vec![
            ("a.json", b"{not json", "not valid JSON"),
            ("b.json", b"{\"width\": 800}", "not a facet layout"),
            ("c.json", b"{\"format\": \"cubist-facet-layout\", \"version\": 99}", "version 99"),
            (
                "d.json",
                b"{\"format\":\"cubist-facet-layout\",\"version\":1,\"facet_count\":2,\"base\":null,\"sites\":[],\"polygons\":[{\"facet\":7,\"points\":[[0,0],[1,0],[1,1]]}]}",
                "polygon 0",
            ),
            (
                "e.json",
                b"{\"format\":\"cubist-facet-layout\",\"version\":1,\"facet_count\":2,\"base\":{\"width\":2,\"height\":2,\"runs\":[[0,3]]},\"sites\":[],\"polygons\":[]}",
                "cover 3 pixels",
            ),
            ("f.png", b"\x89PNG\r\n\x1a\ntruncated", "f.png"),
        ];
        for (name, bytes, want) in cases {
            std::fs::write(p(name), bytes).unwrap();
            let e = load(&p(name)).unwrap_err().to_string();
            assert!(e.contains(want) && e.contains(name) && !e.contains('\n'), "{name}: {e}");
        }
        let e = load(&p("missing.json")).unwrap_err().to_string();
        assert!(e.contains("missing.json") && e.contains("cannot read"), "{e}");
        let e = load(&p("x.txt")).unwrap_err().to_string();
        assert!(e.contains(".json or .png"), "{e}");
        let l = FacetLayout::single();
        let e = save(&p("x.bmp"), &l, &l.rasterize(2, 2)).unwrap_err().to_string();
        assert!(e.contains(".json or .png"), "{e}");
        assert!(!p("x.bmp").exists());
    }
}
