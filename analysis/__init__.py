"""gasfilm's processing layer: capture, spectra, storage, identification, diagnosis."""

import logging

# log records reach the handlers the application configures, never Python's last-resort printer on stderr (the
# command line answers with one line; the log is for the operator afterwards)
logging.getLogger(__name__).addHandler(logging.NullHandler())
