"""The study's figures as PNG: the substitute geometry with the probe points of every strategy
(paper Fig. 4, 5, 8), the deviation maps on the face (Fig. 9), the optimisers' best maximum
deviation per iteration (Fig. 10), deviation histograms (Fig. 11, 12) and maximum deviation
against N with the local bound (Fig. 13). Drawn on matplotlib's Agg canvas without pyplot, so a
GUI's own matplotlib backend is left alone. All lengths in mm."""
from __future__ import annotations

import io
import os

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

from ..strategies.sampling import STRATEGIES
from ..strategies.sampling import strategy_label as label

DPI = 110
PANEL_INCHES = 4.2
# The 3D panels are larger: a surface needs more room than a map.
PANEL_3D_INCHES = 5.6
HISTOGRAM_BINS = 40
LOG_SPAN = 3.0


def _marked(study, flag):
    """The strategies of the study's figures whose record sets ``flag``, in the study's order."""
    return [s for s in study.strategies if s in study.results and getattr(STRATEGIES.get(s), flag, False)]


def colour(strategy):
    """A fixed colour per strategy (tab10 in STRATEGIES order), the same in every figure."""
    names = list(STRATEGIES)
    index = names.index(strategy) if strategy in names else len(names)
    return f"C{index % 10}"


def _grid_of_panels(count, columns=3):
    """(rows, columns) of a small-multiples layout for count panels."""
    columns = min(columns, count) if count > 4 else min(2, count)
    return int(np.ceil(count / columns)), columns


def panel_title(study, strategy):
    """A strategy's display name, with the seed shown where the study ran it over several."""
    seeds = study.settings["seeds"]
    if strategy in study.settings["seeded"] and len(seeds) > 1:
        return f"{label(strategy)} (seed {seeds[0]})"
    return label(strategy)


def _ordered_results(study):
    """[(strategy, SamplingResult)] kept for the figures, in the study's strategy order."""
    return [(s, study.results[s]) for s in study.strategies if s in study.results]


def figure_substitutes(study):
    """Paper Fig. 4, 5, 8: the substitute surface of every strategy with its probe points (3D, mm)."""
    entries = _ordered_results(study)
    if not entries:
        return None
    rows, columns = _grid_of_panels(len(entries))
    fig = Figure(figsize=(PANEL_3D_INCHES * columns, PANEL_3D_INCHES * rows), layout="constrained")
    for index, (strategy, result) in enumerate(entries):
        ax = fig.add_subplot(rows, columns, index + 1, projection="3d", computed_zorder=False)
        surface = result.substitute_grid()
        ax.plot_surface(surface[..., 0], surface[..., 1], surface[..., 2], color="lightsteelblue",
                        alpha=0.75, rcount=30, ccount=30, linewidth=0, shade=True, zorder=1)
        ax.scatter(*result.points.T, color="crimson", s=10, depthshade=False, zorder=2)
        ax.set_box_aspect(None, zoom=1.0)
        ax.set_title(f"{panel_title(study, strategy)}\nmax deviation {result.deviation.maximum:.3f} mm",
                     fontsize=10)
        for setter, name in ((ax.set_xlabel, "x"), (ax.set_ylabel, "y"), (ax.set_zlabel, "z")):
            setter(f"{name} (mm)", fontsize=8, labelpad=1)
        ax.tick_params(labelsize=7, pad=0)
    fig.suptitle(f"Substitute geometry and probe points, N = {study.figure_n}")
    return fig


def figure_deviation_maps(study):
    """Paper Fig. 9: deviation of each strategy's substitute over the face (mm), points overlaid."""
    entries = _ordered_results(study)
    if not entries:
        return None
    rows, columns = _grid_of_panels(len(entries))
    fig = Figure(figsize=(PANEL_INCHES * columns, 0.9 * PANEL_INCHES * rows), layout="constrained")
    for index, (strategy, result) in enumerate(entries):
        ax = fig.add_subplot(rows, columns, index + 1)
        grid, points, names = result.map_coordinates()
        field = result.deviation.field
        filled = ax.contourf(grid[..., 0], grid[..., 1], field, levels=20, cmap="viridis")
        fig.colorbar(filled, ax=ax, label="deviation (mm)")
        ax.scatter(*points.T, s=10, color="white", edgecolors="black", linewidths=0.5, zorder=3,
                   clip_on=False)
        worst = np.unravel_index(np.nanargmax(field), field.shape)
        ax.plot(*grid[worst], marker="x", color="red", markersize=9, mew=2, zorder=4, clip_on=False)
        ax.set_title(f"{panel_title(study, strategy)}: max {result.deviation.maximum:.3f} mm", fontsize=10,
                     pad=8)
        ax.set_xlabel(names[0])
        ax.set_ylabel(names[1])
        ax.set_aspect("equal")
    fig.suptitle(f"Deviation of the substitute from the face, N = {study.figure_n} (white: probe "
                 "points, red x: largest deviation; each panel has its own colour scale)")
    return fig


