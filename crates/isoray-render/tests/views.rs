//! The debug views against known answers.

use isoray_render::{render, RenderOptions};
use isoray_scene::load_str;

const BALL: &str = r#"
[camera]
position = [0.0, 0.0, 5.0]
target = [0.0, 0.0, 0.0]
fov = 40.0
[render]
width = 33
height = 33
normals = "central"
[[object]]
shape = "SHAPE"
"#;

fn image(shape: &str, view: &str) -> Vec<[f32; 3]> {
    let text = BALL.replace("SHAPE", shape);
    // Step 0.5·d: 2·sphere overestimates the distance twice over.
    let over = [format!("render.view=\"{view}\""), "render.step_scale=0.5".to_string()];
    let scene = load_str(&text, "views.toml", &over).unwrap_or_else(|e| panic!("{e}"));
    render(&scene, &RenderOptions::default()).0.color
}

fn close(got: [f32; 3], want: [f32; 3]) {
    for c in 0..3 {
        assert!((got[c] - want[c]).abs() < 2e-3, "got {got:?}, want {want:?}");
    }
}

const CENTRE: usize = 16 * 33 + 16;

#[test]
fn the_mask_is_white_on_hits_and_black_on_misses() {
    let img = image("sphere(p, 1.0)", "mask");
    assert_eq!(img[CENTRE], [1.0; 3]);
    assert_eq!(img[0], [0.0; 3]);
}

#[test]
fn the_gradient_view_shows_how_far_a_field_is_from_a_distance() {
    // An exact distance: |∇f| = 1, the middle of the heat map (green).
    close(image("sphere(p, 1.0)", "gradient")[CENTRE], [0.0, 0.8, 0.2]);
    // Twice a distance: |∇f| = 2, the top (red); half: 0.5, a quarter up.
    close(image("2.0 * sphere(p, 1.0)", "gradient")[CENTRE], [1.0, 0.0, 0.0]);
    close(image("0.5 * sphere(p, 1.0)", "gradient")[CENTRE], [0.0, 0.3, 1.0]);
}

#[test]
fn the_uv_view_maps_the_image_plane() {
    let img = image("sphere(p, 1.0)", "uv");
    // The centre, uv = (0, 0), lies on the grid: the colour (½, ½, ¼) darkened to a quarter.
    close(img[CENTRE], [0.125, 0.125, 0.0625]);
    // The top-left pixel's centre: uv = (−32/33, 32/33), off the grid.
    let (u, v) = (-32.0f32 / 33.0, 32.0f32 / 33.0);
    close(img[0], [0.5 + 0.5 * u, 0.5 + 0.5 * v, 0.25]);
}

/// Supersample patterns: the rotated grid is RGSS for aa = 2 and gives
/// every sample its own row and column (aa² levels on a horizontal or
/// vertical edge, where the grid has aa); jittered samples stay in their
/// grid cells, differ from pixel to pixel and are the same on every run.
#[test]
fn supersample_patterns() {
    use isoray_render::sample_offset;
    use isoray_scene::AaPattern::{Grid, Jittered, Rotated};
    let pts = |pat, aa: u32, px: u32| -> Vec<(f64, f64)> {
        (0..aa)
            .flat_map(|sy| (0..aa).map(move |sx| (sx, sy)))
            .map(|(sx, sy)| sample_offset(pat, aa, sx, sy, px, 7))
            .collect()
    };
    let mut rgss = pts(Rotated, 2, 0);
    rgss.sort_by(|a, b| a.0.total_cmp(&b.0));
    assert_eq!(
        rgss,
        vec![(0.125, 0.375), (0.375, 0.875), (0.625, 0.125), (0.875, 0.625)]
    );
    for aa in 2..=5u32 {
        let distinct = |v: Vec<f64>| {
            let mut v = v;
            v.sort_by(f64::total_cmp);
            v.dedup();
            v.len()
        };
        let r = pts(Rotated, aa, 0);
        assert_eq!(distinct(r.iter().map(|p| p.0).collect()), (aa * aa) as usize);
        assert_eq!(distinct(r.iter().map(|p| p.1).collect()), (aa * aa) as usize);
        let g = pts(Grid, aa, 0);
        assert_eq!(distinct(g.iter().map(|p| p.1).collect()), aa as usize);
        let (j0, j1) = (pts(Jittered, aa, 0), pts(Jittered, aa, 1));
        assert_ne!(j0, j1);
        assert_eq!(j0, pts(Jittered, aa, 0));
        for (k, &(x, y)) in j0.iter().enumerate() {
            let (sx, sy) = ((k as u32 % aa) as f64, (k as u32 / aa) as f64);
            let n = aa as f64;
            assert!(x >= sx / n && x < (sx + 1.0) / n && y >= sy / n && y < (sy + 1.0) / n);
        }
    }
}
