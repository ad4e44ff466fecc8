//! Known answers for the polygon pipeline: transforms, culling, clipping,
//! scan conversion, perspective-correct interpolation and the Z-buffer.

use isoray_raster::pipeline::{
    clip_near, is_front_facing, rasterize, signed_area, span, ScreenVertex, Vertex, ViewTransform, ZBuffer,
};
use isoray_scene::{Camera, Projection};
use proptest::prelude::*;

fn camera(position: [f64; 3], target: [f64; 3], fov: f64) -> Camera {
    Camera {
        position,
        target,
        up: [0.0, 1.0, 0.0],
        fov,
        projection: Projection::Perspective,
    }
}

fn sv(x: f64, y: f64) -> ScreenVertex<0> {
    ScreenVertex {
        x,
        y,
        inv_w: 1.0,
        attributes: [],
    }
}

/// Hit count per pixel for a set of screen triangles.
fn hits(tris: &[[ScreenVertex<0>; 3]], w: usize, h: usize) -> Vec<u32> {
    let mut count = vec![0u32; w * h];
    for t in tris {
        rasterize(t, w, h, |f| count[f.y as usize * w + f.x as usize] += 1);
    }
    count
}

#[test]
fn world_origin_in_camera_space() {
    let view = ViewTransform::new(&camera([0.0, 0.0, 5.0], [0.0, 0.0, 0.0], 40.0), 64, 48);
    assert_eq!(view.world_to_camera([0.0, 0.0, 0.0]), [0.0, 0.0, -5.0]);
    // Right is +x, up is +y for this camera.
    assert_eq!(view.world_to_camera([1.0, 2.0, 0.0]), [1.0, 2.0, -5.0]);
}

#[test]
fn perspective_projection() {
    assert_eq!(ViewTransform::project([2.0, 4.0, -8.0], 1.0), Some([0.25, 0.5]));
    assert_eq!(ViewTransform::project([2.0, 4.0, 8.0], 1.0), None);
    assert_eq!(ViewTransform::project([2.0, 4.0, 0.0], 1.0), None);
}

#[test]
fn viewport_corners() {
    let (w, h) = (64u32, 48u32);
    let view = ViewTransform::new(&camera([0.0, 0.0, 5.0], [0.0, 0.0, 0.0], 40.0), w, h);
    assert_eq!(view.ndc_to_screen([-1.0, 1.0]), [-0.5, -0.5]);
    assert_eq!(view.ndc_to_screen([1.0, -1.0]), [w as f64 - 0.5, h as f64 - 0.5]);
    assert_eq!(view.ndc_to_screen([0.0, 0.0]), [31.5, 23.5]);
    // A point on the top-left corner of the frustum (fov 90, aspect 2).
    let view = ViewTransform::new(&camera([0.0, 0.0, 0.0], [0.0, 0.0, -1.0], 90.0), 100, 50);
    // (tan 45° is not exactly 1 in floating point, hence the tolerance.)
    let corner = view.to_screen([-6.0, 3.0, -3.0]).unwrap();
    for (got, want) in corner.iter().zip([-0.5, -0.5, 3.0]) {
        assert!((got - want).abs() < 1e-12, "{corner:?}");
    }
    assert_eq!(view.to_screen([0.0, 0.0, 1.0]), None);
}

/// A cube of side `2·s` centred at the origin, 12 triangles counter-clockwise
/// seen from outside.
fn cube(s: f64) -> Vec<[[f64; 3]; 3]> {
    let faces = [
        [[1., -1., 1.], [1., -1., -1.], [1., 1., -1.], [1., 1., 1.]],
        [[-1., -1., -1.], [-1., -1., 1.], [-1., 1., 1.], [-1., 1., -1.]],
        [[-1., 1., 1.], [1., 1., 1.], [1., 1., -1.], [-1., 1., -1.]],
        [[-1., -1., -1.], [1., -1., -1.], [1., -1., 1.], [-1., -1., 1.]],
        [[-1., -1., 1.], [1., -1., 1.], [1., 1., 1.], [-1., 1., 1.]],
        [[1., -1., -1.], [-1., -1., -1.], [-1., 1., -1.], [1., 1., -1.]],
    ];
    let sc = |p: [f64; 3]| p.map(|c| c * s);
    let mut tris = Vec::new();
    for [a, b, c, d] in faces {
        tris.push([sc(a), sc(b), sc(c)]);
        tris.push([sc(a), sc(c), sc(d)]);
    }
    tris
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[test]
fn cube_keeps_six_of_twelve_triangles() {
    let eye = [50.0, 60.0, 70.0];
    let view = ViewTransform::new(&camera(eye, [0.0, 0.0, 0.0], 40.0), 200, 150);
    let tris = cube(10.0);
    assert_eq!(tris.len(), 12);
    let mut kept = 0;
    for t in &tris {
        let n = cross(sub(t[1], t[0]), sub(t[2], t[0]));
        let centroid = [0, 1, 2].map(|k| (t[0][k] + t[1][k] + t[2][k]) / 3.0);
        assert!(
            dot(n, centroid) > 0.0,
            "cube winding must be counter-clockwise from outside"
        );
        let s = t.map(|p| view.to_screen(p).unwrap());
        let front = is_front_facing([s[0][0], s[0][1]], [s[1][0], s[1][1]], [s[2][0], s[2][1]]);
        // Agrees with the 3D test: the face's normal points towards the eye.
        assert_eq!(front, dot(n, sub(eye, t[0])) > 0.0);
        kept += front as usize;
    }
    assert_eq!(kept, 6);
}

#[test]
fn front_face_has_negative_screen_area() {
    // A triangle in the plane z = 0, counter-clockwise seen from +z, seen by
    // a camera on +z: front-facing, negative area (y down).
    let view = ViewTransform::new(&camera([0.0, 0.0, 5.0], [0.0, 0.0, 0.0], 40.0), 64, 64);
    let s = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]].map(|p| {
        let q = view.to_screen(p).unwrap();
        [q[0], q[1]]
    });
    assert!(signed_area(s[0], s[1], s[2]) < 0.0);
    assert!(is_front_facing(s[0], s[1], s[2]));
    assert!(!is_front_facing(s[0], s[2], s[1]));
}

