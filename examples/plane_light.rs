//! Prints the per-plane light measure (`cubist::paint::measure::per_plane_light`) of
//! rendered pictures: the share of facets whose luminance varies across them by a gradient of
//! at least 15% of the image's range.
//!
//!     cubist render scene.glb -o out.png --pass facet-ids
//!     cargo run --release --example plane_light -- out.png [more.png ...]
//!
//! Each PNG is read with its `<stem>.facet-ids.png` beside it (the 16-bit facet ids pass).

use std::path::Path;

use cubist::paint::measure::{luma, per_plane_light};

fn main() {
    let paths: Vec<String> = std::env::args().skip(1).collect();
    if paths.is_empty() {
        eprintln!("usage: plane_light OUT.png [OUT2.png ...] (each with OUT.facet-ids.png beside it)");
        std::process::exit(2);
    }
    println!("| picture | facets counted | lit | share | area share | luma range |");
    println!("|---|---:|---:|---:|---:|---:|");
    for p in &paths {
        let path = Path::new(p);
        let ids_path = path.with_extension("facet-ids.png");
        let (img, ids) = match (image::open(path), image::open(&ids_path)) {
            (Ok(i), Ok(f)) => (i.to_rgba8(), f.to_luma16()),
            (Err(e), _) => {
                eprintln!("{p}: {e}");
                std::process::exit(1);
            }
            (_, Err(e)) => {
                eprintln!("{}: {e}", ids_path.display());
                std::process::exit(1);
            }
        };
        if img.dimensions() != ids.dimensions() {
            eprintln!("{p}: the picture and its facet ids differ in size");
            std::process::exit(1);
        }
        let ids: Vec<u32> = ids.pixels().map(|p| p.0[0] as u32).collect();
        let m = per_plane_light(&luma(&img), &ids, img.width());
        println!(
            "| {} | {} | {} | {:.0}% | {:.0}% | {:.2} |",
            path.file_name().map_or(p.clone(), |n| n.to_string_lossy().into_owned()),
            m.facets,
            m.lit,
            100.0 * m.share,
            100.0 * m.area_share,
            m.range
        );
    }
}
