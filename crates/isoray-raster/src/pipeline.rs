//! The geometric half of the polygon pipeline: world → camera → screen
//! transforms with the ray tracer's conventions, back-face culling,
//! near-plane clipping, scan conversion with a consistent fill rule and
//! perspective-correct interpolation, and a Z-buffer.
//!
//! # Conventions
//!
//! * **Camera space** is right-handed: x right, y up, z *backwards*, so a
//!   point in front of the eye has z < 0 (the camera looks down −z). The axes
//!   are those of the ray tracer's `RayCamera`: forward = normalize(target −
//!   position), right = normalize(forward × up), up' = right × forward.
//! * **Screen space** is in pixels with y down, and the *centre* of pixel
//!   (i, j) is at the integer position (i, j). This is the ray tracer's
//!   continuous image position minus 0.5 (the ray tracer puts the centre of
//!   pixel (i, j) at (i + 0.5, j + 0.5)), so the two renderers sample the
//!   same points. NDC (−1, 1) (top-left corner of the image) maps to
//!   (−0.5, −0.5), NDC (1, −1) to (W − 0.5, H − 0.5).
//! * **Depth** is the camera-space distance along the view axis, `w = −z`
//!   (positive in front of the eye, smaller is nearer). Screen vertices carry
//!   `1/w`, which is linear in screen space; fragment depth is recovered as
//!   `1 / (interpolated 1/w)`.
//! * **Winding**: isoray meshes are counter-clockwise seen from outside. In
//!   y-down screen space such a front face has a *negative* signed area
//!   ([`signed_area`]), i.e. it appears clockwise on screen.
//! * **Fill rule**: a pixel centre (x, y) is covered when `y_top <= y <
//!   y_bottom` and `x_left(y) <= x < x_right(y)` (top-left rule), so a span
//!   from `x_l` to `x_r` covers `ceil(x_l) ..= ceil(x_r) − 1` ([`span`]), and
//!   triangles sharing an edge cover every pixel centre along it exactly once.

use isoray_scene::Camera;

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The world → camera → screen transform of a scene camera for one image
/// size (perspective projection with a vertical field of view).
///
/// For a camera with `Projection::Equirect` the pinhole transform with the
/// camera's `fov` is used (a polygon pipeline cannot draw a panorama).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewTransform {
    eye: [f64; 3],
    right: [f64; 3],
    up: [f64; 3],
    forward: [f64; 3],
    tan_half: f64,
    aspect: f64,
    width: f64,
    height: f64,
}

impl ViewTransform {
    /// Sets up the transform of `camera` for a `width`×`height` image, with
    /// the same axes and field of view as the ray tracer's camera.
    pub fn new(camera: &Camera, width: u32, height: u32) -> Self {
        let [forward, right, up] = camera.basis();
        ViewTransform {
            eye: camera.position,
            right,
            up,
            forward,
            tan_half: camera.tan_half_fov(),
            aspect: width as f64 / height as f64,
            width: width as f64,
            height: height as f64,
        }
    }

    /// Image width in pixels.
    pub fn width(&self) -> f64 {
        self.width
    }

    /// Image height in pixels.
    pub fn height(&self) -> f64 {
        self.height
    }

    /// A world point in camera space: x right, y up, z backwards (points in
    /// front of the eye have z < 0).
    pub fn world_to_camera(&self, p: [f64; 3]) -> [f64; 3] {
        let d = sub(p, self.eye);
        [dot(d, self.right), dot(d, self.up), -dot(d, self.forward)]
    }

    /// A world direction (e.g. a normal) in camera space (rotation only).
    pub fn direction_to_camera(&self, v: [f64; 3]) -> [f64; 3] {
        [dot(v, self.right), dot(v, self.up), -dot(v, self.forward)]
    }

    /// Perspective projection of the camera-space point `p_cam` onto the
    /// plane at distance `d` in front of the eye: `(d·x/(−z), d·y/(−z))`.
    /// `None` when the point is not in front of the eye (z ≥ 0).
    pub fn project(p_cam: [f64; 3], d: f64) -> Option<[f64; 2]> {
        if p_cam[2] >= 0.0 {
            return None;
        }
        let w = -p_cam[2];
        Some([d * p_cam[0] / w, d * p_cam[1] / w])
    }

    /// Normalised device coordinates of a camera-space point: x, y in
    /// [−1, 1] across the image (y up), plus the depth `w = −z`.
    /// `None` when the point is not in front of the eye.
    pub fn camera_to_ndc(&self, p_cam: [f64; 3]) -> Option<[f64; 3]> {
        let [x, y] = Self::project(p_cam, 1.0)?;
        Some([x / (self.tan_half * self.aspect), y / self.tan_half, -p_cam[2]])
    }

