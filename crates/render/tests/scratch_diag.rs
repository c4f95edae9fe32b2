#[path = "support/chi2.rs"]
mod chi2;
use candela_render::math::{Frame, Vec3};
use candela_render::sampling::warp;
use chi2::*;

#[test]
fn cone() {
    let axis = Vec3::new(0.3, -0.5, 3.5).normalize();
    let fr = Frame::from_normal(axis.to_normal());
    for sin_a in [0.2255f32, 0.1, 0.4] {
        let cos_max = (1.0 - sin_a * sin_a).sqrt();
        for seed in 0..4 {
            let t = Chi2 { name: "cone", grid: Grid::new(axis, 2.0, 24), samples: 200_000, seed, expected_mass: Some(1.0), level: 1e-3 };
            let r = t.run(|u| { let d = fr.to_world(warp::square_to_uniform_cone([u[0], u[1]], cos_max)).normalize(); Some((d, warp::uniform_cone_pdf(cos_max))) },
                      |d| if d.dot(axis) >= cos_max { warp::uniform_cone_pdf(cos_max) } else { 0.0 });
            match r { Ok(r) => println!("sin {sin_a} seed {seed}: p {:.3e} chi2 {:.1} dof {} mass {:.5}", r.p_value, r.chi2, r.dof, r.pdf_integral), Err(e) => println!("{e}") }
        }
    }
}
