"""The example notebook runs top to bottom in a real Jupyter kernel (nbclient), as a user's
would: design, change a parameter, look again."""
import json
import shutil
from pathlib import Path

import pytest

nbformat = pytest.importorskip("nbformat", reason="nbformat is a test dependency: pip install -e '.[test]'")
nbclient = pytest.importorskip("nbclient", reason="nbclient is a test dependency: pip install -e '.[test]'")

NOTEBOOK = Path(__file__).resolve().parents[2] / "examples" / "designing_fins.ipynb"


def test_the_example_notebook_runs(tmp_path):
    nb = nbformat.read(NOTEBOOK, as_version=4)
    assert not any(c.get("outputs") for c in nb.cells if c.cell_type == "code"), \
        "commit the notebook without outputs"
    nbclient.NotebookClient(nb, timeout=600, kernel_name="python3",
                            resources={"metadata": {"path": str(tmp_path)}}).execute()
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.outputs]
    assert not [o for o in outputs if o.output_type == "error"]
    # two summaries: the second run took the congruence from the cache and has fewer parts
    summaries = [eval(o.data["text/plain"]) for o in outputs
                 if o.output_type == "execute_result" and "'parts'" in o.data.get("text/plain", "")]
    assert len(summaries) == 2
    first, second = summaries
    assert first["stages from the cache"] == [] and "congruence" in second["stages from the cache"]
    assert second["parts"] < first["parts"] and 0 < second["sun blocked"] <= 1
    # two plotly figures of the fins, both torsal families drawn
    figures = [json.loads(o.data["application/vnd.plotly.v1+json"]) if isinstance(
        o.data["application/vnd.plotly.v1+json"], str) else o.data["application/vnd.plotly.v1+json"]
        for o in outputs if "application/vnd.plotly.v1+json" in o.get("data", {})]
    assert len(figures) == 2
    for fig in figures:
        names = [t.get("name", "") for t in fig["data"]]
        assert any("family 0" in n for n in names) and any("family 1" in n for n in names)
    # the live session's slider: two moves, each redrawn from a preview within the second
    live = [eval(o.data["text/plain"]) for o in outputs
            if o.output_type == "execute_result" and "'redraws'" in o.data.get("text/plain", "")]
    assert len(live) == 1
    redraws = live[0]["redraws"]
    print("notebook slider redraws (s):", [r["seconds"] for r in redraws])
    assert len(redraws) == 2 and {r["kind"] for r in redraws} == {"preview"}
    assert all("remesh" in r["stages"] and "congruence" not in r["stages"] for r in redraws)
    # (their seconds are printed, not asserted: a busy machine is slower; the latency is
    # measured in benchmarks/session_bench.py)
    assert live[0]["built"] == "built" and live[0]["built parts"] < first["parts"]
    assert (tmp_path / "notebook_live" / "parts.csv").is_file()
    # the viewer cell ran: shown, or a message saying how to start the viewer
    last = "".join(o.get("text", "") for o in nb.cells[-1].outputs)
    assert "shown:" in last or "ocp_viewer" in last
    assert (tmp_path / "notebook_out" / "fins.step").is_file()
