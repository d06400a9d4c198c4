"""Small widgets shared by the tabs: the error banner, settings forms built from dataclasses, and plot set-up."""

from __future__ import annotations

import dataclasses
import enum
import re
from typing import Any

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import QEvent, QObject, Qt, QTimer, Signal
from PySide6.QtWidgets import (
    QCheckBox,
    QComboBox,
    QDoubleSpinBox,
    QFormLayout,
    QFrame,
    QGraphicsItem,
    QHBoxLayout,
    QLabel,
    QLineEdit,
    QPushButton,
    QSpinBox,
    QWidget,
)

from gasfilm.analysis.identification import DEFAULT_FIT_BAND_HZ

#: Curve colours (Okabe–Ito based, colour-blind safe; never the measured curve's near-black) in the order models and channels are drawn.
PALETTE = ("#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#882255", "#8C564B", "#999999")
MEASURED_COLOR = "#222222"
ACCEPTED_COLOR = "#1b7f3b"
REJECTED_COLOR = "#b3261e"
PENDING_COLOR = "#a66300"

_SEVERITY_STYLE = {
    "error": ("#fdecea", "#b3261e"),
    "warning": ("#fff4e5", "#a66300"),
    "info": ("#e8f1fb", "#0b5394"),
}

#: Field-name suffixes (the project's unit convention) → unit shown next to the value.
_UNIT_SUFFIXES = (
    ("_1_s", "1/s"),
    ("_hz", "Hz"),
    ("_ms", "ms"),
    ("_s", "s"),
    ("_n", "N"),
    ("_m_s2", "m/s²"),
    ("_kg", "kg"),
    ("_pct", "%"),
    ("_percent", "%"),
    ("_db", "dB"),
    ("_fraction", "fraction"),
)


def split_unit(field_name: str) -> tuple[str, str]:
    """``'pretrigger_s'`` → ``('pretrigger', 's')``; names without a unit suffix get ``''``."""
    for suffix, unit in _UNIT_SUFFIXES:
        if field_name.endswith(suffix) and len(field_name) > len(suffix):
            return field_name[: -len(suffix)], unit
    return field_name, ""


def field_label(field_name: str) -> str:
    base, unit = split_unit(field_name)
    words = re.sub(r"_+", " ", base).strip()
    words = words[:1].upper() + words[1:]
    return f"{words} ({unit})" if unit else words


def sensible_decimals(typical: float) -> int:
    """Decimals that show three significant digits of a value like ``typical`` (1 to 6)."""
    if not typical or not np.isfinite(typical):
        return 2
    return int(min(6, max(1, 2 - np.floor(np.log10(abs(typical))))))


class FixedHeightLabel(QLabel):
    """A word-wrapped label with room for ``lines`` lines whatever its text: the layout around it never moves when
    the text changes (a wrapped QLabel's height-for-width would resize its neighbours, or its whole tab widget)."""

    def __init__(self, text: str = "", lines: int = 2, parent: QWidget | None = None) -> None:
        super().__init__(text, parent)
        self.setWordWrap(True)
        self.setAlignment(Qt.AlignmentFlag.AlignLeft | Qt.AlignmentFlag.AlignTop)
        self.setFixedHeight(lines * self.fontMetrics().lineSpacing() + 4)

    def hasHeightForWidth(self) -> bool:  # noqa: N802 (Qt's name)
        return False


