"""The session's background builder starts a build once its design has stood ``settle``
seconds without a newer edit: a burst of edits builds only the last design."""
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_session import _spec  # noqa: E402

from torsal.pipeline import DEFAULT_PIPELINE, StageCache  # noqa: E402
from torsal.session.build import BUILD_SETTLE_S, Builder, BuildRequest  # noqa: E402
from torsal.session.edits import apply_edit  # noqa: E402


def test_a_burst_of_edits_builds_only_the_last_design(tmp_path):
    done = []
    builder = Builder(tmp_path, StageCache(tmp_path / ".torsal-cache"), DEFAULT_PIPELINE.until("sun"),
                      on_done=lambda req, result, error: done.append((req, result, error, time.monotonic())),
                      settle=2.0)
    spec = _spec()
    t0 = time.monotonic()
    builder.submit(BuildRequest(1, spec, time.perf_counter()))
    builder.submit(BuildRequest(2, apply_edit(spec, spacing=2.0), time.perf_counter()))
    assert builder.busy
    assert builder.wait_idle(120)
    builder.close(10)
    assert [(req.revision, error) for req, _, error, _ in done] == [(2, None)]
    assert builder.cancelled == 0                   # the first never started
    assert done[0][0].spec.fins.spacing == 2.0 and "estimate" in done[0][1].report
    assert done[0][3] - t0 >= 2.0                   # it waited for a newer edit first
    assert BUILD_SETTLE_S > 0