    /// The viewport mapping: NDC (x, y) to screen pixels, y down, with pixel
    /// (i, j)'s centre at integer (i, j). NDC (−1, 1) gives (−0.5, −0.5) and
    /// NDC (1, −1) gives (W − 0.5, H − 0.5).
    pub fn ndc_to_screen(&self, ndc: [f64; 2]) -> [f64; 2] {
        [
            (ndc[0] + 1.0) * 0.5 * self.width - 0.5,
            (1.0 - ndc[1]) * 0.5 * self.height - 0.5,
        ]
    }

    /// Screen position of a camera-space point: `[x, y, depth]` with x, y in
    /// pixels (see [`ViewTransform::ndc_to_screen`]) and depth = −z, the
    /// camera-space distance along the view axis. `None` behind the eye.
    pub fn camera_to_screen(&self, p_cam: [f64; 3]) -> Option<[f64; 3]> {
        let [x, y, w] = self.camera_to_ndc(p_cam)?;
        let [sx, sy] = self.ndc_to_screen([x, y]);
        Some([sx, sy, w])
    }

    /// The world point at screen position (`x`, `y`) (pixels, as
    /// [`ViewTransform::ndc_to_screen`]) and depth `w` in front of the eye:
    /// the inverse of [`ViewTransform::to_screen`].
    pub fn screen_to_world(&self, x: f64, y: f64, w: f64) -> [f64; 3] {
        let nx = (x + 0.5) / self.width * 2.0 - 1.0;
        let ny = 1.0 - (y + 0.5) / self.height * 2.0;
        let cx = nx * self.tan_half * self.aspect * w;
        let cy = ny * self.tan_half * w;
        std::array::from_fn(|k| self.eye[k] + cx * self.right[k] + cy * self.up[k] + w * self.forward[k])
    }

    /// The eye position in world space.
    pub fn eye(&self) -> [f64; 3] {
        self.eye
    }

    /// Screen position of a world point: `[x, y, depth]` as
    /// [`ViewTransform::camera_to_screen`]. `None` behind the eye.
    pub fn to_screen(&self, p_world: [f64; 3]) -> Option<[f64; 3]> {
        self.camera_to_screen(self.world_to_camera(p_world))
    }
}

/// The signed area of the screen triangle (a, b, c), `((b − a) × (c − a)) / 2`, with screen y pointing down.
///
/// A triangle that is counter-clockwise seen from outside (isoray's mesh
/// convention) and faces the camera has a **negative** signed area;
/// a positive area means it faces away.
pub fn signed_area(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> f64 {
    0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))
}

/// Whether the screen triangle (a, b, c) of a counter-clockwise-from-outside
/// mesh faces the camera (negative [`signed_area`]). Edge-on triangles
/// (zero area) count as back faces: they cover no pixel.
pub fn is_front_facing(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> bool {
    signed_area(a, b, c) < 0.0
}

/// A vertex with a position and `N` attributes (normal, uv, colour, … packed
/// as numbers) that are interpolated linearly across the triangle in 3D.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Vertex<const N: usize> {
    /// Position (world or camera space, depending on the stage).
    pub position: [f64; 3],
    /// Attributes to interpolate.
    pub attributes: [f64; N],
}

impl<const N: usize> Vertex<N> {
    /// A vertex from a position and attributes.
    pub fn new(position: [f64; 3], attributes: [f64; N]) -> Self {
        Vertex { position, attributes }
    }

    /// Linear interpolation `self + t·(other − self)` of position and
    /// attributes.
    pub fn lerp(&self, other: &Self, t: f64) -> Self {
        let mut position = [0.0; 3];
        for (k, p) in position.iter_mut().enumerate() {
            *p = self.position[k] + t * (other.position[k] - self.position[k]);
        }
        let mut attributes = [0.0; N];
        for (k, a) in attributes.iter_mut().enumerate() {
            *a = self.attributes[k] + t * (other.attributes[k] - self.attributes[k]);
        }
        Vertex { position, attributes }
    }
}

