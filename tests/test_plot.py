"""Figures carry what they claim: walls where the packing has them, a force-width legend
whose sample lines are as wide as the network's lines of those forces, labels with units."""
import numpy as np
import pytest

from cases import two_row_packing
from forcespace.model.packing import Packing
from forcespace.plot import LABELS, STYLE, plot_packing


def _walled():
    # three disks in a box with side walls: a contact with each wall and the floor
    x, y, r = [1.0, 3.0, 5.0], [1.0, 1.0, 1.0], [1.0, 1.0, 1.0]
    a, b = [-3, 0, 1, -1, -1, -1, 2], [0, 1, 2, 0, 1, 2, -4]
    return Packing.from_arrays(x, y, r, a, b, fn=[0.5, 0.5, 0.5, 1, 1, 1, 0.5], width=6.0,
                               y_bottom=0.0, gravity=1.0)


def _lines(ax):
    return [(tuple(l.get_xdata()), tuple(l.get_ydata())) for l in ax.lines]


def test_side_walls_and_plates_are_drawn_where_the_packing_has_them():
    p = _walled()
    ax = plot_packing(p)
    lines = _lines(ax)
    assert ((0.0, 6.0), (0.0, 0.0)) in lines                       # the floor
    assert any(xs == (0.0, 0.0) for xs, _ in lines)                # left wall at x = 0
    assert any(xs == (6.0, 6.0) for xs, _ in lines)                # right wall at x = width
    walls = [l for l in ax.lines if l.get_linestyle() == "-"]
    assert len(walls) == 3
    q = two_row_packing(3)                                         # periodic: dotted edges
    dotted = [l for l in plot_packing(q).lines if l.get_linestyle() == ":"]
    assert sorted(l.get_xdata()[0] for l in dotted) == [0.0, q.width]


def test_force_legend_widths_match_the_network():
    p = two_row_packing(3)
    ax = plot_packing(p)
    widths = np.asarray(ax.collections[1].get_linewidths())
    k = int(np.argmax(p.fn))
    assert widths[k] == STYLE["max_width"]                         # the largest force
    handles = ax.get_legend().legend_handles[:3]
    for h in handles:
        f = float(h.get_label().split("=")[1].split("\\,")[0])   # "$|f_n| = 0.5\,F_0$"
        # the label is rounded to 3 digits: its width agrees to that
        assert abs(h.get_linewidth() - STYLE["max_width"] * f / p.fn.max()) < 0.01
    assert ax.get_xlabel() == LABELS["x"] and "$" in ax.get_title()


def test_a_log_axis_without_positive_data_is_saved_linear_with_a_note(tmp_path):
    # a study whose chains all failed to converge has no eta to plot on its log axis:
    # the figure is still written (linear, with a note), not a matplotlib error
    from matplotlib.figure import Figure

    from forcespace.io.figures import save_figure
    fig = Figure()
    ax_empty, ax_zero = fig.subplots(1, 2)
    ax_empty.set(xscale="log", yscale="log")
    ax_zero.plot([1.0, 2.0], [0.0, 0.0])
    with pytest.warns(UserWarning, match="no positive values"):    # matplotlib's own
        ax_zero.set(xscale="log", yscale="log")
    save_figure(fig, tmp_path / "f.png", tight=True)
    assert (tmp_path / "f.png").stat().st_size > 0 and (tmp_path / "f.pdf").exists()
    assert ax_zero.get_xscale() == "log" and ax_zero.get_yscale() == "linear"
    assert ax_empty.get_yscale() == "linear"
    assert any("no positive values on the y axis" in t.get_text() for t in ax_zero.texts)


def test_a_title_above_the_figure_edge_is_saved_not_cut_off(tmp_path):
    # packing plots put the force legend above the Axes and the title above that; with
    # an equal aspect tight_layout cannot always make room, and the title was cut off
    import matplotlib.image as mpimg
    from matplotlib.figure import Figure

    from forcespace.io.figures import save_figure
    fig = Figure(figsize=(4, 3), dpi=100)
    ax = fig.subplots()
    ax.set_aspect("equal")
    ax.set_title("a title far above", pad=150)
    save_figure(fig, tmp_path / "f.png", dpi=100)
    img = mpimg.imread(tmp_path / "f.png")
    title = ax.title.get_window_extent()
    assert title.y0 > fig.bbox.height                     # drawn beyond the canvas...
    assert img.shape[0] > fig.bbox.height + title.height  # ...and inside the saved image


def test_the_difference_figure_tells_its_elementary_clusters_apart():
    """The paper's Fig. 2 (``draw --difference``): each elementary cluster's disks shaded
    in a colour of its own, above the disks (else hidden under their faces), below the
    force lines; the slice's edges dashed where asked."""
    from matplotlib.collections import LineCollection, PatchCollection
    from ensemble_cases import grooves
    from forcespace.plot import plot_difference
    from forcespace.space.force_space import ForceSpace
    from forcespace.space.structure import decompose, extreme_pair

    p, prob = grooves([0.3, 0.5, 0.7], mu=0.5)
    an = ForceSpace(ranges=False).compute(prob)
    dec = decompose(prob, an, p)
    elementary = [c for c in dec.clusters if c.elementary]
    assert len(elementary) == 3                                # one per groove
    x1, x2 = extreme_pair(prob, an)
    ax = plot_difference(p, prob, x1, x2, dec.domains, clusters=dec.clusters,
                         slice_edges=(0.5, 2.5))
    shaded = [c for c in ax.collections if isinstance(c, PatchCollection) and c.zorder == 1.5]
    colours = {tuple(c.get_facecolor()[0]) for c in shaded}
    assert len(shaded) == len(colours) == 3
    disks = max(c.zorder for c in ax.collections if isinstance(c, PatchCollection)
                and c not in shaded)
    lines = min(c.zorder for c in ax.collections if isinstance(c, LineCollection))
    assert disks < 1.5 < lines
    assert {l.get_ydata()[0] for l in ax.lines if l.get_linestyle() == "--"} == {0.5, 2.5}
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "3 elementary clusters (one colour each)" in labels


def test_a_packing_without_a_scene_name_is_titled_by_its_file_or_as_a_packing():
    p = _walled()                                       # built from arrays: no scene, no file
    assert plot_packing(p).get_title().startswith("packing: $n = 3$")
    p.source = "/somewhere/my_run.h5"
    assert plot_packing(p).get_title().startswith("my_run: $n = 3$")
