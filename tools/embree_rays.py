#!/usr/bin/env python3
"""Trace the ray sets dumped by `cargo bench --bench rays` with Embree 4 and print rays/s per core
side by side with ours.

    MANYLIGHTS_DUMP_RAYS=/tmp/rays cargo bench --bench rays
    python3 tools/embree_rays.py /tmp/rays [--criterion target/criterion] [--repeats 5]

Dump layout (little-endian f32): DIR/<scene>/triangles.bin holds n x 9 values (three vertices per
triangle); DIR/<scene>/<set>.bin holds n x 7 values (origin, unit direction, tmax; +inf for
closest-hit sets). Sets ending in `_occluded` are traced as occlusion queries, the others as
closest-hit queries, one ray at a time on the calling thread (embreex's `run` loops over
rtcIntersect1 / rtcOccluded1). Embree's time is the calling thread's CPU time, median of the
repeats. Ours is read from criterion's estimates (median time per pass over the same set) of the
last `cargo bench --bench rays` run, so run the two one after the other on a quiet machine.
Needs numpy and embreex (pip install embreex).

With --mitsuba the same rays also go through Mitsuba 3 (pip install mitsuba), the renderer the
peers' harness compares us with: its llvm_ad_rgb variant traces them with its Embree 3 in the
JIT's SIMD-wide packets (`Scene.ray_intersect_preliminary`, `Scene.ray_test`) on one worker
thread, camera rays with the `coherent` hint its integrators give them, each set repeated to at
least a million rays per launch; its time is the process's CPU time, median of the repeats.
"""

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

import numpy as np
from embreex import rtcore_scene
from embreex.mesh_construction import TriangleMesh


def load_f32(path, width):
    data = np.fromfile(path, dtype="<f4")
    if data.size % width:
        sys.exit(f"{path}: {data.size} floats is not a multiple of {width}")
    return data.reshape(-1, width)


def embree_rays_per_s(scene, rays, occlusion, repeats):
    origins = np.ascontiguousarray(rays[:, 0:3])
    dirs = np.ascontiguousarray(rays[:, 3:6])
    tmax = np.ascontiguousarray(rays[:, 6])
    if occlusion:
        trace = lambda: scene.run(origins, dirs, dists=tmax, query="OCCLUDED")  # noqa: E731
    else:
        trace = lambda: scene.run(origins, dirs)  # noqa: E731
    found = trace()
    times = []
    for _ in range(repeats):
        start = time.thread_time()
        trace()
        times.append(time.thread_time() - start)
    # OCCLUDED gives 0 for an occluded ray and -1 otherwise; INTERSECT gives the primitive or -1.
    count = int(np.count_nonzero(found == 0)) if occlusion else int(np.count_nonzero(found >= 0))
    return len(rays) / statistics.median(times), count


# The sets of camera rays, which Mitsuba's integrators trace with `coherent=True` (a hint its
# llvm variant passes to Embree); the others are traced without it, as its integrators trace
# bounce and shadow rays.
COHERENT_SETS = {"camera_closest", "pixel_closest"}


