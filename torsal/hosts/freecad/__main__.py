"""``python -m torsal.hosts.freecad JOB.json``: run a fins job (:func:`torsal.hosts.freecad.job.main`)."""
import sys

from .job import main

if __name__ == "__main__":
    sys.exit(main())
