"""``python -m torsal.hosts.freecad JOB.json``: run a fins job (:func:`torsal.hosts.freecad.job.main`);
``python -m torsal.hosts.freecad --live``: serve a live session to the FreeCAD object on stdin and
stdout (:func:`torsal.hosts.freecad.live.serve`)."""
import sys

from .job import main
from .live import serve

if __name__ == "__main__":
    sys.exit(serve(sys.stdin, sys.stdout) if sys.argv[1:] == ["--live"] else main())
