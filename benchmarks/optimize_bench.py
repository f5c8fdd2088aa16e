"""Congruence optimization: time to quality per Fig. 12 row and solver, re-solves, the facade case, the family.

Tables (``--tables``, default all but ``factor``, ``synthetic`` and ``stop``):

1. ``fig12``: every Fig. 12 row (7a, 7b, 7c, 7d, 9, 11, 13), built from the example design
   files exactly as ``torsal design`` builds them (paper sizes), for each method (``--methods``):
   ``auto`` (``solve()``'s default route), ``alm`` (the augmented Lagrangian; a lifted
   ``min_torsal_angle`` of a design file is imposed in split form for it), ``ipopt`` (the
   solver of record, the design file's form), ``alm+ipopt`` (the augmented Lagrangian's
   answer certified by IPOPT, ``certify=True``), ``lbfgs`` (the paper's baseline). Time to
   quality: from the start of building the problem to the first iterate that is feasible as
   measured on the geometry (torsal angles in degrees, hyperbolicity on the congruence) with
   an objective within 1% of the best objective any method reached on that row (or 1e-8 of it
   where that best is nearly zero: rows 7a and 7b reach 1e-10 to 1e-16); wall and
   processor time (``cpu``), iterations (Newton steps for the augmented Lagrangian) and
   factorizations. Target: <= the paper's T (a 2013 dual core). ``spread``: per congruence, the
   widest angle of its lines from their mean direction (row 11's energies reach zero only as
   its lines turn parallel: there a lower energy is a flatter design, not a better one).
2. ``resolve``: warm re-solves from the previous optimum after one change (a weight of the
   light terms x1.2, the sun turned by 5 degrees, the strokes turned by 5 degrees, the
   ``min_torsal_angle`` bound + 2 degrees), against a cold solve. Target: <= T / 5.
3. ``facade``: the doubly curved 1,089-vertex facade (``normal 2, fair 1, perpendicular 10``
   to one sun, ``hyperbolic``, normals as start) at ``min_torsal_angle`` 40, 60, 80. Targets:
   40 in <= 2.4 s; 60 and 80 ``success`` with every face within 0.1 degree of the bound,
   each <= 7.4 s.
4. ``family``: :func:`torsal.geometry.optimize.family.design_family` (20 doubly curved
   facades and canopies, several suns) x ``min_torsal_angle`` 20, 40, 60, 80 at full size
   (``--family-size``): the share that ends measured-feasible and converged (target >= 95 %),
   the failures with their faces named.
5. ``factor``: the sparse Cholesky backends (:mod:`torsal.geometry.optimize.factor`) on the
   augmented Lagrangian's Newton matrix of rows 7c, 9, 13 and 11 at their start: numeric
   factorization + solve per step (the symbolic analysis is reused where the backend can),
   wall and processor milliseconds; MUMPS twice, called directly
   (``torsal.geometry.optimize.mumps``, analysed once) and through casadi's interface
   (``mumps/casadi``, analysed at every call).
6. ``synthetic``: the 7a term set at 1k, 20k and 100k vertices (no constraint rows, IPOPT's
   projected-Newton passes): build, solve, re-solve; target 100k in < 60 s.
7. ``stop``: the design tolerance (``solve(stop="design")``, the default) against full
   convergence downstream: examples 7c and 9 (``--rows``) run by ``torsal design``'s pipeline up
   to the light stage with each rule and to convergence at a tenth of the tolerance (the noise
   the digits past convergence still make), report.json's congruence, support, fabrication and
   light figures side by side. ``fig12``'s method ``converged`` is ``auto`` to convergence: run it
   beside ``auto`` for time to quality against the converged energy.
8. ``design``: ``torsal design``'s own congruence stage (the pipeline up to it, no cache) on
   examples 7c and 9 (``--rows``) and the doubly curved facade of example 7a at
   ``min_torsal_angle`` 80 (``facade80``): report.json's congruence build + solve against the
   paper's T (7.4 s for the facade), the stage's processor seconds, Newton steps and
   factorizations, its phases and why the solve ended (``congruence.convergence``). Targets:
   build + solve <= T on a 2-core machine.

Issue 44, row 9's end game (``SETTLED_GAMMA`` in :mod:`torsal.geometry.optimize.alm`: rows still
out of their bounds when the objective has settled get their penalties raised at once), before
(HEAD 5e76a52) and after, 2026-11-29 04:05-05:10 UTC on this 2-core machine at a load of 8-12
(other engineers' runs: wall times 3-8 times the processor times, so processor seconds by
``time.process_time`` and counts). ``solve``: the design's ``solve()`` alone, kernels loaded
(three runs before, two after); ``fig12``: ``--tables fig12 --methods auto``, before and after
(``cpu``, and the warm re-solve after the light weights x1.2)::

    row  run     Newton  fact  trials  cpu s solve / fig12      E         min ang  re-solve cpu, it
    9    before     96    390    359   35.3 32.0 / 31.6        0.017225  60.013   3.54, 13
    9    after      74    300    262   24.5 19.8 / 20.9        0.017241  60.006   4.96, 15
    7c   before     27    115     30                / 3.7      0.42716   39.95    1.28,  7
    7c   after      26    111     28   2.9          / 3.3      0.42719   39.97    0.81,  6
    7a, 7b, 7d, 11, 13 (fig12): the same iterations, factorizations and energies before and after
    (7a 3, 7b 4, 7d 9 / 41, 11 8, 13 13 / 16); their processor times moved with the load only
    (11, which IPOPT solves alone, 12.7 -> 15.8 s)

Downstream (``torsal design`` up to the light stage, report.json; as table ``stop``), each figure
relative to the converged run's (140 Newton steps, energy 0.0172064)::

    row 9                               after      before     converged   after     before
    congruence.objective                0.0172409  0.0172248  0.0172064   +0.20 %   +0.11 %
    min_torsal_plane_angle_deg          60.006     60.013     60.012      -0.01 %   +0.00 %
    min_torsal_direction_angle_deg      6.866      7.249      7.399       -7.2 %    -2.0 %
    support.edges                       914        899        897         +1.9 %    +0.2 %
    support.quads                       385        385        378         +1.9 %    +1.9 %
    support.delta_pl_extracted          0.2496     0.2928     0.3255      -23 %     -10 %
    support.delta_pl_optimized          9.003e-05  8.998e-05  9.002e-05   +0.02 %   -0.03 %
    light.blocked_share                 0.6687     0.6500     0.6447      +3.7 %    +0.8 %
    light.transparency                  0.4453     0.4920     0.4613      -3.5 %    +6.7 %
    light.transparency_cone             0.3981     0.4332     0.4115      -3.3 %    +5.3 %
    fabrication.parts                   1223       1236       1114        +9.8 %    +11 %
    fabrication.panels                  854        840        821         +4.0 %    +2.3 %

    row 7c (converged: 31 Newton steps, energy 0.427235)
    congruence.objective                0.427193   0.427161   0.427235    -0.01 %   -0.02 %
    min_torsal_plane_angle_deg          39.975     39.955     40.174      -0.50 %   -0.55 %
    min_torsal_direction_angle_deg      2.435      2.288      2.123       +15 %     +7.8 %
    support.edges                       466        468        466          0 %      +0.4 %
    support.quads                       186        187        185         +0.5 %    +1.1 %
    support.delta_pl_extracted          0.1179     0.2044     0.2040      -42 %     +0.2 %
    support.delta_pl_optimized          8.988e-05  8.987e-05  9.737e-05   -7.7 %    -7.7 %
    light.blocked_share                 0.8852     0.8726     0.8624      +2.6 %    +1.2 %
    light.transparency                  0.6920     0.6493     0.6947      -0.4 %    -6.5 %
    light.transparency_cone             0.4237     0.4201     0.4406      -3.8 %    -4.7 %
    fabrication.parts                   635        580        576         +10 %     +0.7 %
    fabrication.panels                  429        426        420         +2.1 %    +1.4 %

Most differences after are of the size of those before and of the digits past convergence
(``alm.DESIGN_DECREMENT``: tol/10 against converged, blocked share -2.3 to +5 %, transparency
-3.9 to +3.5 %, cone -6 to +7.6 %, edges -2 to +0.6 %, parts -2.9 to +2.2 %, extracted delta_pl
+11 %), in no one direction. Larger: the extracted support's planarity before its own optimization
(row 9 -23 %, 7c -42 %: lower, the optimized one as before) and 7c's parts (+10 %, row 9's before
+11 %): figures of the remeshing that follow digits the energy does not see. One run each: the
spread of a figure between runs of one rule was not measured.

Issues 44 and 43, about 4 factorizations per Newton step (2026-11-29 06:45-07:45 UTC, this 2-core
machine at a load of 14-29: wall times 3-9 times the processor times, so processor seconds and
counts; the brief's quiet-machine measurement of HEAD 9a076d9, load 1.1: 7c 0.51 + 3.42 s, facade80
0.38 + 8.61 s). Where 7c's 111 factorizations in 26 Newton steps come from: 26 directions, 78
passes of the predicted active set (``alm.PREDICT`` = 3 at every step: hundreds of rows change
per pass, the set never repeats), 3 tries of the exact Hessian (3, 8 and 29 negative pivots) and
4 directions whose decrement ends an inner minimization. No symbolic analysis is redone (one per
pattern) and no shift restarts from zero (the projected matrix was never refused). Fewer passes
are not faster: ``PREDICT`` 1 / 0 took 7c 37 / 44 Newton steps (81 / 52 factorizations), the
facade at 80 degrees 49 / 102, so the passes stay. The facade's steps crept instead (the objective
down 3 % a full step, decrements 1e-4) because its exact Newton matrix, tried after full short
steps, had one negative pivot that a shift of 1e-8 of its mean diagonal removes: IPOPT's inertia
correction (``alm.INERTIA_PIVOTS``) takes those exact steps. A warm re-solve ends at the design
tolerance at the rate of its last 3 steps (``alm.WARM_WINDOW``) instead of waiting for 10.
``--tables design`` (``torsal design``'s congruence stage) and session_bench's let-through
region, before (HEAD 9a076d9) and after::

    row        run     cpu s   Newton  fact  exact/corrected  E            min ang   ended by
    7c         before  4.71      26    111    0 / -           0.42719271   39.975    design tolerance
    7c         after   3.58      26    111    0 / 0           0.42719271   39.975    (the same iterates)
    facade80   before  8.56      77    305    2 / -           4.1207e-07   80.28     converged
    facade80   after   4.24      42    166    6 / 5           4.2735e-07   80.54     converged
    9          before  19.8-24.5 74    300    0 / -           0.017240853  60.006    design tolerance
    9          after   24.5      74    300    0 / 0           0.017240853  60.006    (the same iterates)
    region     before  1.95      13     56    the preview: congruence 1.19 s cpu, energy 0.0225343
    region     after   1.49      7      34    congruence 0.78 s cpu, energy 0.0225381 (+0.017 %)

(9's processor seconds: before at a load of 8-12, after at 29.) On a quiet machine the facade's
0.38 + 8.61 s would be about 0.38 + 4.3 s at the processor-time ratio, under its 7.4 s; 7c's path is
unchanged (its 3.92 s against T 3.7 s is the per-step cost: the element Hessians' eigenvalue
projection, about 25 ms a step, and 4.3 factorizations at 8-10 ms each). The region preview's
other stages (support 0.35-0.48 s, light 0.28-0.37 s, remesh 0.08-0.12 s of processor time) keep
it above 1 s. How close the facade at 80 is to converged (it ends by convergence before and
after: its energy is 3e-7 of its start's, and the design tolerance is relative to the energy
itself, so it never ends such a solve first), against a run to tol/10 (46 Newton steps, energy
4.1630e-07): lines at most 0.095 degrees apart (mean 0.039; before 0.245 / 0.186), energy +2.7 %
(before -1.0 %), smallest torsal plane angle 80.54 against 80.83 (before 80.28). The design family
(:func:`~torsal.geometry.optimize.family.design_family`, 20 members at 12 x 12 vertices x 20/40/60/80
degrees, 80 solves): all 80 measured feasible and converged before and after, Newton steps 1713 ->
1610, factorizations 6839 -> 6473, processor time 31.6 -> 30.5 s (load 20-25). 11 solves took fewer
Newton steps (facade-2 at 80: 56 -> 32, canopy-7 at 80: 99 -> 45), 5 more (canopy-11 at 80: 73 ->
106; facade-2 at 60: 7 -> 16, to a lower energy, 2.6e-7 against 4.9e-7), 25 the same steps with up
to 9 factorizations more where the retries fail (a real negative pivot: 3 per failed try; canopy-3
at 80: 94 -> 103), 39 nothing changed.
Keeping the retries off after a failed one for the whole solve was worse in sum (1658 steps, 6661
factorizations). The line search's full step is evaluated as a whole point (its value kernel gives
the same numbers to the last bit): one evaluation less per step taken whole (7c: 26 of 28 trials).

Issue 44, 7c's per-step cost and build (2026-11-29 08:05-08:25 UTC, this 2-core machine at a load
of 17-24: processor seconds and counts). The element Hessians of an energy depend on the point
alone, and the augmented Lagrangian projects them again at the same point after each multiplier
update and failed line search: ``ProjectedHessian`` keeps each block's last projection and
reuses it where the block's matrices are the same to the bit (7c: 31 projections of 3,008 8 x 8
element Hessians, 26 distinct). And an augmented-Lagrangian solve no longer builds IPOPT's NLP
just to evaluate energies and rows (``NlpCache.main`` evaluates them with the solve's own NLP,
the same values; a certifying IPOPT pass builds its own): 0.05 s of processor time of 7c's
build. ``--tables design``, 3 runs each alternating (before = HEAD b379746)::

    row       run     stage cpu s          eigh batches  eigh cpu s          steps  fact  E
    7c        before  3.97 3.46 3.32       62 (31 x 2)   0.92 0.78 0.70      26     111   0.4271927055201825
    7c        after   3.91 3.42 3.18       52 (26 x 2)   0.75 0.68 0.64      26     111   (the same iterates)
    facade80  before  4.09                 120           0.44                42     166   4.273500537141264e-07
    facade80  after   4.43                 114           0.48                42     166   (the same iterates)
    9         before  29.2                 150           6.0                 74     300   0.01724085282788787
    9         after   28.1 (load 14)       148           5.7                 74     300   (the same iterates)

(the same directions to the bit: their sha1 compared; facade80 and 9 one run each, their processor
times within the load's noise). On the brief's quiet machine (25 ms of
projection a step) that is about 0.13 s of 7c's solve and 0.05 s of its build: 3.92 -> about
3.75 s, estimated, not measured quietly; T is 3.7 s. session_bench's region row: eigh batches
of the whole run 108 -> 96, the preview 1.84 / 1.36 -> 1.43 s cpu (load 17-22, noise larger
than the change).

Issue 44, the projection compiled (``--psd compiled``: ``projected.PSD_KERNEL``, the kernel of
:mod:`torsal.geometry.optimize.psd_kernel`, Householder tridiagonalization and implicit QL in C,
about 4.5 us per 8 x 8 matrix against numpy's batched ``eigh`` at about 11), 2026-11-29
09:35-10:30 UTC at a load of 25-30 (processor seconds and counts; stage = ``run_congruence``,
projection = ``psd_projection`` with its threads; before = numpy's, HEAD 7ff80fa)::

    row        eigh      stage cpu s          projection cpu s   Newton  fact  E
    7c         numpy     3.26  3.36  4.56     0.68  0.70  0.92     26      111   0.4271927055201825
    7c         compiled  3.06  3.07  3.14     0.37  0.37  0.38     26      111   0.42719270552018246
    facade80   numpy     4.37                                      42      166   4.273500537141264e-07
    facade80   compiled  4.22                                      42      166   4.2735005370571043e-07
    9          numpy     24.5  27.8                                74      300   0.01724085282788787
    9          compiled  41.1  43.7                                137     555   0.017242473503185904

Up to the support stage: 7c's lines within 1.2e-6 degrees of numpy's, the same remeshed faces
(297 nodes, 466 fins, nodes within 9e-12), delta_pl 0.117875 extracted / 8.9876e-05 optimized
both; the facade at 80 within 8.5e-7 degrees, the same faces (nodes within 2.3e-6), delta_pl
0.00115602 / 8.9359e-05 both; 7a (IPOPT) within 1.2e-6 degrees, the same faces. Row 9 parts at
Newton step 27 (L_A in its 7th digit) inside a first inner minimization that crawls at step
lengths 1/32-1/4, and ends 63 steps later: lines up to 5.3 degrees apart (mean 0.98), 546 -> 537
nodes, 914 -> 899 fins, quads 385 -> 381, delta_pl extracted 0.250 -> 0.314 (optimized 9.003e-05
both), smallest torsal plane angle 60.006 -> 60.013, direction angle 6.87 -> 7.71 degrees. Row 9's
length is a matter of digits past the 15th there, and 74 is the short one: numpy's ``eigh`` with
other rounding (the same decomposition, ``V f(L) V^T`` by einsum instead of matmul; or ``eigh`` of
the upper triangle, ``UPLO="U"``) took 137 / 555 (48.6 s cpu, E 0.0172425) and 136 / 551 (46.3 s
cpu, E 0.0172489), HEAD's own code again 74 / 300 (26.6 s cpu, the same directions' sha1
8465ac3fe002). In every one the inner minimizations crawl: most steps cut to 1/64-1/4 by the line
search, the Levenberg-Marquardt shift bouncing between 1e-5 and 1e-2, each of the first inner
minimizations run to INNER_MAX (40 steps); the 74-step run ends where its objective's change over
10 steps first drops under DESIGN_DECREASE, the others keep descending (44.84 against 44.85 at
their ends). So row 9 at T rests on its rounding on this machine (another BLAS or CPU may take the
137-step path); numpy's ``eigh`` stays the default so as not to lose it here, and 7c stays at its
3.77 s quiet (T 3.7 s). The compiled projection would take about 0.15-0.3 s of 7c's wall on a quiet
machine (0.3-0.55 s cpu over two threads; estimated, not measured quietly) once the crawl no longer
decides row 9's length.

Issue 44, row 9's crawl (``alm.PREDICT_MODEL``: each predicted pass taken only as far as the
step's model of ``L_A`` decreases; ``alm.INNER_MAX`` 40 -> 15), 2026-11-29 12:10-13:05 UTC,
``--tables design``, processor seconds of the congruence stage, before at a load of 1.4-14 and
after at 14-16. ``numpy-U``: numpy's ``eigh`` of the upper triangle, the same projection with
other rounding (before: af50f4a's runs)::

    row        eigh      run     Newton  fact  cpu s   E            min ang  ended by
    9          numpy     before    74    300   26.6    0.017241     60.01    design tolerance
    9          compiled  before   137    555   40.2    0.017242     60.01    design tolerance
    9          numpy-U   before   136    551   46.3    0.017249     -        design tolerance
    9          numpy     after     82    332   31.2    0.016936     59.97    design tolerance
    9          compiled  after     82    333   28.1    0.016937     59.93    design tolerance
    9          numpy-U   after     76    309   28.8    0.016939     59.96    design tolerance
    7c         numpy     before    26    111   3.24    0.42719      39.97    design tolerance
    7c         numpy     after     26    112   3.38    0.42719      39.96    design tolerance
    7c         compiled  after     26    112   3.15    0.42719      39.96    design tolerance
    facade80   numpy     before    42    166   4.65    4.2735e-07   80.54    converged
    facade80   numpy     after     29    118   3.44    4.1642e-07   80.34    converged
    facade80   compiled  after     29    118   3.64    4.1642e-07   80.34    converged

Before, the step the predicted passes ended at had a linearized ``L_A`` above the start's on row 9
(rows moved across their bounds added 0.3-6 to the penalty against the 0.05-0.3 the energy
lost), so the line search cut most steps to 1/64-1/4 and where the solve ended hung on rounding;
with the model's minimum along each pass most steps are 1/2-1 and every kernel lands on the same
design: energies within 0.02 % of each other, 1.8 % under before's (and under the 140-step
converged 0.0172064 of before), each measured feasible (the bound to its 0.1 degree). With the
model alone (INNER_MAX 40) row 9 took 130 / 135 Newton steps (numpy / compiled, 44.8 / 40.8 s,
energy 0.01688): the first inner minimizations ran to their 40 steps at the first multipliers;
INNER_MAX 10 took 108, 20 took 82 (numpy). 7c and the facade take the same steps with each kernel.

Run:  .venv/bin/python benchmarks/optimize_bench.py [--tables fig12 resolve facade family factor synthetic stop design]
          [--rows 7a 7b 7c 7d 9 11 13] [--methods auto converged alm ipopt alm+ipopt lbfgs]
          [--facade-angles 40 60 80] [--psd numpy|compiled]

Timings on a shared machine vary: the script prints the machine (CPU model, cores, the BLAS
threads in use) and the load average; compare methods by processor time and counts. Under each
``fig12`` and ``facade`` run a ``phases`` line splits its wall time: ``compile`` (the first
build of the row's NLPs in this process, less a second one: compiling or loading the C
kernels), ``build`` (assembling the NLP), the augmented Lagrangian's ``hessian``, ``factor``
(factorizations with their solves), ``line search`` and the rest of its steps (``other``),
and IPOPT's time (``certify`` after the augmented Lagrangian, ``ipopt`` alone). Measured
numbers other than issue 44's before/after above are in the optimizer's report and in
examples/README.md, not here.
"""
from __future__ import annotations

