//! Known answers for the A-buffer: mask areas, resolve, coverage, merging.

use isoray_raster::abuffer::{resolve, ABuffer, Fragment, FragmentList, Mask};

const BLACK: [f32; 3] = [0.0; 3];

fn frag(mask: Mask, zmin: f32, zmax: f32, color: [f32; 3], opacity: f32, object: u32) -> Fragment {
    Fragment {
        mask,
        zmin,
        zmax,
        color,
        opacity,
        object,
    }
}

fn close(a: [f32; 3], b: [f32; 3]) -> bool {
    a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-6)
}

#[test]
fn sixteen_bits_is_half_area() {
    assert_eq!(Mask(0x0000_ffff).area(), 0.5);
    assert_eq!(Mask(0x5555_5555).area(), 0.5);
    assert_eq!(Mask::FULL.area(), 1.0);
    assert_eq!(Mask::EMPTY.area(), 0.0);
}

#[test]
fn mask_layout_bit_is_row_times_eight_plus_column() {
    assert_eq!(Mask::bit_index(3, 2), 19);
    assert!(Mask(1 << 19).contains(3, 2));
    assert_eq!(Mask::sample_offset(0, 0), [-0.4375, -0.375]);
    assert_eq!(Mask::sample_offset(7, 3), [0.4375, 0.375]);
}

#[test]
fn opaque_white_half_pixel_over_black_is_half_grey() {
    let f = frag(Mask(0x0000_ffff), 1.0, 1.0, [1.0; 3], 1.0, 0);
    let c = resolve(&[f], BLACK);
    assert!(close(c, [0.5; 3]), "{c:?}");
}

#[test]
fn half_transparent_red_over_opaque_blue() {
    let mut list = FragmentList::new();
    list.insert(frag(Mask::FULL, 2.0, 2.0, [0.0, 0.0, 1.0], 1.0, 1));
    list.insert(frag(Mask::FULL, 1.0, 1.0, [1.0, 0.0, 0.0], 0.5, 0));
    let c = list.resolve([0.0, 1.0, 0.0]);
    assert!(close(c, [0.5, 0.0, 0.5]), "{c:?}");
}

#[test]
fn intersecting_fragments_front_visibility_three_quarters() {
    let mut list = FragmentList::new();
    list.insert(frag(Mask::FULL, 2.0, 4.0, BLACK, 1.0, 1));
    list.insert(frag(Mask::FULL, 1.0, 3.0, [1.0; 3], 1.0, 0));
    assert_eq!(list.len(), 2);
    let c = list.resolve([0.3, 0.6, 0.9]);
    assert!(close(c, [0.75; 3]), "{c:?}");
}

#[test]
fn uncovered_bits_show_background_and_opaque_hides_behind() {
    let mut list = FragmentList::new();
    // Opaque red over the left half; green behind it over everything.
    list.insert(frag(Mask(0x0f0f_0f0f), 1.0, 1.0, [1.0, 0.0, 0.0], 1.0, 0));
    list.insert(frag(Mask::FULL, 5.0, 5.0, [0.0, 1.0, 0.0], 1.0, 1));
    assert!(close(list.resolve(BLACK), [0.5, 0.5, 0.0]));
    // Only the top half of green: the other quarter is background blue.
    let mut list = FragmentList::new();
    list.insert(frag(Mask(0x0f0f_0f0f), 1.0, 1.0, [1.0, 0.0, 0.0], 1.0, 0));
    list.insert(frag(Mask(0x0000_ffff), 5.0, 5.0, [0.0, 1.0, 0.0], 1.0, 1));
    assert!(close(list.resolve([0.0, 0.0, 1.0]), [0.5, 0.25, 0.25]));
}

fn bbox(tris: &[[[f64; 2]; 3]]) -> (i32, i32, i32, i32) {
    let pts = tris.iter().flatten();
    let x0 = pts.clone().map(|p| p[0]).fold(f64::INFINITY, f64::min).floor() as i32 - 1;
    let x1 = pts.clone().map(|p| p[0]).fold(f64::NEG_INFINITY, f64::max).ceil() as i32 + 1;
    let y0 = pts.clone().map(|p| p[1]).fold(f64::INFINITY, f64::min).floor() as i32 - 1;
    let y1 = pts.map(|p| p[1]).fold(f64::NEG_INFINITY, f64::max).ceil() as i32 + 1;
    (x0, x1, y0, y1)
}

