//! Render every SVG plot of a directory to PNG (for the README's figures).
//!
//! Run: `cargo run --release --example svg_to_png -- SVG_DIR PNG_DIR`, e.g. after
//! `cargo run --release -p ins-gnss -- run data/navego/kf-gins-ADIS16488.yaml --smooth
//! --plots --report --truth data/navego/truth.nav.zst --skip 60 --out target/navego-plots`:
//! `cargo run --release --example svg_to_png -- target/navego-plots docs/img`.

use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<PathBuf> = std::env::args_os().skip(1).map(PathBuf::from).collect();
    let [from, to] = args.as_slice() else {
        return Err("usage: svg_to_png SVG_DIR PNG_DIR".into());
    };
    std::fs::create_dir_all(to)?;
    let mut options = resvg::usvg::Options::default();
    let db = options.fontdb_mut();
    db.load_system_fonts();
    // plotters asks for `sans-serif`: the first of these families that is installed
    let installed = |name: &str| db.faces().any(|f| f.families.iter().any(|(n, _)| n == name));
    if let Some(family) =
        ["DejaVu Sans", "Liberation Sans", "Arial", "Helvetica"].into_iter().find(|f| installed(f))
    {
        db.set_sans_serif_family(family);
        options.font_family = family.to_string();
    }
    let mut names: Vec<PathBuf> =
        std::fs::read_dir(from)?.map(|e| e.map(|e| e.path())).collect::<Result<_, _>>()?;
    names.sort();
    for svg in names.iter().filter(|p| p.extension().is_some_and(|e| e == "svg")) {
        let tree = resvg::usvg::Tree::from_data(&std::fs::read(svg)?, &options)?;
        let size = tree.size().to_int_size();
        let mut pixmap =
            resvg::tiny_skia::Pixmap::new(size.width(), size.height()).ok_or("empty image")?;
        resvg::render(&tree, resvg::tiny_skia::Transform::default(), &mut pixmap.as_mut());
        let png = to.join(svg.with_extension("png").file_name().ok_or("no name")?);
        pixmap.save_png(&png)?;
        println!("{} -> {} ({}×{})", svg.display(), png.display(), size.width(), size.height());
    }
    Ok(())
}
