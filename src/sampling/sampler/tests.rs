//! Every sampler: uniform points (chi-square), decorrelated pixels, per-pixel stratification,
//! distinct K×N points, and sequences that progressive passes continue.

use super::*;

const KINDS: [SamplerKind; 5] = [
    SamplerKind::Independent,
    SamplerKind::Stratified,
    SamplerKind::Lhs,
    SamplerKind::Halton,
    SamplerKind::Sobol,
];

/// The number pairs `read` gives for each (pixel, camera sample, light slot k, point n).
fn collect(
    kind: SamplerKind,
    pixels: u64,
    spp: u32,
    (k, n): (u32, u32),
    read: impl Fn(&CameraSample, u32, u32) -> Option<[f64; 2]>,
) -> Vec<[f64; 2]> {
    let sampler = Sampler::new(kind, 7, 0, spp, k, n);
    let mut out = Vec::new();
    for pixel in 0..pixels {
        let px = sampler.pixel(pixel);
        for s in 0..spp {
            let cs = px.camera_sample(s);
            for slot_k in 0..k {
                for slot_n in 0..n {
                    out.extend(read(&cs, slot_k, slot_n));
                }
            }
        }
    }
    out
}

/// Pearson's chi-square of the points on a g × g grid against the uniform distribution, and
/// its 5σ bound: (g² − 1) degrees of freedom, mean g² − 1, variance 2(g² − 1).
fn chi_square(points: &[[f64; 2]], g: usize) -> (f64, f64) {
    let mut cells = vec![0u64; g * g];
    for p in points {
        assert!(
            p.iter().all(|x| (0.0..1.0).contains(x)),
            "{p:?} outside [0,1)²"
        );
        let (i, j) = ((p[0] * g as f64) as usize, (p[1] * g as f64) as usize);
        cells[j * g + i] += 1;
    }
    let expected = points.len() as f64 / (g * g) as f64;
    let chi2 = cells
        .iter()
        .map(|&c| (c as f64 - expected).powi(2) / expected)
        .sum();
    let dof = (g * g - 1) as f64;
    (chi2, dof + 5.0 * (2.0 * dof).sqrt())
}

fn f(x: [f32; 2]) -> [f64; 2] {
    x.map(|v| v as f64)
}

/// What `read` gives for each of a pixel's camera samples 0 … count − 1.
fn first_samples<T>(px: &PixelSampler, count: u32, read: impl Fn(&CameraSample) -> T) -> Vec<T> {
    (0..count).map(|s| read(&px.camera_sample(s))).collect()
}

#[test]
fn every_group_and_every_pair_of_groups_is_uniform() {
    // 256 pixels × 8 camera samples × (K, N) = (2, 2): within each 2D group, and across groups
    // of one camera sample (independent scrambles make the joint distribution uniform too).
    // A number shared by several slots (the jitter by all, a light choice by its N points) is
    // read once: repeated values would inflate chi².
    type Read = fn(&CameraSample, u32, u32) -> Option<[f64; 2]>;
    let pairs: [(&str, Read); 7] = [
        ("pixel jitter", |c, k, n| {
            (k + n == 0).then(|| f(c.pixel_jitter()))
        }),
        ("light point", |c, k, n| Some(f(c.light_point(k, n)))),
        ("bsdf direction", |c, k, n| {
            Some(f(c.bsdf_direction(k * 2 + n)))
        }),
        ("light choice × bsdf lobe", |c, k, n| {
            (n == 0).then(|| [c.light_choice(k), c.bsdf_lobe(k) as f64])
        }),
        ("pixel x × light point x", |c, k, n| {
            (k + n == 0).then(|| [c.pixel_jitter()[0] as f64, c.light_point(0, 0)[0] as f64])
        }),
        ("light choice × light point y", |c, k, n| {
            (n == 0).then(|| [c.light_choice(k), c.light_point(k, 0)[1] as f64])
        }),
        ("light point y × bsdf direction x", |c, k, n| {
            Some([
                c.light_point(k, n)[1] as f64,
                c.bsdf_direction(k * 2 + n)[0] as f64,
            ])
        }),
    ];
    for kind in KINDS {
        for (name, read) in pairs {
            let points = collect(kind, 256, 8, (2, 2), read);
            let (chi2, bound) = chi_square(&points, 8);
            assert!(chi2 < bound, "{kind:?} {name}: chi² {chi2:.1} ≥ {bound:.1}");
        }
    }
}

