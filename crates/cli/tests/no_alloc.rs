//! The hot path allocates nothing: rendering more samples per pixel must not allocate more.
//!
//! A counting global allocator counts the allocations made while rendering every example scene
//! (both scene languages, every material, light and integrator they use) at 2 and at 8 samples
//! per pixel on one thread: the counts must be equal, so nothing is allocated per sample, per
//! ray or per path vertex (only per render and per tile).

// Why unsafe code is allowed in this file: a global allocator is an `unsafe impl GlobalAlloc`;
// it forwards every call unchanged to the system allocator and only counts.
#![allow(unsafe_code)]

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};

use candela_render::integrator::{IntegratorKind, IntegratorSettings};
use candela_render::render::{render, RenderSettings};
use candela_scene::{load_scene, LoadOptions};

struct Counting;

static ALLOCATIONS: AtomicU64 = AtomicU64::new(0);

thread_local! {
    /// Set on the thread that renders while it is measured: other threads (decoders' pools,
    /// the test harness) may allocate at any time and are not counted.
    static COUNTING: Cell<bool> = const { Cell::new(false) };
}

fn count() {
    if COUNTING.with(Cell::get) {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
    }
}

// SAFETY: every method forwards to `System` with the caller's arguments.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count();
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        count();
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count();
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Allocations made while rendering `scene` with its own integrator at `spp`.
fn allocations(path: &Path, spp: u32, pool: &rayon::ThreadPool) -> u64 {
    let loaded = load_scene(path, &LoadOptions::default()).expect("the example loads");
    let name = loaded
        .hints
        .integrator
        .clone()
        .unwrap_or_else(|| "path".into());
    let kind = IntegratorKind::from_name(&name).expect("a known integrator");
    let settings = IntegratorSettings {
        max_depth: loaded.hints.max_depth,
        rr_depth: loaded.hints.rr_depth,
        hide_emitters: loaded.hints.hide_emitters,
        num_of_rays: 1,
        ..Default::default()
    };
    let integrator = kind.build(&loaded.scene, &settings).unwrap().integrator;
    let rs = RenderSettings {
        width: 24,
        height: 16,
        spp,
        seed: 3,
        ..Default::default()
    };
    // The pool has one thread: the whole render runs on it.
    pool.install(|| {
        let before = ALLOCATIONS.load(Ordering::Relaxed);
        COUNTING.with(|c| c.set(true));
        let out = render(&loaded.scene, integrator.as_ref(), &rs, &|_| {});
        COUNTING.with(|c| c.set(false));
        let after = ALLOCATIONS.load(Ordering::Relaxed);
        drop(out);
        after - before
    })
}

#[test]
fn more_samples_allocate_nothing_more() {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    let mut scenes: Vec<_> = std::fs::read_dir(&root)
        .unwrap()
        .chain(std::fs::read_dir(root.join("mitsuba")).unwrap())
        .chain(std::fs::read_dir(root.join("instancing")).unwrap())
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "scene" || e == "xml"))
        .collect();
    scenes.sort();
    assert!(scenes.len() > 20, "the examples are found");
    let mut report = Vec::new();
    for scene in &scenes {
        // Warm up once (lazily initialised tables, thread-local stacks).
        allocations(scene, 1, &pool);
        let few = allocations(scene, 2, &pool);
        let many = allocations(scene, 8, &pool);
        if many != few {
            report.push(format!(
                "{}: {few} allocations at 2 spp, {many} at 8 spp",
                scene.display()
            ));
        }
    }
    assert!(report.is_empty(), "{}", report.join("\n"));
}
