//! Rows of the form-factor matrix ([`super::row`]), computed on demand by the chosen method
//! (hemicube or ray casting). Gauss–Seidel computes and keeps all rows (in parallel); progressive
//! refinement asks for the rows of its shooting patches only and keeps them in a bounded cache,
//! so it never needs the N² matrix.

use super::hemicube::{Hemicube, HemicubeScratch, Raster};
use super::mesh::Meshing;
use super::options::{FormFactorMethod, RadiosityOptions};
use super::patches::{infos, PatchInfo};
use super::raycast::{self, RayCasting};
use super::row::{Row, RowAcc};
use crate::scene::Scene;
use rayon::prelude::*;

/// Computes rows with one method.
pub(crate) struct Engine<'a> {
    scene: &'a Scene,
    mesh: &'a Meshing,
    hemicube: Option<(Hemicube, Raster)>,
    rays: u32,
    seed: u64,
    emitters: Option<Vec<u32>>,
    traced: Vec<bool>,
}

/// Per-thread scratch memory of an [`Engine`].
pub(crate) struct Scratch {
    acc: RowAcc,
    hc: Option<HemicubeScratch>,
}

impl<'a> Engine<'a> {
    /// An engine for `mesh` (whose patches are final).
    pub fn new(
        scene: &'a Scene,
        mesh: &'a Meshing,
        method: FormFactorMethod,
        resolution: u32,
        rays: u32,
        seed: u64,
    ) -> Self {
        let hemicube = (method == FormFactorMethod::Hemicube)
            .then(|| (Hemicube::new(resolution), Raster::new(mesh)));
        let emitters = if method == FormFactorMethod::RayCast {
            raycast::emitter_list(mesh)
        } else {
            None
        };
        Self {
            scene,
            mesh,
            hemicube,
            rays,
            seed,
            emitters,
            traced: raycast::traced_materials(scene),
        }
    }

    /// Fresh scratch memory for one thread.
    pub fn scratch(&self) -> Scratch {
        Scratch {
            acc: RowAcc::new(self.mesh.patches.len()),
            hc: self.hemicube.as_ref().map(|(h, _)| h.scratch()),
        }
    }

    /// Row `i`.
    pub fn row(&self, i: u32, s: &mut Scratch) -> Row {
        match (&self.hemicube, &mut s.hc) {
            (Some((h, raster)), Some(hs)) => h.row(raster, self.mesh, i, hs, &mut s.acc),
            _ => RayCasting {
                scene: self.scene,
                mesh: self.mesh,
                traced: &self.traced,
                rays: self.rays,
                seed: self.seed,
                emitters: self.emitters.as_deref(),
            }
            .row(i, &mut s.acc),
        }
    }

    /// The rows of `ids`, computed in parallel (the result does not depend on the thread count).
    pub fn rows(&self, ids: &[u32]) -> Vec<Row> {
        ids.par_iter()
            .map_init(|| self.scratch(), |s, &i| self.row(i, s))
            .collect()
    }
}

/// The patches of a scene (without refinement) and every row of their form-factor matrix.
#[derive(Clone, Debug)]
pub struct FormFactorMatrix {
    /// The patches.
    pub patches: Vec<PatchInfo>,
    /// Row i: the non-zero F_ij as (j, F_ij), sorted by j.
    pub rows: Vec<Vec<(u32, f32)>>,
}

impl FormFactorMatrix {
    /// Meshes `scene` and computes all form factors with the method and parameters of `opts`.
    pub fn compute(scene: &Scene, opts: &RadiosityOptions) -> Self {
        Self::compute_rows(scene, opts, &|_| true)
    }

    /// Like [`FormFactorMatrix::compute`], but only the rows of the patches `which` accepts
    /// (the others are left empty).
    pub fn compute_rows(
        scene: &Scene,
        opts: &RadiosityOptions,
        which: &dyn Fn(&PatchInfo) -> bool,
    ) -> Self {
        let m = Meshing::build(scene, opts.patch_size, opts.cull_hidden_sides);
        let patches = infos(&m, &[]);
        let engine = Engine::new(
            scene,
            &m,
            opts.form_factors,
            opts.hemicube_resolution,
            opts.rays_per_patch,
            opts.seed,
        );
        let ids: Vec<u32> = (0..m.patches.len() as u32)
            .filter(|&i| which(&patches[i as usize]))
            .collect();
        let mut rows = vec![Vec::new(); m.patches.len()];
        for (i, r) in ids.iter().zip(engine.rows(&ids)) {
            rows[*i as usize] = r.cols.into_iter().zip(r.vals).collect();
        }
        Self { patches, rows }
    }
}
