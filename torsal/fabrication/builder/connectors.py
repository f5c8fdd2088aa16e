"""Connectors of the part ends: bent brackets in the corners of butt joints, splice plates
across mitred seams (issue 15; placement rules in :mod:`torsal.fabrication.joints`).

:class:`ConnectorPlacer` puts a connector where :class:`~.ends.EndJoiner` (and its
:class:`~.butts.ButtTrimmer`) joined two parts and records the joint and the connector part
(``C-N<node>-<i>``), or names the joint in ``unconnected_joints`` where there is no room for
one. Lengths in the fin system's ``unit``.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..joints import corners, direction_into, place_connector
from ..model import (CONNECTOR_FAMILY, FAMILY_COLORS, Joint, JointKind, Part, PartId, _fold_deg,
                     _miter, quad_normals)

#: gap left between a connector and the plates it lies on, as a fraction of the thickness
#: (so that touching faces are not coincident for the boolean checks; 0.03 mm at 3 mm)
CONNECTOR_GAP = 0.01


def _starts_on(quad: np.ndarray, a: np.ndarray, b: np.ndarray) -> bool:
    """Whether the edge of ``quad`` (4, 3) on the node line ``a -> b`` is its ``a_i b_i`` edge
    (corners 0, 3; a trimmed end stands a little off the line), not its ``a_j b_j`` edge."""
    u = (b - a) / np.linalg.norm(b - a)
    r = quad - a
    off = np.linalg.norm(r - np.outer(r @ u, u), axis=1)
    return bool(off[0] + off[3] <= off[1] + off[2])


class _SeamLegs(NamedTuple):
    """The two panels meeting at a seam, seen from its node line: ``v1``, ``v2`` the unit
    directions from the line into each panel (square to the line, :func:`~.joints.direction_into`),
    ``n1``, ``n2`` their normals (:func:`~.model.quad_normals`)."""

    v1: np.ndarray
    v2: np.ndarray
    n1: np.ndarray
    n2: np.ndarray


def _seam_legs(qe: np.ndarray, qp: np.ndarray, a: np.ndarray, b: np.ndarray) -> _SeamLegs:
    """:class:`_SeamLegs` of the panels ``qe``, ``qp`` (4, 3) at the node line ``a -> b``,
    where a splice plate's two legs go."""
    v1, v2 = direction_into(qe, _starts_on(qe, a, b), a, b), direction_into(qp, _starts_on(qp, a, b), a, b)
    return _SeamLegs(v1, v2, quad_normals(qe[None])[0], quad_normals(qp[None])[0])


def seam_splice(e: Part, je: int, p: Part, jp: int, a, b, towards, *, thickness: float,
                gap: float, memo=None):
    """The splice plate across a seam where panel ``je`` of part ``e`` ends on the node line
    ``a -> b`` and panel ``jp`` of part ``p`` carries its fin on (flat within
    :data:`~.joints.CONTINUE_ANGLE`), on the side the unit vector ``towards`` points to, ``gap``
    off both plates' solids (:func:`~.joints.place_connector`). Returns ``(quads (2, 4, 3) or
    None, option)``, the option as ``FinSystem._sites`` keeps them: ``(side1, side2, panel1,
    panel2, direction, fold angle, hosts)``. ``memo``: a kernel cache
    (``FinSystem._cached``)."""
    qe, qp = e.panels[je], p.panels[jp]
    v1, v2, n1, n2 = _seam_legs(qe, qp, a, b)
    n2 = n2 if n2 @ n1 >= 0 else -n2
    fold = _fold_deg(n1, n2)
    s = 1.0 if towards @ n1 >= 0 else -1.0
    opt = ((s * n1, v1), (s * n2, v2), qe, qp, -(n1 + n2) * s, fold, ((e.name, je), (p.name, jp)))
    # p folds at this node line where its other panel stands on the far side of the seam:
    # its mitred edge stands out past the line, under the leg on e
    plates = (e.slab_corners(je, thickness), p.slab_corners(jp, thickness))
    args = (place_connector, a, b, *opt[:4])
    kw = {"thickness": thickness, "gap": gap, "plates": plates}
    q = memo(*args, **kw) if memo is not None else args[0](*args[1:], **kw)
    return q, opt