import argparse
import os
import time

import numpy as np

from torsal.geometry.congruence import Congruence
from torsal.geometry.mesh import edge_face_adjacency
from torsal.geometry.optimize import CongruenceProblem
from torsal.geometry.surfaces import facade_patch

EXAMPLES = __import__("pathlib").Path(__file__).resolve().parent.parent / "examples"

SUN = np.array([0.3, -0.8, -0.5]) / np.linalg.norm([0.3, -0.8, -0.5])
OPTS = {"jit": True}     # compiled kernels (cached in ~/.cache/torsal/kernels after the first run)


def _rotated_sun(deg: float) -> np.ndarray:
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]) @ SUN


def _boundary_strokes(c: Congruence):
    """Faces with a boundary edge and the edge's direction (Fig. 7a: align with the boundary)."""
    edges, edge_faces = edge_face_adjacency(c.faces)
    bd = edge_faces[:, 1] < 0
    faces, keep = np.unique(edge_faces[bd, 0], return_index=True)
    e = edges[bd][keep]
    return faces, c.vertices[e[:, 1]] - c.vertices[e[:, 0]]


def problem_7a(c, sun):
    faces, dirs = _boundary_strokes(c)
    return (CongruenceProblem(c, **OPTS).normal(weight=2).fair(weight=1).perpendicular(sun, weight=10)
            .torsal_direction(faces, dirs, weight=0.1))


