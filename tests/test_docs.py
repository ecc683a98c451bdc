"""The worked plugin example of docs/architecture.md runs as written."""

import re
from pathlib import Path

DOC = Path(__file__).resolve().parents[1] / "docs" / "architecture.md"


def test_architecture_plugin_example_runs(capsys):
    blocks = re.findall(r"```python\n(.*?)```", DOC.read_text(), flags=re.S)
    assert len(blocks) == 3
    ns: dict = {}
    for b in blocks:
        exec(compile(b, str(DOC), "exec"), ns)
    out = capsys.readouterr().out
    assert "centroid_distance" in out or "chamfer_3d" in out
    from graphseg.graphs import edge_adders

    assert "centroid_distance" in edge_adders.names()
    edge_adders.unregister("centroid_distance")
    assert "centroid_distance" not in edge_adders.names()
