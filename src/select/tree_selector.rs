//! The `bvh` selector: bounded lights (triangles, points, spots) in a light BVH; infinite lights
//! (directional lights and the environment map), which have no position, chosen outside the tree
//! with probability Φ_infinite / (Φ_infinite + Φ_tree), each ∝ its power (π·R²·E for a
//! directional light, π·R²·∫L dω for the environment, over the scene's bounding sphere of radius
//! R). Where nothing in the tree can reach the shading point (every root lane's importance is 0) the
//! infinite lights take all the probability.

use glam::Vec3;

use super::light_tree::{LightBounds, LightBvh};
use super::ShadingContext;
use crate::lights::{Light, Lights};

#[derive(Clone, Debug)]
pub struct BvhSelector {
    tree: LightBvh,
    /// Infinite lights: (light index, its share of the infinite lights' power).
    infinite: Vec<(usize, f64)>,
    /// Probability of choosing from the tree where the tree can contribute.
    p_tree: f64,
}

/// Light bounds for the tree: a triangle is a box with a normal cone of angle 0 (θe = 90°);
/// a point light emits in every direction; a spot light within its outer cone.
fn bounds_of(light: &Light) -> Option<LightBounds> {
    // Φ beyond f32 (π·A·L > 3.4e38) is clamped: an infinite Φ would leave the light out.
    let phi = (light.power() as f32).min(f32::MAX);
    match light {
        Light::Triangle(t) => {
            let (p1, p2) = (t.p0 + t.e1, t.p0 + t.e2);
            Some(LightBounds {
                lo: t.p0.min(p1).min(p2),
                hi: t.p0.max(p1).max(p2),
                phi,
                w: t.normal,
                cos_theta_o: 1.0,
                cos_theta_e: 0.0,
                two_sided: t.two_sided,
            })
        }
        Light::Point(p) => {
            let (w, cos_theta_o) = match p.spot {
                Some((axis, _, cos_outer)) => (axis, cos_outer),
                None => (Vec3::Z, -1.0),
            };
            Some(LightBounds {
                lo: p.position,
                hi: p.position,
                phi,
                w,
                cos_theta_o,
                // A spot's falloff is inside θo; a small θe keeps the cone test non-degenerate.
                cos_theta_e: if p.spot.is_some() { 1e-3f32.cos() } else { 0.0 },
                two_sided: false,
            })
        }
        Light::Directional(_) | Light::Environment(_) => None,
    }
}

impl BvhSelector {
    /// Builds the tree and reorders `lights` so that the tree's leaves hold lights 0..M.
    pub fn build(lights: &mut Lights) -> BvhSelector {
        // Bounds are made as the build asks for them: a list of them would hold 52 B per light
        // through the whole build.
        let binary = LightBvh::binary(lights.lights.len(), |i| {
            bounds_of(&lights.lights[i]).unwrap_or(LightBounds {
                lo: Vec3::ZERO,
                hi: Vec3::ZERO,
                phi: 0.0,
                w: Vec3::Z,
                cos_theta_o: 1.0,
                cos_theta_e: 0.0,
                two_sided: false,
            })
        });
        // The lights are renumbered into leaf order (serial, ~0.1 s at 1M lights) and then summed
        // while the binary tree is collapsed into wide nodes: neither reads what the other
        // writes, and the collapse keeps the other core busy meanwhile.
        let included = binary.order().len();
        let (tree, (tree_power, directional)) = rayon::join(
            || binary.collapse(),
            || {
                lights.reorder(binary.order());
                let tree_power: f64 = lights.lights[..included].iter().map(Light::power).sum();
                let directional: Vec<(usize, f64)> = lights
                    .lights
                    .iter()
                    .enumerate()
                    .filter(|(_, l)| matches!(l, Light::Directional(_) | Light::Environment(_)))
                    .map(|(i, l)| (i, l.power()))
                    .filter(|(_, phi)| *phi > 0.0)
                    .collect();
                (tree_power, directional)
            },
        );
        drop(binary);
        let infinite_power: f64 = directional.iter().map(|(_, phi)| phi).sum();
        let total = tree_power + infinite_power;
        let p_tree = if tree.is_empty() {
            0.0
        } else if total > 0.0 {
            tree_power / total
        } else {
            1.0
        };
        let infinite = directional
            .into_iter()
            .map(|(i, phi)| (i, phi / infinite_power))
            .collect();
        BvhSelector {
            tree,
            infinite,
            p_tree,
        }
    }

    /// The selector with its tree's far lanes below `far_sin` ([`LightBvh::with_far_sin`]).
    pub fn with_far_sin(mut self, far_sin: f32) -> BvhSelector {
        self.tree = self.tree.with_far_sin(far_sin);
        self
    }

    #[inline]
    pub fn sample(&self, ctx: &ShadingContext, u: f64) -> Option<(usize, f64)> {
        if self.infinite.is_empty() {
            // p_tree is 1 (or 0 for an empty tree, which samples nothing).
            return self
                .tree
                .sample_with(ctx.p, ctx.n, ctx.lobe, u.min(1.0 - f64::EPSILON))
                .map(|(l, p)| (l, p * self.p_tree));
        }
        // With infinite lights the tree is chosen only where it can reach the receiver: its
        // root, evaluated once here, answers that and starts the walk.
        let root = self.tree.root_with(ctx.p, ctx.n, ctx.lobe);
        let p_tree = if root.is_some() { self.p_tree } else { 0.0 };
        let p_infinite = 1.0 - p_tree;
        if u < p_infinite {
            let mut acc = 0.0;
            for &(light, share) in &self.infinite {
                acc += share * p_infinite;
                if u < acc {
                    return Some((light, share * p_infinite));
                }
            }
            return self
                .infinite
                .last()
                .map(|&(light, share)| (light, share * p_infinite));
        }
        let u_tree = ((u - p_infinite) / p_tree).min(1.0 - f64::EPSILON);
        self.tree
            .sample_below_with(&root?, ctx.p, ctx.n, ctx.lobe, u_tree)
            .map(|(l, p)| (l, p * p_tree))
    }

    pub fn pmf(&self, ctx: &ShadingContext, light: usize) -> f64 {
        // A light in the tree: where the tree cannot reach the receiver its pmf is 0 already,
        // so the root is not evaluated a second time to ask.
        if self.infinite.is_empty() || light < self.tree.len() {
            return self.tree.pmf_with(ctx.p, ctx.n, ctx.lobe, light) * self.p_tree;
        }
        let p_tree = if self.tree.can_reach(ctx.p, ctx.n) {
            self.p_tree
        } else {
            0.0
        };
        let p_infinite = 1.0 - p_tree;
        self.infinite
            .iter()
            .find(|(l, _)| *l == light)
            .map_or(0.0, |&(_, share)| share * p_infinite)
    }

    pub fn bytes(&self) -> usize {
        self.tree.bytes() + self.infinite.len() * std::mem::size_of::<(usize, f64)>()
    }

    pub fn node_count(&self) -> usize {
        self.tree.node_count()
    }
}