def change(problem_fn, p, c):
    """The designer's change: the sun moves by 5 degrees and one weight changes."""
    sun = _rotated_sun(5.0)
    p.perpendicular(sun, weight=12)
    return sun


ROWS = [  # name, (nu, nv), paper |V|, |F|, T, problem
    ("7a", (33, 33), 1073, 2048, 0.4, problem_7a),
    ("20k", (141, 141), None, None, None, problem_7a),
    ("100k", (317, 317), None, None, None, problem_7a),
]


def run_row(name, grid, T, problem_fn, solvers, lbfgs_iter):
    v, f = facade_patch(nu=grid[0], nv=grid[1], width=12.0 * grid[0] / 33, height=6.0 * grid[1] / 33)
    c = Congruence.from_normals((v, f))
    out = []
    for solver in solvers:
        t0 = time.perf_counter()
        p = problem_fn(c, SUN)
        r1 = p.solve(solver=solver, max_iter=None if solver == "ipopt" else lbfgs_iter)
        first = time.perf_counter() - t0
        no_td = (int(np.isnan(c.torsal_angle()).sum()), int(np.isnan(r1.congruence.torsal_angle()).sum()))
        sun = change(problem_fn, p, c)
        t1 = time.perf_counter()
        r2 = p.solve(solver=solver, max_iter=None if solver == "ipopt" else lbfgs_iter)
        again = time.perf_counter() - t1
        worst = max(r2.max_violation.values(), default=0.0)
        perp = float(np.abs(r2.congruence.directions @ sun).mean())
        hyp = float((r2.congruence.hyperbolicity() >= 0).mean())
        out.append(dict(row=name, V=len(v), F=len(f), T=T, solver=solver, build=r1.build_seconds,
                        solve=r1.solve_seconds, first=first, it1=r1.iterations, ok1=r1.success,
                        resolve=again, rebuild=r2.build_seconds, it2=r2.iterations, ok2=r2.success,
                        E0=r1.energies_before["total"], E1=r1.energies_after["total"],
                        E2=r2.energies_after["total"], worst=worst, perp=perp, hyp=hyp,
                        status=r2.status, no_td=no_td, note=r1.status))
    return out