def figure_convergence(study):
    """Paper Fig. 10: best maximum deviation (mm) per PSO iteration and per evaluation of the
    optimal strategy, with the uniform strategies and the local bound for reference."""
    entries = [(s, r) for s, r in _ordered_results(study) if r.history is not None and len(r.history)]
    if not entries:
        return None
    fig = Figure(figsize=(6.0 * len(entries), 4.5), layout="constrained")
    bound = study.bounds.get(study.figure_n)
    for index, (strategy, result) in enumerate(entries):
        ax = fig.add_subplot(1, len(entries), index + 1)
        steps = np.arange(1, len(result.history) + 1)
        ax.plot(steps, result.history, color=colour(strategy), label=label(strategy))
        for reference in _marked(study, "reference"):
            if reference != strategy:
                ax.axhline(study.results[reference].deviation.maximum, color=colour(reference),
                           linestyle=":", label=label(reference))
        if bound is not None:
            ax.axhline(bound.grid, color="black", linestyle="--", label="local bound about the best")
        ax.set_xscale("log")
        _scale_y(ax)
        ax.set_xlabel(STRATEGIES[strategy].progress_unit if strategy in STRATEGIES else "step")
        ax.set_ylabel("best maximum deviation (mm)")
        ax.set_title(f"{panel_title(study, strategy)}, N = {study.figure_n}: "
                     f"final {result.history[-1]:.4f} mm")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    return fig


def figure_histograms(study):
    """Paper Fig. 11, 12: distribution of the deviation over the grid nodes (mm), same bins for
    the uniform strategies, PSO and the optimal strategy."""
    entries = [(s, study.results[s]) for s in _marked(study, "figures")]
    entries = entries or _ordered_results(study)[:4]
    if not entries:
        return None
    values = [r.deviation.field[np.isfinite(r.deviation.field)] for _, r in entries]
    bins = np.linspace(0.0, max(v.max() for v in values), HISTOGRAM_BINS + 1)
    rows, columns = _grid_of_panels(len(entries))
    fig = Figure(figsize=(5.0 * columns, 3.6 * rows), layout="constrained")
    axes = fig.subplots(rows, columns, sharex=True, sharey=True, squeeze=False).ravel()
    for ax, (strategy, result), deviation in zip(axes, entries, values):
        ax.hist(deviation, bins=bins, color=colour(strategy))
        ax.axvline(deviation.mean(), color="black", linestyle="--", label=f"mean {deviation.mean():.3f} mm")
        ax.axvline(deviation.max(), color="red", label=f"max {deviation.max():.3f} mm")
        ax.set_title(f"{panel_title(study, strategy)}: std {deviation.std():.3f} mm", fontsize=10)
        ax.set_xlabel("deviation (mm)")
        ax.set_ylabel("grid nodes")
        ax.tick_params(labelbottom=True, labelleft=True)
        ax.legend(fontsize=8)
    for ax in axes[len(entries):]:
        ax.set_visible(False)
    grid = entries[0][1].deviation.field.shape
    fig.suptitle(f"Deviation at the {grid[0]} x {grid[1]} grid nodes, N = {study.figure_n}")
    return fig


