"""Plots stay readable: labels of clustered points do not overlap (clshade.report)."""
from __future__ import annotations


def test_clustered_point_labels_do_not_overlap(tmp_path):
    import matplotlib          # a default dependency: `clshade aa` and `bench --plot` draw with it
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.text import Text

    from clshade.report.plots import label_points

    fig, ax = plt.subplots(figsize=(7, 4.5))
    points = [(5.0 + 0.02 * i, 1e-7 * (1 + 0.05 * i), f"rung number {i}") for i in range(6)]
    points += [(10.0, 4e-8, "far away"), (5.1, 1e-2, "alone at the top")]
    ax.scatter([p[0] for p in points], [p[1] for p in points])
    ax.set_yscale("log")
    label_points(ax, points)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    boxes = [Text.get_window_extent(t, renderer) for t in ax.texts]      # the texts, not their leader lines
    assert len(boxes) == len(points)
    overlaps = [(a.get_text(), b.get_text()) for i, (a, ba) in enumerate(zip(ax.texts, boxes))
                for b, bb in zip(ax.texts[i + 1:], boxes[i + 1:]) if ba.overlaps(bb)]
    assert not overlaps, overlaps
    plt.close(fig)
