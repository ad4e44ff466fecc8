//! An orbit camera: yaw, pitch and distance about the target, with the
//! world's y axis up, to and from the scene's `[camera]` position.
//!
//! ```
//! use isoray_studio::orbit::Orbit;
//! let mut cam = isoray_scene::Camera::default();
//! cam.position = [0.0, 0.0, 5.0];
//! let mut o = Orbit::of(&cam);
//! assert!((o.distance - 5.0).abs() < 1e-12);
//! o.rotate(std::f64::consts::FRAC_PI_2, 0.0);
//! let p = o.position();
//! assert!((p[0] - 5.0).abs() < 1e-9 && p[2].abs() < 1e-9);
//! ```

use isoray_scene::Camera;

/// Pitch stays this far from straight up or down (radians), so the view
/// direction never lines up with `up`.
const PITCH_LIMIT: f64 = 1.55;

/// A camera orbiting its target.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Orbit {
    /// The point looked at.
    pub target: [f64; 3],
    /// Angle about the y axis from +z, radians.
    pub yaw: f64,
    /// Angle above the horizontal plane, radians.
    pub pitch: f64,
    /// Distance from the target.
    pub distance: f64,
}

impl Orbit {
    /// The orbit through the camera's position about its target.
    pub fn of(camera: &Camera) -> Orbit {
        let t = camera.target;
        let d = [
            camera.position[0] - t[0],
            camera.position[1] - t[1],
            camera.position[2] - t[2],
        ];
        let distance = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt().max(1e-6);
        Orbit {
            target: t,
            yaw: d[0].atan2(d[2]),
            pitch: (d[1] / distance).clamp(-1.0, 1.0).asin(),
            distance,
        }
    }

    /// Turns by `dyaw` about the vertical and tilts by `dpitch`.
    pub fn rotate(&mut self, dyaw: f64, dpitch: f64) {
        self.yaw += dyaw;
        self.pitch = (self.pitch + dpitch).clamp(-PITCH_LIMIT, PITCH_LIMIT);
    }

    /// Multiplies the distance by `factor` (kept positive).
    pub fn zoom(&mut self, factor: f64) {
        if factor.is_finite() && factor > 0.0 {
            self.distance = (self.distance * factor).max(1e-3);
        }
    }

    /// Slides the target (and the eye with it) across the view: `dx` to
    /// the right and `dy` up on screen, in units of the distance to the
    /// target, so a pan moves the picture by the same fraction at any zoom.
    pub fn pan(&mut self, dx: f64, dy: f64) {
        if !(dx.is_finite() && dy.is_finite()) {
            return;
        }
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        // The view direction is -(cp·sy, sp, cp·cy); right = forward × y
        // and up = right × forward, both unit vectors.
        let right = [cy, 0.0, -sy];
        let up = [-sp * sy, cp, -sp * cy];
        let r = self.distance;
        for k in 0..3 {
            self.target[k] += r * (dx * right[k] + dy * up[k]);
        }
    }

    /// The eye position.
    pub fn position(&self) -> [f64; 3] {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        let r = self.distance;
        [
            self.target[0] + r * cp * sy,
            self.target[1] + r * sp,
            self.target[2] + r * cp * cy,
        ]
    }

    /// Sets the camera's position and target to this orbit's (y up).
    pub fn apply(&self, camera: &mut Camera) {
        camera.position = self.position();
        camera.target = self.target;
        camera.up = [0.0, 1.0, 0.0];
    }
}
