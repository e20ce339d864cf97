"""Report of a strategy study: the paper's figures as PNG files and one self-contained HTML page.

:func:`write_report` draws a :class:`cmmsampling.study.Study` (from :func:`cmmsampling.compare`):
the substitute geometry with the probe points of every strategy (paper Fig. 4, 5, 8), the deviation
maps on the face (Fig. 9), the optimisers' best maximum deviation per iteration (Fig. 10), deviation
histograms (Fig. 11, 12), maximum deviation against N with the local bound (Fig. 13) and
the tables (Table 1). Figures are drawn on matplotlib's Agg canvas without pyplot, so a GUI's own
matplotlib backend is left alone. All lengths in mm.
"""
from __future__ import annotations

import base64
import html
import io
import os

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

from .geometry.surface import SurfaceModel
from .strategies.sampling import STRATEGIES
from .strategies.sampling import strategy_label as label
from .study import Study

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


def write_report(study: Study, folder: str | os.PathLike) -> str:
    """Write the study's figures as PNG files and report.html (figures embedded) into folder.

    study: a Study from :func:`cmmsampling.compare`; folder: created if missing.
    Returns the path of report.html.
    """
    os.makedirs(folder, exist_ok=True)
    figures = write_figures(study, folder)
    path = os.path.join(folder, "report.html")
    with open(path, "w", encoding="utf-8") as stream:
        stream.write(report_html(study, figures))
    return path


CSS = """
body { font-family: sans-serif; margin: 2em auto; max-width: 1400px; color: #222; }
table { border-collapse: collapse; margin: 1em 0; font-size: 0.9em; }
th, td { border: 1px solid #bbb; padding: 0.25em 0.6em; text-align: right; }
th:first-child, td:first-child { text-align: left; }
thead th { background: #eef; }
tr.bound td { font-style: italic; background: #f6f6f6; }
tr.group td { border-top: 2px solid #666; }
td.best { font-weight: bold; background: #e6f5e6; }
figure { margin: 2em 0; }
figure img { max-width: 100%; border: 1px solid #ddd; }
.warning { background: #fee; border: 1px solid #c66; padding: 0.6em; }
"""


def report_html(study, figures):
    """The self-contained HTML page: settings, Table 1, the full table and the figures (base64 PNG).

    figures: as returned by :func:`write_figures`.
    """
    parts = [f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>Sampling strategies compared"
             f"</title><style>{CSS}</style></head><body>",
             "<h1>Sampling strategies compared</h1>", _settings_html(study)]
    if study.cancelled:
        parts.append("<p class='warning'>The study was cancelled: only the runs completed are shown.</p>")
    for (strategy, n), message in study.refused.items():
        parts.append(f"<p class='warning'>{html.escape(label(strategy))} at N = {n} was refused: "
                     f"{html.escape(message)}</p>")
    parts += ["<h2>Table 1: maximum deviation (mm) per strategy and number of probe points</h2>",
              _matrix_html(study),
              "<p>± : standard deviation over the seeds. Bold: the smallest maximum at each N. "
              "Deviation: the distance in space between the face and the delivered substitute, both "
              "ways (face to substitute, substitute over the face's domain back to the face). Local "
              "bound: the least first-order maximum that reshaping the best substitute at that N along "
              "its normals could reach; a yardstick of how far that substitute is from a local optimum, "
              "not a bound on what other point sets can reach.</p>",
              "<h2>All measures</h2>",
              "<p>Means over the seeds (± standard deviation). Ratios are to "
              f"{label(study.settings['baseline'])} sampling "
              "at the same N; multiples are of the local bound at that N.</p>",
              _summary_html(study), "<h2>Figures</h2>"]
    for name, caption, png in figures:
        if png is None:
            parts.append(f"<p><em>{name}.png: nothing to draw (no run at N = {study.figure_n}, or no "
                         "strategy that this figure shows).</em></p>")
            continue
        encoded = base64.b64encode(png).decode("ascii")
        parts.append(f"<figure><img alt='{name}' src='data:image/png;base64,{encoded}'>"
                     f"<figcaption>{html.escape(caption)} (<code>{name}.png</code>)</figcaption></figure>")
    parts.append("</body></html>")
    return "\n".join(parts)


