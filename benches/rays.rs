//! Ray throughput of the geometry core alone (`Accel`), on the three kinds of rays a render
//! traces, single-threaded:
//!
//! * `camera_closest`: one jittered camera ray per pixel of a 256-pixel-wide image (closest hit);
//! * `shadow_occluded`: from each camera hit to a uniformly chosen point (area-uniform) on a
//!   uniformly chosen emissive triangle, both ends moved off their surfaces exactly as
//!   `Accel::segment_occluded` does (any hit), by the walk alone (`Accel::occluded_by_walk`), and
//!   `shadow_occluded_recent`: the same rays as the renderer asks them (`Accel::occluded`: the
//!   eight triangles that blocked the thread's latest rays first, the walk when none does);
//! * `bounce_closest`: from each camera hit, a cosine-weighted direction about the face-forward
//!   geometric normal (closest hit, unbounded);
//! * `pixel_closest`: `PACKET` jittered camera rays per pixel of a 64-pixel-wide image, traced
//!   one at a time, and `pixel_closest_packets`: the same rays, each pixel's in one packet
//!   (`Accel::closest_hits`), as the renderer traces a pixel's samples;
//! * `pixel_bounce`: from the hits of those `PACKET` rays per pixel (other jitters), one cosine
//!   bounce each, a pixel's consecutive, traced one at a time, and `pixel_bounce_packets`: each
//!   pixel's in one packet. The rays start within a pixel's footprint but point every way, so
//!   the packets take the masked walk (`Accel::closest_hits`): on an Intel Xeon guest (`cargo
//!   bench --bench rays -- pixel_bounce`, two runs) 5.19–5.28 against 4.82–4.92 M rays/s single
//!   on the town, 7.70–7.76 against 7.31–7.32 on the 50k city, 14.18–14.51 against 14.75–14.87
//!   on the Cornell box. The renderer still traces its BSDF rays one at a time (README).
//!
//! Scenes: `scenes/cornell.glb`, `scenes/town.glb`, and the generated `city` with 50,000 emitters
//! (seed 1, as `manylights gen city`); with `MANYLIGHTS_BENCH_1M=1` also the 1,000,000-emitter
//! city. Time is the benchmark thread's CPU time (`CLOCK_THREAD_CPUTIME_ID`), so that other
//! processes on a shared machine inflate it less than wall time; criterion reports it per pass
//! over a set with the set's ray count as throughput (elements/s = rays/s on one core).
//!
//! With `MANYLIGHTS_DUMP_RAYS=DIR` the bench also writes, per scene, `DIR/<scene>/triangles.bin`
//! (n × 9 little-endian f32: the vertices of each triangle) and `DIR/<scene>/<set>.bin` (n × 7 f32:
//! origin, unit direction, tmax; tmax = +inf for closest-hit sets), which
//! `tools/embree_rays.py` traces with Embree 4 for a side-by-side figure.

use std::hint::black_box;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Duration;

use criterion::measurement::{Measurement, ValueFormatter};
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
mod common;
use common::{generated_city, shipped};
use glam::Vec3;
use manylights::accel::{offset_ray_origin, Accel, PACKET};
use manylights::scene::{Camera, Scene};
use rand_core::{Rng, SeedableRng};
use rand_pcg::Pcg32;

/// CPU time of the calling thread, in nanoseconds.
struct ThreadCpuTime;

fn thread_cpu_ns() -> u64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid timespec for the call to write.
    let status = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    assert_eq!(status, 0, "clock_gettime(CLOCK_THREAD_CPUTIME_ID) failed");
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
}

impl Measurement for ThreadCpuTime {
    type Intermediate = u64;
    type Value = u64;
    fn start(&self) -> u64 {
        thread_cpu_ns()
    }
    fn end(&self, start: u64) -> u64 {
        thread_cpu_ns() - start
    }
    fn add(&self, a: &u64, b: &u64) -> u64 {
        a + b
    }
    fn zero(&self) -> u64 {
        0
    }
    fn to_f64(&self, value: &u64) -> f64 {
        *value as f64
    }
    fn formatter(&self) -> &dyn ValueFormatter {
        &CpuFormatter
    }
}