#[test]
fn light_choice_fills_53_bits_uniformly() {
    // The low 8 of the 21 appended bits, as a 16 × 16 histogram of (bits 45..49, 49..53).
    for kind in KINDS {
        let points = collect(kind, 64, 16, (4, 1), |c, k, _| {
            let bits = (c.light_choice(k) * 2f64.powi(53)) as u64;
            Some([(bits & 15) as f64 / 16.0, ((bits >> 4) & 15) as f64 / 16.0])
        });
        let (chi2, bound) = chi_square(&points, 16);
        assert!(chi2 < bound, "{kind:?}: chi² {chi2:.1} ≥ {bound:.1}");
    }
}

#[test]
fn neighbouring_pixels_are_decorrelated() {
    // Pearson correlation of the same (dimension, index) in pixels 2q and 2q + 1, one index per
    // pair (points of one pixel are stratified, hence dependent; disjoint pixel pairs are
    // independent): about N(0, 1/M) over M pairs when uncorrelated; allow 5/√M.
    let pairs = 20_000u64;
    for kind in KINDS {
        let read: fn(&CameraSample) -> [f64; 4] = |c| {
            let [a, b] = c.pixel_jitter();
            [
                a as f64,
                b as f64,
                c.light_choice(0),
                c.light_point(0, 0)[0] as f64,
            ]
        };
        let sampler = Sampler::new(kind, 3, 0, 16, 1, 1);
        let values: Vec<([f64; 4], [f64; 4])> = (0..pairs)
            .map(|q| {
                let s = (q % 16) as u32;
                let (a, b) = (sampler.pixel(2 * q), sampler.pixel(2 * q + 1));
                (read(&a.camera_sample(s)), read(&b.camera_sample(s)))
            })
            .collect();
        for dim in 0..4 {
            let (mut xy, mut xx, mut yy) = (0.0, 0.0, 0.0);
            for (a, b) in &values {
                let (x, y) = (a[dim] - 0.5, b[dim] - 0.5);
                xy += x * y;
                xx += x * x;
                yy += y * y;
            }
            let r = xy / (xx * yy).sqrt();
            let bound = 5.0 / (pairs as f64).sqrt();
            assert!(
                r.abs() < bound,
                "{kind:?} dim {dim}: r = {r:.4} (bound {bound:.4})"
            );
        }
    }
}

/// Which cell of a gx × gy grid each point falls in; asserts each is hit at most once.
fn assert_one_per_cell(points: &[[f64; 2]], gx: usize, gy: usize, what: &str) {
    let mut seen = vec![false; gx * gy];
    for p in points {
        let cell = (p[1] * gy as f64) as usize * gx + (p[0] * gx as f64) as usize;
        assert!(!seen[cell], "{what}: cell {cell} of {gx}x{gy} hit twice");
        seen[cell] = true;
    }
}

#[test]
fn stratified_hits_every_stratum_of_a_pixel_once() {
    // spp 16, K = 2, N = 2: 16 jitters on 4×4, 32 light choices on 32 intervals, 64 light points
    // and 64 BSDF directions on 8×8.
    for pixel in [0u64, 1, 12345] {
        let sampler = Sampler::new(SamplerKind::Stratified, 5, 0, 16, 2, 2);
        let px = sampler.pixel(pixel);
        let mut jitter = Vec::new();
        let mut choice = Vec::new();
        let mut point = Vec::new();
        let mut dir = Vec::new();
        for s in 0..16 {
            let c = px.camera_sample(s);
            jitter.push(f(c.pixel_jitter()));
            for k in 0..2 {
                choice.push([c.light_choice(k), 0.0]);
                for n in 0..2 {
                    point.push(f(c.light_point(k, n)));
                    dir.push(f(c.bsdf_direction(k * 2 + n)));
                }
            }
        }
        assert_one_per_cell(&jitter, 4, 4, "pixel jitter");
        assert_one_per_cell(&choice, 32, 1, "light choice");
        assert_one_per_cell(&point, 8, 8, "light point");
        assert_one_per_cell(&dir, 8, 8, "bsdf direction");
    }
}