def _fmt(x, spec):
    return "-" if x is None else format(x, spec)


# ------------------------------------------------------------------ Fig. 12 rows from the examples
FIG12 = [  # row, design file, paper T (s)
    ("7a", "7a_facade_block.toml", 0.4),
    ("7b", "7b_facade_strokes.toml", 1.4),
    ("7c", "7c_facade_see_through.toml", 3.7),
    ("7d", "7d_flat_facade_regions.toml", 1.0),
    ("9", "9_selective_shading.toml", 29.0),
    ("11", "11_aligned_substructure.toml", 11.0),
    ("13", "13_reflect_to_ceiling.toml", 17.0),
]
LIGHT_TERMS = ("perpendicular", "parallel", "torsal_plane", "reflect")


def example_problem(design: str):
    """The eq. (9) problem of an example design, as the pipeline builds it (oriented mesh A)."""
    from torsal.pipeline.design_file import load_design_file
    from torsal.geometry.mesh import area_vector
    from torsal.pipeline.problem import congruence_problem
    from torsal.pipeline.stages import sun_directions, surface_mesh

    spec = load_design_file(EXAMPLES / design)
    v, f = surface_mesh(spec)
    vec, w = sun_directions(spec)
    if area_vector(v, f) @ (vec * w[:, None]).sum(0) < 0:
        f = f[:, ::-1].copy()
    return spec, (lambda: congruence_problem(spec, v, f, vec, w)), len(v), len(f)


def _designer_change(p):
    """Weights of the light terms x1.2 (NLP parameters: no rebuild)."""
    for name, (kind, w, _) in p.terms.items():
        if kind == "energy" and name.startswith(LIGHT_TERMS):
            p.set_weight(name, 1.2 * w)


def _turn(v, deg: float):
    """Rows of ``v`` (3,) or (m, 3) turned by ``deg`` about z."""
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    return np.asarray(v) @ np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]).T


def _change_sun(p):
    """Every light-direction term's direction turned by 5 degrees (NLP parameters): the lines'
    light directions (f_perp, f_par) and the torsal planes' normals (f_plane, Fig. 7d), with
    their strokes re-derived from the turned normals as the design file derives them."""
    for name, t in list(p.registry.terms.items()):
        if name.startswith(("perpendicular", "parallel")):
            t.par[:] = _turn(t.par, 5.0)
        elif name.startswith("torsal_plane"):
            p.torsal_plane(t.elements, normals=_turn(t.par[:, 6:9], 5.0), weight=t.weight, name=name)


def _change_stroke(p):
    """The strokes' barycentric directions re-drawn 5 degrees off: every torsal_direction term's
    and every torsal_plane term's (f_plane = f_dir + <e_c, n>^2, its normals kept)."""
    for name, t in list(p.registry.terms.items()):
        if name.startswith(("torsal_direction", "torsal_plane")):
            faces = t.elements
            a = p.congruence.vertices[p.congruence.faces[faces]]
            w = t.par[:, :6].reshape(-1, 2, 3)
            d = np.einsum("mk,mkj->mj", w[:, 1] - w[:, 0], a)
            if name.startswith("torsal_plane"):
                p.torsal_plane(faces, _turn(d, 5.0), normals=t.par[:, 6:9], weight=t.weight, name=name)
            else:
                p.torsal_direction(faces, _turn(d, 5.0), weight=t.weight, name=name)


def _change_bound(p):
    """``min_torsal_angle`` + 2 degrees (same faces and form: parameters only)."""
    t = p.registry.terms.get("min_torsal_angle")
    if t is not None:
        p.min_torsal_angle(t.bound + 2.0, faces=np.unique(t.elements), form="lift" if t.lift else "split",
                           between=t.between)


CHANGES = {"weight": _designer_change, "sun": _change_sun, "stroke": _change_stroke, "bound": _change_bound}


def _split_form(p):
    """A lifted ``min_torsal_angle`` re-imposed in split form (same bound and faces), for the
    augmented Lagrangian (which has no lifted variables)."""
    t = p.registry.terms.get("min_torsal_angle")
    if t is not None and t.lift:
        p.min_torsal_angle(t.bound, faces=np.unique(t.elements), form="split", between=t.between)
    return p


