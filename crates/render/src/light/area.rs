//! Area lights: emissive shapes sampled by area or by solid angle.
//!
//! Every emissive surface is an area light. Spheres seen from outside are sampled uniformly in
//! the cone they subtend (when their placement is a similarity); other spheres (ellipsoids),
//! parallelograms, disks, boxes and meshes are sampled uniformly by area (mesh triangles chosen
//! in proportion to their area, which for a uniform emitter is their power). Planes, polyhedra
//! and CSG emit but are not sampled: paths find them by BSDF sampling alone.

use super::Emission;
use super::{LightSample, Target};
use crate::color::Rgb;
use crate::geometry::Geometry;
use crate::math::{Normal3, Point3, Vec3, PI};
use crate::sampling::{warp, Distribution1D};
use crate::shape::{Cube, Disk, LocalGeometry, Mesh, Parallelogram, Sphere};
use crate::spectrum::Wavelengths;

/// The sampleable shape of an area light.
// An explicit tag: a match reads one byte, where the niche in a field cost six instructions.
#[derive(Clone, Debug, PartialEq)]
#[repr(u8)]
pub enum AreaShape {
    /// A sphere; `cone` holds its centre and radius when its placement is a similarity.
    Sphere {
        /// The sphere.
        sphere: Sphere,
        /// Centre and radius for cone sampling.
        cone: Option<(Point3, f32)>,
    },
    /// A parallelogram.
    Parallelogram(Parallelogram),
    /// A disk.
    Disk(Disk),
    /// A box, its faces chosen by area.
    Cube {
        /// The box.
        cube: Cube,
        /// Distribution over the six faces.
        faces: Distribution1D,
    },
    /// The triangles of a mesh, chosen by area.
    Mesh {
        /// Mesh index in the geometry.
        mesh: u32,
        /// Distribution over its triangles.
        triangles: Distribution1D,
    },
}

/// An emissive shape with the index of its emission.
#[derive(Clone, Debug, PartialEq)]
pub struct AreaLight {
    /// What is sampled.
    pub shape: AreaShape,
    /// Index into the scene's emissions.
    pub emission: u32,
    /// Total area.
    pub area: f32,
    /// 1 / `area`: the density of uniform area sampling.
    inv_area: f32,
}

impl AreaLight {
    /// A sphere light.
    pub fn sphere(sphere: Sphere, emission: u32) -> Self {
        let m = &sphere.world_from_object;
        let (c0, c1, c2) = (m.vector(Vec3::X), m.vector(Vec3::Y), m.vector(Vec3::Z));
        let r = c0.norm();
        let similar = (c1.norm() - r).abs() < 1e-4 * r
            && (c2.norm() - r).abs() < 1e-4 * r
            && c0.dot(c1).abs() < 1e-4 * r * r
            && c1.dot(c2).abs() < 1e-4 * r * r
            && c0.dot(c2).abs() < 1e-4 * r * r;
        let cone = similar.then(|| (m.point(Point3::ORIGIN), r));
        let area = match cone {
            Some((_, r)) => 4.0 * PI * r * r,
            None => ellipsoid_area(c0.norm(), c1.norm(), c2.norm()),
        };
        Self {
            shape: AreaShape::Sphere { sphere, cone },
            emission,
            area,
            inv_area: 1.0 / area,
        }
    }

    /// A parallelogram light.
    pub fn parallelogram(p: Parallelogram, emission: u32) -> Self {
        let area = p.area();
        Self {
            shape: AreaShape::Parallelogram(p),
            emission,
            area,
            inv_area: 1.0 / area,
        }
    }

    /// A disk light.
    pub fn disk(d: Disk, emission: u32) -> Self {
        let w = &d.world_from_object;
        let area = PI * w.vector(Vec3::X).cross(w.vector(Vec3::Y)).norm();
        Self {
            shape: AreaShape::Disk(d),
            emission,
            area,
            inv_area: 1.0 / area,
        }
    }

    /// A box light.
    pub fn cube(cube: Cube, emission: u32) -> Self {
        let areas = cube.face_areas();
        let area = areas.iter().sum();
        Self {
            shape: AreaShape::Cube {
                faces: Distribution1D::new(&areas),
                cube,
            },
            emission,
            area,
            inv_area: 1.0 / area,
        }
    }

    /// A light over `m`, which is mesh `index` of the scene's geometry.
    pub fn mesh(m: &Mesh, index: u32, emission: u32) -> Self {
        let areas: Vec<f32> = (0..m.len() as u32).map(|i| m.area(i)).collect();
        let area = areas.iter().map(|&a| a as f64).sum::<f64>() as f32;
        Self {
            shape: AreaShape::Mesh {
                mesh: index,
                triangles: Distribution1D::new(&areas),
            },
            emission,
            area,
            inv_area: 1.0 / area,
        }
    }

