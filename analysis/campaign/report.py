"""The campaign report (one self-contained HTML page) from the results table.

Sections: the campaign at a glance; K(f) and C(f) of the identified film per condition (the paper's Figures 3–4
style: K = Re Z(j2πf) in N/m, C = Im Z(j2πf)/(2πf) in N·s/m, each session's best model, the rig spec's film at that
condition dashed); each parameter of the campaign's model against the condition with 1-σ error bars (the spec's
values, i.e. its laws, as crosses); the best model per condition; the diagnosis across the campaign (a finding seen
at some conditions only is marked); the sessions that failed, each with its error.
"""

from __future__ import annotations

import base64
import collections
import datetime
import html
import io
import math
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from gasfilm.analysis.campaign.table import group_label, grouped
from gasfilm.analysis.campaign.session_task import parameter_column, sigma_column, spec_column

#: Points of the K(f)/C(f) curves.
CURVE_POINTS = 200

_STYLE = """
body { font-family: sans-serif; margin: 2em; max-width: 1100px; }
table { border-collapse: collapse; margin: 0.5em 0 1em; font-size: 0.9em; }
th, td { border: 1px solid #bbb; padding: 3px 8px; text-align: left; vertical-align: top; }
th { background: #eee; } .news { background: #fff3cd; } .error { color: #a00; }
img { max-width: 100%; }
"""


#: The largest condition value drawn against (beyond it matplotlib cannot lay out ticks); such rows are in the table.
PLOTTABLE_CONDITION = 1e100


def _png(figure: Any) -> str:
    import matplotlib.pyplot as plt

    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=100)
    plt.close(figure)
    return f"<img alt='figure' src='data:image/png;base64,{base64.b64encode(buffer.getvalue()).decode('ascii')}'>"


def _table(header: Sequence[str], rows: Sequence[Sequence[Any]], classes: Sequence[str] | None = None) -> str:
    head = "".join(f"<th>{html.escape(str(cell))}</th>" for cell in header)
    body = "".join(
        f"<tr class='{(classes or [''] * len(rows))[number]}'>"
        + "".join(f"<td>{html.escape(str(cell))}</td>" for cell in row) + "</tr>"
        for number, row in enumerate(rows))
    return f"<table><tr>{head}</tr>{body}</table>"


