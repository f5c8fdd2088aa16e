"""Read torsal's fins.step in CadQuery with the part names. Run it in a CadQuery environment of
its own (CadQuery and build123d cannot share one: their OpenCascade wheels clash):

    python -m venv cq && cq/bin/pip install cadquery
    cq/bin/python examples/hosts/cadquery_read_step.py out/7a/fins.step
"""
import sys

import cadquery as cq


def read_fins(path: str) -> dict[str, "cq.Solid"]:
    """Every part of a torsal STEP file by name (the names of parts.csv), in mm."""
    assy = cq.Assembly.importStep(path)             # cadquery >= 2.5: names and colours kept
    return {name: node.shapes[0].Solids()[0] for name, node in assy.objects.items()
            if node.shapes and not node.children}  # part name -> cq.Solid, in mm


if __name__ == "__main__":
    parts = read_fins(sys.argv[1])
    volume = sum(s.Volume() for s in parts.values())
    print(f"{len(parts)} parts, {volume / 1e9:.4f} m^3; first: {sorted(parts)[:3]}")