/// Shows CPU times in ms and element throughputs in M/s (values arrive in ns).
struct CpuFormatter;

impl ValueFormatter for CpuFormatter {
    fn scale_values(&self, _typical: f64, values: &mut [f64]) -> &'static str {
        values.iter_mut().for_each(|v| *v *= 1e-6);
        "ms (CPU)"
    }
    fn scale_throughputs(&self, _typical: f64, t: &Throughput, values: &mut [f64]) -> &'static str {
        let per_pass = match *t {
            Throughput::Elements(n) | Throughput::Bytes(n) | Throughput::BytesDecimal(n) => n,
            Throughput::Bits(n) => n,
            Throughput::ElementsAndBytes { elements, .. } => elements,
        } as f64;
        values.iter_mut().for_each(|v| *v = per_pass * 1e3 / *v);
        "M/s (CPU)"
    }
    fn scale_for_machines(&self, _values: &mut [f64]) -> &'static str {
        "ns"
    }
}

/// Width of the image whose camera rays are recorded (height from the camera's aspect).
const WIDTH: u32 = 256;

/// A batch of rays of one kind: origin + t·dir, t ∈ [0, tmax).
struct RaySet {
    name: &'static str,
    origins: Vec<Vec3>,
    dirs: Vec<Vec3>,
    tmax: Vec<f32>,
}

impl RaySet {
    fn new(name: &'static str) -> Self {
        RaySet {
            name,
            origins: Vec::new(),
            dirs: Vec::new(),
            tmax: Vec::new(),
        }
    }

    fn push(&mut self, origin: Vec3, dir: Vec3, tmax: f32) {
        self.origins.push(origin);
        self.dirs.push(dir);
        self.tmax.push(tmax);
    }

    fn len(&self) -> usize {
        self.origins.len()
    }

    /// Number of closest hits, tracing each run of `PACKET` rays as one packet.
    fn trace_packets(&self, accel: &Accel) -> usize {
        let mut count = 0;
        let mut hits = [None; PACKET];
        let rays: Vec<(Vec3, Vec3)> = self
            .origins
            .iter()
            .copied()
            .zip(self.dirs.iter().copied())
            .collect();
        for packet in rays.chunks(PACKET) {
            let hits = &mut hits[..packet.len()];
            accel.closest_hits(packet, hits);
            count += hits.iter().filter(|h| h.is_some()).count();
        }
        count
    }

    /// Number of closest hits (or of occluded rays, when `occlusion`, by the walk alone).
    fn trace(&self, accel: &Accel, occlusion: bool) -> usize {
        let mut count = 0;
        for i in 0..self.len() {
            let (o, d, t) = (self.origins[i], self.dirs[i], self.tmax[i]);
            let found = if occlusion {
                accel.occluded_by_walk(o, d, t)
            } else {
                accel.closest_hit(o, d, t).is_some()
            };
            count += usize::from(found);
        }
        count
    }

    /// Number of occluded rays, the remembered occluders asked first (`Accel::occluded`).
    fn occluded_recent(&self, accel: &Accel) -> usize {
        (0..self.len())
            .filter(|&i| accel.occluded(self.origins[i], self.dirs[i], self.tmax[i]))
            .count()
    }
}