/// A triangle in the plane y = 0 with attribute `x + 2z`.
fn xz_tri(p: [[f64; 2]; 3]) -> [Vertex<1>; 3] {
    p.map(|[x, z]| Vertex::new([x, 0.0, z], [x + 2.0 * z]))
}

fn area3(t: &[Vertex<1>; 3]) -> f64 {
    let c = cross(sub(t[1].position, t[0].position), sub(t[2].position, t[0].position));
    0.5 * dot(c, c).sqrt()
}

#[test]
fn near_plane_clipping() {
    let near = 1.0;
    // (triangle, expected pieces, expected in-front area)
    let cases: [([[f64; 2]; 3], usize, f64); 4] = [
        ([[0.0, -2.0], [2.0, -6.0], [-2.0, -6.0]], 1, 8.0),
        ([[0.0, 0.0], [2.0, -4.0], [-2.0, -4.0]], 2, 7.5),
        ([[0.0, -4.0], [-2.0, 0.0], [2.0, 0.0]], 1, 4.5),
        ([[0.0, 0.0], [-2.0, -0.5], [2.0, 0.5]], 0, 0.0),
    ];
    for (behind, (p, n, area)) in cases.into_iter().enumerate() {
        let tri = xz_tri(p);
        assert_eq!(tri.iter().filter(|v| v.position[2] > -near).count(), behind);
        let orig_n = cross(
            sub(tri[1].position, tri[0].position),
            sub(tri[2].position, tri[0].position),
        );
        let pieces = clip_near(tri, near);
        assert_eq!(pieces.len(), n, "{behind} vertices behind");
        let mut total = 0.0;
        for piece in &pieces {
            for v in piece {
                assert!(v.position[2] <= -near);
                // Attributes are interpolated with the position.
                assert!((v.attributes[0] - (v.position[0] + 2.0 * v.position[2])).abs() < 1e-12);
            }
            // Winding is preserved.
            let pn = cross(
                sub(piece[1].position, piece[0].position),
                sub(piece[2].position, piece[0].position),
            );
            assert!(dot(pn, orig_n) > 0.0);
            total += area3(piece);
        }
        assert!((total - area).abs() < 1e-12, "{behind} behind: area {total} != {area}");
    }
}

#[test]
fn span_fill_rule() {
    assert_eq!(span(2.3, 7.0).collect::<Vec<_>>(), vec![3, 4, 5, 6]);
    assert_eq!(span(2.3, 7.4).collect::<Vec<_>>(), vec![3, 4, 5, 6, 7]);
    assert_eq!(span(3.0, 3.0).count(), 0);
    assert_eq!(span(-1.5, 0.5).collect::<Vec<_>>(), vec![-1, 0]);
}

#[test]
fn rasterized_spans_follow_the_fill_rule() {
    // A right triangle whose vertical left edge is at x = 2.3: row y covers
    // 2.3 <= x < right edge.
    let tri = [sv(2.3, 0.5), sv(2.3, 10.5), sv(12.3, 10.5)];
    let c = hits(&[tri], 16, 16);
    for y in 0..16 {
        let row: Vec<usize> = (0..16).filter(|&x| c[y * 16 + x] > 0).collect();
        let yf = y as f64;
        let expect: Vec<usize> = if (0.5..10.5).contains(&yf) {
            span(2.3, 2.3 + (yf - 0.5)).map(|x| x as usize).collect()
        } else {
            vec![]
        };
        assert_eq!(row, expect, "row {y}");
    }
}