#: method -> (solver, formulation, solve options)
METHODS = {
    "auto": ("auto", lambda p: p, {}),
    # solve()'s default route run to the solver's own convergence, not to the design tolerance
    # (stop="design", solve()'s default): the reference a design-tolerance answer is measured against
    "converged": ("auto", lambda p: p, {"stop": "converged"}),
    "alm": ("alm", _split_form, {}),
    "ipopt": ("ipopt", lambda p: p, {}),
    "alm+ipopt": ("alm", _split_form, {"certify": True}),
    "lbfgs": ("lbfgs", lambda p: p, {}),
}


def _timed(fn):
    w, c = time.perf_counter(), time.process_time()
    out = fn()
    return out, time.perf_counter() - w, time.process_time() - c


def _compile_seconds(make) -> float:
    """Seconds the first build of a problem's NLPs (augmented Lagrangian's and IPOPT's) takes
    in this process beyond a second one: compiling the C kernels (or loading them from the
    disk cache). After it, every timed solve finds them loaded."""
    def build():
        p = make()
        return sum(p.build(s) for s in ("alm", "ipopt"))
    return max(build() - build(), 0.0)


def _phases(r, compile_s: float | None = None) -> str:
    """A solve's wall time by phase (see the module docstring), from ``r.timings``."""
    t = r.timings
    parts = [] if compile_s is None else [("compile", compile_s)]
    parts.append(("build", t.get("build", 0.0)))
    if "alm" in t:
        inner = [(k, t.get(f"alm {k}", 0.0)) for k in ("hessian", "factor", "line search")]
        parts += inner + [("other", t["alm"] - sum(x for _, x in inner))]
    if "ipopt pass 1" in t:
        parts.append(("ipopt pass 1", t["ipopt pass 1"]))
    if "ipopt" in t:
        parts.append(("certify" if "alm" in t else "ipopt", t["ipopt"]))
    if "lbfgs" in t:
        parts.append(("lbfgs", t["lbfgs"]))
    return "phases (s): " + ", ".join(f"{k} {x:.2f}" for k, x in parts) + f"; total {t.get('total', 0.0):.2f}"


def _machine() -> str:
    """The CPU model (/proc/cpuinfo), its cores (and those this process may use), and the
    threads of every BLAS in use (threadpoolctl; casadi's OpenBLAS, which MUMPS uses, as
    ``solve()`` sets it)."""
    import threadpoolctl
    from torsal.geometry.optimize.factor import limit_mumps_threads

    model = "unknown CPU"
    try:
        with open("/proc/cpuinfo") as fh:
            model = next((ln.split(":", 1)[1].strip() for ln in fh if ln.startswith("model name")), model)
    except OSError:
        pass
    usable = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    casadi_blas = limit_mumps_threads()          # as solve() does; None: the user's choice
    pools = [f"{p['internal_api']} {os.path.basename(p['filepath'])} {p['num_threads']}"
             for p in threadpoolctl.threadpool_info()]
    pools.append(f"casadi's openblas (MUMPS) {casadi_blas if casadi_blas is not None else 'as the environment sets'}")
    return f"machine: {model}, {os.cpu_count()} cores ({usable} usable); threads: " + "; ".join(pools)


def run_fig12_row(name, design, T, methods, lbfgs_iter):
    spec, make, nv, nf = example_problem(design)
    compile_s = _compile_seconds(make)    # compiled kernels cached on disk before any timing
    runs = {}
    for method in methods:
        solver, formulate, kw = METHODS[method]
        kw = {**kw, "max_iter": lbfgs_iter if solver == "lbfgs" else spec.constraints.max_iter}
        (p, r), wall, cpu = _timed(lambda: (lambda q: (q, q.solve(solver=solver, **kw)))(formulate(make())))
        setup_w, setup_c = _setup(r, wall), _setup(r, cpu, cpu=True)
        _designer_change(p)
        r2, w2, c2 = _timed(lambda: p.solve(solver=solver, **kw))
        runs[method] = dict(r=r, wall=wall, cpu=cpu, setup_w=setup_w, setup_c=setup_c, r2=r2, w2=w2, c2=c2)
    best = _best(run["r"] for run in runs.values())
    best2 = _best(run["r2"] for run in runs.values())     # of the changed design
    out = []
    for method, run in runs.items():
        r, r2 = run["r"], run["r2"]
        goal = _goal(best)
        ttq = None if goal is None else r.time_to(goal)
        ttc = None if goal is None else r.time_to(goal, cpu=True)
        goal2 = _goal(best2)
        ttq2 = None if goal2 is None else r2.time_to(goal2)
        setup2 = _setup(r2, run["w2"])
        out.append(dict(row=name, V=nv, F=nf, T=T, method=method, solver=r.solver, wall=run["wall"],
                        cpu=run["cpu"], ttq=None if ttq is None else ttq + run["setup_w"],
                        ttc=None if ttc is None else ttc + run["setup_c"], it=r.iterations,
                        fact=r.counts.get("factorizations", "-"), ok=r.success, feasible=r.feasible,
                        E=r.objective, best=best, w2=run["w2"], c2=run["c2"], it2=r2.iterations,
                        ok2=r2.feasible, ttq2=None if ttq2 is None else ttq2 + setup2,
                        ang=r.min_torsal_angle_deg, spread=_spread(r), status=r.status,
                        phases=_phases(r, compile_s)))
    return out


def _goal(best: float | None) -> float | None:
    """The objective a run must reach to count as at quality: within 1 % of ``best``, or 1e-8
    absolutely where ``best`` is (nearly) zero (7a, 7b); None without a best."""
    return None if best is None else best + max(0.01 * abs(best), 1e-8)


def _setup(r, total: float, *, cpu: bool = False) -> float:
    """Seconds of a timed solve (``total``, wall or processor) before its first iterate: the
    build, which time to quality includes."""
    if not r.history:
        return total
    return total - (r.history[-1].cpu_seconds if cpu else r.history[-1].seconds)


def _best(results) -> float | None:
    """The lowest objective of a measured-feasible iterate of any of ``results``."""
    feasible = [x.objective for r in results for x in r.history if x.feasible]
    return min(feasible) if feasible else None


def _spread(r) -> str:
    """Per congruence, the widest angle (degrees) of its lines from their mean direction. Near 0
    the lines are nearly parallel: row 11's energies reach zero only there (no torsal
    structure left to build), so a lower energy on that row is not a better design."""
    from torsal.geometry.congruence import direction_spread

    return "/".join(f"{direction_spread(c.directions):.0f}" for c in r.congruences)


def _load() -> str:
    a = os.getloadavg()
    return f"load average {a[0]:.2f} {a[1]:.2f} {a[2]:.2f} ({os.cpu_count()} cores)"