/// Clips a camera-space triangle against the near plane z = −`near`
/// (Sutherland–Hodgman), keeping the part in front (z ≤ −near).
///
/// Returns 0 triangles (all behind), 1 (all in front, returned unchanged, or
/// two vertices behind) or 2 (one vertex behind: the clipped quadrilateral as
/// a fan). The winding order is preserved; vertices on the plane count as in
/// front; new vertices lie exactly on the plane, with attributes interpolated.
pub fn clip_near<const N: usize>(tri: [Vertex<N>; 3], near: f64) -> Vec<[Vertex<N>; 3]> {
    let plane = -near;
    let inside = |v: &Vertex<N>| v.position[2] <= plane;
    if tri.iter().all(inside) {
        return vec![tri];
    }
    let mut poly: Vec<Vertex<N>> = Vec::with_capacity(4);
    for k in 0..3 {
        let a = &tri[k];
        let b = &tri[(k + 1) % 3];
        let (ia, ib) = (inside(a), inside(b));
        if ia {
            poly.push(*a);
        }
        if ia != ib {
            let t = (plane - a.position[2]) / (b.position[2] - a.position[2]);
            let mut v = a.lerp(b, t);
            v.position[2] = plane;
            poly.push(v);
        }
    }
    (1..poly.len().saturating_sub(1))
        .map(|k| [poly[0], poly[k], poly[k + 1]])
        .collect()
}

/// The pixel columns covered by a span from `x_l` to `x_r` under the fill
/// rule: pixel centres x with `x_l <= x < x_r`, i.e. `ceil(x_l) ..
/// ceil(x_r)` (2.3..7.0 covers 3..=6, 2.3..7.4 covers 3..=7).
pub fn span(x_l: f64, x_r: f64) -> std::ops::Range<i64> {
    (x_l.ceil() as i64)..(x_r.ceil() as i64)
}

/// A triangle vertex in screen space, ready for scan conversion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScreenVertex<const N: usize> {
    /// Screen x in pixels (pixel centres at integers).
    pub x: f64,
    /// Screen y in pixels, down (pixel centres at integers).
    pub y: f64,
    /// `1/w` = `1/(−z)`, linear in screen space.
    pub inv_w: f64,
    /// Attributes (perspective-correctly interpolated by [`rasterize`]).
    pub attributes: [f64; N],
}

impl<const N: usize> ScreenVertex<N> {
    /// Projects a camera-space vertex; `None` if it is not in front of the
    /// eye (clip with [`clip_near`] first).
    pub fn from_camera(view: &ViewTransform, v: &Vertex<N>) -> Option<Self> {
        let [x, y, w] = view.camera_to_screen(v.position)?;
        Some(ScreenVertex {
            x,
            y,
            inv_w: 1.0 / w,
            attributes: v.attributes,
        })
    }

    /// The screen position `[x, y]`.
    pub fn xy(&self) -> [f64; 2] {
        [self.x, self.y]
    }
}

/// One covered pixel of a scan-converted triangle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fragment<const N: usize> {
    /// Pixel column.
    pub x: u32,
    /// Pixel row.
    pub y: u32,
    /// Depth `w = −z` at the pixel centre (perspective-correct).
    pub depth: f64,
    /// Attributes at the pixel centre (perspective-correct).
    pub attributes: [f64; N],
}

/// The x of edge (a, b) at height y, computed the same way for every triangle
/// sharing the edge (endpoints ordered by y), exact at the endpoints.
fn edge_x(a: [f64; 2], b: [f64; 2], y: f64) -> f64 {
    let (a, b) = if (a[1], a[0]) <= (b[1], b[0]) { (a, b) } else { (b, a) };
    if y == a[1] {
        a[0]
    } else if y == b[1] {
        b[0]
    } else {
        a[0] + (y - a[1]) * (b[0] - a[0]) / (b[1] - a[1])
    }
}

/// Scan-converts a screen triangle inside a `width`×`height` image, calling
/// `emit` once for every covered pixel centre (fill rule in the module docs)
/// with perspective-correct depth and attributes. Either winding is accepted;
/// degenerate triangles cover nothing.
pub fn rasterize<const N: usize>(
    tri: &[ScreenVertex<N>; 3],
    width: usize,
    height: usize,
    emit: impl FnMut(&Fragment<N>),
) {
    rasterize_rows(tri, width, 0..height, emit)
}