    /// 1 / the light's area: the area density of its samples (but a sphere's).
    #[inline]
    pub fn inv_area(&self) -> f32 {
        self.inv_area
    }

    /// A point on the light and its area density.
    fn sample_area(&self, geometry: &Geometry, u: [f32; 2]) -> Option<(LocalGeometry, f32)> {
        let g = match &self.shape {
            AreaShape::Sphere { sphere, .. } => {
                let q = warp::square_to_uniform_sphere(u);
                let g = sphere.geometry_at(q);
                return Some((g, self.sphere_area_pdf(sphere, q)));
            }
            AreaShape::Parallelogram(p) => p.geometry(u[0], u[1]),
            AreaShape::Disk(d) => {
                let q = warp::square_to_concentric_disk(u);
                d.geometry(q.x, q.y)
            }
            AreaShape::Cube { cube, faces } => {
                let (face, u0) = faces.sample_discrete(u[0]);
                cube.surface(
                    face as u32,
                    Cube::face_point(face as u32, 2.0 * u0 - 1.0, 2.0 * u[1] - 1.0),
                )
            }
            // The path tracer's Lambert lanes repeat this for meshes whose triangles keep
            // their faces (`integrator/path/surface_lanes.rs`, `LaneLight::Tri`): change both.
            AreaShape::Mesh { mesh, triangles } => {
                let (tri, u0) = triangles.sample_discrete(u[0]);
                let (b1, b2) = warp::square_to_uniform_triangle([u0, u[1]]);
                geometry.mesh_geometry(*mesh, tri as u32, b1, b2).0
            }
        };
        Some((g, self.inv_area))
    }

    /// The area density of uniform-sphere sampling mapped through an arbitrary placement: the
    /// object-space density 1/(4π) divided by the area scale |det M|·|M⁻ᵀ q| at q.
    fn sphere_area_pdf(&self, sphere: &Sphere, q: Vec3) -> f32 {
        if let AreaShape::Sphere {
            cone: Some((_, r)), ..
        } = &self.shape
        {
            return 1.0 / (4.0 * PI * r * r);
        }
        let t = &sphere.world_from_object;
        let (c0, c1, c2) = (t.vector(Vec3::X), t.vector(Vec3::Y), t.vector(Vec3::Z));
        let det = c0.dot(c1.cross(c2)).abs();
        let scale = det * t.normal(q.to_normal()).to_vec().norm();
        1.0 / (4.0 * PI * scale)
    }

    /// [`AreaLight::sample`] for a parallelogram light (`None` for other shapes; `Some(None)`
    /// when the sample is unusable). The path tracer's Lambert lanes repeat it on sixteen lanes
    /// (`integrator/path/surface_lanes.rs`): change both.
    #[inline(always)]
    pub(super) fn sample_parallelogram(
        &self,
        emissions: &[Emission],
        p: Point3,
        u: [f32; 2],
        lambda: &Wavelengths,
    ) -> Option<Option<LightSample>> {
        let AreaShape::Parallelogram(q) = &self.shape else {
            return None;
        };
        let emission = &emissions[self.emission as usize];
        Some(area_sample(
            emission,
            p,
            q.geometry(u[0], u[1]),
            self.inv_area,
            lambda,
        ))
    }