def _settings_html(study):
    """A list of what was studied: the face, N, strategies, seeds, fit, grid, the strategies'
    options, time."""
    model = SurfaceModel.from_face(study.face)
    s = study.settings
    items = [
        f"Face: area {model.area:.1f} mm<sup>2</sup>, bounding box "
        f"{' x '.join(f'{length:.1f}' for length in model.extent)} mm",
        f"Numbers of probe points N: {', '.join(map(str, study.ns))}; figures at N = {study.figure_n}",
        f"Strategies: {', '.join(label(x) for x in study.strategies)}",
        f"Seeds {', '.join(map(str, s['seeds']))} for {', '.join(label(x) for x in s['seeded']) or 'none'}; "
        f"the others run with seed {s['seeds'][0]}",
        f"Substitute: degree {_pair(s['fit_degree'])}, poles "
        f"{_pair(s['fit_poles']) if s['fit_poles'] is not None else 'round(2 sqrt(N) / 3) per direction'}, "
        f"smoothing {s['smoothing']:g}; evaluation grid {_pair(s['grid'])} nodes of (u, v), check grid 3x "
        "denser per direction",
        *(_options_html(name, values) for name, values in s["options"].items()),
        "Deviation: the distance in space between the face and the delivered substitute, both ways, "
        "at nodes on the face (a raster of its domain and points along every edge), signed by side, "
        "mm. Local bound: the least first-order maximum deviation that reshaping the best substitute "
        "at that N along its normals could reach, on the evaluation grid (or the check grid); a "
        "yardstick of how near that substitute is to a local optimum of its own shape, not a bound "
        "on what other point sets could reach.",
        f"Wall time of the study: {study.elapsed_s:.1f} s",
    ]
    return "<ul>" + "".join(f"<li>{item}</li>" for item in items) + "</ul>"


def _options_html(strategy, options):
    """'Label: option value, ...' of one strategy's options, escaped for HTML."""
    listed = ", ".join(f"{key} {value}" for key, value in options.items())
    return html.escape(f"{label(strategy)}: {listed}")


def _pair(value):
    """'a x b' for an int (a = b) or a pair, as sample() takes fit_degree, fit_poles and grid."""
    return " x ".join(str(int(v)) for v in np.broadcast_to(value, 2))


def _matrix_html(study):
    """Strategies x N of the mean maximum deviation (± std over seeds), the best per N in bold,
    and the local bounds below."""
    mean, std = study.matrix("max_mm"), study.matrix("max_mm", "std")
    best = np.nanmin(np.where(np.isnan(mean), np.inf, mean), axis=0)
    head = "".join(f"<th>N = {n}</th>" for n in study.ns)
    rows = []
    for i, strategy in enumerate(study.strategies):
        seeded = max((len(study.runs(strategy, n)) for n in study.ns), default=0) > 1
        cells = []
        for j in range(len(study.ns)):
            text = "" if np.isnan(mean[i, j]) else f"{mean[i, j]:.4f}"
            if text and seeded:
                text += f" ± {std[i, j]:.4f}"
            cells.append(f"<td{' class=best' if mean[i, j] == best[j] else ''}>{text}</td>")
        rows.append(f"<tr><td>{html.escape(label(strategy))}</td>{''.join(cells)}</tr>")
    for name, kind in (("local bound about the best", "grid"), ("local bound, check grid", "check")):
        cells = "".join(f"<td>{getattr(study.bounds[n], kind):.4f}</td>" if n in study.bounds else "<td></td>"
                        for n in study.ns)
        rows.append(f"<tr class='bound'><td>{name}</td>{cells}</tr>")
    return f"<table><thead><tr><th>strategy</th>{head}</tr></thead><tbody>{''.join(rows)}</tbody></table>"


SUMMARY_COLUMNS = (
    ("max_mm", "max (mm)", "{:.4f}"), ("mean_mm", "mean (mm)", "{:.4f}"), ("rms_mm", "RMS (mm)", "{:.4f}"),
    ("check_max_mm", "max, check grid (mm)", "{:.4f}"), ("ratio_max", "max / uniform", "{:.3f}"),
    ("ratio_mean", "mean / uniform", "{:.3f}"), ("ratio_rms", "RMS / uniform", "{:.3f}"),
    ("bound_multiple", "max / bound", "{:.3f}"),
    ("check_bound_multiple", "max / bound, check grid", "{:.3f}"),
    ("time_s", "time (s)", "{:.2f}"),
)


def _number(form, value):
    """A value in its column's format; a dash for NaN (no baseline or bound at that N)."""
    return "–" if np.isnan(value) else form.format(value)


def _summary_html(study):
    """Every measure per strategy and N: means over seeds, ± std where several seeds ran."""
    head = "".join(f"<th>{title}</th>" for _, title, _ in SUMMARY_COLUMNS)
    rows = []
    previous = None
    for a in study.summary():
        cells = []
        for measure, _, form in SUMMARY_COLUMNS:
            text = _number(form, a.mean[measure])
            if len(a.seeds) > 1 and np.isfinite(a.mean[measure]):
                text += " ± " + form.format(a.std[measure])
            cells.append(f"<td>{text}</td>")
        group = " class='group'" if a.n != previous else ""
        previous = a.n
        rows.append(f"<tr{group}><td>{html.escape(label(a.strategy))}</td><td>{a.n}</td>"
                    f"<td>{len(a.seeds)}</td>{''.join(cells)}</tr>")
    return (f"<table><thead><tr><th>strategy</th><th>N</th><th>runs</th>{head}</tr></thead>"
            f"<tbody>{''.join(rows)}</tbody></table>")