def print_fig12(rows, methods, lbfgs_iter):
    print("Fig. 12 rows: time to quality (measured-feasible, energy within 1% of the best any method reached)")
    print(_load())
    print("re-solve: after the light weights x1.2, warm; its ttq against the best any method's re-solve reached")
    head = (f"{'row':>4} {'|V|':>6} {'T':>5} {'method':>9} {'by':>9} | {'wall':>6} {'cpu':>6} {'it':>5} {'fact':>5} | "
            f"{'ttq':>6} {'ttq cpu':>7} {'<=T':>4} | {'re-solve':>8} {'cpu':>6} {'it':>4} {'ttq':>6} {'<=T/5':>5} | "
            f"{'E':>10} {'E best':>10} {'min ang':>7} {'spread':>6} ok")
    print(head)
    print("-" * len(head))
    for name, design, T in FIG12:
        if rows and name not in rows:
            continue
        for r in run_fig12_row(name, design, T, methods, lbfgs_iter):
            ttq = r["ttq"]
            print(f"{r['row']:>4} {r['V']:>6} {T:5.1f} {r['method']:>9} {r['solver']:>9} | {r['wall']:6.1f} "
                  f"{r['cpu']:6.1f} {r['it']:>5} {r['fact']!s:>5} | {_fmt(ttq, '6.1f'):>6} {_fmt(r['ttc'], '7.1f'):>7} "
                  f"{('yes' if ttq is not None and ttq <= T else 'NO'):>4} | {r['w2']:8.2f} {r['c2']:6.2f} "
                  f"{r['it2']:>4} {_fmt(r['ttq2'], '6.2f'):>6} "
                  f"{('yes' if r['ttq2'] is not None and r['ttq2'] <= T / 5 else 'NO'):>5} | {r['E']:10.4e} "
                  f"{_fmt(r['best'], '10.4e'):>10} {_fmt(r['ang'], '7.2f'):>7} {r['spread']:>6} "
                  f"{'yes' if r['ok'] else ('feasible' if r['feasible'] else 'NO: ' + r['status'][:60])}", flush=True)
            print(f"{'':>10}{r['phases']}", flush=True)


def print_resolve(rows):
    print("Warm re-solves (auto) after one change, against the cold solve")
    print(_load())
    print("cold: the first solve; warm: the re-solve after the change; cold of the changed problem: a fresh")
    print("problem with the change solved from the start (feasible as measured, energy, warm's energy off by %,")
    print("same: within 1 % or 1e-8; ttq: the re-solve's time to quality, to its first measured-feasible")
    print("iterate within 1 % (or 1e-8) of the lower of the two answers, as the fig12 table measures a row)")
    head = (f"{'row':>4} {'T/5':>5} {'change':>7} | {'cold':>6} {'cpu':>6} {'it':>4} | {'warm':>6} {'cpu':>6} "
            f"{'it':>4} {'<=T/5':>5} {'feasible':>8} | {'ttq':>6} {'ttq cpu':>7} {'<=T/5':>5} | "
            f"{'cold ch.':>8} {'E warm':>10} {'E cold':>10} {'dE %':>7} same")
    print(head)
    print("-" * len(head))
    for name, design, T in FIG12:
        if rows and name not in rows:
            continue
        spec, make, _, _ = example_problem(design)
        make()
        for change, fn in CHANGES.items():
            p = make()
            r, w, c = _timed(lambda: p.solve(max_iter=spec.constraints.max_iter))
            before = {k: (t.weight, t.bound, t.par.copy()) for k, t in p.registry.terms.items()}
            fn(p)
            changed = any(k not in before or before[k][:2] != (t.weight, t.bound) or
                          before[k][2].shape != t.par.shape or not np.array_equal(before[k][2], t.par)
                          for k, t in p.registry.terms.items())
            if not changed:   # the design has no such term (7d: no strokes of f_dir)
                print(f"{name:>4} {T / 5:5.2f} {change:>7} |   (the design has no term this change moves)")
                continue
            r2, w2, c2 = _timed(lambda: p.solve(max_iter=spec.constraints.max_iter))
            # the same answer as a cold solve of the changed problem: measured feasibility, energy
            q = make()
            fn(q)
            r3 = q.solve(max_iter=spec.constraints.max_iter)
            rel = abs(r2.objective - r3.objective) / max(abs(r3.objective), 1e-300)
            # within 1 %, or 1e-8 absolutely where the energy is (nearly) zero (7a), as fig12
            same = abs(r2.objective - r3.objective) <= max(0.01 * abs(r3.objective), 1e-8)
            best = min(x.objective for x in (r2, r3) if x.feasible) if r2.feasible or r3.feasible else None
            goal = _goal(best)
            setup_w, setup_c = _setup(r2, w2), _setup(r2, c2, cpu=True)
            ttq, ttc = ((None, None) if goal is None or r2.time_to(goal) is None else
                        (r2.time_to(goal) + setup_w, r2.time_to(goal, cpu=True) + setup_c))
            print(f"{name:>4} {T / 5:5.2f} {change:>7} | {w:6.2f} {c:6.2f} {r.iterations:>4} | {w2:6.2f} {c2:6.2f} "
                  f"{r2.iterations:>4} {('yes' if w2 <= T / 5 else 'NO'):>5} {'yes' if r2.feasible else 'NO':>8} | "
                  f"{_fmt(ttq, '6.2f'):>6} {_fmt(ttc, '7.2f'):>7} "
                  f"{('yes' if ttq is not None and ttq <= T / 5 else 'NO'):>5} | "
                  f"{'yes' if r3.feasible else 'NO':>8} {r2.objective:10.4e} {r3.objective:10.4e} {100 * rel:7.3f} "
                  f"{'yes' if same else 'NO':>4}", flush=True)


def print_facade(angles=(40, 60, 80)):
    print("The doubly curved 1,089-vertex facade (normal 2, fair 1, perp 10, hyperbolic, normals as start)")
    print(_load())
    print("re-solve: after the sun turned by 5 degrees, warm from the answer")
    v, f = facade_patch(nu=33, nv=33)
    c = Congruence.from_normals((v, f))
    head = (f"{'angle':>5} {'solver':>6} {'by':>9} | {'wall':>6} {'cpu':>6} {'it':>4} {'fact':>5} | {'success':>7} "
            f"{'min ang':>7} {'faces < bound-0.1':>17} | {'E':>10} | {'re-solve':>8} {'cpu':>6} {'it':>4} "
            f"{'success':>7} {'min ang':>7} {'E':>10}")
    print(head)
    print("-" * len(head))
    for angle in angles:
        for solver in ("auto", "ipopt"):
            make = (lambda: CongruenceProblem(c, jit=True).normal(weight=2).fair(weight=1)
                    .perpendicular(SUN, weight=10).hyperbolic().min_torsal_angle(angle))
            compile_s = _compile_seconds(make)     # kernels compiled before timing
            (p, r), w, cp = _timed(lambda: (lambda q: (q, q.solve(solver=solver)))(make()))
            m = r.measured["min_torsal_angle"]
            below = int((m.values < angle - 0.1).sum())
            p.perpendicular(_rotated_sun(5.0), weight=10)
            r2, w2, c2 = _timed(lambda: p.solve(solver=solver))
            print(f"{angle:>5} {solver:>6} {r.solver:>9} | {w:6.2f} {cp:6.2f} {r.iterations:>4} "
                  f"{r.counts.get('factorizations', '-')!s:>5} | {str(r.success):>7} {r.min_torsal_angle_deg:7.2f} "
                  f"{below:>17} | {r.objective:10.4e} | {w2:8.2f} {c2:6.2f} {r2.iterations:>4} "
                  f"{str(r2.success):>7} {r2.min_torsal_angle_deg:7.2f} {r2.objective:10.4e}", flush=True)
            print(f"{'':>6}{_phases(r, compile_s)}", flush=True)


