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
    args = parser.parse_args()

    scenes = sorted(p for p in args.dump.iterdir() if (p / "triangles.bin").is_file())
    if not scenes:
        sys.exit(f"{args.dump}: no <scene>/triangles.bin (run the bench with MANYLIGHTS_DUMP_RAYS)")
    print(f"{'scene':<10} {'set':<16} {'rays':>8} {'hits':>8} {'Embree Mrays/s':>15} "
          f"{'ours Mrays/s':>13} {'ours/Embree':>12}")
    for folder in scenes:
        tris = load_f32(folder / "triangles.bin", 9).reshape(-1, 3, 3)
        scene = rtcore_scene.EmbreeScene()
        TriangleMesh(scene, np.ascontiguousarray(tris))
        for set_path in sorted(folder.glob("*.bin")):
            if set_path.name == "triangles.bin":
                continue
            rays = load_f32(set_path, 7)
            occlusion = set_path.stem.endswith("_occluded")
            embree, count = embree_rays_per_s(scene, rays, occlusion, args.repeats)
            ours = ours_rays_per_s(args.criterion, folder.name, set_path.stem, len(rays))
            ours_text = f"{ours / 1e6:13.2f} {ours / embree:12.2f}" if ours else f"{'-':>13} {'-':>12}"
            print(f"{folder.name:<10} {set_path.stem:<16} {len(rays):>8} {count:>8} "
                  f"{embree / 1e6:15.2f} {ours_text}")
            # The same rays traced by us in packets (a pixel's rays in one walk), if benched.
            packets = ours_rays_per_s(args.criterion, folder.name, set_path.stem + "_packets", len(rays))
            if packets:
                print(f"{folder.name:<10} {'  in packets':<16} {len(rays):>8} {count:>8} "
                      f"{embree / 1e6:15.2f} {packets / 1e6:13.2f} {packets / embree:12.2f}")


if __name__ == "__main__":
    main()