#[test]
fn shared_edge_covered_exactly_once() {
    let (w, h) = (24usize, 24usize);
    let p = [[1.3, 2.7], [15.45, 0.6], [18.2, 14.9], [3.1, 16.35]].map(|[x, y]| sv(x, y));
    for tris in [
        [[p[0], p[1], p[2]], [p[0], p[2], p[3]]],
        [[p[1], p[2], p[3]], [p[1], p[3], p[0]]],
    ] {
        let c = hits(&tris, w, h);
        for y in 0..h {
            for x in 0..w {
                let q = [x as f64, y as f64];
                // Exact inside test against the (convex, clockwise-on-screen
                // or not) quad: same sign for all four edges.
                let s: Vec<f64> = (0..4).map(|k| signed_area(p[k].xy(), p[(k + 1) % 4].xy(), q)).collect();
                let inside = s.iter().all(|&a| a > 0.0) || s.iter().all(|&a| a < 0.0);
                let outside = s.iter().any(|&a| a > 0.0) && s.iter().any(|&a| a < 0.0);
                let n = c[y * w + x];
                assert!(n <= 1, "pixel ({x}, {y}) hit {n} times");
                if inside {
                    assert_eq!(n, 1, "crack at ({x}, {y})");
                }
                if outside {
                    assert_eq!(n, 0, "outside hit at ({x}, {y})");
                }
            }
        }
    }
}

#[test]
fn vertex_fan_on_pixel_centres() {
    // Eight triangles around a vertex exactly on a pixel centre, with edges
    // through pixel centres: every pixel centre inside the octagon-ish square
    // is hit exactly once, including the shared vertex and edges.
    let (w, h) = (12usize, 12usize);
    let c = sv(5.0, 5.0);
    let ring = [
        [1.0, 1.0],
        [5.0, 1.0],
        [9.0, 1.0],
        [9.0, 5.0],
        [9.0, 9.0],
        [5.0, 9.0],
        [1.0, 9.0],
        [1.0, 5.0],
    ];
    let tris: Vec<_> = (0..8)
        .map(|k| {
            [
                c,
                sv(ring[k][0], ring[k][1]),
                sv(ring[(k + 1) % 8][0], ring[(k + 1) % 8][1]),
            ]
        })
        .collect();
    let counts = hits(&tris, w, h);
    let whole = hits(
        &[
            [sv(1.0, 1.0), sv(9.0, 1.0), sv(9.0, 9.0)],
            [sv(1.0, 1.0), sv(9.0, 9.0), sv(1.0, 9.0)],
        ],
        w,
        h,
    );
    assert_eq!(counts, whole);
    for y in 0..h {
        for x in 0..w {
            let expect = (1..9).contains(&x) && (1..9).contains(&y);
            assert_eq!(counts[y * w + x], expect as u32, "({x}, {y})");
        }
    }
}

fn coord() -> impl Strategy<Value = f64> {
    prop_oneof![(0.0f64..20.0), (0i32..=40).prop_map(|k| k as f64 * 0.5)]
}

proptest! {
    /// Two triangles on either side of a shared diagonal: no pixel is hit
    /// twice, and every pixel centre strictly inside the union (including on
    /// the open diagonal) is hit once.
    #[test]
    fn shared_diagonal_partition(p in proptest::array::uniform4((coord(), coord()))) {
        let mut p = p.map(|(x, y)| [x, y]);
        let s1 = signed_area(p[0], p[2], p[1]);
        let s3 = signed_area(p[0], p[2], p[3]);
        prop_assume!(s1 != 0.0 && s3 != 0.0);
        if s1 * s3 > 0.0 {
            // Reflect p3 through the diagonal's midpoint to the other side.
            p[3] = [p[0][0] + p[2][0] - p[3][0], p[0][1] + p[2][1] - p[3][1]];
            prop_assume!(signed_area(p[0], p[2], p[1]) * signed_area(p[0], p[2], p[3]) < 0.0);
        }
        let (w, h) = (22usize, 22usize);
        let t1 = [sv(p[0][0], p[0][1]), sv(p[1][0], p[1][1]), sv(p[2][0], p[2][1])];
        let t2 = [sv(p[0][0], p[0][1]), sv(p[2][0], p[2][1]), sv(p[3][0], p[3][1])];
        let c = hits(&[t1, t2], w, h);
        let strictly_in = |t: [[f64; 2]; 3], q: [f64; 2]| {
            let a = [signed_area(t[0], t[1], q), signed_area(t[1], t[2], q), signed_area(t[2], t[0], q)];
            a.iter().all(|&v| v > 0.0) || a.iter().all(|&v| v < 0.0)
        };
        for y in 0..h {
            for x in 0..w {
                let q = [x as f64, y as f64];
                let n = c[y * w + x];
                prop_assert!(n <= 1, "pixel ({}, {}) hit {} times", x, y, n);
                let on_diag = signed_area(p[0], p[2], q) == 0.0
                    && (q[0] - p[0][0]) * (q[0] - p[2][0]) + (q[1] - p[0][1]) * (q[1] - p[2][1]) < 0.0;
                if on_diag || strictly_in([p[0], p[1], p[2]], q) || strictly_in([p[0], p[2], p[3]], q) {
                    prop_assert_eq!(n, 1, "crack at ({}, {})", x, y);
                }
            }
        }
    }
}