def print_family(size: int, n: int):
    from torsal.geometry.optimize.family import design_family

    print(f"Family: {n} doubly curved designs x min_torsal_angle 20/40/60/80, {size} x {size} vertices (auto)")
    print(_load())
    ok, total, cpu, fails = 0, 0, 0.0, []
    for m in design_family(n, size=size):
        for angle in (20, 40, 60, 80):
            r, w, c = _timed(lambda: m.make(angle, jit=True).solve())
            total += 1
            cpu += c
            if r.success:
                ok += 1
            else:
                fails.append((m.name, angle, r))
    print(f"success (measured-feasible and converged): {ok} / {total} = {100 * ok / total:.1f} %, "
          f"processor time {cpu:.1f} s")
    for name, angle, r in fails:
        faces = {k: v[:10].tolist() for k, v in r.violated.items() if len(v)}
        print(f"  {name} at {angle} deg: {r.solver}, {r.status[:100]}; faces {faces}")


def print_factor(rows):
    from torsal.geometry.optimize.alm import NewtonSystem
    from torsal.geometry.optimize import mumps
    from torsal.geometry.optimize.factor import BACKENDS, SparseCholesky, available, limit_mumps_threads
    from torsal.geometry.optimize.nlp import tangent_frames

    limit_mumps_threads()      # as solve() does

    print("Sparse Cholesky of the augmented Lagrangian's Newton matrix (per step: factor + solve)")
    print(_load())
    # MUMPS twice: called directly (analysed once) and through casadi's interface (every call)
    columns = [("mumps", True), ("mumps", False)] + [(b, None) for b in BACKENDS if b != "mumps"]
    print(f"{'row':>4} {'n':>6} {'nnz(K)':>8} | "
          + " ".join(f"{b if d is not False else 'mumps/casadi':>13}" for b, d in columns)
          + "   (ms wall / processor: MUMPS's BLAS may use a second thread)")
    for name, design, _ in FIG12:
        if name not in (rows or ["7c", "9", "13", "11"]):
            continue
        spec, make, _, _ = example_problem(design)
        p = _split_form(make())
        p.build("alm")
        b = p.nlp.built["tangent/alm"]
        # every congruence's directions (row 11 optimizes two together)
        par = b.parameters(p.registry.current(), tangent_frames(p.registry.directions()))
        x = np.zeros(b.n_var)
        sys_ = NewtonSystem.of(b, "splu")
        h = b.hess_lag.nonzeros([x, par, np.array([float(b.n_vertices)]), np.zeros(b.n_g)])
        jac = np.asarray(b.jac_g(x, par)[1].nonzeros())
        k = sys_.values(h, jac, np.full(b.n_g, 10.0), 1e-6 * float(np.mean(h)))
        rhs = np.ones(b.n_var)
        cells = []
        for backend, direct in columns:
            if not available(backend) or direct and not mumps.available():
                cells.append(f"{'n/a':>13}")
                continue
            if direct is not None:
                mumps._checked = None if direct else False      # the next SparseCholesky's route
            if backend in ("csparse", "splu") and b.n_var > 10_000:
                cells.append(f"{'(minutes)':>13}")     # row 11: not supernodal, no refactorization
                continue
            f = SparseCholesky(sys_.chol.upper(k), backend)
            w0 = time.perf_counter()
            f.factor(k)
            f.solve(rhs)
            reps = 10 if time.perf_counter() - w0 < 1.0 else 2      # row 11: seconds per factorization
            w0, c0 = time.perf_counter(), time.process_time()
            for _ in range(reps):
                f.factor(k)
                f.solve(rhs)
            w, c = (1000 / reps) * (time.perf_counter() - w0), (1000 / reps) * (time.process_time() - c0)
            cells.append(f"{w:6.1f}/{c:<6.1f}")
            mumps._checked = None
        print(f"{name:>4} {b.n_var:>6} {sys_.chol.nnz:>8} | " + " ".join(cells), flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tables", nargs="*", default=["fig12", "resolve", "facade", "family"],
                    choices=["fig12", "resolve", "facade", "family", "factor", "synthetic", "stop", "design"])
    ap.add_argument("--methods", nargs="*", default=list(METHODS), choices=list(METHODS))
    ap.add_argument("--rows", nargs="*", default=None, help="Fig. 12 rows (default all)")
    ap.add_argument("--lbfgs-iter", type=int, default=500)
    ap.add_argument("--facade-angles", nargs="*", type=float, default=[40, 60, 80],
                    help="min_torsal_angle bounds of the facade table")
    ap.add_argument("--family-size", type=int, default=33)
    ap.add_argument("--family-n", type=int, default=20)
    ap.add_argument("--max-vertices", type=int, default=100_000, help="synthetic rows up to this size")
    ap.add_argument("--no-jit", action="store_true", help="interpreted casadi kernels")
    ap.add_argument("--psd", choices=["numpy", "compiled"], default=None,
                    help="the element Hessians' eigendecompositions (projected.PSD_KERNEL; default its default)")
    args = ap.parse_args()
    OPTS["jit"] = not args.no_jit
    if args.psd:
        from torsal.geometry.optimize import projected
        projected.PSD_KERNEL = args.psd
    print(_machine())
    print()
    if "fig12" in args.tables:
        print_fig12(args.rows, args.methods, args.lbfgs_iter)
        print()
    if "resolve" in args.tables:
        print_resolve(args.rows)
        print()
    if "facade" in args.tables:
        print_facade(args.facade_angles)
        print()
    if "family" in args.tables:
        print_family(args.family_size, args.family_n)
        print()
    if "factor" in args.tables:
        print_factor(args.rows)
        print()
    if "synthetic" in args.tables:
        print_synthetic(args.max_vertices)
    if "stop" in args.tables:
        print_stop(args.rows or ["7c", "9"])
    if "design" in args.tables:
        print_design(args.rows or ["7c", "9", "facade80"])


#: what the ``stop`` table compares, (section, key) of report.json
STOP_FIGURES = [("congruence", "iterations"), ("congruence", "objective"),
                ("congruence", "min_torsal_plane_angle_deg"), ("congruence", "min_torsal_direction_angle_deg"),
                ("support", "edges"), ("support", "quads"), ("support", "delta_pl_extracted"),
                ("support", "delta_pl_optimized"), ("light", "blocked_share"), ("light", "transparency"),
                ("light", "transparency_cone"), ("fabrication", "parts"), ("fabrication", "panels")]


#: the ``stop`` table's runs: the default (the design tolerance), to convergence, and to
#: convergence at a tenth of the tolerance (how much the digits past convergence still move the
#: figures: the noise against which the design tolerance's differences are read)
STOP_RUNS = {"design": {}, "converged": {"stop": "converged"}, "tol/10": {"stop": "converged", "tol": 1e-5}}


