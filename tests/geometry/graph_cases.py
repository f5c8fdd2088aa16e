"""Analytic graph surfaces shared by the frame-field and remeshing tests.

Not a test module: ``test_frame_field.py`` and ``test_remesh.py`` import these (pytest puts
this folder on ``sys.path``).
"""
import numpy as np

from torsal.geometry.congruence import Congruence
from torsal.geometry.mesh import vertex_normals
from torsal.geometry.surfaces import graph_surface


def saddle(x, y):
    return 0.3 * (x**2 - 0.5 * y**2) + 0.1 * x**3


def star(x, y):  # umbilic at the origin with a star (index -1/2) pattern
    return 0.5 * (x**2 + y**2) + 0.3 * (x**3 - 3 * x * y**2)


def principal_directions(f, x, y, h=1e-5):
    """Analytic principal directions of the graph z = f(x, y) at (x, y), (m, 2, 3) unit: the
    eigenvectors of I^-1 II mapped to 3D by (1, 0, f_x), (0, 1, f_y)."""
    fx = (f(x + h, y) - f(x - h, y)) / (2 * h)
    fy = (f(x, y + h) - f(x, y - h)) / (2 * h)
    fxx = (f(x + h, y) - 2 * f(x, y) + f(x - h, y)) / h**2
    fyy = (f(x, y + h) - 2 * f(x, y) + f(x, y - h)) / h**2
    fxy = (f(x + h, y + h) - f(x + h, y - h) - f(x - h, y + h) + f(x - h, y - h)) / (4 * h * h)
    I = np.stack([np.stack([1 + fx**2, fx * fy], -1), np.stack([fx * fy, 1 + fy**2], -1)], -2)
    II = np.stack([np.stack([fxx, fxy], -1), np.stack([fxy, fyy], -1)], -2)
    _, vec = np.linalg.eig(np.linalg.solve(I, II))
    X = np.stack([np.stack([np.ones_like(x), 0 * x, fx], -1), np.stack([0 * x, np.ones_like(x), fy], -1)], -2)
    out = np.einsum("mij,mjd->mid", np.real(vec).transpose(0, 2, 1), X)
    return out / np.linalg.norm(out, axis=2, keepdims=True)


def noisy_saddle(noise=0.01, seed=0, n=31):
    """The saddle's normal congruence with the lines tilted by ~``noise`` rad of random noise
    per vertex: the torsal (principal) directions are still those of the saddle on every
    scale above the mesh, but per face they scatter by ~15 degrees and the raw frame field
    has hundreds of spurious singularities -- like a congruence whose strongly weighted design
    term left face-to-face noise (example 13, f_plane at 5000)."""
    V, F = graph_surface(saddle, nu=n, nv=n)
    rng = np.random.default_rng(seed)
    return Congruence(V, F, vertex_normals(V, F) + noise * rng.normal(size=V.shape))
