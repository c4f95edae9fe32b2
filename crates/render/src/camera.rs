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
//!
//! A perspective camera may have a thin [`Lens`] (depth of field, Mitsuba's `thinlens`): the
//! ray for (u, v) then starts at a uniformly sampled point of the aperture, a disk around the
//! eye perpendicular to the view axis, and passes through the point where the pinhole ray meets
//! the plane in focus, so that only that plane is sharp.

use crate::math::{Point3, Ray, Transform, Vec3, BATCH};
use crate::sampling::warp::square_to_concentric_disk;

/// A thin lens, in the units of the camera's frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lens {
    /// Radius of the aperture (> 0).
    pub radius: f32,
    /// Distance from the aperture to the plane in focus, along the view axis (> 0).
    pub focus_distance: f32,
}

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
    /// The thin lens of a perspective camera with depth of field; `None` for a pinhole.
    pub lens: Option<Lens>,
}

impl Camera {
    /// An orthogonal camera.
    pub fn orthogonal(aspect_ratio: f32, world_from_camera: Transform) -> Self {
        Self {
            projection: Projection::Orthogonal,
            aspect_ratio,
            world_from_camera,
            lens: None,
        }
    }

    /// A perspective camera with screen distance `distance`.
    pub fn perspective(distance: f32, aspect_ratio: f32, world_from_camera: Transform) -> Self {
        Self {
            projection: Projection::Perspective { distance },
            aspect_ratio,
            world_from_camera,
            lens: None,
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

    /// The ray through the screen point (u, v) ∈ \[0, 1\]²: u = 0 is the left edge, v = 0 the bottom.
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

    /// [`Camera::ray`] for each point `uv[k]` of the screen, into `rays[k]` (a camera without
    /// a lens): the same rays, bit for bit, with the pinhole's position computed once and the
    /// directions lane by lane in arrays the compiler vectorises.
    pub fn rays(&self, uv: &[[f32; 2]; BATCH], n: usize, rays: &mut [Ray]) {
        debug_assert!(self.lens.is_none() && n <= BATCH && n <= rays.len());
        let Projection::Perspective { distance } = self.projection else {
            for (r, &[u, v]) in rays.iter_mut().zip(uv).take(n) {
                *r = self.ray(u, v);
            }
            return;
        };
        let t = &self.world_from_camera;
        let o = t.point(Point3::new(-distance, 0.0, 0.0));
        let m = &t.m.m;
        let (mut x, mut y, mut z) = ([0f32; BATCH], [0f32; BATCH], [0f32; BATCH]);
        for k in 0..BATCH {
            let sy = (1.0 - 2.0 * uv[k][0]) * self.aspect_ratio;
            let sz = 2.0 * uv[k][1] - 1.0;
            // Transform::vector and Vec3::normalize, written out over the lanes.
            let dx = m[0][0] * distance + m[0][1] * sy + m[0][2] * sz;
            let dy = m[1][0] * distance + m[1][1] * sy + m[1][2] * sz;
            let dz = m[2][0] * distance + m[2][1] * sy + m[2][2] * sz;
            let inv = 1.0 / (dx * dx + dy * dy + dz * dz).sqrt();
            (x[k], y[k], z[k]) = (dx * inv, dy * inv, dz * inv);
        }
        for k in 0..n {
            rays[k] = Ray::new(o, Vec3::new(x[k], y[k], z[k]));
        }
    }

    /// The same camera with a thin lens (perspective cameras only; others stay as they are).
    pub fn with_lens(self, lens: Lens) -> Self {
        match self.projection {
            Projection::Perspective { .. } => Self {
                lens: Some(lens),
                ..self
            },
            Projection::Orthogonal => self,
        }
    }

    /// The ray through (u, v) from the point of the aperture that `lens_sample` ∈ [0,1)² picks
    /// uniformly; [`Camera::ray`] without a lens.
    #[inline]
    pub fn ray_through_lens(&self, u: f32, v: f32, lens_sample: [f32; 2]) -> Ray {
        let (Some(lens), Projection::Perspective { distance }) = (self.lens, self.projection)
        else {
            return self.ray(u, v);
        };
        let eye = Point3::new(-distance, 0.0, 0.0);
        let dir = Vec3::new(distance, (1.0 - 2.0 * u) * self.aspect_ratio, 2.0 * v - 1.0);
        let focus = eye + dir * (lens.focus_distance / distance);
        let p = square_to_concentric_disk(lens_sample);
        let o = eye + Vec3::new(0.0, p.x * lens.radius, p.y * lens.radius);
        let t = &self.world_from_camera;
        Ray::new(t.point(o), t.vector(focus - o).normalize())
    }
}

/// The screen distance whose vertical field of view is `fov_deg` degrees.
pub fn distance_for_fov(fov_deg: f32) -> f32 {
    1.0 / (fov_deg.to_radians() / 2.0).tan()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A batch of pinhole rays is [`Camera::ray`] lane by lane, bit for bit, for both
    /// projections and a partial batch.
    #[test]
    fn batched_rays_are_the_single_rays() {
        let place = Transform::look_at(
            Point3::new(0.3, 3.5, 8.5),
            Point3::new(0.0, 0.5, 0.1),
            Vec3::new(0.0, 1.0, 0.0),
        )
        .unwrap();
        let mut uv = [[0f32; 2]; BATCH];
        for (k, p) in uv.iter_mut().enumerate() {
            *p = [
                (k as f32 * 0.37 + 0.01).fract(),
                (k as f32 * 0.61 + 0.3).fract(),
            ];
        }
        for cam in [
            Camera::perspective_fov(50.0, 1.3, place),
            Camera::orthogonal(0.8, place),
        ] {
            for n in [BATCH, 5] {
                let mut rays = [Ray::new(Point3::ORIGIN, Vec3::X); BATCH];
                cam.rays(&uv, n, &mut rays);
                for k in 0..n {
                    let one = cam.ray(uv[k][0], uv[k][1]);
                    assert_eq!(rays[k].o, one.o, "{k}");
                    let bits = |v: Vec3| [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()];
                    assert_eq!(bits(rays[k].d), bits(one.d), "{k}");
                    assert_eq!((rays[k].tmin, rays[k].tmax), (one.tmin, one.tmax));
                }
            }
        }
    }

    /// Every ray of a thin lens for one screen point starts on the aperture disk (radius 0.2
    /// around the eye, across the view axis) and passes through the one point where the pinhole
    /// ray meets the plane in focus (5 units ahead); without a lens nothing changes.
    #[test]
    fn thin_lens_rays_meet_on_the_plane_in_focus() {
        let place = Transform::translation(Vec3::new(1.0, 2.0, 3.0)) * Transform::rotation_z(30.0);
        let pinhole = Camera::perspective(2.0, 1.5, place);
        let lens = Lens {
            radius: 0.2,
            focus_distance: 5.0,
        };
        let c = pinhole.with_lens(lens);
        assert_eq!(
            pinhole.ray_through_lens(0.3, 0.6, [0.9, 0.1]),
            pinhole.ray(0.3, 0.6)
        );
        assert_eq!(Camera::orthogonal(1.0, place).with_lens(lens).lens, None);
        let (u, v) = (0.3, 0.6);
        let p = pinhole.ray(u, v);
        let eye = place.point(Point3::new(-2.0, 0.0, 0.0));
        let axis = place.vector(Vec3::X);
        // The pinhole ray reaches the plane in focus after 5 / cos(angle to the axis).
        let focus = p.at(5.0 / p.d.dot(axis));
        let mut mean = Vec3::new(0.0, 0.0, 0.0);
        let n = 64;
        for i in 0..n {
            let s = [(i % 8) as f32 / 8.0 + 0.03, (i / 8) as f32 / 8.0 + 0.05];
            let r = c.ray_through_lens(u, v, s);
            let off = r.o - eye;
            assert!(
                off.norm() <= 0.2 + 1e-5 && off.dot(axis).abs() < 1e-5,
                "{off:?}"
            );
            let t = (focus - r.o).dot(r.d);
            assert!(
                (r.at(t) - focus).norm() < 1e-4,
                "{i}: misses the focus point"
            );
            mean += off / n as f32;
        }
        // The stratified aperture samples are spread around the eye.
        assert!(mean.norm() < 0.02, "{mean:?}");
    }

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
