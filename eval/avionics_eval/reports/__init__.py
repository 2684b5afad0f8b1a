"""Report commands: each prints JSON (and may write plots under docs/img/) for the numbers quoted in docs/."""

from pathlib import Path


def save_figure(fig, path: Path) -> Path:
    """Write a matplotlib figure as the PNG the docs embed, and release it."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
