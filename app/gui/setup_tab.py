"""Setup tab: device, channels and sensors, sample rate, trigger, windows, validation rules, rig spec and the
session's operating conditions."""

from __future__ import annotations

from pathlib import Path

from PySide6.QtCore import Qt, Signal
from PySide6.QtWidgets import (
    QCheckBox,
    QComboBox,
    QDoubleSpinBox,
    QFileDialog,
    QFormLayout,
    QGridLayout,
    QGroupBox,
    QHBoxLayout,
    QHeaderView,
    QLabel,
    QLineEdit,
    QPushButton,
    QSizePolicy,
    QSpinBox,
    QTableWidget,
    QTableWidgetItem,
    QVBoxLayout,
    QWidget,
)

import gasfilm.drivers as drivers
from gasfilm.analysis.capture import SLOPES, TriggerSettings
from gasfilm.analysis.conditions import STANDARD_CONDITIONS, parse_condition_table
from gasfilm.analysis.physics.spec import RigSpec
from gasfilm.analysis.settings import SETTING_LABELS
from gasfilm.analysis.spectra import WindowSettings
from gasfilm.analysis.validation import ValidationSettings
from gasfilm.app.gui.sensors import DEFAULT_SENSOR_LIBRARY, Sensor, load_sensor_library
from gasfilm.app.gui.settings import SIM_TIPS, ChannelSetup, SetupState, rig_spec_label, settings_from_dict
from gasfilm.app.gui.widgets import DataclassForm
from gasfilm.drivers.errors import GasfilmError
from gasfilm.drivers.interface import NI9234_VALID_RATES_HZ, SENSITIVITY_UNITS, ChannelKind, Coupling

TYPED_IN = "typed in"


def _check_date(text: str, what: str) -> None:
    import datetime

    try:
        datetime.date.fromisoformat(text)
    except ValueError:
        raise GasfilmError(f"{what}: '{text}' is not a date (YYYY-MM-DD)") from None
_COLUMNS = ("Use", "Channel", "Name", "Type", "Sensor", "Sensitivity", "Units", "Serial", "Calibrated", "IEPE",
            "Coupling")


