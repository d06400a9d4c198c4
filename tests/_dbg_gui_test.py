import traceback
from tests.test_gui import window, _settings
import tests.test_gui as T
def test_dbg(qtbot, window, tmp_path):
    try:
        T.test_full_hammer_session_through_the_gui(qtbot, window, tmp_path)
    except BaseException:
        with open("/tmp/gui-scratch/dbg.log", "w") as f:
            traceback.print_exc(file=f)
        raise
