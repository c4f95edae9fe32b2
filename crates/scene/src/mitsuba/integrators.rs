//! Mitsuba `<integrator>` plugins: which of candela's integrators renders the scene, and with
//! what path length, roulette and emitter visibility (render hints).

use super::props::Props;
use super::xml::Element;
use super::Loader;
use crate::error::SceneError;

impl<'t> Loader<'t> {
    /// `<integrator>`: render hints.
    pub(super) fn integrator(&mut self, e: &'t Element) -> Result<(), SceneError> {
        let p = self.props(e)?;
        let max_depth = |p: &Props| {
            p.int_in("max_depth", -1, (-1, i32::MAX as i64))
                .map(|d| d as i32)
        };
        let rr_depth = |p: &Props| {
            p.int_in("rr_depth", 5, (1, u32::MAX as i64))
                .map(|d| d as u32)
        };
        let (depth, rr) = match e.kind() {
            "path" | "volpath" | "volpathmis" | "prb" | "prbvolpath" | "ptracer" => {
                (max_depth(&p)?, rr_depth(&p)?)
            }
            // Mitsuba's `direct` is physically based direct illumination: paths of at most two
            // vertices, which is what the path tracer computes with max_depth 2.
            "direct" | "direct_projective" => {
                p.ignore(&["emitter_samples", "bsdf_samples", "shading_samples"]);
                (2, 5)
            }
            // Mitsuba's `moment` renders its nested integrators and adds their second moments
            // as AOVs: candela renders the first one, as that integrator.
            "moment" => {
                let nested = p.objects("integrator");
                let Some(&(first, _)) = nested.first() else {
                    return Err(self.err(e.pos, "integrator 'moment' needs a nested <integrator>"));
                };
                self.warn(
                    e.pos,
                    format!(
                        "integrator 'moment': rendering its first nested integrator '{}' (no moment AOVs){}",
                        first.kind(),
                        if nested.len() > 1 { "; the other nested integrators are ignored" } else { "" }
                    ),
                );
                self.finish(&p);
                return self.integrator(first);
            }
            other => {
                return Err(self.err(
                    e.pos,
                    format!("unsupported integrator '{other}' (supported: path, volpath, volpathmis, prb, prbvolpath, ptracer (as path), direct, direct_projective, moment)"),
                ));
            }
        };
        self.hints.integrator = Some("path".into());
        self.hints.max_depth = Some(depth);
        self.hints.rr_depth = Some(rr);
        self.hints.hide_emitters = p.or("hide_emitters", false)?;
        p.ignore(&["samples_per_pass", "timeout"]);
        self.finish(&p);
        Ok(())
    }
}
