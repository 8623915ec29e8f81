//! `shoal diff --plot`'s picture says which colour is which fish (issue 36): a legend with a
//! short line of each named fish's colour and one of the grey ghosts.

use crate::common;

use shoal_script::timeline::{self, RecordSpec};

/// The longest run of pixels of exactly `color` along any row of `img`.
fn longest_row_run(img: &image::RgbImage, color: [u8; 3]) -> u32 {
    let mut best = 0;
    for y in 0..img.height() {
        let mut run = 0;
        for x in 0..img.width() {
            if img.get_pixel(x, y).0 == color {
                run += 1;
                best = best.max(run);
            } else {
                run = 0;
            }
        }
    }
    best
}

/// Two recordings of the default scene with different seeds part at once; the plot of their
/// diff carries a legend: a 20-pixel swatch of every path colour (ten fish are named, so all
/// eight colours appear) and of the grey the first run is drawn in. A fish's path only rarely
/// runs straight along a row for that long, and never for all eight colours at once.
#[test]
fn the_diff_plot_has_a_legend_naming_each_colour() {
    assert!(
        shoal_script::plot::fonts_work(),
        "no font for plotters: the legend (and every label) needs one (fonts-dejavu-core)"
    );
    let root = common::repo();
    let scripts = root.join("scripts");
    let spec = |seed| RecordSpec {
        root,
        scripts: &scripts,
        scene: "scenes/default.lua",
        seed,
        lanes: 1,
        seconds: 1.0,
        lod: None,
    };
    let a = timeline::record(&spec(1)).unwrap();
    let b = timeline::record(&spec(2)).unwrap();
    let d = timeline::diff(&a, &b);
    let parted = d
        .fish
        .iter()
        .filter(|f| f.first_divergence_s.is_some())
        .count();
    assert!(parted >= 10, "only {parted} fish part: pick other seeds");
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("diff.png");
    timeline::plot::write(&a, &b, &d, &path).unwrap();
    let img = image::open(&path).unwrap().to_rgb8();
    let colours = [
        [31, 119, 180],
        [214, 39, 40],
        [44, 160, 44],
        [148, 103, 189],
        [255, 127, 14],
        [23, 190, 207],
        [140, 86, 75],
        [188, 189, 34],
    ];
    for c in colours {
        let run = longest_row_run(&img, c);
        assert!(
            run >= 18,
            "no legend swatch of colour {c:?} (longest run {run} px)"
        );
    }
    let grey = longest_row_run(&img, [150, 150, 150]);
    assert!(
        grey >= 18,
        "no legend swatch of the grey first run ({grey} px)"
    );
}
