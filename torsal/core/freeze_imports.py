"""Imported last by the fork server the workers are forked from (its preload, see
:func:`torsal.fabrication.workers.start_fork_server`): it freezes (:func:`gc.freeze`) every
object the server's imports made (OpenCascade, numpy, scipy, trimesh, torsal: about 300,000),
so that the garbage collections of every process forked from it (the solids' workers, the
concurrent stages, the nester, the IFC) and of the server's own exit do not walk them, and
do not write to the pages the processes share with the server (copy on write).

Only there: imported by anything else (a test run that imports every module for its
doctests) it does nothing, as frozen objects are never collected.
"""
import gc
import sys


def _in_fork_server_preload() -> bool:
    """Is this module being imported by ``multiprocessing.forkserver.main`` (its preload)?"""
    frame = sys._getframe(1)
    while frame is not None:
        code = frame.f_code
        if code.co_name == "main" and code.co_filename.endswith(("multiprocessing/forkserver.py",
                                                                 "multiprocessing\\forkserver.py")):
            return True
        frame = frame.f_back
    return False


if _in_fork_server_preload():
    gc.freeze()
