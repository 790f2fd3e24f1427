//! Unshadowed irradiance from an environment map onto a receiver of any normal,
//!     E(n) = ∫ luminance(L(ω)) · max(0, n·ω) dω,
//! over the map box-filtered to at most 128×64 cells (luminance × solid angle gathered at each
//! cell's centre direction). The 32 brightest cells (a sun) are summed exactly at every query;
//! the rest, a smooth sky whose cosine-convolution is smooth in n, is tabulated once on a 32×16
//! equirectangular grid of normals and interpolated bilinearly. A table costs at most
//! 8,192 × 512 multiply-adds whatever the map's size, a query 32 dot products. The oracle
//! selector weighs the environment by it.

use std::f64::consts::PI;

use glam::DVec3;

use crate::sampling::warp::equirectangular_direction;

/// Normals per row and per column of the table.
const GRID_WIDTH: usize = 32;
const GRID_HEIGHT: usize = 16;
/// The largest map resolution summed over (finer maps are box-filtered down to it).
const SUM_WIDTH: usize = 128;
const SUM_HEIGHT: usize = 64;

/// Cells summed exactly at every query.
const EXPLICIT_CELLS: usize = 32;

/// E(n) in the map's own frame (the map's equirectangular convention).
#[derive(Clone, Debug)]
pub struct IrradianceTable {
    /// The brightest cells: (centre direction, luminance × solid angle).
    explicit: Vec<(DVec3, f64)>,
    /// E of the other cells at GRID_WIDTH × GRID_HEIGHT normals (cell centres, row 0 nearest
    /// the zenith).
    values: Vec<f64>,
}

impl IrradianceTable {
    /// From a width × height map's per-texel luminance (row 0 at the zenith).
    pub fn new(luminance: &[f32], width: usize, height: usize) -> IrradianceTable {
        // Gather luminance × solid angle into at most SUM_WIDTH × SUM_HEIGHT cells.
        let (cw, ch) = (width.min(SUM_WIDTH), height.min(SUM_HEIGHT));
        let mut flux = vec![0.0f64; cw * ch];
        for j in 0..height {
            let (t0, t1) = (
                PI * j as f64 / height as f64,
                PI * (j + 1) as f64 / height as f64,
            );
            let omega = 2.0 * PI / width as f64 * (t0.cos() - t1.cos());
            let row = j * ch / height;
            for i in 0..width {
                flux[row * cw + i * cw / width] += luminance[j * width + i] as f64 * omega;
            }
        }
        let mut cells: Vec<(DVec3, f64)> = flux
            .iter()
            .enumerate()
            .filter(|(_, f)| **f > 0.0)
            .map(|(k, &f)| {
                let (i, j) = (k % cw, k / cw);
                let u = (i as f64 + 0.5) / cw as f64;
                let v = (j as f64 + 0.5) / ch as f64;
                (equirectangular_direction(u, v), f)
            })
            .collect();
        cells.sort_by(|a, b| b.1.total_cmp(&a.1));
        let explicit: Vec<(DVec3, f64)> = cells.drain(..cells.len().min(EXPLICIT_CELLS)).collect();
        let values = (0..GRID_WIDTH * GRID_HEIGHT)
            .map(|k| {
                let u = ((k % GRID_WIDTH) as f64 + 0.5) / GRID_WIDTH as f64;
                let v = ((k / GRID_WIDTH) as f64 + 0.5) / GRID_HEIGHT as f64;
                let n = equirectangular_direction(u, v);
                cells.iter().map(|(w, f)| f * n.dot(*w).max(0.0)).sum()
            })
            .collect();
        IrradianceTable { explicit, values }
    }

    /// E at map-frame unit normal n: the brightest cells exactly, the rest bilinear between the
    /// four nearest grid normals (wrapping in φ, clamped at the poles).
    pub fn at(&self, n: DVec3) -> f64 {
        let bright: f64 = self
            .explicit
            .iter()
            .map(|(w, f)| f * n.dot(*w).max(0.0))
            .sum();
        let phi = (-n.x).atan2(n.z).rem_euclid(2.0 * PI);
        let x = phi / (2.0 * PI) * GRID_WIDTH as f64 - 0.5;
        let y = (n.y.clamp(-1.0, 1.0).acos() / PI * GRID_HEIGHT as f64 - 0.5)
            .clamp(0.0, (GRID_HEIGHT - 1) as f64);
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let column = |c: f64| (c as i64).rem_euclid(GRID_WIDTH as i64) as usize;
        let (c0, c1) = (column(x0), column(x0 + 1.0));
        let (r0, r1) = (y0 as usize, (y0 as usize + 1).min(GRID_HEIGHT - 1));
        let value = |c: usize, r: usize| self.values[r * GRID_WIDTH + c];
        bright
            + (1.0 - fy) * ((1.0 - fx) * value(c0, r0) + fx * value(c1, r0))
            + fy * ((1.0 - fx) * value(c0, r1) + fx * value(c1, r1))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::rng::PixelRng;

    /// Exact E(n) by summing every texel's luminance × ∫cos over its solid angle, approximated
    /// by 4×4 sub-directions per texel (independent of the table's gathering and grid).
    fn brute_force(lum: &[f32], w: usize, h: usize, n: DVec3) -> f64 {
        let q = 4;
        let mut e = 0.0;
        for j in 0..h * q {
            let (t0, t1) = (
                PI * j as f64 / (h * q) as f64,
                PI * (j + 1) as f64 / (h * q) as f64,
            );
            let omega = 2.0 * PI / (w * q) as f64 * (t0.cos() - t1.cos());
            for i in 0..w * q {
                let d = equirectangular_direction(
                    (i as f64 + 0.5) / (w * q) as f64,
                    (j as f64 + 0.5) / (h * q) as f64,
                );
                e += lum[(j / q) * w + i / q] as f64 * omega * n.dot(d).max(0.0);
            }
        }
        e
    }

    #[test]
    fn a_constant_sky_gives_pi_l_for_every_normal() {
        let table = IrradianceTable::new(&[2.0; 64 * 32], 64, 32);
        let mut rng = PixelRng::new(4, 4);
        for _ in 0..50 {
            let n = DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * 2.0 - 1.0;
            let e = table.at(n.normalize());
            assert!((e - 2.0 * PI).abs() < 0.01 * 2.0 * PI, "E = {e}");
        }
    }

    #[test]
    fn a_sun_and_sky_is_tabulated_within_a_few_percent() {
        // A smooth sky plus a bright 3×3-texel sun, on a map finer than the summed resolution.
        let (w, h) = (256, 128);
        let lum: Vec<f32> = (0..w * h)
            .map(|k| {
                let (i, j) = (k % w, k / w);
                let sun = (150..153).contains(&i) && (40..43).contains(&j);
                if sun {
                    3000.0
                } else if j < h / 2 {
                    0.3 + 0.5 * (j as f32 / h as f32)
                } else {
                    0.05
                }
            })
            .collect();
        let table = IrradianceTable::new(&lum, w, h);
        let mut rng = PixelRng::new(8, 1);
        let mut worst: f64 = 0.0;
        for _ in 0..100 {
            let n = (DVec3::new(rng.next_f64(), rng.next_f64(), rng.next_f64()) * 2.0 - 1.0)
                .normalize();
            let exact = brute_force(&lum, w, h, n);
            worst = worst.max((table.at(n) - exact).abs() / exact);
        }
        assert!(worst < 0.05, "largest relative error {worst}");
    }
}