def print_stop(rows):
    """The design tolerance (``solve(stop="design")``, the default) against full convergence,
    downstream: each example run by ``torsal design``'s pipeline up to the light stage (the
    congruence, the remeshed support structure, the fins built, the light through them) with
    each of :data:`STOP_RUNS`; report.json's figures side by side, each relative to the
    converged run's."""
    import dataclasses
    import tempfile
    from functools import partial

    from torsal.pipeline.design import Design
    from torsal.pipeline.stages import DEFAULT_PIPELINE, run_congruence

    print("The design tolerance against convergence, downstream (torsal design up to the light stage)")
    print(_load())
    for name, design, T in FIG12:
        if name not in rows:
            continue
        reports = {}
        for run, options in STOP_RUNS.items():
            pl = DEFAULT_PIPELINE.until("light")
            pl = pl.replace(dataclasses.replace(pl["congruence"], run=partial(run_congruence, solve_options=options)))
            with tempfile.TemporaryDirectory() as out:
                res = Design.from_toml(EXAMPLES / design).run(out, pipeline=pl, use_cache=False, size_limit=False)
            reports[run] = res.report
            c = res.report["congruence"]
            conv = c.get("convergence") or {}
            print(f"{name:>4} T {T:5.1f} {run:>9}: congruence build + solve "
                  f"{c['build_s'] + c['solve_s']:6.2f} s ({'<=' if c['build_s'] + c['solve_s'] <= T else '>'} T), "
                  f"{conv.get('reason')}, decrement {conv.get('newton_decrement')}, "
                  f"recent decrease {conv.get('recent_decrease')}", flush=True)
        print(f"{'':>6}{'':<46} " + " ".join(f"{r:>12}" for r in STOP_RUNS) + "  relative to converged")
        for section, key in STOP_FIGURES:
            vals = {r: _figure(reports[r], section, key) for r in STOP_RUNS}
            ref = vals["converged"]
            rel = " ".join(f"{(v - ref) / abs(ref):+9.2e}" if isinstance(v, float) and isinstance(ref, float) and ref
                           else f"{'':>9}" for r, v in vals.items() if r != "converged")
            print(f"{'':>6}{section + '.' + key:<46} " + " ".join(f"{_fmt(v, '12.6g'):>12}" for v in vals.values())
                  + f"  {rel}", flush=True)


#: the ``design`` table's doubly curved facade: example 7a's at this ``min_torsal_angle``, and
#: its target (the issue's, for the facade at 80 degrees)
FACADE_DESIGN = ("facade80", "7a_facade_block.toml", 80.0, 7.4)


def _design_runs(rows):
    """``(row, Design, T)`` of the ``design`` table: Fig. 12 rows by their design files, and
    ``facade80`` (:data:`FACADE_DESIGN`)."""
    from torsal.pipeline.design import Design

    for name, design, T in FIG12:
        if name in rows:
            yield name, Design.from_toml(EXAMPLES / design), T
    name, design, angle, T = FACADE_DESIGN
    if name in rows:
        d = Design.from_toml(EXAMPLES / design)
        spec = d.spec
        yield name, Design(spec.model_copy(update={"constraints": spec.constraints.model_copy(
            update={"min_torsal_angle": angle})})), T


def print_design(rows):
    """``torsal design``'s congruence stage as its report.json gives it (see the module
    docstring, table ``design``)."""
    import dataclasses
    import tempfile

    from torsal.pipeline.stages import DEFAULT_PIPELINE, run_congruence

    from torsal.geometry.optimize import projected, psd_kernel

    print("torsal design's congruence stage (report.json congruence; the pipeline up to it, no cache)")
    kernel = projected.PSD_KERNEL if projected.PSD_KERNEL != "compiled" or psd_kernel.available() else "numpy"
    print(f"{_load()}; element Hessians' eigendecompositions: {kernel}")
    head = (f"{'row':>8} {'T':>5} | {'build':>6} {'solve':>7} {'b+s':>7} {'<=T':>4} | {'cpu':>6} {'steps':>5} "
            f"{'fact':>5} | {'E':>10} {'min ang':>7} | ended by, decrement, recent decrease")
    print(head)
    print("-" * len(head))
    for name, design, T in _design_runs(rows):
        cpu = {}

        def timed(inp):
            out, _, cpu["s"] = _timed(lambda: run_congruence(inp))
            return out
        pl = DEFAULT_PIPELINE.until("congruence")
        pl = pl.replace(dataclasses.replace(pl["congruence"], run=timed))
        with tempfile.TemporaryDirectory() as out:
            c = design.run(out, pipeline=pl, use_cache=False, size_limit=False).report["congruence"]
        bs, n, conv = c["build_s"] + c["solve_s"], c.get("counts", {}), c.get("convergence") or {}
        print(f"{name:>8} {T:5.1f} | {c['build_s']:6.2f} {c['solve_s']:7.2f} {bs:7.2f} {'yes' if bs <= T else 'NO':>4} | "
              f"{cpu['s']:6.2f} {n.get('newton_steps', c['iterations'])!s:>5} {n.get('factorizations', '-')!s:>5} | "
              f"{c['energies']['total']:10.4e} {c['min_torsal_plane_angle_deg']:7.2f} | {conv.get('reason')}, "
              f"{_fmt(conv.get('newton_decrement'), '.1e')}, {_fmt(conv.get('recent_decrease'), '.1e')}", flush=True)
        t = c.get("timings_s", {})
        print(f"{'':>10}phases (s): " + ", ".join(f"{k} {v:.2f}" for k, v in t.items()) + f"; {_load()}",
              flush=True)


def _figure(report: dict, section: str, key: str):
    """``report[section][key]``; the congruence's objective is its energies' total."""
    sec = report.get(section, {})
    if section == "congruence" and key == "objective":
        return float(sec.get("energies", {}).get("total", float("nan")))
    v = sec.get(key)
    return float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else v


def print_synthetic(max_vertices: int):
    head = (f"{'row':>5} {'|V|':>7} {'|F|':>7} {'T':>5} {'solver':>6} | {'build':>6} {'solve':>7} "
            f"{'it':>4} {'b+s':>7} {'all':>7} {'<2T':>4} | {'re-solve':>8} {'it':>4} {'<T':>4} | "
            f"{'E start':>9} {'E first':>9} {'E re':>9} {'worst viol':>10} {'|<e,d>|':>8} {'hyp%':>5} "
            f"{'no td':>11} ok")
    print(_load())
    print(head)
    print("-" * len(head))
    for name, grid, pv, pf, T, fn in ROWS:
        if grid[0] * grid[1] > max_vertices * 1.01:
            continue
        for r in run_row(name, grid, T, fn, ["ipopt"], 500):
            bs = r["build"] + r["solve"]
            t_ok = "" if T is None else ("yes" if bs < 2 * T else "NO")
            if name == "100k":   # target: 100k vertices in < 60 s in all (problem, build, solve)
                t_ok = "yes" if r["first"] < 60 else "NO"
            r_ok = "" if T is None else ("yes" if r["resolve"] < T else "NO")
            print(f"{r['row']:>5} {r['V']:>7} {r['F']:>7} {_fmt(T, '5.1f'):>5} {r['solver']:>6} | "
                  f"{r['build']:6.2f} {r['solve']:7.2f} {r['it1']:>4} {bs:7.2f} {r['first']:7.2f} {t_ok:>4} | "
                  f"{r['resolve']:8.2f} {r['it2']:>4} {r_ok:>4} | {r['E0']:9.3e} {r['E1']:9.3e} "
                  f"{r['E2']:9.3e} {r['worst']:10.2e} {r['perp']:8.4f} {100 * r['hyp']:5.1f} "
                  f"{'%d->%d' % r['no_td']:>11} "
                  f"{'ok' if r['ok1'] and r['ok2'] else 'FAIL: ' + r['status'][:60]}", flush=True)


if __name__ == "__main__":
    main()
