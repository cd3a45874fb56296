"""Draw the walker on its truss as a PNG (``ros2 run walker_sim render_walker``).

Renders the plant at its start configuration (``sim.start`` of the parameter file) with
pybullet's software renderer: no display needed.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from walker_core.parameter_schema import ParameterError
from walker_core.parameter_file import ParameterFile
from walker_sim.core.config import plant_sections
from walker_sim.core.plant import WalkerPlant
from walker_sim.core.render import Camera, render_plant, save_png

__all__ = ['main']


def main(argv=None) -> int:
    """Write the image; exit code 2 on an invalid parameter file."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--output', type=Path, default=Path('walker.png'),
                        help='PNG file to write (default: walker.png)')
    parser.add_argument('--params-file', help='parameter file (default: the installed one)')
    parser.add_argument('--width', type=int, default=960, help='image width [px]')
    parser.add_argument('--height', type=int, default=640, help='image height [px]')
    parser.add_argument('--close-up', action='store_true',
                        help='frame the robot rather than the whole truss')
    args = parser.parse_args(argv)
    try:
        params, sim = plant_sections(ParameterFile.read(args.params_file))
        with WalkerPlant(params, sim) as plant:
            camera = None
            if args.close_up:
                state = plant.state()
                middle = 0.5 * (state.poses['a'].position + state.poses['b'].position)
                camera = Camera(target=(middle[0], middle[1], 0.3), distance=1.8, yaw=20.0,
                                pitch=-20.0)
            image = render_plant(plant, camera, args.width, args.height)
    except (ParameterError, ValueError) as error:
        print(f'render_walker: {error}', file=sys.stderr)
        return 2
    print(f'wrote {save_png(image, args.output)}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
