//! A scene made ready to render: its ray accelerator, lights and light selector, built once and
//! shared by every estimator configuration that uses the same selector.

use std::time::Instant;

use super::{Estimator, Strategy};
use crate::accel::Accel;
use crate::lights::Lights;
use crate::material::Brdf;
use crate::measure::cpu_time::{cpu_seconds_between, process_cpu_seconds};
use crate::scene::memory::lights_before_geometry;
use crate::scene::Scene;
use crate::select::{LightSelector, SelectorKind, DEFAULT_FAR_SIN};

pub struct PreparedScene {
    pub scene: Scene,
    pub accel: Accel,
    pub lights: Lights,
    /// None when the scene has no lights.
    pub selector: Option<LightSelector>,
    /// Each material's BRDF with its base colour factor (the whole BRDF where it is not
    /// textured).
    pub brdfs: Vec<Brdf>,
    /// Seconds spent building the BVH over triangles.
    pub bvh_seconds: f64,
    /// Seconds spent building the lights and the selector.
    pub light_seconds: f64,
    /// The part of `light_seconds` spent building the selector (the light tree, or the alias
    /// table) once the lights were made.
    pub selector_seconds: f64,
    /// The process's CPU seconds (all threads) over the selector's build, which runs alone:
    /// the one-off cost a render with this selector pays before its first sample (None where
    /// the system gives no CPU time).
    pub selector_cpu_seconds: Option<f64>,
}

impl PreparedScene {
    /// The ray accelerator and the lights are built one after the other, in the order
    /// `lights_before_geometry` chooses so that the larger build's temporaries are not alive
    /// beside the other's finished structure.
    pub fn new(scene: Scene, kind: SelectorKind) -> PreparedScene {
        Self::new_with(scene, kind, DEFAULT_FAR_SIN)
    }

    /// [`new`](Self::new) with the light tree's far lanes below `far_sin` (`bvh`; see
    /// [`DEFAULT_FAR_SIN`]).
    pub fn new_with(scene: Scene, kind: SelectorKind, far_sin: f32) -> PreparedScene {
        let build_accel = |scene: &Scene| {
            let t = Instant::now();
            (Accel::build(scene), t.elapsed().as_secs_f64())
        };
        let build_lights = |scene: &Scene| {
            let t = Instant::now();
            let mut lights = Lights::from_scene(scene);
            let made = t.elapsed().as_secs_f64();
            let cpu = process_cpu_seconds();
            let selector = LightSelector::build_with(kind, &mut lights, far_sin);
            let cpu = cpu_seconds_between(cpu, process_cpu_seconds());
            let total = t.elapsed().as_secs_f64();
            (lights, selector, (total, total - made, cpu))
        };
        let (
            (accel, bvh_seconds),
            (lights, selector, (light_seconds, selector_seconds, selector_cpu_seconds)),
        ) = if lights_before_geometry(scene.emissive_triangles() as u64) {
            let lights = build_lights(&scene);
            (build_accel(&scene), lights)
        } else {
            let accel = build_accel(&scene);
            (accel, build_lights(&scene))
        };
        let brdfs = scene.materials.iter().map(Brdf::new).collect();
        PreparedScene {
            scene,
            accel,
            lights,
            selector,
            brdfs,
            bvh_seconds,
            light_seconds,
            selector_seconds,
            selector_cpu_seconds,
        }
    }

    /// The K×N estimator for one strategy over this scene (M = 1 candidate; see
    /// `Estimator::with_candidates`).
    pub fn estimator(&self, strategy: Strategy, k: u32, n: u32) -> Estimator<'_> {
        Estimator {
            scene: &self.scene,
            accel: &self.accel,
            lights: &self.lights,
            selector: self.selector.as_ref(),
            brdfs: &self.brdfs,
            strategy,
            k,
            n,
            m: 1,
        }
    }
}
