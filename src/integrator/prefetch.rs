//! Warming the cache for a packet's light choices. With thousands of lights, choosing one reads
//! a random alias-table bin, then the chosen light's bin (its pmf) and the light itself: three
//! dependent cache misses per camera sample, taken one sample after another when each sample is
//! shaded in turn. Making a packet's choices ahead of its camera rays' traversal, and asking
//! only for those lines to be loaded, lets the misses of all its samples overlap with each
//! other and with the traversal. The number that makes each slot-0 choice is kept in its sample
//! for the shading, which makes the choice again, identically: this pass changes no result.
//! The triangles a packet's camera rays hit are asked for the same way, between its traversal
//! and its shading.

use super::estimator::Estimator;
use super::Strategy;
use crate::accel::Hit;
use crate::sampling::prefetch::prefetch;
use crate::sampling::sampler::CameraSample;
use crate::select::LightSelector;

impl Estimator<'_> {
    /// Starts loading the bins and lights that the K light choices of each of `samples` read,
    /// where the selector's choice does not depend on the shading point (the power selector's
    /// alias table) and the strategy draws one light per slot from `light_choice`. Each
    /// sample's slot-0 choice is then kept in it (`with_first_light_choice`), so that this pass
    /// and the shading compute it once.
    pub fn prefetch_lights(&self, samples: &mut [CameraSample]) {
        let Some(LightSelector::Power(table)) = self.selector else {
            return;
        };
        if !matches!(
            self.strategy,
            Strategy::LightArea | Strategy::LightSolidAngle | Strategy::Mis
        ) {
            return;
        }
        // First every sample's first bin, so that the second pass's reads of them (each
        // followed by an unpredictable branch) find their lines on the way.
        for cs in samples.iter_mut() {
            *cs = cs.with_first_light_choice();
            for slot in 0..self.k {
                table.prefetch_sample(cs.light_choice(slot));
            }
        }
        for cs in samples.iter() {
            for slot in 0..self.k {
                let l = table.sample(cs.light_choice(slot));
                table.prefetch(l);
                prefetch(&self.lights.lights[l]);
            }
        }
    }

    /// Starts loading the scene triangles that a packet's camera rays hit (positions, normals,
    /// material), so that their cache misses overlap instead of stalling each sample's shading
    /// in turn.
    pub fn prefetch_hits(&self, hits: &[Option<Hit>]) {
        for hit in hits.iter().flatten() {
            prefetch(&self.scene.triangles[hit.triangle as usize]);
        }
    }
}