    /// Samples a point of the light seen from `p`: the direction, emitted radiance towards `p`,
    /// and the density per unit solid angle.
    pub fn sample(
        &self,
        geometry: &Geometry,
        emissions: &[Emission],
        p: Point3,
        u: [f32; 2],
        lambda: &Wavelengths,
    ) -> Option<LightSample> {
        let emission = &emissions[self.emission as usize];
        // Parallelograms (the usual area light) on a straight path of their own, so that the
        // sampled point stays in registers.
        if let AreaShape::Parallelogram(q) = &self.shape {
            return area_sample(emission, p, q.geometry(u[0], u[1]), self.inv_area, lambda);
        }
        if let AreaShape::Sphere {
            sphere,
            cone: Some((c, r)),
        } = &self.shape
        {
            let d2 = p.squared_distance(*c);
            if d2 > r * r * 1.0001 {
                // Sample the cone of directions the sphere subtends (1 − cos θ_max from
                // sin²θ_max = r²/d², exact for the tiny cones of small, distant spheres).
                // (The path tracer's lanes repeat these operations, `SphereSamples` in
                // `integrator/path/surface_lanes.rs`: change both.)
                let one_minus_cos = warp::one_minus_cos_from_sin2(r * r / d2);
                let d = d2.sqrt();
                let axis = (*c - p) / d;
                let frame = crate::math::Frame::from_normal(axis.to_normal());
                // (Unit to round-off: a unit vector in an orthonormal frame. The sample waits
                // on a chain of square roots and divisions; nothing is added to it that the
                // geometry gives otherwise.)
                let wi = frame.to_world(warp::square_to_uniform_cone_narrow(u, one_minus_cos));
                // Where the direction meets the sphere, in world space (the sphere is round
                // there), from the sampled angle θ off the axis (a = 1 − cos θ, as the cone
                // sample draws it): along wi the centre is at d·cos θ, the ray passes at
                // h² = d²·sin²θ = d²·a(2 − a) from it and enters √(r² − h²) before (the tangent
                // point at the silhouette, where round-off may make r² − h² negative). The
                // normal is the point's offset from the centre over the radius.
                let a = u[0] * one_minus_cos;
                let h2 = d2 * (a * (2.0 - a));
                let t = d * (1.0 - a) - (r * r - h2).max(0.0).sqrt();
                let n = (p + wi * t - *c) * (1.0 / *r);
                let q = *c + n * *r;
                // A uniform radiance reads no texture coordinates.
                let uv = if emission.radiance.is_constant() {
                    crate::math::Point2::new(0.0, 0.0)
                } else {
                    let o = sphere.world_from_object.inv_point(q).to_vec();
                    sphere.geometry_at(o / o.norm()).uv
                };
                let n = n.to_normal();
                let li = emission.radiance_at(uv, n, -wi, lambda);
                return Some(LightSample {
                    wi,
                    li,
                    pdf: warp::uniform_cone_pdf_narrow(one_minus_cos),
                    delta: false,
                    target: Target::Surface(q, n),
                });
            }
        }
        let (g, pdf_area) = self.sample_area(geometry, u)?;
        area_sample(emission, p, g, pdf_area, lambda)
    }

    /// The solid-angle density with which [`AreaLight::sample`] picks the point `q` (normal `n`)
    /// of the light as seen from `p`.
    pub fn pdf(&self, p: Point3, q: Point3, n: Normal3) -> f32 {
        let pdf_area = match &self.shape {
            AreaShape::Sphere { sphere, cone } => {
                if let Some((c, r)) = cone {
                    let d2 = p.squared_distance(*c);
                    if d2 > r * r * 1.0001 {
                        return warp::uniform_cone_pdf_narrow(warp::one_minus_cos_from_sin2(
                            r * r / d2,
                        ));
                    }
                }
                let ql = sphere.world_from_object.inv_point(q).to_vec();
                self.sphere_area_pdf(sphere, ql / ql.norm())
            }
            _ => self.inv_area,
        };
        let to = q - p;
        let d2 = to.squared_norm();
        let cos = n.dot_vec(to).abs() / d2.sqrt();
        if cos > 0.0 {
            pdf_area * d2 / cos
        } else {
            0.0
        }
    }

    /// The total emitted power (flux) for a uniform emitter: π·L·A (one side) or twice that.
    pub fn power(&self, emissions: &[Emission]) -> Rgb {
        let e = &emissions[self.emission as usize];
        e.radiance.average() * (PI * self.area * if e.two_sided { 2.0 } else { 1.0 })
    }
}

/// The light sample for the point `g` of an emitter, drawn with area density `pdf_area`, as
/// seen from `p`.
#[inline(always)]
fn area_sample(
    emission: &Emission,
    p: Point3,
    g: LocalGeometry,
    pdf_area: f32,
    lambda: &Wavelengths,
) -> Option<LightSample> {
    let to = g.p - p;
    let d2 = to.squared_norm();
    if !(d2 > 0.0) {
        return None;
    }
    let wi = to / d2.sqrt();
    let cos = g.n.dot_vec(wi).abs();
    if !(cos > 0.0) {
        return None;
    }
    Some(LightSample {
        wi,
        li: emission.radiance_at(g.uv, g.n, -wi, lambda),
        pdf: pdf_area * d2 / cos,
        delta: false,
        target: Target::Surface(g.p, g.n),
    })
}

/// The surface area of an ellipsoid with semi-axes a, b, c (Knud Thomsen's formula, within
/// ~1 %; only used for the power of ellipsoidal lights).
fn ellipsoid_area(a: f32, b: f32, c: f32) -> f32 {
    let p = 1.6075f32;
    let (ap, bp, cp) = (a.powf(p), b.powf(p), c.powf(p));
    4.0 * PI * ((ap * bp + ap * cp + bp * cp) / 3.0).powf(1.0 / p)
}
