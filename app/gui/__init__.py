"""The technician's GUI (PySide6 + pyqtgraph): Setup → Measure → FRF → Identify → Diagnose.

A thin shell over :mod:`drivers` and :mod:`analysis`. The acquisition and long jobs run on worker threads
(:mod:`gasfilm.app.gui.workers`); :mod:`gasfilm.app.gui.controller` holds the session state on the GUI thread; the tabs draw it.
Start it with ``gasfilm gui [--device sim] [--session FILE]``.
"""
