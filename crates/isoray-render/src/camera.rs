//! Primary rays from the scene camera (the convention of `docs/SCENE.md`).

use glam::DVec3;
use isoray_scene::{Camera, Projection};

/// A pinhole camera ready to generate rays for one image size.
#[derive(Debug, Clone, Copy)]
pub struct RayCamera {
    origin: DVec3,
    forward: DVec3,
    right: DVec3,
    up: DVec3,
    tan_half: f64,
    aspect: f64,
    width: f64,
    height: f64,
    projection: Projection,
}

impl RayCamera {
    /// Sets up the camera for a `width`×`height` image.
    pub fn new(c: &Camera, width: u32, height: u32) -> Self {
        let [forward, right, up] = c.basis().map(DVec3::from);
        RayCamera {
            origin: DVec3::from(c.position),
            forward,
            right,
            up,
            tan_half: c.tan_half_fov(),
            aspect: width as f64 / height as f64,
            width: width as f64,
            height: height as f64,
            projection: c.projection,
        }
    }

    /// The ray origin (the eye).
    pub fn origin(&self) -> DVec3 {
        self.origin
    }

    /// The unit direction through image position (x, y) in pixels, where
    /// (i + 0.5, j + 0.5) is the centre of pixel (i, j).
    /// With the equirectangular projection, (x / width, y / height) is the
    /// (u, v) of `isoray_scene::env`, in world axes.
    pub fn direction(&self, x: f64, y: f64) -> DVec3 {
        if self.projection == Projection::Equirect {
            return DVec3::from(isoray_scene::env::equirect_direction(x / self.width, y / self.height));
        }
        let ndc_x = x / self.width * 2.0 - 1.0;
        let ndc_y = 1.0 - y / self.height * 2.0;
        (self.forward + ndc_x * self.tan_half * self.aspect * self.right + ndc_y * self.tan_half * self.up).normalize()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_pixel_looks_at_target() {
        let cam = Camera {
            position: [0.0, 0.0, 5.0],
            target: [0.0, 0.0, 0.0],
            up: [0.0, 1.0, 0.0],
            fov: 90.0,
            projection: Projection::Perspective,
        };
        let rc = RayCamera::new(&cam, 100, 50);
        let d = rc.direction(50.0, 25.0);
        assert!((d - DVec3::new(0.0, 0.0, -1.0)).length() < 1e-12);
        // Top edge centre: 45 degrees up for a 90 degree vertical fov.
        let top = rc.direction(50.0, 0.0);
        assert!((top - DVec3::new(0.0, 1.0, -1.0).normalize()).length() < 1e-12);
        // Right edge: tan = aspect = 2; x to the right is +x.
        let r = rc.direction(100.0, 25.0);
        assert!((r - DVec3::new(2.0, 0.0, -1.0).normalize()).length() < 1e-12);
    }
}