def _film_curves(model: Any, values: dict[str, float], freq_hz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """K(f) in N/m and C(f) in N·s/m of a film model (a name or a :class:`FilmModel`) with ``values``."""
    from gasfilm.analysis.physics.elements import get_model

    omega = 2 * np.pi * freq_hz
    stiffness = (get_model(model) if isinstance(model, str) else model).stiffness(1j * omega, values)
    return stiffness.real, stiffness.imag / omega


def _row_model(row: dict[str, Any], model_name: str) -> Any:
    """The network a session's fit of ``model_name`` holds (its identifiable form), else the model's own."""
    from gasfilm.analysis.physics.elements import get_model, parse_network

    network = row.get(f"{model_name}.network")
    return parse_network(network, model_name) if network else get_model(model_name)


def _campaign_parameters(rows: Sequence[dict[str, Any]], model_name: str) -> list[Any]:
    """The parameters of ``model_name`` any session's fit determines, in the model's order (a parameter no session's
    identifiable form holds is left out)."""
    from gasfilm.analysis.physics.elements import get_model

    held = {parameter.name: parameter for row in rows for parameter in _row_model(row, model_name).parameters}
    ordered = [p for p in get_model(model_name).parameters if p.name in held]
    return ordered + [p for name, p in held.items() if name not in {q.name for q in ordered}]


def _model_values(row: dict[str, Any], model_name: str) -> dict[str, float] | None:
    values = {}
    for parameter in _row_model(row, model_name).parameters:
        value = row.get(parameter_column(model_name, parameter.name, parameter.unit))
        if value is None:
            return None
        values[parameter.name] = float(value)
    return values


def _spec_values(row: dict[str, Any]) -> tuple[str, dict[str, float]] | None:
    from gasfilm.analysis.physics.elements import get_model

    name = row.get("spec.film_model")
    if not name:
        return None
    values = {}
    for parameter in get_model(name).parameters:
        value = row.get(spec_column(parameter.name, parameter.unit))
        if value is None:
            return None
        values[parameter.name] = float(value)
    return name, values


def kc_figure(groups: dict[tuple, list[dict[str, Any]]], by: Sequence[str]) -> Any:
    """K(f) and C(f) of each session's best model, one colour per condition; the rig spec's film dashed."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, (k_axis, c_axis) = plt.subplots(1, 2, figsize=(11, 4.2))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for number, (key, rows) in enumerate(groups.items()):
        colour = colours[number % len(colours)]
        label = group_label(by, key)
        for row_number, row in enumerate(rows):
            values = _model_values(row, row["best_model"])
            freq_hz = np.linspace(row["band_low_hz"], row["band_high_hz"], CURVE_POINTS)
            if values is not None:
                k, c = _film_curves(_row_model(row, row["best_model"]), values, freq_hz)
                k_axis.plot(freq_hz, k, color=colour, lw=1.2, label=label if row_number == 0 else None)
                c_axis.plot(freq_hz, c, color=colour, lw=1.2)
        spec = _spec_values(rows[0])
        if spec is not None:
            freq_hz = np.linspace(rows[0]["band_low_hz"], rows[0]["band_high_hz"], CURVE_POINTS)
            k, c = _film_curves(spec[0], spec[1], freq_hz)
            k_axis.plot(freq_hz, k, color=colour, lw=1.0, ls="--")
            c_axis.plot(freq_hz, c, color=colour, lw=1.0, ls="--")
    k_axis.set(xlabel="frequency (Hz)", ylabel="dynamic stiffness K(f) = Re Z (N/m)",
               title="Identified film stiffness per condition")
    c_axis.set(xlabel="frequency (Hz)", ylabel="damping C(f) = Im Z / ω (N·s/m)",
               title="Identified film damping per condition")
    c_axis.set_yscale("log")
    for axis in (k_axis, c_axis):
        axis.grid(True, alpha=0.3)
    k_axis.legend(fontsize=7, title="solid: identified (best model)\ndashed: rig spec at the condition",
                  title_fontsize=7)
    figure.tight_layout()
    return figure


def parameters_figure(rows: Sequence[dict[str, Any]], by: Sequence[str], model_name: str) -> Any | None:
    """Each parameter of ``model_name`` against the first condition of ``by`` (one series per value of the others),
    with 1-σ error bars; the rig spec's value as a cross where its film is the same model."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    parameters = _campaign_parameters(rows, model_name)
    x_key = f"condition.{by[0]}"
    usable = [row for row in rows if isinstance(row.get(x_key), (int, float))  # (a condition plottable on an axis)
              and math.isfinite(row[x_key]) and abs(row[x_key]) <= PLOTTABLE_CONDITION]
    if not usable:
        return None
    series = grouped(usable, by[1:]) if len(by) > 1 else {(): list(usable)}
    columns = min(3, len(parameters))
    lines = -(-len(parameters) // columns)
    figure, axes = plt.subplots(lines, columns, figsize=(4 * columns, 3.2 * lines), squeeze=False)
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for axis, parameter in zip(axes.flat, parameters):
        value_column = parameter_column(model_name, parameter.name, parameter.unit)
        sigma_name = sigma_column(model_name, parameter.name, parameter.unit)
        for number, (key, members) in enumerate(series.items()):
            colour = colours[number % len(colours)]
            x = np.array([row[x_key] for row in members], float)
            y = np.array([row.get(value_column) if row.get(value_column) is not None else np.nan for row in members])
            sigma = np.array([row.get(sigma_name) if row.get(sigma_name) is not None else np.nan for row in members])
            label = group_label(by[1:], key) if by[1:] else "identified"
            axis.errorbar(x, y, yerr=np.nan_to_num(sigma), fmt="o", ms=4, capsize=3, color=colour, label=label)
            at_bound = np.isnan(sigma)
            if np.any(at_bound):
                axis.plot(x[at_bound], y[at_bound], "o", mfc="none", ms=9, color=colour)
            spec_x, spec_y = [], []
            for row in members:
                spec = _spec_values(row)
                if spec is not None and spec[0] == model_name and parameter.name in spec[1]:
                    spec_x.append(row[x_key])
                    spec_y.append(spec[1][parameter.name])
            if spec_x:
                axis.plot(spec_x, spec_y, "x", ms=8, color=colour)
        axis.set(xlabel=by[0], ylabel=f"{parameter.name} ({parameter.unit})", title=f"{model_name}: {parameter.name}")
        axis.grid(True, alpha=0.3)
    for axis in list(axes.flat)[len(parameters):]:
        axis.set_visible(False)
    axes.flat[0].legend(fontsize=7, title="× rig spec (its law); ○ at a bound", title_fontsize=7)
    figure.tight_layout()
    return figure


def campaign_model(rows: Sequence[dict[str, Any]]) -> str | None:
    """The model whose parameters are shown against the conditions: the rig spec's film model when every session's
    spec has the same one among the fitted models, else the model most often best."""
    spec_models = {row.get("spec.film_model") for row in rows}
    if len(spec_models) == 1 and None not in spec_models:
        name = spec_models.pop()
        if any(key.startswith(f"{name}.") for key in rows[0]):
            return name
    counts = collections.Counter(row["best_model"] for row in rows)
    return counts.most_common(1)[0][0] if counts else None


def _diagnosis_section(groups: dict[tuple, list[dict[str, Any]]], by: Sequence[str]) -> str:
    rows_by_group = {key: [row for row in members if row.get("diagnosis_verdict") is not None]
                     for key, members in groups.items()}
    if not any(rows_by_group.values()):
        return "<p>No diagnosis was run (campaign run with --no-diagnosis).</p>"
    findings = sorted({finding.strip() for members in rows_by_group.values() for row in members
                       for finding in (row.get("diagnosis_findings") or "").split(";") if finding.strip()})
    verdicts = sorted({row["diagnosis_verdict"] for members in rows_by_group.values() for row in members})
    header = ["", *[group_label(by, key) for key in rows_by_group]]
    table_rows, classes = [], []
    for verdict in verdicts:
        table_rows.append([f"verdict: {verdict}", *[
            f"{sum(row['diagnosis_verdict'] == verdict for row in members)}/{len(members)}"
            for members in rows_by_group.values()]])
        classes.append("")
    news = []
    for finding in findings:
        counts = [sum(finding in (row.get("diagnosis_findings") or "").split("; ") for row in members)
                  for members in rows_by_group.values()]
        some_only = 0 < sum(1 for count in counts if count) < len(counts)
        if some_only:
            news.append(finding)
        table_rows.append([f"finding: {finding}" + (" (at some conditions only)" if some_only else ""),
                           *[f"{count}/{len(members)}" for count, members in zip(counts, rows_by_group.values())]])
        classes.append("news" if some_only else "")
    unexplained = [sum(bool(row.get("diagnosis_unexplained")) for row in members)
                   for members in rows_by_group.values()]
    table_rows.append(["residual not explained", *[f"{count}/{len(members)}" for count, members
                                                    in zip(unexplained, rows_by_group.values())]])
    classes.append("")
    summary = ("<p>Findings seen at some conditions only (news: the film or the rig changes with the operating "
               f"point): <b>{html.escape(', '.join(news))}</b>.</p>" if news else
               "<p>No finding is specific to some conditions: every finding (if any) appears at every condition.</p>")
    return summary + _table(header, table_rows, classes)


def campaign_html(rows: Sequence[dict[str, Any]], by: Sequence[str], title: str = "gasfilm campaign") -> str:
    """The report as one self-contained HTML page."""
    analysed = [row for row in rows if not row.get("error")]
    failed = [row for row in rows if row.get("error")]
    groups = grouped(analysed, by)
    sections = [
        f"<h1>{html.escape(title)}</h1>",
        f"<p>{len(rows)} sessions: {len(analysed)} analysed, {len(failed)} failed; grouped by "
        f"{html.escape(', '.join(by))} into {len(groups)} conditions. Written "
        f"{datetime.datetime.now().astimezone().strftime('%Y-%m-%d %H:%M %Z')}.</p>",
    ]
    if analysed:
        sections.append("<h2>Identified film per condition: K(f) and C(f)</h2>")
        sections.append("<p>K(f) = Re Z(j2πf), C(f) = Im Z(j2πf)/(2πf) of each session's best model (lowest BIC of "
                        "the models fitted), over its identification band; dashed: the rig spec stored with the "
                        "session, at the session's conditions (its film laws, where it has them).</p>")
        sections.append(_png(kc_figure(groups, by)))
        model = campaign_model(analysed)
        figure = parameters_figure(analysed, by, model) if model else None
        if figure is not None:
            sections.append(f"<h2>{html.escape(model)} parameters against {html.escape(by[0])}</h2>")
            sections.append("<p>Error bars: 1 σ of the fit. A ring marks a parameter at its search bound (not a "
                            "measurement, no σ).</p>")
            sections.append(_png(figure))
            sections.append(_parameter_table(groups, by, model))
        from gasfilm.analysis.campaign.rigid import rigid_section

        sections.append(rigid_section(analysed, by, _png))
        sections.append("<h2>Best model per condition</h2>")
        sections.append(_table(("Condition", "Sessions", "Best model (lowest BIC): sessions"), [
            (group_label(by, key), len(members), ", ".join(
                f"{name} ×{count}" for name, count in collections.Counter(r["best_model"] for r in members)
                .most_common()))
            for key, members in groups.items()]))
        sections.append("<h2>Diagnosis across the campaign</h2>")
        sections.append(_diagnosis_section(groups, by))
    stale = [row for row in analysed if row.get("stored_fits_stale")]
    if stale:
        sections.append("<h2>Sessions whose stored fits are stale</h2>")
        sections.append("<p>The campaign fits every session on all its accepted hits; these sessions also store fits "
                        "made on fewer (their own reports and the GUI show those): <code>gasfilm fit SESSION "
                        "--refit</code> fits them again.</p>")
        sections.append(_table(("Session", "Stored fits"),
                               [(Path(row["session"]).name, row["stored_fits_stale"]) for row in stale]))
    reduced = sorted({note for row in analysed for key, note in row.items() if key.endswith(".notes") and note})
    if reduced:
        sections.append("<h2>Models in their identifiable form</h2>")
        sections.append("<p>What the data do not determine is taken out of a fit (never filled with a value): a "
                        "parameter a session's fit leaves out has no point in the figures.</p><ul>"
                        + "".join(f"<li>{html.escape(note)}</li>" for note in reduced[:20]) + "</ul>")
    if failed:
        sections.append(f"<h2 class='error'>Sessions that failed ({len(failed)})</h2>")
        sections.append(_table(("Session", "Error"), [(row["session"], row["error"]) for row in failed]))
    sections.append("<h2>Sessions</h2>")
    sections.append(_table(
        ("Session", *by, "Accepted hits (fitted)", "Best model", "Diagnosis", "Findings", "Time (s)"),
        [(Path(row["session"]).name, *[row.get(f"condition.{key}", "—") for key in by],
          f"{row.get('accepted_hits', '—')}" + (" (stored fits stale)" if row.get("stored_fits_stale") else ""),
          row.get("best_model", "—")
          + (f" — warning: {row['fit_warnings']}" if row.get("fit_warnings") else ""),
          row.get("diagnosis_verdict") or ("error" if row.get("error") else "—"),
          row.get("diagnosis_findings") or "—",
          "cached" if row.get("cached") else f"{row.get('seconds', 0.0):.1f}") for row in rows]))
    return (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{html.escape(title)}</title>"
            f"<style>{_STYLE}</style></head><body>{''.join(sections)}</body></html>\n")


def _parameter_table(groups: dict[tuple, list[dict[str, Any]]], by: Sequence[str], model_name: str) -> str:
    """Per condition: each parameter's weighted mean ± σ over its sessions, and the rig spec's value."""
    parameters = _campaign_parameters([row for members in groups.values() for row in members], model_name)
    header = ["Condition", *[f"{p.name} ({p.unit})" for p in parameters]]
    lines = []
    for key, members in groups.items():
        cells = [group_label(by, key)]
        for parameter in parameters:
            values = [(row.get(parameter_column(model_name, parameter.name, parameter.unit)),
                       row.get(sigma_column(model_name, parameter.name, parameter.unit))) for row in members]
            measured = [(value, sigma) for value, sigma in values if value is not None and sigma]
            if measured:
                weights = np.array([1 / sigma**2 for _value, sigma in measured])
                mean = float(np.sum(weights * [value for value, _sigma in measured]) / np.sum(weights))
                text = f"{mean:.4g} ± {1 / np.sqrt(np.sum(weights)):.2g}"
            else:
                text = "at a bound" if values else "—"
            spec = _spec_values(members[0])
            if spec is not None and spec[0] == model_name and parameter.name in spec[1]:
                text += f" (spec {spec[1][parameter.name]:.4g})"
            cells.append(text)
        lines.append(cells)
    return _table(header, lines)


def write_campaign_report(rows: Sequence[dict[str, Any]], by: Sequence[str], path: Path) -> Path:
    """Write the HTML report to ``path``."""
    path.write_text(campaign_html(rows, by), encoding="utf-8")
    return path
