"""Generate the example design surface: a doubly curved facade patch (Fig. 7a size).

Writes ``examples/facade_patch.obj``: a 12 m x 6 m wall bulging 0.9 m towards the outside
(-y, south), with a slight saddle twist; 33 x 33 vertices, 2048 triangles, metres.

    python examples/make_facade.py [OUT.obj]
"""
import sys
from pathlib import Path

import trimesh

from torsal.geometry.surfaces import facade_patch


def main(out: str | Path = Path(__file__).with_name("facade_patch.obj")) -> Path:
    v, f = facade_patch(nu=33, nv=33)
    out = Path(out)
    tmp = out.with_name(out.stem + ".tmp.obj")
    trimesh.Trimesh(v, f, process=False).export(tmp)
    tmp.replace(out)
    return out


if __name__ == "__main__":
    print(main(*sys.argv[1:]))
