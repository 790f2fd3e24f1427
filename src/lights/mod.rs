//! Lights: one per emissive triangle plus the scene's punctual lights and its environment map,
//! each with the power used for selection and its own sampling routine. A textured emitter's
//! power uses its emission averaged over the triangle's own uv footprint, not the factor or the
//! whole image's mean.

pub mod environment;
pub mod polygon;
pub mod power_stats;
pub mod punctual;
pub mod spherical_triangle;
pub mod triangle;

use std::sync::Arc;

use glam::Vec3;
use rayon::prelude::*;

pub use environment::{EnvironmentLight, EnvironmentMap, EnvironmentSample};
pub use punctual::{DeltaSample, DirectionalLight, PointLight};
pub use triangle::{Technique, TriangleLight, TriangleSample};

use crate::sampling::prefetch::prefetch;
use crate::scene::Scene;

/// Whether a surface with unit front normal `n` emits toward direction `w` (pointing away from
/// the surface): always when two-sided, else only from the counter-clockwise front face.
#[inline]
pub fn emits_toward(n: Vec3, two_sided: bool, w: Vec3) -> bool {
    let c = n.dot(w);
    c > 0.0 || (two_sided && c < 0.0)
}

/// One light of any kind (static dispatch on the hot path).
#[derive(Clone, Debug)]
pub enum Light {
    Triangle(TriangleLight),
    /// A point light, or a spot light when it has a cone.
    Point(PointLight),
    Directional(DirectionalLight),
    /// The environment map: an infinite light sampled by direction.
    Environment(EnvironmentLight),
}

impl Light {
    /// Φ used for selection (f64): π·A·luminance(L) (×2 two-sided), 4π·luminance(I), π·R²·luminance(E),
    /// π·R²·∫luminance(L)dω for the environment.
    pub fn power(&self) -> f64 {
        match self {
            Light::Triangle(t) => t.power(),
            Light::Point(p) => p.power(),
            Light::Directional(d) => d.power(),
            Light::Environment(e) => e.power(),
        }
    }

    /// The exact sample of a delta light at p (None for area lights).
    #[inline]
    pub fn sample_delta(&self, p: Vec3) -> Option<DeltaSample> {
        match self {
            Light::Triangle(_) | Light::Environment(_) => None,
            Light::Point(l) => l.sample(p),
            Light::Directional(d) => Some(d.sample()),
        }
    }
}

/// All lights of a scene, and which light each emissive triangle is.
#[derive(Clone, Debug, Default)]
pub struct Lights {
    pub lights: Vec<Light>,
    /// Scene triangle → light index (u32::MAX for non-emissive triangles), for MIS: a BSDF ray
    /// that hits an emitter needs that light's selection probability.
    light_of_triangle: Vec<u32>,
    /// Index of the environment light, if the scene has one (rays that escape the scene see it).
    environment: Option<usize>,
}

impl Lights {
    /// One light per triangle whose material emits, then the punctual lights, then the
    /// environment map (its sampling distribution built here from the scene's image).
    pub fn from_scene(scene: &Scene) -> Lights {
        let emitting: Vec<u32> = (0..scene.triangles.len() as u32)
            .filter(|&i| scene.material_of(i as usize).is_emissive())
            .collect();
        // Sized once: a million lights grown by doubling would hold 1.5× their bytes at a time.
        // On huge pages: light sampling reads them at random.
        let mut lights = crate::alloc::on_huge_pages(|| {
            Vec::with_capacity(
                emitting.len() + scene.punctual.len() + usize::from(scene.environment.is_some()),
            )
        });
        // Made in parallel (a textured emitter averages its texture over the triangle).
        lights.par_extend(emitting.par_iter().map(|&i| {
            let (i, t) = (i as usize, &scene.triangles[i as usize]);
            let m = scene.material_of(i);
            let [p0, p1, p2] = t.positions;
            Light::Triangle(TriangleLight {
                p0,
                e1: p1 - p0,
                e2: p2 - p0,
                normal: t.geometric_normal(),
                area: t.area(),
                radiance: scene.mean_emission(i),
                two_sided: m.double_sided,
                textured: m.emissive_texture.is_some(),
                triangle: i as u32,
            })
        }));
        let (lo, hi) = scene.bounds();
        let radius = 0.5 * (hi - lo).length();
        lights.extend(
            scene
                .punctual
                .iter()
                .map(|l| punctual::from_punctual(l, radius, scene.punctual_units)),
        );
        if let Some(image) = &scene.environment {
            lights.push(Light::Environment(EnvironmentLight {
                map: Arc::new(EnvironmentMap::new(image.clone())),
                scene_radius: radius,
            }));
        }
        let mut out = Lights {
            lights,
            light_of_triangle: Vec::new(),
            environment: None,
        };
        out.index_triangles(scene.triangles.len());
        out
    }

