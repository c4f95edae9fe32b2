//! Cameras with the course's conventions.
//!
//! In its own frame a camera looks along **+x** with **+z up**; the image's u coordinate grows
//! towards −y (to the right) and v grows upwards. A camera is placed in the world by its
//! transformation `world_from_camera`.
//!
//! - Orthogonal: the ray for (u, v) starts at (−1, (1−2u)·a, 2v−1) with direction (1, 0, 0).
//! - Perspective: the ray starts at (−d, 0, 0) with direction (d, (1−2u)·a, 2v−1), where `d` is
//!   the distance between the eye and the screen: the vertical field of view is 2·atan(1/d).
//!
//! `a` is the aspect ratio (width/height of the screen). Camera rays are normalised in world
//! space, so that hit parameters are distances.

use crate::math::{Point3, Ray, Transform, Vec3};

/// How a camera projects the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Parallel rays.
    Orthogonal,
    /// Rays from an eye at distance `distance` behind the screen.
    Perspective {
        /// The screen distance `d`.
        distance: f32,
    },
}

/// A camera: projection, screen aspect ratio and placement.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// The projection.
    pub projection: Projection,
    /// Width over height of the screen.
    pub aspect_ratio: f32,
    /// Camera → world.
    pub world_from_camera: Transform,
}

impl Camera {
    /// An orthogonal camera.
    pub fn orthogonal(aspect_ratio: f32, world_from_camera: Transform) -> Self {
        Self {
            projection: Projection::Orthogonal,
            aspect_ratio,
            world_from_camera,
        }
    }

    /// A perspective camera with screen distance `distance`.
    pub fn perspective(distance: f32, aspect_ratio: f32, world_from_camera: Transform) -> Self {
        Self {
            projection: Projection::Perspective { distance },
            aspect_ratio,
            world_from_camera,
        }
    }

    /// A perspective camera from its vertical field of view in degrees (0 < fov < 180).
    pub fn perspective_fov(
        vertical_fov_deg: f32,
        aspect_ratio: f32,
        world_from_camera: Transform,
    ) -> Self {
        Self::perspective(
            distance_for_fov(vertical_fov_deg),
            aspect_ratio,
            world_from_camera,
        )
    }

    /// The ray through the screen point (u, v) ∈ [0,1]²: u = 0 is the left edge, v = 0 the bottom.
    #[inline]
    pub fn ray(&self, u: f32, v: f32) -> Ray {
        let sy = (1.0 - 2.0 * u) * self.aspect_ratio;
        let sz = 2.0 * v - 1.0;
        let (o, d) = match self.projection {
            Projection::Orthogonal => (Point3::new(-1.0, sy, sz), Vec3::X),
            Projection::Perspective { distance } => (
                Point3::new(-distance, 0.0, 0.0),
                Vec3::new(distance, sy, sz),
            ),
        };
        let t = &self.world_from_camera;
        Ray::new(t.point(o), t.vector(d).normalize())
    }
}

/// The screen distance whose vertical field of view is `fov_deg` degrees.
pub fn distance_for_fov(fov_deg: f32) -> f32 {
    1.0 / (fov_deg.to_radians() / 2.0).tan()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn orthogonal_corner_rays_by_hand() {
        let c = Camera::orthogonal(2.0, Transform::IDENTITY);
        let r = c.ray(0.0, 0.0);
        assert_eq!(r.o, Point3::new(-1.0, 2.0, -1.0));
        assert_eq!(r.d, Vec3::X);
        assert_eq!(c.ray(1.0, 1.0).o, Point3::new(-1.0, -2.0, 1.0));
        assert_eq!(c.ray(0.0, 1.0).o, Point3::new(-1.0, 2.0, 1.0));
        assert_eq!(c.ray(1.0, 0.0).o, Point3::new(-1.0, -2.0, -1.0));
    }

    #[test]
    fn perspective_corner_rays_hit_the_screen_corners() {
        let c = Camera::perspective(1.0, 2.0, Transform::IDENTITY);
        for (u, v, corner) in [
            (0.0, 0.0, Point3::new(0.0, 2.0, -1.0)),
            (1.0, 0.0, Point3::new(0.0, -2.0, -1.0)),
            (0.0, 1.0, Point3::new(0.0, 2.0, 1.0)),
            (1.0, 1.0, Point3::new(0.0, -2.0, 1.0)),
        ] {
            let r = c.ray(u, v);
            assert_eq!(r.o, Point3::new(-1.0, 0.0, 0.0));
            // The screen is the plane x = 0: reach it at t = 1/d.x.
            let p = r.at(1.0 / r.d.x);
            assert!(p.approx_eq(corner, 1e-5), "{p:?}");
        }
    }

    #[test]
    fn cameras_follow_their_transformation() {
        let c = Camera::orthogonal(
            1.0,
            Transform::translation(Vec3::new(0.0, -2.0, 0.0)) * Transform::rotation_z(90.0),
        );
        let r = c.ray(0.5, 0.5);
        assert!(r.o.approx_eq(Point3::new(0.0, -3.0, 0.0), 1e-6));
        assert!(r.d.approx_eq(Vec3::Y, 1e-6));
    }

    #[test]
    fn field_of_view_sets_the_distance() {
        assert!((distance_for_fov(90.0) - 1.0).abs() < 1e-6);
        let c = Camera::perspective_fov(60.0, 1.0, Transform::IDENTITY);
        let top = c.ray(0.5, 1.0).d;
        assert!((top.z.atan2(top.x).to_degrees() - 30.0).abs() < 1e-4);
    }
}