class ConnectorPlacer:
    """Places the connectors of a fin system ``fs`` under construction: fills its ``joints``,
    connector parts (``_connectors``), their alternative places (``_sites``) and
    ``unconnected_joints``."""

    def __init__(self, fs):
        self.fs = fs

    def _seam_splice(self, e: Part, je: int, p: Part, jp: int, node: int, towards, a, b) -> None:
        """A bent splice plate across the seam where panel ``je`` of ``e`` ends and panel ``jp``
        of ``p`` carries it on, on the side of the seam the unit vector ``towards`` points to
        (no other plate at the node is there; :func:`seam_splice`); the joint is a mitre with
        a splice (the two parts in either order)."""
        fs = self.fs
        q, opt = seam_splice(e, je, p, jp, a, b, towards, thickness=fs.thickness,
                             gap=CONNECTOR_GAP * fs.thickness, memo=fs._cached)
        names = tuple(sorted((e.name, p.name)))
        self._record(JointKind.MITRE_SPLICE, node, names, -opt[0][1], q, opt[4], opt[5], e.name,
                     "the panels are too small for a splice plate",
                     site=(a.copy(), b.copy(), [opt]) if q is not None else None)
    def _bracket(self, p: Part, j: int, node: int, cont, names, pa, pb, *, insert,
                 n_corners: int = 1, start: bool) -> int:
        """Bent brackets in the most open corner(s) between panel ``j`` of the butted part ``p``
        and a panel ``(n, v, quad, (part name, panel))`` of the continuous plate ``cont``;
        records the joint(s), and for each bracket the other corners it may move to
        (``_sites``); ``start``: ``p`` ends there with its start. Returns the number of
        brackets placed."""
        fs = self.fs
        quad = p.panels[j]
        line = pb - pa
        vb = direction_into(quad, start, pa, pb)
        # other parts' panels and the brackets already there must not be in the corner
        obstacles = [v for v in fs._dirs.get(node, [])] + fs._bracket_dirs.get(node, [])
        every = fs._cached(corners, [v for _, v, _, _ in cont], vb, line, obstacles)
        picks = every[:n_corners]
        nb0 = quad_normals(quad[None])[0]

        def option(i, angle):
            nc, vc, qc, host = cont[i]
            nc = nc if nc @ vb > 0 else -nc
            nb = nb0 if nb0 @ vc > 0 else -nb0
            return ((nc, vc), (nb, vb), qc, quad, -(vc + vb), angle, (host, (p.name, j)))

        placed = 0
        why = "no corner between 25 and 172 deg for a bracket"
        for i, angle in picks:
            opt = option(i, angle)
            # (no plate corners: in a corner under 180 deg each leg has only its own plate
            # under it, see joints.connector_offset)
            q = fs._cached(place_connector, pa, pb, *opt[:4], thickness=fs.thickness,
                           gap=CONNECTOR_GAP * fs.thickness)
            why = "the panels are too small for a bracket"
            if q is not None:
                others = [option(k, a) for k, a in every if (k, a) not in picks]
                self._record(JointKind.BUTT_BRACKET, node, names + (p.name,), insert, q,
                             opt[4], angle, p.name, why, site=(pa, pb, [opt] + others))
                vc = opt[0][1]
                fs._bracket_dirs.setdefault(node, []).append((vc + vb) / np.linalg.norm(vc + vb))
                placed += 1
        if not placed:
            self._record(JointKind.BUTT_BRACKET, node, names + (p.name,), insert, None, None,
                         picks[0][1] if picks else 90.0, p.name, why)
        return placed

    def _splice(self, e: Part, p: Part, node: int, other) -> None:
        """A bent splice plate across the mitred seam between ``e`` (ending at ``node``) and
        ``p`` (starting there), on the side clear of the other family's plate ``other``."""
        fs = self.fs
        qe, qp = e.panels[-1], p.panels[0]
        pa, pb = qp[0], qp[3]
        v1, v2, n1, n2 = _seam_legs(qe, qp, pa, pb)
        fold = _fold_deg(n1, n2)
        q = None
        why = "the other family's plate passes on both sides of the seam"
        site = None
        if len(other) < 2:
            side = -(other[0][1] @ (n1 + n2)) if other else (v1 + v2) @ (n1 + n2)
            s = 1.0 if side >= 0 else -1.0
            hosts = ((e.name, len(e.panels) - 1), (p.name, 0))
            # either side of the seam where no plate of the other family is (the first: the
            # one away from it, or the convex side)
            opts = [((sg * n1, v1), (sg * n2, v2), qe, qp, -(n1 + n2) * sg, fold, hosts)
                    for sg in ((s, -s) if not other else (s,))]
            q = fs._cached(place_connector, pa, pb, *opts[0][:4], thickness=fs.thickness,
                           gap=CONNECTOR_GAP * fs.thickness,
                           plates=(e.slab_corners(len(e.panels) - 1, fs.thickness),
                                   p.slab_corners(0, fs.thickness)))
            why = "the panels are too small for a splice plate"
            site = (pa.copy(), pb.copy(), opts)
        cdir = -(n1 + n2) * (1.0 if q is None else s)
        self._record(JointKind.MITRE_SPLICE, node, (e.name, p.name), -v2, q, cdir, fold, p.name, why,
                     site=site)

    def _record(self, kind, node, names, insert, q, cdir, angle, part, why, *, site=None) -> None:
        """Append a :class:`Joint` (and its connector part built from the quads ``q``, or an
        entry of ``unconnected_joints`` if there is none). ``site``: ``(a, b, options)`` where
        the connector may go instead, each option ``(side1, side2, panel1, panel2, direction,
        angle, hosts)`` as :func:`~.joints.connector_variants` takes them, the first the one
        used; ``hosts`` the (part name, panel) each leg lies on (``_sites``)."""
        fs = self.fs
        conn = None
        if q is not None:
            idx = fs._n_conn.get(node, 0)
            fs._n_conn[node] = idx + 1
            n = quad_normals(q)
            c = Part(id=PartId(CONNECTOR_FAMILY, node, idx), panels=q, nodes=np.full(3, node),
                     edges=np.full(2, -1), miters=np.array([n[0], _miter(n[0], n[1]), n[1]]),
                     color=FAMILY_COLORS[CONNECTOR_FAMILY], span=(0, 2))
            fs._connectors.append(c)
            conn = c.name
            names = names + (conn,)
            if site is not None:
                fs._sites[conn] = site
        else:
            fs.unconnected_joints.append((part, node, why))
        unit = lambda x: None if x is None else np.asarray(x, float) / np.linalg.norm(x)  # noqa: E731
        fs.joints.append(Joint(kind, int(node), tuple(names), unit(insert), conn, unit(cdir),
                                 float(angle)))
