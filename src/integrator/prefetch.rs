//! Warming the cache for a packet's light choices. With thousands of lights, choosing one reads
//! a random alias-table bin, then the chosen light's bin (its pmf) and the light itself: three
//! dependent cache misses per camera sample, taken one sample after another when each sample is
//! shaded in turn. The packet's first bins are asked for before its camera rays' traversal and
//! read after it, when they have arrived; the choices then ask for the lights and their bins,
//! whose misses overlap each other and the shading of the samples before them. Each sample's
//! slot-0 choice is kept for its shading, which takes it instead of choosing again (the same
//! light and p_l): this changes no result. The triangles a packet's camera rays hit are asked
//! for the same way, between its traversal and its shading.
//!
//! Reading the bins right after asking for them, before the traversal, left the reads waiting:
//! 5.7–6.5% of the render's CPU samples fell in this file's functions, 3.3–4.9% with the
//! traversal in between (perf, power + mis on the peers' Lambert copy of the 50k city, 32 spp,
//! three runs each).

use super::estimator::Estimator;
use super::Strategy;
use crate::accel::{Hit, PACKET};
use crate::sampling::alias::Start;
use crate::sampling::prefetch::prefetch;
use crate::sampling::sampler::CameraSample;
use crate::select::LightSelector;

impl Estimator<'_> {
    /// The first half of the light prefetch: starts loading the alias-table bins that the K
    /// light choices of each of `samples` read first, where the selector's choice does not
    /// depend on the shading point (the power selector's alias table) and the strategy draws
    /// one light per slot from `light_choice`. Returns each sample's slot-0 start for
    /// [`prefetch_lights`](Self::prefetch_lights), or None where this pass does nothing. The
    /// caller traces the packet's camera rays in between, so that the bins have arrived when
    /// their reads (each followed by an unpredictable branch) are made.
    pub fn prefetch_light_bins(&self, samples: &[CameraSample]) -> Option<[Start; PACKET]> {
        let Some(LightSelector::Power(table)) = self.selector else {
            return None;
        };
        if !matches!(
            self.strategy,
            Strategy::LightArea | Strategy::LightSolidAngle | Strategy::Mis
        ) {
            return None;
        }
        let mut starts = [table.start(0.0); PACKET];
        for (cs, start) in samples.iter().zip(&mut starts) {
            *start = table.start(cs.light_choice(0));
            table.prefetch_start(*start);
            for slot in 1..self.k {
                table.prefetch_sample(cs.light_choice(slot));
            }
        }
        Some(starts)
    }

    /// The second half: makes each sample's slot-0 choice from its start (kept in
    /// `first_lights`, for `radiance_from` to take instead of choosing it again: the same
    /// light, whose p_l is its `pmf`, bit for bit the p_l of the choice), and starts loading
    /// the chosen lights and their bins (their pmf), for every slot.
    pub fn prefetch_lights(
        &self,
        samples: &[CameraSample],
        starts: &[Start; PACKET],
        first_lights: &mut [Option<usize>],
    ) {
        let Some(LightSelector::Power(table)) = self.selector else {
            return;
        };
        for ((cs, &start), first) in samples.iter().zip(starts).zip(first_lights) {
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