fn uniform(rng: &mut Pcg32) -> f32 {
    (rng.next_u32() >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
}

/// A unit vector about `n` with density cos θ / π (Malley: a uniform disk point lifted).
fn cosine_direction(n: Vec3, u1: f32, u2: f32) -> Vec3 {
    let (t, b) = n.any_orthonormal_pair();
    let r = u1.sqrt();
    let phi = std::f32::consts::TAU * u2;
    let (x, y) = (r * phi.cos(), r * phi.sin());
    let z = (1.0 - u1).max(0.0).sqrt();
    (x * t + y * b + z * n).normalize()
}

/// The scene's camera, or one framing its bounds.
fn scene_camera(scene: &Scene) -> Camera {
    let (lo, hi) = scene.bounds();
    scene
        .camera
        .clone()
        .unwrap_or_else(|| Camera::framing(lo, hi, 1.0))
}

/// Width of the image whose pixels each get `PACKET` camera rays.
const PIXEL_SET_WIDTH: u32 = 64;

/// Calls `each(rng, origin, dir)` for `PACKET` jittered camera rays per pixel of a
/// `PIXEL_SET_WIDTH`-pixel-wide image, a pixel's rays one after another, from random numbers
/// seeded with `seed` (two a ray for its jitter, then whatever `each` draws).
fn each_pixel_ray(scene: &Scene, seed: u64, mut each: impl FnMut(&mut Pcg32, Vec3, Vec3)) {
    let camera = scene_camera(scene);
    let (width, height) = camera.resolution(PIXEL_SET_WIDTH, None);
    let mut rng = Pcg32::seed_from_u64(seed);
    for y in 0..height {
        for x in 0..width {
            for _ in 0..PACKET {
                let (jx, jy) = (uniform(&mut rng), uniform(&mut rng));
                let (origin, dir) = camera.ray(x as f32 + jx, y as f32 + jy, width, height);
                each(&mut rng, origin, dir);
            }
        }
    }
}

/// `PACKET` jittered camera rays per pixel, a pixel's rays consecutive.
fn record_pixels(scene: &Scene, seed: u64) -> RaySet {
    let mut set = RaySet::new("pixel_closest");
    each_pixel_ray(scene, seed, |_, origin, dir| {
        set.push(origin, dir, f32::INFINITY)
    });
    set
}

/// For each of `PACKET` jittered camera rays per pixel of a 64-pixel-wide image, a cosine bounce
/// ray from its hit (a pixel's rays consecutive; rays that miss give none).
fn record_pixel_bounces(scene: &Scene, accel: &Accel, seed: u64) -> RaySet {
    let mut set = RaySet::new("pixel_bounce");
    each_pixel_ray(scene, seed, |rng, origin, dir| {
        let (u1, u2) = (uniform(rng), uniform(rng));
        if let Some((p, n)) = surface_at(scene, accel, origin, dir) {
            let bounce = cosine_direction(n, u1, u2);
            set.push(offset_ray_origin(p, n), bounce, f32::INFINITY);
        }
    });
    set
}

/// The closest hit of a ray, as the point and the geometric normal turned toward the ray's origin.
fn surface_at(scene: &Scene, accel: &Accel, origin: Vec3, dir: Vec3) -> Option<(Vec3, Vec3)> {
    let hit = accel.closest_hit(origin, dir, f32::INFINITY)?;
    let tri = &scene.triangles[hit.triangle as usize];
    let [p0, p1, p2] = tri.positions;
    let p = p0 + hit.b1 * (p1 - p0) + hit.b2 * (p2 - p0);
    let ng = tri.geometric_normal();
    Some((p, if ng.dot(dir) > 0.0 { -ng } else { ng }))
}

/// Records the three ray sets of one frame: camera rays, and at every camera hit one shadow ray
/// and one bounce ray.
fn record(scene: &Scene, accel: &Accel, seed: u64) -> [RaySet; 3] {
    let camera = scene_camera(scene);
    let (width, height) = camera.resolution(WIDTH, None);
    let emitters: Vec<usize> = (0..scene.triangles.len())
        .filter(|&i| scene.material_of(i).is_emissive())
        .collect();
    let mut rng = Pcg32::seed_from_u64(seed);
    let [mut cam, mut shadow, mut bounce] =
        ["camera_closest", "shadow_occluded", "bounce_closest"].map(RaySet::new);
    for y in 0..height {
        for x in 0..width {
            let (jx, jy) = (uniform(&mut rng), uniform(&mut rng));
            let (origin, dir) = camera.ray(x as f32 + jx, y as f32 + jy, width, height);
            cam.push(origin, dir, f32::INFINITY);
            let Some((p, n)) = surface_at(scene, accel, origin, dir) else {
                continue;
            };
            if !emitters.is_empty() {
                let light = &scene.triangles[emitters[rng.next_u32() as usize % emitters.len()]];
                let (u1, u2) = (uniform(&mut rng), uniform(&mut rng));
                let s = u1.sqrt();
                let [q0, q1, q2] = light.positions;
                let q = q0 * (1.0 - s) + q1 * (s * (1.0 - u2)) + q2 * (s * u2);
                let nl = light.geometric_normal();
                let nl = if nl.dot(p - q) < 0.0 { -nl } else { nl };
                let from = offset_ray_origin(p, n);
                let to = offset_ray_origin(q, nl);
                let d = to - from;
                let len = d.length();
                if len > 0.0 {
                    shadow.push(from, d / len, len);
                }
            }
            let (u1, u2) = (uniform(&mut rng), uniform(&mut rng));
            bounce.push(
                offset_ray_origin(p, n),
                cosine_direction(n, u1, u2),
                f32::INFINITY,
            );
        }
    }
    [cam, shadow, bounce]
}

fn write_f32s(path: &Path, values: impl Iterator<Item = f32>) {
    let file = std::fs::File::create(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut out = std::io::BufWriter::new(file);
    for v in values {
        out.write_all(&v.to_le_bytes()).expect("write ray dump");
    }
    out.flush().expect("write ray dump");
}

fn dump(dir: &Path, scene_name: &str, scene: &Scene, sets: &[RaySet]) {
    let folder: PathBuf = dir.join(scene_name);
    std::fs::create_dir_all(&folder).unwrap_or_else(|e| panic!("{}: {e}", folder.display()));
    let verts = scene
        .triangles
        .iter()
        .flat_map(|t| t.positions.into_iter().flat_map(|p| p.to_array()));
    write_f32s(&folder.join("triangles.bin"), verts);
    for set in sets {
        let rays = (0..set.len()).flat_map(|i| {
            let (o, d) = (set.origins[i], set.dirs[i]);
            [o.x, o.y, o.z, d.x, d.y, d.z, set.tmax[i]]
        });
        write_f32s(&folder.join(format!("{}.bin", set.name)), rays);
    }
}

fn bench_scene(c: &mut Criterion<ThreadCpuTime>, name: &str, scene: &Scene) {
    let accel = Accel::build(scene);
    let [cam, shadow, bounce] = record(scene, &accel, 7);
    let pixel_bounces = record_pixel_bounces(scene, &accel, 9);
    let sets = [cam, shadow, bounce, record_pixels(scene, 8), pixel_bounces];
    if let Some(dir) = std::env::var_os("MANYLIGHTS_DUMP_RAYS") {
        dump(Path::new(&dir), name, scene, &sets);
    }
    let mut group = c.benchmark_group(name);
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2));
    for set in &sets {
        let occlusion = set.name.ends_with("occluded");
        group.throughput(Throughput::Elements(set.len() as u64));
        group.bench_function(set.name, |b| {
            b.iter(|| black_box(set.trace(&accel, occlusion)))
        });
    }
    let shadow = &sets[1];
    group.throughput(Throughput::Elements(shadow.len() as u64));
    group.bench_function("shadow_occluded_recent", |b| {
        b.iter(|| black_box(shadow.occluded_recent(&accel)))
    });
    let pixels = &sets[3];
    group.throughput(Throughput::Elements(pixels.len() as u64));
    group.bench_function("pixel_closest_packets", |b| {
        b.iter(|| black_box(pixels.trace_packets(&accel)))
    });
    let bounces = &sets[4];
    group.throughput(Throughput::Elements(bounces.len() as u64));
    group.bench_function("pixel_bounce_packets", |b| {
        b.iter(|| black_box(bounces.trace_packets(&accel)))
    });
    group.finish();
}

fn rays(c: &mut Criterion<ThreadCpuTime>) {
    bench_scene(c, "cornell", &shipped("cornell"));
    bench_scene(c, "town", &shipped("town"));
    bench_scene(c, "city50k", &generated_city(50_000));
    if std::env::var_os("MANYLIGHTS_BENCH_1M").is_some() {
        bench_scene(c, "city1m", &generated_city(1_000_000));
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().with_measurement(ThreadCpuTime);
    targets = rays
}
criterion_main!(benches);