#[test]
fn large_triangle_edge_pixels_have_quantised_area() {
    let tri = [[0.3, 0.7], [100.2, 3.1], [40.6, 80.9]];
    let (x0, x1, y0, y1) = bbox(&[tri]);
    let (mut partial, mut full, mut total) = (0, 0, 0u32);
    for y in y0..=y1 {
        for x in x0..=x1 {
            let m = Mask::coverage(&tri, x, y);
            let a = m.area() * 32.0;
            assert_eq!(a, a.round());
            assert_eq!(a as u32, m.count());
            total += m.count();
            if m == Mask::FULL {
                full += 1;
            } else if !m.is_empty() {
                partial += 1;
            }
        }
    }
    assert!(partial > 100, "{partial}");
    assert!(full > 3000, "{full}");
    // Area of the triangle ≈ covered subsamples / 32.
    let [a, b, c] = tri;
    let area = 0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])).abs();
    let covered = total as f64 / 32.0;
    assert!((covered - area).abs() / area < 0.01, "{covered} vs {area}");
    // Winding order does not matter.
    let rev = [tri[2], tri[1], tri[0]];
    for y in y0..=y1 {
        for x in x0..=x1 {
            assert_eq!(Mask::coverage(&tri, x, y), Mask::coverage(&rev, x, y));
        }
    }
}

/// `t` split into two triangles along the segment from vertex 0 to point `m`
/// on edge 1–2: masks disjoint, union equal to the whole triangle's mask.
fn check_split(t: [[f64; 2]; 3], m: [f64; 2], min_shared_edge_pixels: usize) {
    let a = [t[0], t[1], m];
    let b = [m, t[2], t[0]];
    let (x0, x1, y0, y1) = bbox(&[t]);
    let mut shared_edge_pixels = 0;
    for y in y0..=y1 {
        for x in x0..=x1 {
            let (ma, mb, mt) = (
                Mask::coverage(&a, x, y),
                Mask::coverage(&b, x, y),
                Mask::coverage(&t, x, y),
            );
            assert!((ma & mb).is_empty(), "overlap at ({x}, {y}): {ma:?} {mb:?}");
            assert_eq!(ma | mb, mt, "gap at ({x}, {y}) in {t:?}");
            if !ma.is_empty() && !mb.is_empty() {
                shared_edge_pixels += 1;
            }
        }
    }
    assert!(shared_edge_pixels >= min_shared_edge_pixels, "{shared_edge_pixels}");
}

#[test]
fn triangles_sharing_an_edge_have_complementary_masks() {
    // Dyadic coordinates: edge functions are exact, so collinear sub-edges agree.
    // Generic slope.
    check_split([[2.0, 1.0], [60.0, 9.0], [20.0, 50.0]], [40.0, 29.5], 20);
    // Slope 2 (dy/dx): the shared edge runs through many subsamples exactly.
    check_split(
        [[0.0625, 0.125], [40.0625, 0.125], [0.0625, 80.125]],
        [20.0625, 40.125],
        20,
    );
    // Horizontal shared edge through a subsample row (y = j − 0.5 + 0.625).
    check_split(
        [[0.0625, 0.125], [30.0625, 20.125], [30.0625, -19.875]],
        [30.0625, 0.125],
        20,
    );
    // Vertical shared edge through a subsample column (x = i − 0.5 + 0.0625).
    // The subsamples on it belong to the triangle on its right (left edge), so
    // no pixel is split between the two.
    let t = [[5.5625, 0.0], [-20.0, 30.0], [30.0, 30.0]];
    check_split(t, [5.5625, 30.0], 0);
    let (left, right) = ([t[0], t[1], [5.5625, 30.0]], [[5.5625, 30.0], t[2], t[0]]);
    assert_eq!(Mask::coverage(&right, 6, 10), Mask::FULL);
    assert_eq!(Mask::coverage(&left, 6, 10), Mask::EMPTY);
    assert_eq!(Mask::coverage(&left, 5, 10), Mask::FULL);
    // Reversed winding.
    check_split([[20.0, 50.0], [60.0, 9.0], [2.0, 1.0]], [31.0, 5.0], 20);
}

#[test]
fn shared_edge_arbitrary_coordinates_disjoint_and_complete() {
    // Non-dyadic shared edge p–q: every subsample is covered by exactly one of
    // the two triangles, or by neither only outside the quadrilateral.
    let (p, q) = ([3.3, 2.7], [47.9, 38.1]);
    let (r, s) = ([45.1, 1.3], [1.7, 41.9]);
    let a = [p, q, r];
    let b = [q, p, s];
    let (x0, x1, y0, y1) = bbox(&[a, b]);
    let mut shared = 0;
    for y in y0..=y1 {
        for x in x0..=x1 {
            let (ma, mb) = (Mask::coverage(&a, x, y), Mask::coverage(&b, x, y));
            assert!((ma & mb).is_empty());
            if !ma.is_empty() && !mb.is_empty() {
                shared += 1;
                // Pixels well inside the quad along the shared edge are fully covered.
                let t = ((x as f64 - p[0]) * (q[0] - p[0]) + (y as f64 - p[1]) * (q[1] - p[1]))
                    / ((q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2));
                if (0.1..0.9).contains(&t) {
                    assert_eq!(ma | mb, Mask::FULL, "gap at ({x}, {y})");
                }
            }
        }
    }
    assert!(shared > 20);
}