#[test]
fn perspective_correct_interpolation() {
    // Camera at the origin looking down −z, 90° fov, 102×102 pixels. A floor
    // quad at y = −1 from z = −2 (u = 0) to z = −10 (u = 1).
    let (w, h) = (102usize, 102usize);
    let view = ViewTransform::new(&camera([0.0, 0.0, 0.0], [0.0, 0.0, -1.0], 90.0), w as u32, h as u32);
    let v = |x: f64, z: f64, u: f64| Vertex::new([x, -1.0, z], [u]);
    let quad = [
        v(-1.0, -2.0, 0.0),
        v(1.0, -2.0, 0.0),
        v(1.0, -10.0, 1.0),
        v(-1.0, -10.0, 1.0),
    ];
    let mut zb = ZBuffer::new(w, h, [0.0; 3]);
    let mut u_at = vec![f64::NAN; w * h];
    for tri in [[quad[0], quad[1], quad[2]], [quad[0], quad[2], quad[3]]] {
        let n = zb.draw_world_triangle(&view, 0.1, true, tri, |f| {
            u_at[f.y as usize * w + f.x as usize] = f.attributes[0];
            [1.0; 3]
        });
        assert!(n > 0, "the floor faces the camera");
    }
    // The true 3D midpoint (0, −1, −6) projects onto row 59.
    let mid = view.to_screen([0.0, -1.0, -6.0]).unwrap();
    assert!((mid[1] - 59.0).abs() < 1e-9, "{mid:?}");
    let u = u_at[59 * w + 50];
    assert!((u - 0.5).abs() < 1e-9, "u = {u}");
    // Screen-space linear interpolation would give something very different.
    let near_y = view.to_screen([0.0, -1.0, -2.0]).unwrap()[1];
    let far_y = view.to_screen([0.0, -1.0, -10.0]).unwrap()[1];
    let linear = (near_y - 59.0) / (near_y - far_y);
    assert!((linear - 0.5).abs() > 0.2, "linear {linear}");
    // Depth is the camera-space distance −z, also perspective-correct.
    assert!((zb.depth[59 * w + 50] - 6.0).abs() < 1e-9);
}

#[test]
fn zbuffer_keeps_the_nearer_triangle() {
    let (w, h) = (32usize, 32usize);
    let view = ViewTransform::new(&camera([0.0, 0.0, 10.0], [0.0, 0.0, 0.0], 40.0), w as u32, h as u32);
    // The far triangle (z = 0) is twice the size of the near one (z = 1).
    let tri = |z: f64| {
        let s = 2.0 - z;
        [[-s, -s, z], [s, -s, z], [0.0, s, z]].map(|p| Vertex::new(p, [z]))
    };
    let red = [1.0, 0.0, 0.0];
    let blue = [0.0, 0.0, 1.0];
    for order in [[0.0, 1.0], [1.0, 0.0]] {
        let mut zb = ZBuffer::new(w, h, [0.0; 3]);
        for z in order {
            // z = 1 is nearer to the eye at z = 10: red.
            let colour = if z == 1.0 { red } else { blue };
            zb.draw_world_triangle(&view, 0.1, true, tri(z), |_| colour);
        }
        let centre = view.to_screen([0.0, 0.0, 1.0]).unwrap();
        let (cx, cy) = (centre[0].round() as usize, centre[1].round() as usize);
        assert_eq!(zb.pixel(cx, cy), red);
        assert!((zb.depth[cy * w + cx] - 9.0).abs() < 1e-9);
        // Every pixel the near triangle covers is red, whatever the order.
        let mut near_cover = vec![false; w * h];
        let s = tri(1.0)
            .map(|v| ScreenVertex::from_camera(&view, &Vertex::new(view.world_to_camera(v.position), [])).unwrap());
        rasterize(&s, w, h, |f| near_cover[f.y as usize * w + f.x as usize] = true);
        assert!(near_cover.iter().filter(|&&c| c).count() > 20);
        for (covered, colour) in near_cover.iter().zip(&zb.color) {
            if *covered {
                assert_eq!(*colour, red);
            }
        }
        assert!(zb.color.contains(&blue), "the far triangle shows around the near one");
    }
}