class Banner(QFrame):
    """A non-modal message strip above the tabs: device faults, refused settings, finished jobs."""

    def __init__(self, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.setObjectName("banner")
        self._label = QLabel()
        self._label.setWordWrap(True)
        self._label.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
        close = QPushButton("Dismiss")
        close.setFlat(True)
        close.clicked.connect(self.hide)
        layout = QHBoxLayout(self)
        layout.setContentsMargins(10, 6, 6, 6)
        layout.addWidget(self._label, 1)
        layout.addWidget(close)
        # Room for two lines, kept while hidden: a message never shifts the tabs below it.
        self.setFixedHeight(2 * self._label.fontMetrics().lineSpacing() + 18)
        policy = self.sizePolicy()
        policy.setRetainSizeWhenHidden(True)
        self.setSizePolicy(policy)
        self.severity = ""
        self.history: list[tuple[str, str]] = []
        self.hide()

    @property
    def text(self) -> str:
        return self._label.text()

    def withdraw(self, prefix: str) -> None:
        """Hide the message shown if it starts with ``prefix``: a refusal whose reason has gone (the acquisition it
        asked to stop has stopped) must not stay."""
        if self.isVisible() and self.text.startswith(prefix):
            self.hide()

    def show_message(self, text: str, severity: str = "error") -> None:
        background, foreground = _SEVERITY_STYLE[severity]
        self.severity = severity
        self.history.append((severity, text))
        self._label.setText(text)
        self._label.setToolTip(text)
        self.setStyleSheet(
            f"QFrame#banner {{ background: {background}; border: 1px solid {foreground}; border-radius: 4px; }}"
            f"QLabel {{ color: {foreground}; font-weight: 600; }}"
        )
        self.show()


class DataclassForm(QWidget):
    """An editor for a settings dataclass: one row per field, labelled from ``labels`` (field → (words with unit,
    tooltip)), else from the field name with the unit its suffix says."""

    changed = Signal()

    def __init__(
        self,
        settings_type: type,
        choices: dict[str, tuple[str, ...]] | None = None,
        optional_defaults: dict[str, float] | None = None,
        labels: dict[str, tuple[str, str]] | None = None,
        parent: QWidget | None = None,
    ) -> None:
        super().__init__(parent)
        self.settings_type = settings_type
        labels = labels or {}
        self._defaults = settings_type()
        self._choices = choices or {}
        self._optional_defaults = optional_defaults or {}
        self._editors: dict[str, QWidget] = {}
        self._switches: dict[str, QCheckBox] = {}
        self.labels: dict[str, str] = {}  # field name → the words shown beside its editor
        layout = QFormLayout(self)
        layout.setFieldGrowthPolicy(QFormLayout.FieldGrowthPolicy.FieldsStayAtSizeHint)
        for f in dataclasses.fields(settings_type):
            if not f.init:
                continue
            default = getattr(self._defaults, f.name)
            optional = "None" in str(f.type)
            if optional:
                default = float(self._optional_defaults.get(f.name, 1.0)) if default is None else default
            editor = self._editor_for(f.name, default)
            if editor is None:
                continue
            self._editors[f.name] = editor
            label, help_text = labels.get(f.name, (field_label(f.name), ""))
            self.labels[f.name] = label
            if help_text:
                editor.setToolTip(help_text)
            if optional:
                switch = QCheckBox()
                switch.setObjectName(f"{f.name}_on")
                switch.setToolTip("off: no window (rectangular)")
                switch.setChecked(getattr(self._defaults, f.name) is not None)
                editor.setEnabled(switch.isChecked())
                switch.toggled.connect(editor.setEnabled)
                switch.toggled.connect(self.changed)
                self._switches[f.name] = switch
                row = QHBoxLayout()
                row.addWidget(switch)
                row.addWidget(editor)
                layout.addRow(label, row)
            else:
                layout.addRow(label, editor)

    def _editor_for(self, name: str, default: Any) -> QWidget | None:
        if isinstance(default, bool):
            editor = QCheckBox()
            editor.setChecked(default)
            editor.toggled.connect(self.changed)
        elif isinstance(default, enum.Enum):
            editor = QComboBox()
            for member in type(default):
                editor.addItem(str(member.value), member.value)
            editor.setCurrentIndex(editor.findData(default.value))
            editor.currentIndexChanged.connect(self.changed)
        elif isinstance(default, int):
            editor = QSpinBox()
            editor.setRange(-1_000_000, 1_000_000_000)
            editor.setValue(default)
            editor.valueChanged.connect(self.changed)
        elif isinstance(default, float):
            editor = QDoubleSpinBox()
            editor.setDecimals(sensible_decimals(default))
            editor.setRange(-1e9, 1e9)
            editor.setStepType(QDoubleSpinBox.StepType.AdaptiveDecimalStepType)
            editor.setValue(default)
            editor.setMinimumWidth(110)
            editor.valueChanged.connect(self.changed)
        elif isinstance(default, str) and name in self._choices:
            editor = QComboBox()
            for choice in self._choices[name]:
                editor.addItem(choice, choice)
            editor.setCurrentIndex(max(0, editor.findData(default)))
            editor.currentIndexChanged.connect(self.changed)
        elif isinstance(default, str):
            editor = QLineEdit(default)
            editor.editingFinished.connect(self.changed)
        else:
            return None
        editor.setObjectName(name)
        return editor

    def values(self) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for name, editor in self._editors.items():
            if isinstance(editor, QCheckBox):
                out[name] = editor.isChecked()
            elif isinstance(editor, QComboBox):
                out[name] = editor.currentData()
            elif isinstance(editor, (QSpinBox, QDoubleSpinBox)):
                out[name] = editor.value()
            elif isinstance(editor, QLineEdit):
                out[name] = editor.text()
            if name in self._switches and not self._switches[name].isChecked():
                out[name] = None
        return out

    def set_values(self, values: dict[str, Any]) -> None:
        for name, value in values.items():
            editor = self._editors.get(name)
            if editor is None:
                continue
            switch = self._switches.get(name)
            if switch is not None:
                switch.blockSignals(True)
                switch.setChecked(value is not None)
                editor.setEnabled(value is not None)
                switch.blockSignals(False)
                if value is None:
                    continue
            editor.blockSignals(True)
            if isinstance(editor, QCheckBox):
                editor.setChecked(bool(value))
            elif isinstance(editor, QComboBox):
                index = editor.findData(value.value if isinstance(value, enum.Enum) else value)
                if index >= 0:
                    editor.setCurrentIndex(index)
            elif isinstance(editor, QSpinBox):
                editor.setValue(int(value))
            elif isinstance(editor, QDoubleSpinBox):
                editor.setValue(float(value))
            elif isinstance(editor, QLineEdit):
                editor.setText(str(value))
            editor.blockSignals(False)


def configure_pyqtgraph() -> None:
    """White background, dark text: plots that read like a report and export cleanly."""
    pg.setConfigOptions(background="w", foreground="#222222", antialias=False)


#: Gap between a legend and the edge of the plot's view, in pixels.
LEGEND_MARGIN_PX = 8
#: The least height (px) the data keep when a legend is given room above them (a small plot, e.g. the restoring force's).
MIN_DATA_HEIGHT_PX = 40
#: Where a legend may sit, in the order tried: (horizontal, vertical) signs of pyqtgraph's legend offset
#: (−1: right or bottom, +1: left or top): top right, top left, bottom right, bottom left.
_LEGEND_CORNERS = ((-1, 1), (1, 1), (-1, -1), (1, -1))


class LazyMenuViewBox(pg.ViewBox):
    """A view whose right-click menu (pyqtgraph's axis ranges, mouse mode, export) is built the first time it is
    asked for: built for every plot, the menus were a fifth of the time a main window took to open."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, enableMenu=False, **kwargs)
        self.state["enableMenu"] = True

    def getMenu(self, ev: Any) -> Any:  # noqa: N802 - pyqtgraph's name
        if self.menu is None and self.menuEnabled():
            self._applyMenuEnabled()
        return self.menu

    def getContextMenus(self, event: Any) -> list:  # noqa: N802 - pyqtgraph's name
        menu = self.getMenu(event)
        return menu.actions() if menu is not None else []


class SteadyLabelAxis(pg.AxisItem):
    """An axis that sets its label's rich text only when the text changes: pyqtgraph sets it again at every change of
    range (for the SI prefix), and parsing it was a tenth of the time a main window took to open."""

    def _updateLabel(self) -> None:  # noqa: N802 - pyqtgraph's name
        text = self.labelString()
        if text != getattr(self, "_label_text", None):
            self._label_text = text
            self.label.setHtml(text)
            self._adjustSize()
        self.picture = None
        self.update()


class PlainLogAxis(SteadyLabelAxis):
    """A logarithmic frequency axis labelled in plain numbers at 1, 2 and 5 of each decade (10, 20, 50, 100 Hz), as
    the PNG figures label theirs, instead of pyqtgraph's 2·10¹ at every tick (which run together)."""

    def logTickStrings(self, values: list[float], scale: float, spacing: float) -> list[str]:  # noqa: N802
        labels = []
        for value in values:
            number = 10.0 ** float(value) * scale
            mantissa = number / 10.0 ** np.floor(np.log10(number)) if number > 0 else 0.0
            labels.append(f"{number:g}" if any(abs(mantissa - m) < 1e-6 * m for m in (1.0, 2.0, 5.0)) else "")
        return labels


class TidyPlotItem(pg.PlotItem):
    """A plot whose legend shows only while one of its curves has data (an empty plot has no empty legend box) and
    sits in the corner of the view where it hides the fewest drawn points, never over a curve's highest or lowest
    point: when no corner is free of them, the view is raised to make room for it above the data. It is placed again
    whenever the data, the range or the size changes (once per event-loop turn, however many curves changed)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._legend_timer = QTimer()
        self._legend_timer.setSingleShot(True)
        self._legend_timer.setInterval(0)
        self._legend_timer.timeout.connect(self.tidy_legend)
        self.vb.sigRangeChanged.connect(self._legend_timer.start)
        self.vb.sigResized.connect(self._legend_timer.start)
        self.legend_corner = _LEGEND_CORNERS[0]
        # the cursor read-out: the value under the mouse, with the axes' names and units, in the view's top left
        # corner; made when the mouse first enters the view (an item in every view would repaint it on every change)
        self.readout: pg.TextItem | None = None

    def readout_text(self, view_x: float, view_y: float) -> str:
        """The point (in view coordinates: log10 of a logarithmic axis) in the axes' words and units."""
        x_log, y_log = self.vb.state["logMode"]
        x = 10.0**view_x if x_log else view_x
        y = 10.0**view_y if y_log else view_y
        parts = []
        for side, value in (("bottom", x), ("left", y)):
            axis = self.getAxis(side)
            name, unit = axis.labelText or side, axis.labelUnits
            parts.append(f"{name} {value:.4g}{' ' + unit if unit else ''}")
        return ", ".join(parts)

    def show_readout(self, scene_pos: Any) -> None:
        """Mouse moved on the scene: the read-out follows it inside the view, hides outside."""
        if not self.vb.sceneBoundingRect().contains(scene_pos):
            if self.readout is not None:
                self.readout.setVisible(False)
            return
        point = self.vb.mapSceneToView(scene_pos)
        if not (np.isfinite(point.x()) and np.isfinite(point.y())):
            return
        if self.readout is None:
            self.readout = pg.TextItem(color="#222222", anchor=(0, 0), fill=pg.mkBrush(255, 255, 255, 200))
            self.readout.setParentItem(self.vb)
            self.readout.setPos(4, 2)
            self.readout.setZValue(1000)
        self.readout.setText(self.readout_text(point.x(), point.y()))
        self.readout.setVisible(True)

    def addItem(self, item: Any, *args: Any, **kwargs: Any) -> None:
        super().addItem(item, *args, **kwargs)
        changed = getattr(item, "sigPlotChanged", None)
        if changed is not None:
            changed.connect(self._legend_timer.start)

    def _drawn_points_px(self) -> tuple[np.ndarray, np.ndarray, list[tuple[float, float]]]:
        """Every drawn point of the visible curves in view pixels (x right, y down), and each curve's highest and
        lowest point."""
        (x0, x1), (y0, y1) = self.vb.viewRange()
        width, height = self.vb.width(), self.vb.height()
        xs, ys, extremes = [], [], []
        for item in self.listDataItems():
            if not item.isVisible():
                continue
            x, y = item.getData()
            if x is None or y is None or len(x) == 0:
                continue
            finite = np.isfinite(x) & np.isfinite(y)
            x, y = np.asarray(x)[finite], np.asarray(y)[finite]
            if x.size == 0 or x1 == x0 or y1 == y0:
                continue
            px = (x - x0) / (x1 - x0) * width
            py = (y1 - y) / (y1 - y0) * height
            xs.append(px)
            ys.append(py)
            extremes += [(px[np.argmax(y)], py[np.argmax(y)]), (px[np.argmin(y)], py[np.argmin(y)])]
        if not xs:
            return np.empty(0), np.empty(0), []
        return np.concatenate(xs), np.concatenate(ys), extremes

    def legend_rect_px(self, corner: tuple[int, int]) -> tuple[float, float, float, float]:
        """(left, top, right, bottom) of the legend in view pixels when it sits in ``corner``."""
        rect = self.legend.boundingRect()
        width, height = self.vb.width(), self.vb.height()
        left = LEGEND_MARGIN_PX if corner[0] > 0 else width - LEGEND_MARGIN_PX - rect.width()
        top = LEGEND_MARGIN_PX if corner[1] > 0 else height - LEGEND_MARGIN_PX - rect.height()
        return left, top, left + rect.width(), top + rect.height()

    def tidy_legend(self) -> None:
        legend = self.legend
        if legend is None:
            return
        has_data = any(
            getattr(sample.item, "xData", None) is not None and len(sample.item.xData) > 0
            for sample, _ in legend.items
        )
        legend.setVisible(has_data)
        if not has_data:
            return
        xs, ys, extremes = self._drawn_points_px()

        def cost(corner: tuple[int, int]) -> tuple[int, int]:
            left, top, right, bottom = self.legend_rect_px(corner)
            covered_extremes = sum(left <= x <= right and top <= y <= bottom for x, y in extremes)
            covered = int(np.count_nonzero((xs >= left) & (xs <= right) & (ys >= top) & (ys <= bottom)))
            return covered_extremes, covered

        costs = {corner: cost(corner) for corner in _LEGEND_CORNERS}
        best = min(_LEGEND_CORNERS, key=lambda corner: costs[corner])
        if costs[best][0] > 0 and self._make_room_on_top():
            best = _LEGEND_CORNERS[0]  # the band made above the data is free
        elif costs[self.legend_corner] <= costs[best]:  # stay put unless another corner hides less
            best = self.legend_corner
        self.legend_corner = best
        horizontal, vertical = self.legend_corner
        legend.setOffset((horizontal * LEGEND_MARGIN_PX, vertical * LEGEND_MARGIN_PX))

    def _make_room_on_top(self) -> bool:
        """When every corner would hide a curve's highest or lowest point (point clouds reaching all four corners),
        raise the top of the view by the legend's height so that it sits above the data, as plotting tools make room
        for a legend; False when the data would keep less than :data:`MIN_DATA_HEIGHT_PX` below it."""
        need_px = self.legend.boundingRect().height() + 2 * LEGEND_MARGIN_PX
        height_px = self.vb.height()
        if height_px - need_px < MIN_DATA_HEIGHT_PX:
            return False
        y0, y1 = self.vb.viewRange()[1]
        self.vb.setRange(yRange=(y0, y1 + (y1 - y0) * need_px / (height_px - need_px)), padding=0,
                         disableAutoRange=False)
        return True


class _SceneStaysActive(QObject):
    """Event filter for a plot's scene: once active, it stays so. Qt activates a graphics scene each time its view is
    shown and deactivates it when hidden (a tab switch), and every plot item repaints itself on either change and
    drops its cached pixmap: switching to the Measure tab painted each of its plots three times (55 ms offscreen,
    17 ms once). Plots have no keyboard focus or active/inactive colours that the activation would change."""

    def eventFilter(self, scene: QObject, event: QEvent) -> bool:  # noqa: N802 (Qt's name)
        if event.type() == QEvent.Type.WindowDeactivate:
            return True
        return event.type() == QEvent.Type.WindowActivate and scene.isActive()


_SCENE_STAYS_ACTIVE = _SceneStaysActive()


def make_plot(
    title: str,
    left: tuple[str, str],
    bottom: tuple[str, str] = ("Frequency", "Hz"),
    log_y: bool = False,
    legend: bool = True,
    grid: bool = True,
    log_x: bool = False,
) -> pg.PlotWidget:
    """A plot with labelled axes and units, a grid (off for live views: it is redrawn with every frame) and
    (optionally) a legend kept clear of the data (:class:`TidyPlotItem`). Frequencies stay in Hz (no mHz on an
    empty plot's 0–1 range); ``log_x``: a logarithmic x axis labelled in plain numbers (:class:`PlainLogAxis`)."""
    axes = {side: (PlainLogAxis if log_x and side in ("bottom", "top") else SteadyLabelAxis)(side)
            for side in ("left", "bottom", "top", "right")}
    widget = pg.PlotWidget(plotItem=TidyPlotItem(title=title, viewBox=LazyMenuViewBox(), axisItems=axes))
    item = widget.getPlotItem()
    item.setLabel("left", left[0], units=left[1] or None)
    item.setLabel("bottom", bottom[0], units=bottom[1] or None)
    for side, (_, unit) in (("left", left), ("bottom", bottom)):
        if "/" in unit or "°" in unit or unit in ("", "1", "Hz"):
            item.getAxis(side).enableAutoSIPrefix(False)
    if grid:
        item.showGrid(x=True, y=True, alpha=0.25)
    if log_y or log_x:
        item.setLogMode(x=log_x, y=log_y)
    if legend:
        item.addLegend(
            offset=(-LEGEND_MARGIN_PX, LEGEND_MARGIN_PX), labelTextSize="9pt", brush=pg.mkBrush(255, 255, 255, 210),
            pen=pg.mkPen("#bbbbbb"),
        )
        item.legend.setVisible(False)  # until a curve has data
    if bottom[1] == "Hz":  # an empty plot shows the default fit band, not 0–1 Hz; data autoranges as usual
        band = np.log10(DEFAULT_FIT_BAND_HZ) if log_x else DEFAULT_FIT_BAND_HZ
        item.vb.setRange(xRange=band, padding=0.02, disableAutoRange=False)
    item.setDownsampling(auto=True, mode="peak")
    item.setClipToView(True)
    for side in ("left", "bottom", "top", "right"):
        # an axis drawn once into a pixmap, redrawn only when its ticks change: replaying its recorded text at every
        # repaint took most of a tab's repaint (~120 ms for the Measure tab offscreen, which a job's result waited for)
        item.getAxis(side).setCacheMode(QGraphicsItem.CacheMode.DeviceCoordinateCache)
    widget.scene().installEventFilter(_SCENE_STAYS_ACTIVE)
    widget.scene().sigMouseMoved.connect(item.show_readout)
    return widget


class HomeViews:
    """Every plot's view as the window first laid it out — which axes follow the data, the ranges of those that do
    not (coherence 0–1, phase −90…270°, an empty plot's default band) — so that opening a session shows its data as a
    fresh window would: no zoom or range of the previous session's stays (as a measurement program rescales its
    displays when another data set is loaded)."""

    def __init__(self, root: QWidget) -> None:
        self._views = []
        for plot in root.findChildren(pg.PlotWidget):
            item = plot.getPlotItem()
            view = item.vb
            self._views.append((item, view, list(view.state["autoRange"]), [list(r) for r in view.targetRange()],
                                list(view.state["logMode"])))

    def restore(self) -> None:
        """Each axis back to its first range (and to following the data where it did); an axis shown in other
        coordinates since (a logarithmic frequency axis switched on) follows the data. A cursor read-out, which names
        a point of the previous data, hides until the mouse moves again."""
        for item, view, auto, target, log in self._views:
            if getattr(item, "readout", None) is not None:
                item.readout.setVisible(False)
            for axis, name in ((0, "xRange"), (1, "yRange")):
                if view.linkedView(axis) is not None:  # it follows the view it is linked to
                    continue
                # (setRange switches the axis's auto-range off; switched on again, pyqtgraph ranges it on the data:
                # it does so only when auto-range is switched on)
                follows = auto[axis]
                if view.state["logMode"][axis] == log[axis]:
                    view.setRange(**{name: target[axis]}, padding=0)
                else:
                    view.enableAutoRange(axis=axis, enable=False)
                    follows = True
                view.enableAutoRange(axis=axis, enable=follows)


def show_legend_only_with_data(plot: pg.PlotWidget) -> None:
    """Hide a plot's legend while none of its curves has data, and place it clear of the data now."""
    item = plot.getPlotItem()
    if isinstance(item, TidyPlotItem):
        item.tidy_legend()


def set_region_hz(region: pg.LinearRegionItem, low_hz: float, high_hz: float, log_x: bool) -> None:
    """Place a frequency band on a plot whose x axis may be logarithmic (view coordinates are then log10 f)."""
    if log_x:
        low_hz, high_hz = np.log10(max(low_hz, 1e-3)), np.log10(max(high_hz, 1e-3))
    region.setRegion((low_hz, high_hz))


def phase_deg(h: np.ndarray) -> np.ndarray:
    """Phase in degrees in [−90°, 270°): an accelerance's 180° (below resonance) and 0° (above) without wrapping."""
    return (np.degrees(np.angle(h)) + 90.0) % 360.0 - 90.0


def pen(color: str, width: float = 1.5, style: Qt.PenStyle = Qt.PenStyle.SolidLine) -> Any:
    return pg.mkPen(color=color, width=width, style=style)