#[test]
fn degenerate_triangle_covers_nothing() {
    let tri = [[0.0, 0.0], [4.0, 4.0], [8.0, 8.0]];
    for y in -1..10 {
        for x in -1..10 {
            assert!(Mask::coverage(&tri, x, y).is_empty());
        }
    }
}

#[test]
fn same_object_depth_overlap_merges_others_do_not() {
    let mut list = FragmentList::new();
    list.insert(frag(Mask(0x0000_00ff), 1.0, 2.0, [1.0, 0.0, 0.0], 1.0, 7));
    list.insert(frag(Mask(0x0000_ff00), 1.5, 3.0, [0.0, 0.0, 1.0], 1.0, 7));
    assert_eq!(list.len(), 1);
    let f = list.fragments()[0];
    assert_eq!(f.mask, Mask(0x0000_ffff));
    assert_eq!((f.zmin, f.zmax), (1.0, 3.0));
    assert!(close(f.color, [0.5, 0.0, 0.5]));
    // Different object overlapping in depth: kept apart.
    list.insert(frag(Mask(0xffff_0000), 1.2, 2.5, [0.0, 1.0, 0.0], 1.0, 8));
    assert_eq!(list.len(), 2);
    // Same object, disjoint in depth: kept apart.
    list.insert(frag(Mask(0x00ff_0000), 10.0, 11.0, [0.0, 1.0, 0.0], 1.0, 7));
    assert_eq!(list.len(), 3);
    // A fragment bridging two same-object fragments merges all three.
    list.insert(frag(Mask(0xff00_0000), 2.5, 10.5, [1.0; 3], 1.0, 7));
    assert_eq!(list.len(), 2);
    let zs: Vec<f32> = list.fragments().iter().map(|f| f.zmin).collect();
    assert_eq!(zs, vec![1.0, 1.2]);
    assert_eq!(list.fragments()[0].mask, Mask(0xff00_ffff) | Mask(0x00ff_0000));
}

#[test]
fn lists_are_sorted_front_to_back() {
    let mut buf = ABuffer::new(3, 2);
    let zs = [5.0, 1.0, 9.0, 3.0, 7.0, 2.0, 8.0];
    for (i, &z) in zs.iter().enumerate() {
        buf.add(1, 1, frag(Mask::FULL, z, z + 0.5, [0.1; 3], 0.5, i as u32));
    }
    buf.add(7, 7, frag(Mask::FULL, 1.0, 1.0, [1.0; 3], 1.0, 0)); // ignored
    let list = buf.list(1, 1);
    assert_eq!(list.len(), zs.len());
    assert!(list.fragments().windows(2).all(|w| w[0].zmin <= w[1].zmin));
}

#[test]
fn resolve_image_known_answers() {
    let mut buf = ABuffer::new(2, 2);
    buf.add(0, 0, frag(Mask(0x0000_ffff), 1.0, 1.0, [1.0; 3], 1.0, 0));
    buf.add(1, 0, frag(Mask::FULL, 2.0, 2.0, [0.0, 0.0, 1.0], 1.0, 1));
    buf.add(1, 0, frag(Mask::FULL, 1.0, 1.0, [1.0, 0.0, 0.0], 0.5, 0));
    buf.add(0, 1, frag(Mask::FULL, 1.0, 3.0, [1.0; 3], 1.0, 0));
    buf.add(0, 1, frag(Mask::FULL, 2.0, 4.0, BLACK, 1.0, 1));
    let img = buf.resolve_image(BLACK);
    assert_eq!(img.len(), 4);
    assert!(close(img[0], [0.5; 3]));
    assert!(close(img[1], [0.5, 0.0, 0.5]));
    assert!(close(img[2], [0.75; 3]));
    assert!(close(img[3], BLACK));
    buf.clear();
    assert!(buf.lists.iter().all(FragmentList::is_empty));
}

#[test]
fn triangle_coverage_into_abuffer_resolves_to_area() {
    // Two abutting opaque triangles of a square, same colour: edge pixels along
    // the diagonal resolve to full colour (no cracks, no double counting).
    let (p, q) = ([0.3, 0.2], [9.7, 9.9]);
    let a = [p, [9.7, 0.2], q];
    let b = [p, q, [0.3, 9.9]];
    let mut buf = ABuffer::new(10, 10);
    for y in 0..10 {
        for x in 0..10 {
            for (k, t) in [a, b].iter().enumerate() {
                let m = Mask::coverage(t, x as i32, y as i32);
                buf.add(x, y, frag(m, 1.0 + k as f32, 1.0 + k as f32, [1.0; 3], 1.0, k as u32));
            }
        }
    }
    let img = buf.resolve_image(BLACK);
    for y in 2..8 {
        for x in 2..8 {
            assert!(close(img[y * 10 + x], [1.0; 3]), "({x}, {y}) = {:?}", img[y * 10 + x]);
        }
    }
}