def figure_max_vs_n(study):
    """Paper Fig. 13: maximum deviation (mm), its multiple of the local bound and the run
    time (s) against N for every strategy; seeded strategies as the mean over their seeds with a band
    from the smallest to the largest."""
    if not study.rows:
        return None
    ns = np.array(study.ns)
    fig = Figure(figsize=(16.5, 5.2), layout="constrained")
    axes = fig.subplots(1, 3)
    panels = (("max_mm", "maximum deviation (mm)"), ("bound_multiple", "max deviation / local bound"),
              ("time_s", "run time (s)"))
    _draw_bounds(axes[0], study)
    axes[1].axhline(1.0, color="black", linestyle="--", label="local bound about the best")
    for ax, (measure, title) in zip(axes, panels):
        for i, strategy in enumerate(study.strategies):
            _plot_series(ax, ns, study, i, strategy, measure)
        _scale_y(ax)
        ax.set_xlabel("number of probe points N")
        ax.set_ylabel(title)
        ax.set_xticks(ns)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_title("Maximum deviation")
    axes[1].set_title("How far from the best found (local bound)")
    axes[2].set_title("Run time")
    handles = dict(zip(*reversed(axes[0].get_legend_handles_labels())))
    names = [label(s) for s in study.strategies if label(s) in handles]
    names += [name for name in handles if name not in names]
    axes[2].legend([handles[name] for name in names], names, loc="upper left",
                   bbox_to_anchor=(1.02, 1.0), fontsize=9)
    return fig


def _scale_y(ax):
    """Logarithmic y axis labelled 1, 2, 5 times the powers of ten in plain numbers; linear where the
    data span less than LOG_SPAN (a log axis would show hardly a label)."""
    low, high = ax.dataLim.intervaly
    if not (low > 0 and high / low >= LOG_SPAN):
        return
    ax.set_yscale("log")
    ax.yaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
    ax.yaxis.set_major_formatter(FuncFormatter(lambda value, _: f"{value:g}"))
    ax.yaxis.set_minor_formatter(NullFormatter())


def _plot_series(ax, ns, study, index, strategy, measure):
    """One strategy's mean over seeds against N, with a min-max band where it ran over several seeds."""
    mean = study.matrix(measure)[index]
    if np.all(np.isnan(mean)):
        return
    ax.plot(ns, mean, color=colour(strategy), label=label(strategy), marker="o", markersize=4)
    if max((len(study.runs(strategy, n)) for n in study.ns), default=0) > 1:
        ax.fill_between(ns, study.matrix(measure, "low")[index], study.matrix(measure, "high")[index],
                        color=colour(strategy), alpha=0.15, linewidth=0)


def _draw_bounds(ax, study):
    """The local bounds about the best substitute (grid and check grid) against N."""
    if not study.bounds:
        return
    ns = sorted(study.bounds)
    ax.plot(ns, [study.bounds[n].grid for n in ns], color="black", linestyle="--", linewidth=2,
            label="local bound about the best")
    ax.plot(ns, [study.bounds[n].check for n in ns], color="black", linestyle=":", linewidth=2,
            label="local bound, check grid")


FIGURES = (
    ("substitutes", figure_substitutes,
     "Substitute geometry (the least-squares B-spline fitted to the probe points) with the probe "
     "points of every strategy (paper Fig. 4, 5, 8). Axes in mm."),
    ("deviation_maps", figure_deviation_maps,
     "Deviation of each substitute from the CAD face over the face (paper Fig. 9); colour bars in mm."),
    ("convergence", figure_convergence,
     "Best maximum deviation found so far by the optimisers (paper Fig. 10), with the uniform "
     "strategies and the local bound about the best substitute for reference."),
    ("histograms", figure_histograms,
     "Distribution of the deviation over the evaluation grid's nodes (paper Fig. 11, 12)."),
    ("max_vs_n", figure_max_vs_n,
     "Maximum deviation, its multiple of the local bound, and run time against the number "
     "of probe points (paper Fig. 13). Strategies run over several seeds show the mean over the seeds "
     "and a band from the smallest to the largest."),
)


def render_png(fig):
    """The figure as PNG bytes (Agg canvas, DPI dots per inch)."""
    FigureCanvasAgg(fig)
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=DPI)
    return buffer.getvalue()


def write_figures(study, folder):
    """Draw every figure that has data into folder as <name>.png.

    Returns [(name, caption, png bytes or None)] in FIGURES order (None: nothing to draw, e.g. a
    study cancelled before the figures' N).
    """
    written = []
    for name, draw, caption in FIGURES:
        fig = draw(study)
        png = render_png(fig) if fig is not None else None
        if png is not None:
            with open(os.path.join(folder, f"{name}.png"), "wb") as stream:
                stream.write(png)
        written.append((name, caption, png))
    return written