    fn index_triangles(&mut self, triangles: usize) {
        // Refilled in place: a second table beside the first would add 4 B per triangle to the
        // light BVH's build peak, when `reorder` calls this.
        self.light_of_triangle.clear();
        // On huge pages: every emitter a BSDF ray hits is looked up here.
        crate::alloc::on_huge_pages(|| self.light_of_triangle.resize(triangles, u32::MAX));
        self.environment = None;
        for (l, light) in self.lights.iter().enumerate() {
            match light {
                Light::Triangle(t) => self.light_of_triangle[t.triangle as usize] = l as u32,
                Light::Environment(_) => self.environment = Some(l),
                _ => {}
            }
        }
    }

    /// Reorders the lights so that `order[k]` becomes light k; lights not named keep their
    /// relative order after them. (The light BVH wants its leaves' lights contiguous.)
    pub fn reorder(&mut self, order: &[u32]) {
        let mut named = vec![false; self.lights.len()];
        for &i in order {
            named[i as usize] = true;
        }
        // Light k becomes light source[k]; applied in place, cycle by cycle (a second list of a
        // million lights would add 72 MB to the light tree's peak).
        let source: Vec<u32> = order
            .iter()
            .copied()
            .chain((0..self.lights.len() as u32).filter(|&i| !named[i as usize]))
            .collect();
        let mut placed = named;
        placed.fill(false);
        for start in 0..source.len() {
            let mut k = start;
            while !placed[k] {
                placed[k] = true;
                let from = source[k] as usize;
                if from == start {
                    break;
                }
                // The next swap reads light source[from], a miss far from here: start it now.
                prefetch(&self.lights[source[from] as usize]);
                self.lights.swap(k, from);
                k = from;
            }
        }
        let triangles = self.light_of_triangle.len();
        self.index_triangles(triangles);
    }

    /// The light that scene triangle `t` is, if it emits.
    #[inline]
    pub fn light_of_triangle(&self, t: u32) -> Option<usize> {
        let l = self.light_of_triangle[t as usize];
        (l != u32::MAX).then_some(l as usize)
    }

    /// The environment light and its index, if the scene has one.
    #[inline]
    pub fn environment(&self) -> Option<(usize, &EnvironmentMap)> {
        let l = self.environment?;
        match &self.lights[l] {
            Light::Environment(e) => Some((l, &e.map)),
            _ => None,
        }
    }

    pub fn len(&self) -> usize {
        self.lights.len()
    }

    pub fn is_empty(&self) -> bool {
        self.lights.is_empty()
    }

    pub fn triangle_count(&self) -> usize {
        self.lights
            .iter()
            .filter(|l| matches!(l, Light::Triangle(_)))
            .count()
    }

    /// The emissive triangles.
    pub fn triangles(&self) -> impl Iterator<Item = &TriangleLight> {
        self.lights.iter().filter_map(|l| match l {
            Light::Triangle(t) => Some(t),
            _ => None,
        })
    }

    /// Φ of every light (f64).
    pub fn powers(&self) -> Vec<f64> {
        self.lights.iter().map(Light::power).collect()
    }

    /// Total emitted power Σ Φ, summed in f64.
    pub fn total_power(&self) -> f64 {
        self.lights.iter().map(Light::power).sum()
    }
}
