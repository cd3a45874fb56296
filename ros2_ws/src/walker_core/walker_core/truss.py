"""The truss face the walker stands on: nodes on a grid, each with a threaded hole (axis +z).

Nodes are named ``n<column>_<row>`` (``n0_0`` at the origin, columns along +x, rows along +y),
each in one spelling only: ASCII decimal numbers without leading zeros.
"""

from __future__ import annotations

import dataclasses
import re

import numpy as np

__all__ = ['UnknownNodeError', 'Truss']

# One spelling per node: 'n4_03' or 'n4_3\n' would otherwise name n4_3 ($ matches before a
# trailing newline, \d any script's digits).
_NUMBER = r'(0|[1-9][0-9]*)'
_NODE_NAME = re.compile(rf'n{_NUMBER}_{_NUMBER}', re.ASCII)


class UnknownNodeError(ValueError):
    """A node name that is malformed or not on this truss."""


@dataclasses.dataclass(frozen=True)
class Truss:
    """Geometry of a rectangular truss face.

    Parameters
    ----------
    spacing : float
        Distance between neighbouring nodes [m].
    columns, rows : int
        Number of nodes along x and y.
    origin : tuple of 2 float
        Position of node ``n0_0`` in the world frame [m].
    """

    spacing: float
    columns: int
    rows: int
    origin: tuple[float, float] = (0.0, 0.0)

    @classmethod
    def from_parameters(cls, params) -> 'Truss':
        """Build from :class:`walker_core.robot_parameters.WalkerParameters`."""
        t = params.truss
        return cls(t.spacing, t.columns, t.rows, (t.origin_x, t.origin_y))

    @property
    def node_names(self) -> list[str]:
        """Every node name, row by row."""
        return [f'n{c}_{r}' for r in range(self.rows) for c in range(self.columns)]

    def index(self, name: str) -> tuple[int, int]:
        """``(column, row)`` of a node; raises :class:`UnknownNodeError` if not on the truss."""
        match = _NODE_NAME.fullmatch(name) if isinstance(name, str) else None
        if match is None:
            raise UnknownNodeError(f'{name!r} is not a node name: expected n<column>_<row>, '
                                   f'e.g. n0_0')
        column, row = int(match.group(1)), int(match.group(2))
        if column >= self.columns or row >= self.rows:
            raise UnknownNodeError(
                f'node {name!r} is not on the truss: columns are 0..{self.columns - 1}, '
                f'rows 0..{self.rows - 1}')
        return column, row

    def name(self, column: int, row: int) -> str:
        """Name of the node at ``(column, row)``."""
        name = f'n{column}_{row}'
        self.index(name)
        return name

    def position(self, name: str) -> np.ndarray:
        """Position [m] of a node's hole mouth in the world frame (z = 0)."""
        column, row = self.index(name)
        return np.array([self.origin[0] + column * self.spacing,
                         self.origin[1] + row * self.spacing, 0.0])

    def neighbors(self, name: str) -> list[str]:
        """Nodes one spacing away (the ones a step can reach), in +x, +y, -x, -y order."""
        column, row = self.index(name)
        candidates = [(column + 1, row), (column, row + 1), (column - 1, row), (column, row - 1)]
        return [f'n{c}_{r}' for c, r in candidates
                if 0 <= c < self.columns and 0 <= r < self.rows]

    def nearest_node(self, point: np.ndarray) -> tuple[str, float]:
        """Node whose hole is nearest a point, and its horizontal distance [m]."""
        point = np.asarray(point, dtype=float)
        column = int(np.clip(round((point[0] - self.origin[0]) / self.spacing), 0,
                             self.columns - 1))
        row = int(np.clip(round((point[1] - self.origin[1]) / self.spacing), 0, self.rows - 1))
        name = f'n{column}_{row}'
        return name, float(np.linalg.norm(self.position(name)[:2] - point[:2]))
