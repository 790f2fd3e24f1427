//! Warming the cache for a packet's light choices. With thousands of lights, choosing one reads
//! a random alias-table bin, then the chosen light's bin (its pmf) and the light itself: three
//! dependent cache misses per camera sample, taken one sample after another when each sample is
//! shaded in turn. Making a packet's choices ahead of its camera rays' traversal, and asking
//! only for those lines to be loaded, lets the misses of all its samples overlap with each
//! other and with the traversal. Each sample's slot-0 choice is kept for its shading, which
//! takes it instead of choosing again (the same light and p_l): this pass changes no result.
//! The triangles a packet's camera rays hit are asked for the same way, between its traversal
//! and its shading.

use super::estimator::Estimator;
use super::Strategy;
use crate::accel::{Hit, PACKET};
use crate::sampling::prefetch::prefetch;
use crate::sampling::sampler::CameraSample;
use crate::select::LightSelector;

impl Estimator<'_> {
    /// Starts loading the bins and lights that the K light choices of each of `samples` read,
    /// where the selector's choice does not depend on the shading point (the power selector's
    /// alias table) and the strategy draws one light per slot from `light_choice`. Each
    /// sample's slot-0 light is kept in `first_lights` (None where this pass chose nothing),
    /// for `radiance_from` to take instead of choosing it again: the same light, whose p_l is
    /// its `pmf` (bit for bit the p_l of the choice).
    pub fn prefetch_lights(&self, samples: &[CameraSample], first_lights: &mut [Option<usize>]) {
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
        // Slot 0's start is kept for the second pass.
        let mut starts = [table.start(0.0); PACKET];
        for (cs, start) in samples.iter().zip(&mut starts) {
            *start = table.start(cs.light_choice(0));
            table.prefetch_start(*start);
            for slot in 1..self.k {
                table.prefetch_sample(cs.light_choice(slot));
            }
        }
        for ((cs, &start), first) in samples.iter().zip(&starts).zip(first_lights) {
            let l = table.sample_from(start);
            *first = Some(l);
            table.prefetch(l);
            prefetch(&self.lights.lights[l]);
            for slot in 1..self.k {
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
