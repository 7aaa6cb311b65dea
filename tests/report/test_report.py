"""The formatter (clshade/report/): plots stay readable (labels of clustered points do not overlap), and
the bench's table and plot show the 0.1 % low only where there are frames enough to measure it."""
from __future__ import annotations

import pytest


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


@pytest.mark.extra
def test_low01_only_from_1000_frames(tmp_path):
    """Below 1000 frames the 0.1 % low is the slowest frame again: the table prints –, the plot has no bar."""
    from clshade.report.bench import LOW01_MIN_FRAMES, bench_table, plot_fps
    row = dict(label="m", mean_ms=1.0, avg_fps=1000.0, low1_fps=500.0, low01_fps=123.4, median_ms=1.0, p99_ms=2.0,
               host_overhead_ms=0.1, mpixel_per_s=1.0, bytes_per_pixel=48, mean_bytes_per_pixel=40.0,
               lambert_ratio=1.0, copy_ratio=1.0, numpy_ms=1.0, numpy_ratio=1.0, max_rel_error=0.0,
               mean_rel_error=0.0)
    assert "123.4" not in bench_table([dict(row, frames=LOW01_MIN_FRAMES - 1)])
    assert "123.4" in bench_table([dict(row, frames=LOW01_MIN_FRAMES)])
    import matplotlib.pyplot as plt
    bars = []
    real_bar = plt.Axes.bar
    def counting_bar(self, *a, **k):
        bars.append(k.get("label"))
        return real_bar(self, *a, **k)
    import unittest.mock
    with unittest.mock.patch.object(plt.Axes, "bar", counting_bar):
        plot_fps([dict(row, frames=60)], tmp_path / "a.png", "t")
        assert bars == ["average", "1 % low"]
        bars.clear()
        plot_fps([dict(row, frames=1000)], tmp_path / "b.png", "t")
        assert bars == ["average", "1 % low", "0.1 % low"]