/// [`rasterize`] restricted to the pixel rows `rows` (a band of the image,
/// for rasterising bands in parallel): the fragments are exactly those of
/// [`rasterize`] whose row is in `rows`.
pub fn rasterize_rows<const N: usize>(
    tri: &[ScreenVertex<N>; 3],
    width: usize,
    rows: std::ops::Range<usize>,
    mut emit: impl FnMut(&Fragment<N>),
) {
    let p = [tri[0].xy(), tri[1].xy(), tri[2].xy()];
    let area2 = 2.0 * signed_area(p[0], p[1], p[2]);
    if area2 == 0.0 || !area2.is_finite() || width == 0 || rows.is_empty() {
        return;
    }
    let mut s = p;
    s.sort_by(|a, b| a[1].total_cmp(&b[1]).then(a[0].total_cmp(&b[0])));
    let [v0, v1, v2] = s;
    let y_start = v0[1].ceil().max(rows.start as f64);
    let y_end = v2[1].ceil().min(rows.end as f64);
    let mut y = y_start;
    while y < y_end {
        let x_long = edge_x(v0, v2, y);
        let x_short = if y < v1[1] {
            edge_x(v0, v1, y)
        } else {
            edge_x(v1, v2, y)
        };
        let (x_l, x_r) = if x_long <= x_short {
            (x_long, x_short)
        } else {
            (x_short, x_long)
        };
        let cols = span(x_l, x_r);
        let (c0, c1) = (cols.start.max(0), cols.end.min(width as i64));
        for xi in c0..c1 {
            let q = [xi as f64, y];
            // Screen-space barycentric weights of vertices 0, 1, 2.
            let l0 = 2.0 * signed_area(p[1], p[2], q) / area2;
            let l1 = 2.0 * signed_area(p[2], p[0], q) / area2;
            let l2 = 1.0 - l0 - l1;
            let lw = [l0 * tri[0].inv_w, l1 * tri[1].inv_w, l2 * tri[2].inv_w];
            let inv_w = lw[0] + lw[1] + lw[2];
            let mut attributes = [0.0; N];
            for (k, a) in attributes.iter_mut().enumerate() {
                *a = (lw[0] * tri[0].attributes[k] + lw[1] * tri[1].attributes[k] + lw[2] * tri[2].attributes[k])
                    / inv_w;
            }
            emit(&Fragment {
                x: xi as u32,
                y: y as u32,
                depth: 1.0 / inv_w,
                attributes,
            });
        }
        y += 1.0;
    }
}

/// A depth buffer with a colour buffer: hidden-surface removal by keeping,
/// per pixel, the nearest fragment drawn so far.
#[derive(Debug, Clone, PartialEq)]
pub struct ZBuffer {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Depth (`w = −z`, camera-space distance) of the nearest fragment per
    /// pixel, row-major; `f64::INFINITY` where nothing was drawn.
    pub depth: Vec<f64>,
    /// Colour of the nearest fragment per pixel, row-major.
    pub color: Vec<[f32; 3]>,
}

impl ZBuffer {
    /// An empty buffer: infinite depth, every pixel `background`.
    pub fn new(width: usize, height: usize, background: [f32; 3]) -> Self {
        ZBuffer {
            width,
            height,
            depth: vec![f64::INFINITY; width * height],
            color: vec![background; width * height],
        }
    }

    /// Resets depth to infinity and colour to `background`.
    pub fn clear(&mut self, background: [f32; 3]) {
        self.depth.fill(f64::INFINITY);
        self.color.fill(background);
    }

    /// The colour at pixel (x, y).
    pub fn pixel(&self, x: usize, y: usize) -> [f32; 3] {
        self.color[y * self.width + x]
    }

    /// Scan-converts a screen triangle; every fragment strictly nearer than
    /// what the pixel holds is shaded with `shade` and stored (the shader runs
    /// only for visible-so-far fragments). Returns the number of fragments
    /// written.
    pub fn draw_triangle<const N: usize>(
        &mut self,
        tri: &[ScreenVertex<N>; 3],
        mut shade: impl FnMut(&Fragment<N>) -> [f32; 3],
    ) -> usize {
        let (w, h) = (self.width, self.height);
        let mut written = 0;
        rasterize(tri, w, h, |f| {
            let i = f.y as usize * w + f.x as usize;
            if f.depth < self.depth[i] {
                self.depth[i] = f.depth;
                self.color[i] = shade(f);
                written += 1;
            }
        });
        written
    }

    /// The whole pipeline for one world-space triangle: camera transform,
    /// near-plane clipping at distance `near`, projection, optional back-face
    /// culling (counter-clockwise-from-outside winding) and
    /// [`ZBuffer::draw_triangle`]. Attributes are passed through unchanged
    /// (e.g. world-space normals). Returns the number of fragments written.
    pub fn draw_world_triangle<const N: usize>(
        &mut self,
        view: &ViewTransform,
        near: f64,
        cull_back_faces: bool,
        tri: [Vertex<N>; 3],
        mut shade: impl FnMut(&Fragment<N>) -> [f32; 3],
    ) -> usize {
        let cam = tri.map(|v| Vertex::new(view.world_to_camera(v.position), v.attributes));
        let mut written = 0;
        for piece in clip_near(cam, near) {
            let s = piece.map(|v| ScreenVertex::from_camera(view, &v));
            let [Some(a), Some(b), Some(c)] = s else { continue };
            if cull_back_faces && !is_front_facing(a.xy(), b.xy(), c.xy()) {
                continue;
            }
            written += self.draw_triangle(&[a, b, c], &mut shade);
        }
        written
    }
}
