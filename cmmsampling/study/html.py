"""The study's report: report.html with the paper's table, the settings, the figures embedded."""
from __future__ import annotations

import base64
import html
import os

import numpy as np

from ..geometry.surface import SurfaceModel
from ..strategies.sampling import strategy_label
from .compare import Study
from .figures import write_figures


def label(strategy):
    """A strategy's label, escaped for HTML (a registered strategy's label is not ours)."""
    return html.escape(strategy_label(strategy))


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
        parts.append(f"<p class='warning'>{label(strategy)} at N = {n} was refused: "
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
    return f"{label(strategy)}: {html.escape(listed)}"


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
        rows.append(f"<tr><td>{label(strategy)}</td>{''.join(cells)}</tr>")
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
        rows.append(f"<tr{group}><td>{label(a.strategy)}</td><td>{a.n}</td>"
                    f"<td>{len(a.seeds)}</td>{''.join(cells)}</tr>")
    return (f"<table><thead><tr><th>strategy</th><th>N</th><th>runs</th>{head}</tr></thead>"
            f"<tbody>{''.join(rows)}</tbody></table>")
