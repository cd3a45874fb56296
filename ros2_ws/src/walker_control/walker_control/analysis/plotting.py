"""The figures' matplotlib (Agg backend, no display) and where they are saved."""

from __future__ import annotations

from pathlib import Path

__all__ = ['pyplot', 'save_figure']


def pyplot():
    """Return ``matplotlib.pyplot`` on the Agg backend (no display needed)."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig, path: Path) -> None:
    """Save ``fig`` as a PNG at ``path`` (its directory made) and close it."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    pyplot().close(fig)