class SetupTab(QWidget):
    """Edits a :class:`SetupState`; ``changed`` fires on every edit, ``problem`` names what is invalid ('' if none)."""

    changed = Signal()
    teds_said = Signal(str)  # what Read TEDS found, one line for the banner

    def __init__(self, state: SetupState, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.sensors: list[Sensor] = load_sensor_library(DEFAULT_SENSOR_LIBRARY)
        self.sensor_library_path = DEFAULT_SENSOR_LIBRARY
        self._loading = False

        self.device_combo = QComboBox()
        self.device_combo.setEditable(True)
        refresh = QPushButton("Find devices")
        refresh.clicked.connect(self.refresh_devices)
        self.sim_auto_hammer = QCheckBox("Simulated hammer also hits by itself (every 1.5–3 s)")
        self.sim_tip = QComboBox()
        self.sim_tip.addItems(SIM_TIPS)
        self.sim_seed = QSpinBox()
        self.sim_seed.setRange(0, 1_000_000)
        self.sim_speed = QDoubleSpinBox()
        self.sim_speed.setRange(0.25, 10.0)
        self.sim_speed.setDecimals(2)
        self.sim_speed.setSingleStep(0.5)
        self.sim_speed.setSuffix(" × real time")
        self.sim_speed.setToolTip("The simulated module streams this many seconds of signal per second: a demo session "
                                  "in less time (hit times stay in signal seconds)")
        device_box = QGroupBox("Device")
        device_form = QFormLayout(device_box)
        device_row = QHBoxLayout()
        device_row.addWidget(self.device_combo, 1)
        device_row.addWidget(refresh)
        device_form.addRow("NI 9234 module", device_row)
        device_form.addRow("", self.sim_auto_hammer)
        device_form.addRow("Simulated hammer tip", self.sim_tip)
        device_form.addRow("Simulator seed", self.sim_seed)
        device_form.addRow("Simulator speed", self.sim_speed)
        self.operator = QLineEdit()
        self.operator.setObjectName("operator")
        self.operator.setPlaceholderText("who runs the test")
        self.test_object = QLineEdit()
        self.test_object.setObjectName("test_object")
        self.test_object.setPlaceholderText("what is tested, e.g. air bearing B-17 on mover M2")
        device_form.addRow("Operator", self.operator)
        device_form.addRow("Test object", self.test_object)

        self.table = QTableWidget(len(state.channels), len(_COLUMNS))
        self.table.setHorizontalHeaderLabels(_COLUMNS)
        self.table.verticalHeader().setVisible(False)
        self.response_combo = QComboBox()
        library_button = QPushButton("Sensor library…")
        library_button.clicked.connect(self._choose_sensor_library)
        self.library_label = QLabel(str(self.sensor_library_path))
        channels_box = QGroupBox("Channels and sensors")
        channels_layout = QVBoxLayout(channels_box)
        channels_layout.addWidget(self.table)
        channel_row = QHBoxLayout()
        channel_row.addWidget(QLabel("FRF response channel"))
        channel_row.addWidget(self.response_combo)
        channel_row.addStretch(1)
        channel_row.addWidget(self.library_label)
        channel_row.addWidget(library_button)
        self.teds_button = QPushButton("Read TEDS")
        self.teds_button.setObjectName("read_teds")
        self.teds_button.setToolTip("Read the sensors' TEDS chips through the NI 9234 (IEPE sensors that have one): "
                                    "sensitivity, serial number and model fill the rows")
        self.teds_button.clicked.connect(lambda: self.teds_said.emit(self.read_teds()))
        channel_row.addWidget(self.teds_button)
        channels_layout.addLayout(channel_row)

        self.rate_combo = QComboBox()
        for divisor, rate in enumerate(NI9234_VALID_RATES_HZ, start=1):
            self.rate_combo.addItem(f"{rate:,.2f} S/s  (51 200 / {divisor})".replace(",", " "), rate)
        self.live_view_s = QDoubleSpinBox()
        self.live_view_s.setRange(0.2, 10.0)
        self.live_view_s.setSuffix(" s")
        self.trigger_form = DataclassForm(
            TriggerSettings, choices={"slope": SLOPES}, labels=SETTING_LABELS["trigger"]
        )
        trigger_box = QGroupBox("Sampling and trigger")
        trigger_layout = QFormLayout(trigger_box)
        trigger_layout.addRow("Sample rate", self.rate_combo)
        trigger_layout.addRow("Live view length", self.live_view_s)
        trigger_layout.addRow(self.trigger_form)

        self.window_form = DataclassForm(
            WindowSettings,
            optional_defaults={"force_window_ms": 10.0, "exponential_end_fraction": 0.01},
            labels=SETTING_LABELS["window"],
        )
        window_box = QGroupBox("Windows")
        QVBoxLayout(window_box).addWidget(self.window_form)

        self.validation_form = DataclassForm(ValidationSettings, labels=SETTING_LABELS["validation"])
        self.auto_accept = QCheckBox("Accept hits that pass every check (double hit included) without asking")
        self.auto_reject = QCheckBox("Reject hits that fail a check without asking")
        self.min_coherence = QDoubleSpinBox()
        self.min_coherence.setObjectName("min_coherence")
        self.min_coherence.setRange(0.0, 1.0)
        self.min_coherence.setDecimals(2)
        self.min_coherence.setSingleStep(0.01)
        self.min_coherence.setToolTip(
            "An automatically accepted hit waits for you instead when, with it, the mean coherence γ² in the usable "
            "band falls below this (0: no coherence check)"
        )
        self.target_averages = QSpinBox()
        self.target_averages.setObjectName("target_averages")
        self.target_averages.setRange(0, 10_000)
        self.target_averages.setSpecialValueText("no target")
        self.target_averages.setToolTip("The acquisition stops once this many hits are accepted")
        self.usable_drop_db = QDoubleSpinBox()
        self.usable_drop_db.setObjectName("usable_drop_db")
        self.usable_drop_db.setRange(3.0, 60.0)
        self.usable_drop_db.setDecimals(1)
        self.usable_drop_db.setSuffix(" dB")
        self.usable_drop_db.setToolTip(
            "The FRF is trusted where the force spectrum is within this of its low-frequency level (10–20 dB)"
        )
        validation_box = QGroupBox("Hit checks")
        QVBoxLayout(validation_box).addWidget(self.validation_form)
        rules_box = QGroupBox("Accept rules")
        rules_layout = QVBoxLayout(rules_box)
        rules_layout.addWidget(self.auto_accept)
        rules_layout.addWidget(self.auto_reject)
        rules = QFormLayout()
        rules.addRow("Auto-accept only while coherence γ² ≥", self.min_coherence)
        rules.addRow("Target averages (stop when reached)", self.target_averages)
        rules.addRow("Usable band: force spectrum within", self.usable_drop_db)
        rules_layout.addLayout(rules)

        self.rig_path = QLineEdit()
        self.rig_path.setPlaceholderText(rig_spec_label(""))
        browse = QPushButton("Open…")
        browse.clicked.connect(self._choose_rig_spec)
        nominal = QPushButton("Nominal")
        nominal.clicked.connect(lambda: (self.rig_path.setText(""), self._emit_changed()))
        self.rig_summary = QLabel()
        self.rig_summary.setWordWrap(True)
        rig_box = QGroupBox("Rig spec (simulated rig and diagnosis reference)")
        rig_layout = QVBoxLayout(rig_box)
        rig_row = QHBoxLayout()
        rig_row.addWidget(self.rig_path, 1)
        rig_row.addWidget(browse)
        rig_row.addWidget(nominal)
        rig_layout.addLayout(rig_row)
        rig_layout.addWidget(self.rig_summary)

        self.conditions_table = QTableWidget(0, 2)
        self.conditions_table.setObjectName("conditions_table")
        self.conditions_table.setHorizontalHeaderLabels(("Condition, unit in the name", "Value"))
        self.conditions_table.horizontalHeader().setSectionResizeMode(0, QHeaderView.ResizeMode.ResizeToContents)
        self.conditions_table.horizontalHeader().setStretchLastSection(True)
        self.conditions_table.verticalHeader().setVisible(False)
        self.conditions_table.verticalHeader().setDefaultSectionSize(self.fontMetrics().height() + 6)
        self.conditions_table.setToolTip("Stored with the session and shown by replay, fit, diagnose, the report and "
                                         "campaigns; an empty value is not recorded. Add a label such as bearing = "
                                         "B-17 in an empty row. A rig spec with film laws is played at these.")
        add_condition = QPushButton("Add a condition")
        add_condition.clicked.connect(lambda: self._add_condition_row("", ""))
        # (its rows scroll: its height must not take room from the accept rules and hit checks below)
        self.conditions_table.setSizePolicy(QSizePolicy.Policy.Expanding, QSizePolicy.Policy.Ignored)
        conditions_box = QGroupBox("Operating conditions")
        conditions_layout = QVBoxLayout(conditions_box)
        conditions_layout.addWidget(self.conditions_table)
        conditions_layout.addWidget(add_condition)

        self.problem_label = QLabel()
        self.problem_label.setWordWrap(True)

        # The device beside the rig and its operating point, three columns under the channel table: everything fits
        # the window's default size without scrolling.
        grid = QGridLayout(self)
        grid.addWidget(device_box, 0, 0)
        rig_and_conditions = QVBoxLayout()
        rig_and_conditions.addWidget(rig_box)
        rig_and_conditions.addWidget(conditions_box, 1)
        grid.addLayout(rig_and_conditions, 0, 1, 1, 2)
        grid.addWidget(channels_box, 1, 0, 1, 3)
        grid.addWidget(trigger_box, 2, 0)
        side = QVBoxLayout()
        side.addWidget(window_box)
        side.addWidget(rules_box)
        side.addStretch(1)
        grid.addLayout(side, 2, 1)
        grid.addWidget(validation_box, 2, 2)
        grid.addWidget(self.problem_label, 3, 0, 1, 3)
        grid.setRowStretch(0, 1)  # the spare height to the operating conditions, the boxes below at their size
        for column in range(3):
            grid.setColumnStretch(column, 1)

        for form in (self.trigger_form, self.window_form, self.validation_form):
            form.changed.connect(self._emit_changed)
        for box in (self.sim_auto_hammer, self.auto_accept, self.auto_reject):
            box.toggled.connect(self._emit_changed)
        self.device_combo.currentTextChanged.connect(self._emit_changed)
        self.sim_tip.currentIndexChanged.connect(self._emit_changed)
        self.sim_seed.valueChanged.connect(self._emit_changed)
        self.sim_speed.valueChanged.connect(self._emit_changed)
        self.rate_combo.currentIndexChanged.connect(self._emit_changed)
        self.live_view_s.valueChanged.connect(self._emit_changed)
        for spin in (self.min_coherence, self.target_averages, self.usable_drop_db):
            spin.valueChanged.connect(self._emit_changed)
        self.response_combo.currentIndexChanged.connect(self._emit_changed)
        self.rig_path.editingFinished.connect(self._emit_changed)
        self.operator.editingFinished.connect(self._emit_changed)
        self.test_object.editingFinished.connect(self._emit_changed)
        self.conditions_table.itemChanged.connect(self._emit_changed)

        self.refresh_devices()
        header = self.table.horizontalHeader()
        for column in ("Name", "Sensor", "Units"):
            header.setSectionResizeMode(_COLUMNS.index(column), QHeaderView.ResizeMode.Stretch)
        self.set_state(state)
        self._fit_table_to_rows()

    def _fit_table_to_rows(self) -> None:
        """Every channel row visible, the text columns sharing the width: nothing in the table is cut off."""
        header = self.table.horizontalHeader()
        self.table.resizeColumnsToContents()
        self.table.resizeRowsToContents()
        rows = sum(self.table.rowHeight(row) for row in range(self.table.rowCount()))
        self.table.setFixedHeight(header.sizeHint().height() + rows + 2 * self.table.frameWidth() + 2)
        self.table.setMinimumWidth(sum(self.table.columnWidth(c) for c in range(self.table.columnCount())))

    # --- state in and out ------------------------------------------------------------------------------------------

    def set_state(self, state: SetupState) -> None:
        self._loading = True
        if self.device_combo.findText(state.device) < 0:
            self.device_combo.addItem(state.device)
        self.device_combo.setCurrentText(state.device)
        self.sim_auto_hammer.setChecked(state.sim_auto_hammer)
        self.sim_tip.setCurrentText(state.sim_tip)
        self.sim_seed.setValue(state.sim_seed)
        self.sim_speed.setValue(state.sim_speed)
        for row, channel in enumerate(state.channels):
            self._fill_row(row, channel)
        index = self.rate_combo.findData(min(NI9234_VALID_RATES_HZ, key=lambda r: abs(r - state.sample_rate_hz)))
        self.rate_combo.setCurrentIndex(index)
        self.live_view_s.setValue(state.live_view_s)
        self.trigger_form.set_values(state.trigger)
        self.window_form.set_values(state.window)
        self.validation_form.set_values(state.validation)
        self.auto_accept.setChecked(state.auto_accept)
        self.auto_reject.setChecked(state.auto_reject)
        self.min_coherence.setValue(state.min_coherence)
        self.target_averages.setValue(state.target_averages)
        self.usable_drop_db.setValue(state.usable_drop_db)
        self.rig_path.setText(state.rig_spec_path)
        self.operator.setText(state.operator)
        self.test_object.setText(state.test_object)
        self.conditions_table.setRowCount(0)
        for key, value in {**{key: "" for key in STANDARD_CONDITIONS}, **state.conditions}.items():
            self._add_condition_row(key, value)
        self._refresh_response_channels(state.response_channel)
        self._loading = False
        self._emit_changed()

    def state(self) -> SetupState:
        return SetupState(
            device=self.device_combo.currentText().strip() or drivers.SIMULATED_DEVICE_NAME,
            channels=[self._read_row(row) for row in range(self.table.rowCount())],
            response_channel=self.response_combo.currentData() or "",
            sample_rate_hz=float(self.rate_combo.currentData()),
            trigger=self.trigger_form.values(),
            window=self.window_form.values(),
            validation=self.validation_form.values(),
            rig_spec_path=self.rig_path.text().strip(),
            auto_accept=self.auto_accept.isChecked(),
            auto_reject=self.auto_reject.isChecked(),
            sim_auto_hammer=self.sim_auto_hammer.isChecked(),
            sim_tip=self.sim_tip.currentText(),
            sim_seed=self.sim_seed.value(),
            sim_speed=self.sim_speed.value(),
            live_view_s=self.live_view_s.value(),
            target_averages=self.target_averages.value(),
            min_coherence=self.min_coherence.value(),
            usable_drop_db=self.usable_drop_db.value(),
            conditions=self._conditions(),
            operator=self.operator.text().strip(),
            test_object=self.test_object.text().strip(),
        )

    def set_window(self, values: dict) -> None:
        """Change window settings (the cursors on the Measure tab); ``changed`` fires once."""
        self.window_form.set_values(values)
        self._emit_changed()

    def problem(self) -> str:
        """The first invalid setting as a one-line message, '' when the setup can be armed."""
        state = self.state()
        try:
            state.daq_config()
            state.trigger_settings()
            settings_from_dict(WindowSettings, state.window)
            settings_from_dict(ValidationSettings, state.validation)
            if state.rig_spec_path:
                RigSpec.load(state.rig_spec_path)
            parse_condition_table(state.conditions)
            for channel in state.enabled_channels():
                if channel.calibration_date:
                    _check_date(channel.calibration_date, f"{channel.physical_channel} calibration date")
        except GasfilmError as error:
            return str(error)
        return ""

    # --- operating conditions --------------------------------------------------------------------------------------

    def _add_condition_row(self, key: str, value: str) -> None:
        row = self.conditions_table.rowCount()
        self.conditions_table.insertRow(row)
        name = QTableWidgetItem(key)
        name.setToolTip(STANDARD_CONDITIONS.get(key, "a name ending in its unit (…_mpa, …_um), or a label"))
        self.conditions_table.setItem(row, 0, name)
        self.conditions_table.setItem(row, 1, QTableWidgetItem(value))

    def _conditions(self) -> dict[str, str]:
        """The table as typed: name → value text (rows without a value left out)."""
        table = {}
        for row in range(self.conditions_table.rowCount()):
            name, value = (self.conditions_table.item(row, column) for column in (0, 1))
            key, text = (name.text().strip() if name else ""), (value.text().strip() if value else "")
            if key and text:
                table[key] = text
        return table

    # --- channel table ---------------------------------------------------------------------------------------------

    def _create_row(self, row: int) -> None:
        """The editors of one channel row, made once and reused by every :meth:`set_state`."""
        coupling = QComboBox()
        coupling.addItems([c.value for c in Coupling])
        kind = QComboBox()
        for member in ChannelKind:
            kind.addItem(member.value, member.value)
        sensitivity = QDoubleSpinBox()
        sensitivity.setDecimals(3)
        sensitivity.setRange(0.0, 100_000.0)
        label = QLabel()
        label.setAlignment(Qt.AlignmentFlag.AlignCenter)
        use, name, sensor, units, iepe = QCheckBox(), QLineEdit(), QComboBox(), QComboBox(), QCheckBox()
        serial, calibrated = QLineEdit(), QLineEdit()
        serial.setPlaceholderText("serial")
        calibrated.setPlaceholderText("YYYY-MM-DD")
        calibrated.setToolTip("the sensor's last calibration date")
        for column, widget in enumerate((use, label, name, kind, sensor, sensitivity, units, serial, calibrated, iepe,
                                         coupling)):
            self.table.setCellWidget(row, column, widget)
        serial.editingFinished.connect(self._emit_changed)
        calibrated.editingFinished.connect(self._emit_changed)
        use.toggled.connect(lambda _=False: self._channels_changed())
        name.editingFinished.connect(self._emit_changed)
        kind.currentIndexChanged.connect(lambda _=0, r=row: self._kind_changed(r))
        sensor.currentIndexChanged.connect(lambda _=0, r=row: self._sensor_picked(r))
        sensitivity.valueChanged.connect(lambda _=0.0, r=row: self._typed_in(r))
        units.currentIndexChanged.connect(lambda _=0, r=row: self._typed_in(r))
        iepe.toggled.connect(self._emit_changed)
        coupling.currentIndexChanged.connect(self._emit_changed)

    def _fill_row(self, row: int, channel: ChannelSetup) -> None:
        if self.table.cellWidget(row, 0) is None:
            self._create_row(row)
        cells = {column: self.channel_cell(row, column) for column in _COLUMNS}
        for widget in cells.values():
            widget.blockSignals(True)
        cells["Use"].setChecked(channel.enabled)
        cells["Channel"].setText(channel.physical_channel)
        cells["Name"].setText(channel.name)
        cells["Type"].setCurrentIndex(max(0, cells["Type"].findData(channel.kind)))
        cells["Sensitivity"].setValue(channel.sensitivity)
        cells["IEPE"].setChecked(channel.iepe)
        cells["Coupling"].setCurrentText(channel.coupling)
        cells["Serial"].setText(channel.serial)
        cells["Calibrated"].setText(channel.calibration_date)
        self._set_teds(row, channel.teds)
        for widget in cells.values():
            widget.blockSignals(False)
        self._fill_sensor_choices(row, channel.kind, channel.sensor_model)
        self._fill_units(row, channel.kind, channel.units)

    def channel_cell(self, row: int, column: str) -> QWidget:
        return self.table.cellWidget(row, _COLUMNS.index(column))

    def _read_row(self, row: int) -> ChannelSetup:
        sensor = self.channel_cell(row, "Sensor").currentData()
        return ChannelSetup(
            physical_channel=self.channel_cell(row, "Channel").text(),
            kind=self.channel_cell(row, "Type").currentData(),
            enabled=self.channel_cell(row, "Use").isChecked(),
            name=self.channel_cell(row, "Name").text(),
            sensor_model=sensor or "",
            sensitivity=self.channel_cell(row, "Sensitivity").value(),
            units=self.channel_cell(row, "Units").currentText(),
            iepe=self.channel_cell(row, "IEPE").isChecked(),
            coupling=self.channel_cell(row, "Coupling").currentText(),
            serial=self.channel_cell(row, "Serial").text().strip(),
            calibration_date=self.channel_cell(row, "Calibrated").text().strip(),
            teds=self.channel_cell(row, "Serial").property("teds") or "",
        )

    def _fill_sensor_choices(self, row: int, kind: str, selected: str) -> None:
        combo: QComboBox = self.channel_cell(row, "Sensor")
        combo.blockSignals(True)
        combo.clear()
        combo.addItem(TYPED_IN, "")
        for sensor in self.sensors:
            if sensor.kind.value == kind:
                combo.addItem(sensor.key, sensor.key)
                calibrated = f"; calibrated {sensor.calibration_date}" if sensor.calibration_date else ""
                combo.setItemData(combo.count() - 1, sensor.description + calibrated, Qt.ItemDataRole.ToolTipRole)
        combo.setCurrentIndex(max(0, combo.findData(selected)))
        combo.blockSignals(False)

    def _fill_units(self, row: int, kind: str, selected: str) -> None:
        combo: QComboBox = self.channel_cell(row, "Units")
        combo.blockSignals(True)
        combo.clear()
        combo.addItems(list(SENSITIVITY_UNITS[ChannelKind(kind)]))
        if combo.findText(selected) >= 0:
            combo.setCurrentText(selected)
        combo.blockSignals(False)

    def _kind_changed(self, row: int) -> None:
        kind = self.channel_cell(row, "Type").currentData()
        self._fill_sensor_choices(row, kind, "")
        self._fill_units(row, kind, "")
        self._channels_changed()

    def _sensor_picked(self, row: int) -> None:
        key = self.channel_cell(row, "Sensor").currentData()
        sensor = next((s for s in self.sensors if s.key == key), None)
        if sensor is not None:
            spin: QDoubleSpinBox = self.channel_cell(row, "Sensitivity")
            spin.blockSignals(True)
            spin.setValue(sensor.sensitivity)
            spin.blockSignals(False)
            self._fill_units(row, sensor.kind.value, sensor.units)
            self.channel_cell(row, "Serial").setText(sensor.serial)
            self.channel_cell(row, "Calibrated").setText(sensor.calibration_date)
            self._set_teds(row, "")
        self._emit_changed()

    def _set_teds(self, row: int, teds: str) -> None:
        """Remember what the row's TEDS chip said (shown as the serial's tooltip)."""
        cell = self.channel_cell(row, "Serial")
        cell.setProperty("teds", teds)
        cell.setToolTip(teds or "the sensor's serial number")

    def read_teds(self) -> str:
        """Read the TEDS of every enabled channel's sensor (NI 9234: IEPE sensors with a TEDS chip): its sensitivity,
        serial and model fill the row; returns what was found, one line."""
        state = self.state()
        channels = {c.physical_channel: ChannelKind(c.kind) for c in state.enabled_channels()}
        try:
            found = drivers.read_teds(state.device, channels)
        except GasfilmError as error:
            return f"TEDS: {error}"
        said = []
        for row in range(self.table.rowCount()):
            channel = self._read_row(row).physical_channel
            if channel not in found:
                continue
            teds = found[channel]
            if teds is None:
                said.append(f"{channel} no TEDS")
                continue
            self._fill_sensor_choices(row, self._read_row(row).kind, "")
            spin: QDoubleSpinBox = self.channel_cell(row, "Sensitivity")
            spin.blockSignals(True)
            spin.setValue(teds.sensitivity)
            spin.blockSignals(False)
            self._fill_units(row, self._read_row(row).kind, teds.sensitivity_units)
            self.channel_cell(row, "Serial").setText(str(teds.serial_number))
            self._set_teds(row, teds.description())
            said.append(f"{channel} serial {teds.serial_number}, {teds.sensitivity:g} {teds.sensitivity_units}")
        self._emit_changed()
        return "TEDS: " + "; ".join(said) + ("" if any("serial" in part for part in said) else
                                             " (the sensors carry no TEDS chip)")

    def _typed_in(self, row: int) -> None:
        """A sensitivity or unit edited by hand no longer matches the library entry."""
        combo: QComboBox = self.channel_cell(row, "Sensor")
        key = combo.currentData()
        sensor = next((s for s in self.sensors if s.key == key), None)
        current = self._read_row(row)
        if sensor is not None and (sensor.sensitivity != current.sensitivity or sensor.units != current.units):
            combo.blockSignals(True)
            combo.setCurrentIndex(0)
            combo.blockSignals(False)
        self._emit_changed()

    def _channels_changed(self) -> None:
        self._refresh_response_channels(self.response_combo.currentData())
        self._emit_changed()

    def _refresh_response_channels(self, selected: str | None) -> None:
        self.response_combo.blockSignals(True)
        self.response_combo.clear()
        for row in range(self.table.rowCount()):
            channel = self._read_row(row)
            if channel.enabled and channel.kind == ChannelKind.ACCELERATION.value:
                self.response_combo.addItem(f"{channel.physical_channel} — {channel.name}", channel.physical_channel)
        self.response_combo.setCurrentIndex(max(0, self.response_combo.findData(selected)))
        self.response_combo.blockSignals(False)

    # --- device, library and rig spec --------------------------------------------------------------------------------

    def refresh_devices(self) -> None:
        current = self.device_combo.currentText()
        self.device_combo.blockSignals(True)
        self.device_combo.clear()
        self.device_combo.addItems(drivers.list_devices())
        if current:
            if self.device_combo.findText(current) < 0:
                self.device_combo.addItem(current)
            self.device_combo.setCurrentText(current)
        self.device_combo.blockSignals(False)

    def load_sensor_library(self, path: str | Path) -> None:
        """Use another sensor library file (rows keep their typed-in values)."""
        self.sensors = load_sensor_library(path)
        self.sensor_library_path = Path(path)
        self.library_label.setText(str(path))
        for row in range(self.table.rowCount()):
            channel = self._read_row(row)
            self._fill_sensor_choices(row, channel.kind, channel.sensor_model)
        self._emit_changed()

    def _choose_sensor_library(self) -> None:
        path, _ = QFileDialog.getOpenFileName(self, "Sensor library", str(self.sensor_library_path), "TOML (*.toml)")
        if path:
            self.load_sensor_library(path)

    def _choose_rig_spec(self) -> None:
        start = self.rig_path.text() or str(DEFAULT_SENSOR_LIBRARY.parent / "rigs")  # the shipped rig specs
        path, _ = QFileDialog.getOpenFileName(self, "Rig spec", start, "Rig spec (*.toml)")
        if path:
            self.rig_path.setText(path)
            self._emit_changed()

    def _emit_changed(self) -> None:
        if self._loading:
            return
        is_sim = self.device_combo.currentText().strip() == drivers.SIMULATED_DEVICE_NAME
        for widget in (self.sim_auto_hammer, self.sim_tip, self.sim_seed, self.sim_speed):
            widget.setEnabled(is_sim)
        self.rig_summary.setText(self._rig_summary())
        problem = self.problem()
        self.problem_label.setText(f"⚠ {problem}" if problem else "✓ Setup is valid")
        self.problem_label.setStyleSheet("color: #b3261e;" if problem else "color: #1b7f3b;")
        self.changed.emit()

    def _rig_summary(self) -> str:
        path = self.rig_path.text().strip()
        try:
            spec = RigSpec.load(path) if path else RigSpec.nominal("FOMGF")
        except GasfilmError as error:
            return str(error)
        return f"{rig_spec_label(path)} — mass {spec.mass_kg:g} kg"

