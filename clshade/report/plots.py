"""What every plot shares: matplotlib loaded headless, the title-legend-write ending, and point
labels that do not overlap."""
from __future__ import annotations

from pathlib import Path

from clshade.errors import ClshadeError
from clshade.outputs import write_atomic


def pyplot():
    """matplotlib.pyplot on the Agg backend; a ClshadeError naming the fix where matplotlib is missing
    (commands call it before a long run, so that --plot fails first)."""
    try:
        import matplotlib
    except ImportError as exc:
        raise ClshadeError("--plot needs matplotlib, a dependency of clshade missing from this environment: "
                           "pip install matplotlib") from exc
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def write_figure(plt, fig, path: Path) -> None:
    """Write the figure as `path` (atomically, 120 dpi) and close it."""
    write_atomic(path, lambda tmp: fig.savefig(tmp, dpi=120))
    plt.close(fig)


def finish(plt, fig, ax, path: Path, title: str, legend_size: int) -> None:
    """Title, legend, tight layout; write the PNG and close the figure."""
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=legend_size)
    fig.tight_layout()
    write_figure(plt, fig, path)


def label_points(ax, points: list[tuple[float, float, str]], fontsize: float = 6) -> None:
    """Annotate (x, y, label) points without overlapping labels: each label goes up-right of its
    point unless its (measured) box overlaps one already placed, then to the first free slot
    stacked below or above, with a leader line back to the point. Call after the axes' scales
    and limits are set."""
    from matplotlib.text import Text

    fig = ax.figure
    fig.canvas.draw()                                   # the final transforms (scales, limits)
    renderer = fig.canvas.get_renderer()
    placed = []
    order = sorted(points, key=lambda p: -ax.transData.transform((p[0], p[1]))[1])
    for x, y, label in order:
        note = ax.annotate(label, (x, y), fontsize=fontsize, xytext=(3, 3), textcoords="offset points")
        for k in range(40):
            note.xyann = (3, 3.0 + (-1) ** k * ((k + 1) // 2) * (fontsize + 2))   # 3, -5, 11, -13, … points
            note.update_positions(renderer)
            box = Text.get_window_extent(note, renderer)                       # the text alone
            if not any(box.overlaps(other) for other in placed):
                break
        if k:                                           # moved off its point: a leader line back to it
            offset = note.xyann
            note.remove()
            ax.annotate(label, (x, y), fontsize=fontsize, xytext=offset, textcoords="offset points",
                        arrowprops=dict(arrowstyle="-", lw=0.4, color="0.5", shrinkA=0, shrinkB=2))
        placed.append(box)
