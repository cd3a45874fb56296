#!/usr/bin/env python3
"""Benchmark of the wrist camera: what a frame and its detection cost, and the vision's error.

Usage: ``python3 benchmarks/camera_benchmark.py [--frames N]``. Sets up the environment like
the other scripts, prints a table and writes ``benchmarks/results/camera.json``.

The plant core's wrist cameras (:mod:`walker_sim.core.wrist_camera`, the shipped camera and
rendering parameters with the camera switched on) render a gripper held over a node at the
approach height, at offsets drawn uniformly within 8 mm of the hole (seeded), posed directly
(no physics); the hole finder (:mod:`walker_supervisor.core.hole_finder`) measures each frame.
Reported:

* the wall-clock cost of the first frame (the scene's build), of every later frame (its two
  software renders, shadowed and not, for the hard shadows), of a frame's exposure alone (what
  the plant's loop spends on it: the truth and the draws of latency and pixel noise; the plant
  renders in a process of its own) and of a detection, median and 90th percentile;
* the vision error, measured against the truth each frame carries (deterministic: the same
  seed gives the same figures on any machine), median, 95th percentile and largest, and how
  many frames found no hole.

A camera switched off (``gripper.camera.enabled: false``, the shipped file) costs nothing: the
plant builds no scene and renders nothing. The timings depend on the machine and its load (the
JSON records both).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO_ROOT / 'scripts'))
sys.path.insert(0, str(REPO_ROOT / 'benchmarks'))

import walker_env  # noqa: E402

RESULTS = REPO_ROOT / 'benchmarks' / 'results' / 'camera.json'
#: [m] Offsets of the gripper from the hole are drawn uniformly within this along x and y.
OFFSET = 0.008
SEED = 51


def measure(frames: int) -> dict:
    """Render and measure ``frames`` frames; return the costs and the errors."""
    import numpy as np

    from walker_core.camera import CameraModel
    from walker_core.parameter_schema import replace_in_section
    from walker_core.robot_parameters import load_walker_parameters
    from walker_core.truss import Truss
    from walker_sim.core.camera_truth import MountErrors
    from walker_sim.core.config import load_sim_parameters
    from walker_sim.core.contact import NodeGeometry
    from walker_sim.core.wrist_camera import WristCameras
    from walker_supervisor.core.hole_finder import HoleFinder

    params = replace_in_section(load_walker_parameters(), {'gripper.camera.enabled': True})
    sim = load_sim_parameters()
    truss = Truss.from_parameters(params)
    model = CameraModel.from_parameters(params.gripper.camera)
    cameras = WristCameras(model, sim.camera, MountErrors(0.0, 0.0, 0), truss,
                           {name: truss.position(name) for name in truss.node_names},
                           NodeGeometry.from_parameters(params), SEED)
    finder = HoleFinder(model, params.gripper.insertion_position_tolerance,
                        sim.camera.pixel_noise)
    height = params.gripper.approach_height
    offsets = np.random.default_rng(SEED).uniform(-OFFSET, OFFSET, (frames + 1, 2))
    render_s, expose_s, detect_s, errors, sigmas, missed = [], [], [], [], [], 0
    first_s = None
    try:
        for i, offset in enumerate(offsets):
            pose = np.eye(4)
            pose[:3, 3] = truss.position('n2_1') + [*offset, height]
            start = time.perf_counter()
            exposure = cameras.expose('b', pose, 0.0)
            exposed = time.perf_counter() - start
            frame = cameras.render(exposure)
            elapsed = time.perf_counter() - start
            if i == 0:
                first_s = elapsed
                continue
            render_s.append(elapsed)
            expose_s.append(exposed)
            start = time.perf_counter()
            found = finder.find(frame.image, height)
            detect_s.append(time.perf_counter() - start)
            if found.found:
                errors.append(float(np.hypot(*(found.offset - frame.mouth_in_gripper[:2]))))
                sigmas.append(found.sigma)
            else:
                missed += 1
    finally:
        cameras.close()

    def stats_ms(values):
        return {'median_ms': round(1e3 * float(np.median(values)), 2),
                'p90_ms': round(1e3 * float(np.percentile(values, 90)), 2)}

    return {
        'image': [model.width, model.height], 'frames': frames,
        'first_frame_ms': round(1e3 * first_s, 2), 'frame': stats_ms(render_s),
        'exposure': stats_ms(expose_s),
        'detection': stats_ms(detect_s),
        'vision_error_mm': {
            'median': round(1e3 * float(np.median(errors)), 4),
            'p95': round(1e3 * float(np.percentile(errors, 95)), 4),
            'max': round(1e3 * float(np.max(errors)), 4)} if errors else None,
        'stated_sigma_mm_median': round(1e3 * float(np.median(sigmas)), 4) if sigmas else None,
        'not_found': missed, 'offset_range_mm': 1e3 * OFFSET, 'seed': SEED}


def table(results: dict) -> str:
    """Return the results as a text table."""
    width, height = results['image']
    error = results['vision_error_mm'] or {}
    rows = [
        ('image', f'{width} x {height} px'),
        ('first frame (builds the scene)', f"{results['first_frame_ms']:.0f} ms"),
        ('frame, median / p90', f"{results['frame']['median_ms']:.0f} / "
                                f"{results['frame']['p90_ms']:.0f} ms"),
        ('exposure, median / p90', f"{results['exposure']['median_ms']:.1f} / "
                                   f"{results['exposure']['p90_ms']:.1f} ms"),
        ('detection, median / p90', f"{results['detection']['median_ms']:.1f} / "
                                    f"{results['detection']['p90_ms']:.1f} ms"),
        ('vision error, median / p95 / max',
         f"{error.get('median', float('nan')):.3f} / {error.get('p95', float('nan')):.3f} / "
         f"{error.get('max', float('nan')):.3f} mm"),
        ('not found', f"{results['not_found']} of {results['frames']}"),
    ]
    name_width = max(len(name) for name, _ in rows)
    return '\n'.join(f'{name:<{name_width}}  {value}' for name, value in rows)


def main() -> int:
    """Measure, print the table, write the JSON."""
    walker_env.reexec_in_environment(os.path.abspath(__file__), sys.argv[1:])
    from bench_support import NOISE_NOTE, machine_info, write_json

    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--frames', type=int, default=40, help='frames measured')
    parser.add_argument('--output', type=Path, default=RESULTS)
    arguments = parser.parse_args()
    if arguments.frames < 1:
        parser.error('--frames must be at least 1')
    results = measure(arguments.frames)
    print(table(results))
    write_json(arguments.output, {'machine': machine_info(), 'note': NOISE_NOTE, **results})
    print(f'wrote {arguments.output}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