#[test]
fn lhs_hits_every_row_and_column_of_a_pixel_once() {
    let sampler = Sampler::new(SamplerKind::Lhs, 5, 0, 12, 3, 1);
    for pixel in [0u64, 77] {
        let px = sampler.pixel(pixel);
        let (mut jitter, mut point) = (Vec::new(), Vec::new());
        for s in 0..12 {
            let c = px.camera_sample(s);
            jitter.push(f(c.pixel_jitter()));
            for k in 0..3 {
                point.push(f(c.light_point(k, 0)));
            }
        }
        for (points, count, what) in [(&jitter, 12, "pixel jitter"), (&point, 36, "light point")] {
            assert_one_per_cell(points, count, 1, &format!("{what} columns"));
            assert_one_per_cell(points, 1, count, &format!("{what} rows"));
        }
    }
}

#[test]
fn sobol_prefixes_are_nets_in_every_group() {
    // The first 2^m points of a pixel's group put one point in each elementary interval of
    // area 2^−m: every 2^a × 2^(m−a) grid.
    let m = 6;
    let sampler = Sampler::new(SamplerKind::Sobol, 9, 0, 1 << m, 1, 1);
    for pixel in [0u64, 3, 999] {
        let px = sampler.pixel(pixel);
        type Read = fn(&CameraSample) -> [f64; 2];
        let groups: [(&str, Read); 3] = [
            ("pixel jitter", |c| f(c.pixel_jitter())),
            ("light point", |c| f(c.light_point(0, 0))),
            ("bsdf direction", |c| f(c.bsdf_direction(0))),
        ];
        for (name, read) in groups {
            let points = first_samples(&px, 1 << m, read);
            for a in 0..=m {
                assert_one_per_cell(&points, 1 << a, 1 << (m - a), name);
            }
        }
        let choice = first_samples(&px, 1 << m, |c| [c.light_choice(0), 0.0]);
        assert_one_per_cell(&choice, 1 << m, 1, "light choice");
    }
}

/// The most points that one box of a 2^a × 2^b × 2^c grid over [0,1)³ holds (`cells` =
/// [a, b, c]).
pub(super) fn most_in_a_box(points: &[[f64; 3]], cells: [u32; 3]) -> u32 {
    let mut counts = std::collections::HashMap::new();
    for p in points {
        let key: Vec<u64> = (0..3)
            .map(|d| (p[d] * f64::from(1 << cells[d])) as u64)
            .collect();
        *counts.entry(key).or_insert(0u32) += 1;
    }
    counts.into_values().max().unwrap_or(0)
}

#[test]
fn sobol_draws_the_light_choice_with_its_point_and_the_lobe_with_its_direction() {
    // With N = 1 the light choice is the third coordinate of the point on the light, and the
    // BSDF lobe the third of the direction's point (the module doc's layout): over a pixel's
    // first 2^m camera samples each triple is a 3D net with t = 1 (every box of a 2^a × 2^b ×
    // 2^c grid with a + b + c = m − 1 holds two points), which numbers taken from two groups,
    // each shuffled with its own seed, are not.
    let m = 6;
    let sampler = Sampler::new(SamplerKind::Sobol, 11, 0, 1 << m, 1, 1);
    for pixel in [0u64, 5, 4321] {
        let px = sampler.pixel(pixel);
        let light = first_samples(&px, 1 << m, |c| {
            let [x, y] = f(c.light_point(0, 0));
            [x, y, c.light_choice(0)]
        });
        let bsdf = first_samples(&px, 1 << m, |c| {
            let BsdfNumbers {
                lobe, direction, ..
            } = c.bsdf_numbers(0);
            let [x, y] = f(direction);
            [x, y, f64::from(lobe)]
        });
        for (name, points) in [("light", light), ("bsdf", bsdf)] {
            for a in 0..m {
                for b in 0..m - a {
                    let cells = [a, b, m - 1 - a - b];
                    let most = most_in_a_box(&points, cells);
                    assert_eq!(
                        most, 2,
                        "{name} point and choice, pixel {pixel}, grid {cells:?}"
                    );
                }
            }
        }
    }
}