class MitsubaScene:
    """The triangles as one Mitsuba mesh, traced by Mitsuba's llvm variant on one thread."""

    def __init__(self, tris):
        import drjit as dr
        import mitsuba as mi
        mi.set_variant("llvm_ad_rgb")
        dr.set_thread_count(1)
        self.dr, self.mi = dr, mi
        n = len(tris)
        mesh = mi.Mesh("triangles", vertex_count=3 * n, face_count=n)
        params = mi.traverse(mesh)
        params["vertex_positions"] = mi.Float(np.ascontiguousarray(tris, dtype=np.float32).ravel())
        params["faces"] = mi.UInt32(np.arange(3 * n, dtype=np.uint32))
        params.update()
        self.scene = mi.load_dict({"type": "scene", "triangles": mesh})

    def rays_per_s(self, rays, occlusion, coherent, repeats):
        dr, mi = self.dr, self.mi
        copies = max(1, -(-1_000_000 // len(rays)))
        rays = np.tile(rays, (copies, 1))
        # Mitsuba's rays take a finite maxt; closest-hit sets hold +inf.
        tmax = np.where(np.isfinite(rays[:, 6]), rays[:, 6], np.float32(3e38)).astype(np.float32)
        column = lambda k: mi.Float(np.ascontiguousarray(rays[:, k]))  # noqa: E731
        ray = mi.Ray3f(mi.Point3f(column(0), column(1), column(2)),
                       mi.Vector3f(column(3), column(4), column(5)), mi.Float(tmax), 0.0,
                       mi.Color0f())

        def trace():
            if occlusion:
                found = self.scene.ray_test(ray, coherent=coherent)
            else:
                found = self.scene.ray_intersect_preliminary(ray, coherent=coherent).t
            dr.eval(found)
            return found

        trace()  # compiles the kernel, untimed
        times = []
        for _ in range(repeats):
            start = time.process_time()
            found = trace()
            times.append(time.process_time() - start)
        found = np.array(found)
        hits = int(np.count_nonzero(found)) if occlusion else int(np.count_nonzero(found < 1e38))
        return len(rays) / statistics.median(times), hits // copies


def ours_rays_per_s(criterion_dir, scene_name, set_name, n):
    estimates = criterion_dir / scene_name / set_name / "new" / "estimates.json"
    if not estimates.is_file():
        return None
    median_ns = json.loads(estimates.read_text())["median"]["point_estimate"]
    return n / (median_ns * 1e-9)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("dump", type=Path, help="the MANYLIGHTS_DUMP_RAYS folder")
    parser.add_argument("--criterion", type=Path, default=Path("target/criterion"),
                        help="criterion's output folder (default: target/criterion)")
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--mitsuba", action="store_true",
                        help="also trace the rays with Mitsuba 3's llvm variant (pip install mitsuba)")
    args = parser.parse_args()

    scenes = sorted(p for p in args.dump.iterdir() if (p / "triangles.bin").is_file())
    if not scenes:
        sys.exit(f"{args.dump}: no <scene>/triangles.bin (run the bench with MANYLIGHTS_DUMP_RAYS)")
    mitsuba_head = f" {'Mitsuba Mrays/s':>16} {'ours/Mitsuba':>13}" if args.mitsuba else ""
    print(f"{'scene':<10} {'set':<16} {'rays':>8} {'hits':>8} {'Embree Mrays/s':>15} "
          f"{'ours Mrays/s':>13} {'ours/Embree':>12}{mitsuba_head}")
    for folder in scenes:
        tris = load_f32(folder / "triangles.bin", 9).reshape(-1, 3, 3)
        scene = rtcore_scene.EmbreeScene()
        TriangleMesh(scene, np.ascontiguousarray(tris))
        mitsuba = MitsubaScene(tris) if args.mitsuba else None
        for set_path in sorted(folder.glob("*.bin")):
            if set_path.name == "triangles.bin":
                continue
            rays = load_f32(set_path, 7)
            occlusion = set_path.stem.endswith("_occluded")
            embree, count = embree_rays_per_s(scene, rays, occlusion, args.repeats)
            ours = ours_rays_per_s(args.criterion, folder.name, set_path.stem, len(rays))
            ours_text = f"{ours / 1e6:13.2f} {ours / embree:12.2f}" if ours else f"{'-':>13} {'-':>12}"
            mitsuba_text, rate = "", None
            if mitsuba:
                # Camera rays as Mitsuba's integrators trace them: with its coherence hint.
                coherent = set_path.stem in COHERENT_SETS
                rate, hits = mitsuba.rays_per_s(rays, occlusion, coherent, args.repeats)
                if hits != count:
                    print(f"note: {folder.name} {set_path.stem}: Mitsuba found {hits} hits, Embree {count}")
                ratio = f"{ours / rate:13.2f}" if ours else f"{'-':>13}"
                mitsuba_text = f" {rate / 1e6:16.2f} {ratio}"
            print(f"{folder.name:<10} {set_path.stem:<16} {len(rays):>8} {count:>8} "
                  f"{embree / 1e6:15.2f} {ours_text}{mitsuba_text}")
            # The same rays traced by us in packets (a pixel's rays in one walk), if benched.
            packets = ours_rays_per_s(args.criterion, folder.name, set_path.stem + "_packets", len(rays))
            if packets:
                mitsuba_text = f" {rate / 1e6:16.2f} {packets / rate:13.2f}" if rate else ""
                print(f"{folder.name:<10} {'  in packets':<16} {len(rays):>8} {count:>8} "
                      f"{embree / 1e6:15.2f} {packets / 1e6:13.2f} {packets / embree:12.2f}"
                      f"{mitsuba_text}")


if __name__ == "__main__":
    main()