#[test]
fn the_bsdf_lobe_and_direction_made_together_are_the_ones_made_apart() {
    for kind in KINDS {
        for (k, n) in [(1, 1), (2, 3)] {
            let sampler = Sampler::new(kind, 5, 0, 4, k, n);
            for pixel in [0u64, 77] {
                let px = sampler.pixel(pixel);
                for s in 0..4 {
                    let cs = px.camera_sample(s);
                    for j in 0..k * n {
                        let both = cs.bsdf_numbers(j);
                        assert_eq!(
                            (both.lobe, both.direction),
                            (cs.bsdf_lobe(j), cs.bsdf_direction(j)),
                            "{kind:?}, K × N = {k} × {n}, pixel {pixel}, sample {s}, slot {j}"
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn halton_prefixes_are_stratified_in_each_dimension() {
    // 25 = 5² camera samples: the jitter's x (base 2) fills 16 intervals with its first 16, y
    // (base 3) 9 intervals with its first 9; the light choice (base 5) fills 25 intervals.
    let sampler = Sampler::new(SamplerKind::Halton, 2, 0, 25, 1, 1);
    let px = sampler.pixel(42);
    let jitter = |c: &CameraSample| f(c.pixel_jitter());
    assert_one_per_cell(&first_samples(&px, 16, jitter), 16, 1, "halton base 2");
    assert_one_per_cell(&first_samples(&px, 9, jitter), 1, 9, "halton base 3");
    let choice = first_samples(&px, 25, |c| [c.light_choice(0), 0.0]);
    assert_one_per_cell(&choice, 25, 1, "halton base 5");
}

#[test]
fn the_k_by_n_points_of_a_camera_sample_are_distinct() {
    for kind in KINDS {
        let sampler = Sampler::new(kind, 1, 0, 4, 4, 4);
        let px = sampler.pixel(10);
        for s in 0..4 {
            let c = px.camera_sample(s);
            let mut points: Vec<[f32; 2]> = (0..4)
                .flat_map(|k| (0..4).map(move |n| (k, n)))
                .map(|(k, n)| c.light_point(k, n))
                .collect();
            points.extend((0..16).map(|j| c.bsdf_direction(j)));
            let mut choices: Vec<f64> = (0..4).map(|k| c.light_choice(k)).collect();
            points.sort_by(|a, b| a.partial_cmp(b).unwrap());
            choices.sort_by(f64::total_cmp);
            assert!(
                points.windows(2).all(|w| w[0] != w[1]),
                "{kind:?}: {points:?}"
            );
            assert!(
                choices.windows(2).all(|w| w[0] != w[1]),
                "{kind:?}: {choices:?}"
            );
        }
    }
}

#[test]
fn a_later_pass_continues_a_sequence_or_restratifies() {
    // One render of 16 samples against two passes of 8: the sequences give the same points;
    // stratified and LHS passes are each a stratified set of their own (different points).
    for kind in KINDS {
        let whole = Sampler::new(kind, 4, 0, 16, 2, 1).pixel(5);
        let first = Sampler::new(kind, 4, 0, 8, 2, 1).pixel(5);
        let second = Sampler::new(kind, 4, 8, 8, 2, 1).pixel(5);
        let read = |c: CameraSample| (c.pixel_jitter(), c.light_choice(1), c.light_point(1, 0));
        let continues =
            (0..8).all(|s| read(whole.camera_sample(s + 8)) == read(second.camera_sample(s)));
        let restarts =
            (0..8).any(|s| read(first.camera_sample(s)) != read(second.camera_sample(s)));
        assert!(restarts, "{kind:?}: the second pass repeats the first");
        let sequence = !matches!(kind, SamplerKind::Stratified | SamplerKind::Lhs);
        assert_eq!(continues, sequence, "{kind:?}");
    }
}
