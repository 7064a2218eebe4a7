"""Helpers shared by the tests of every layer: a chapter figure registered, documented, a PNG, byte-identical to
the committed file; random deformation gradients, central finite differences of a function of ``F``, the
isotropic materials, and work launched off the frame that runs when the test says (:class:`Launcher`)."""

import hashlib
from pathlib import Path

import numpy as np

from tissuefem.engine.materials import MATERIALS
from tissuefem.workbook import figures

#: the step of the central differences of the materials' stress and tangent
H = 1e-6


#: the committed lecture figures
FIGURES_DIR = Path(__file__).resolve().parents[1] / "figures"


def figure_drift(new_dir, names) -> list[str]:
    """One line per file of the figures ``names`` (PNG, and a GIF written beside) that was regenerated into
    ``new_dir`` but differs from, or is missing in, the committed ``figures/``, naming the command that updates it."""
    lines = []
    for name in names:
        for made in sorted(Path(new_dir).glob(f"{name}.*")):
            committed = FIGURES_DIR / made.name
            if not committed.exists():
                lines.append(f"figures/{made.name} is not committed")
            elif committed.read_bytes() != made.read_bytes():
                lines.append(f"figures/{made.name} differs from what the code draws now")
    if lines:
        wanted = " ".join(sorted({line.split()[0][len("figures/"):].rsplit(".", 1)[0] for line in lines}))
        lines.append(f"update: python -m tissuefem figures --only {wanted}  (look at them, then commit them)")
    return lines


def assert_figure_deterministic(name, tmp_path):
    """Registered, documented, a PNG without a 'Software' entry, and byte for byte the committed file (drawn
    earlier, elsewhere); with another matplotlib than the committed files' (its text differs), two runs agree."""
    assert name in figures.FIGURES and figures.FIGURES[name].__doc__
    first = figures.generate([name], tmp_path / "a", progress=None)[0]
    data = first.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    assert b"Software" not in data[:400]
    if figures.matplotlib_note() is None:
        drift = figure_drift(tmp_path / "a", [name])
        assert not drift, "\n".join(drift)
    else:
        second = figures.generate([name], tmp_path / "b", progress=None)[0]
        assert hashlib.sha256(data).digest() == hashlib.sha256(second.read_bytes()).digest()


def isotropic_materials(lam, mu) -> dict:
    """Every isotropic model of the engine (:data:`tissuefem.engine.materials.MATERIALS`) with Lamé ``lam, mu``."""
    return {name: cls(lam, mu) for name, cls in MATERIALS.items()}


def rotation(theta):
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s], [s, c]])


def rotation3(rng, shape):
    """Random rotations ``[3, 3, *shape]``, uniform on SO(3) (from normalised Gaussian quaternions)."""
    q = rng.normal(size=(4,) + tuple(shape))
    w, x, y, z = q / np.linalg.norm(q, axis=0)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def matmul(A, B):
    """Products of fields of d x d matrices ``[d, d, ...]``."""
    return np.einsum("ij...,jk...->ik...", A, B)


#: the named states of :func:`random_F` in 2D and 3D
NAMED_F = {2: {"rest": np.eye(2), "stretched": np.diag([1.3, 0.85]), "sheared": np.array([[1.0, 0.4], [0.0, 1.0]])},
           3: {"rest": np.eye(3), "stretched": np.diag([1.3, 0.85, 1.1]),
               "sheared": np.array([[1.0, 0.4, 0.0], [0.0, 1.0, -0.3], [0.0, 0.0, 1.0]])}}


def random_F(kind, seed=0, shape=(30, 3), dim=2):
    """Fields of F shaped ``[d, d, *shape]`` (``d = dim``, 2 or 3): ``"positive"`` (J > 0), ``"inverted"`` (J < 0,
    down to about -4 in 2D), ``"singular"`` (J = 0), built as ``U diag(s) V^T`` with rotations U, V; or the named
    states ``"rest"``, ``"stretched"``, ``"sheared"`` (the same F everywhere). Inverted samples keep every sum of two
    signed singular values ``>= 0.2``: the corotated rotation is singular where one is 0 (a measure-zero set, tested
    apart)."""
    named = NAMED_F[dim]
    if kind in named:
        return np.broadcast_to(named[kind].reshape(dim, dim, 1, 1), (dim, dim) + shape).copy()
    rng = np.random.default_rng(seed)
    if dim == 3:
        return _random_F3(kind, rng, shape)
    U = rotation(rng.uniform(-np.pi, np.pi, shape))
    V = rotation(rng.uniform(-np.pi, np.pi, shape))
    if kind == "positive":
        s1, s2 = np.exp(rng.normal(0.0, 0.35, shape)), np.exp(rng.normal(0.0, 0.35, shape))
    elif kind == "inverted":
        s1, s2 = rng.uniform(1.2, 2.0, shape), -rng.uniform(0.1, 1.0, shape)
    elif kind == "singular":
        s1, s2 = rng.uniform(0.5, 2.0, shape), np.zeros(shape)
    else:
        raise ValueError(kind)
    z = np.zeros(shape)
    return matmul(matmul(U, np.array([[s1, z], [z, s2]])), V.swapaxes(0, 1))


def _random_F3(kind, rng, shape):
    U, V = rotation3(rng, shape), rotation3(rng, shape)
    if kind == "positive":
        s = np.exp(rng.normal(0.0, 0.3, (3,) + shape))
    elif kind == "inverted":
        s = np.stack([rng.uniform(1.2, 2.0, shape), rng.uniform(1.2, 2.0, shape), -rng.uniform(0.1, 1.0, shape)])
    elif kind == "singular":
        s = np.stack([rng.uniform(0.5, 2.0, shape), rng.uniform(0.5, 2.0, shape), np.zeros(shape)])
    else:
        raise ValueError(kind)
    return np.einsum("ia...,a...,ja...->ij...", U, s, V)


def fd_derivative(f, F, h=H):
    """Central differences of ``f`` with respect to ``F`` (a d x d matrix or a field ``[d, d, ...]``), one entry
    ``F[k, l]`` at a time: ``out[..., k, l, *rest] = (f(F + h e_kl) - f(F - h e_kl)) / 2h``, where ``...`` are the
    leading axes of ``f``'s value (none for an energy, ``(d, d)`` for a stress) and ``rest`` are ``F.shape[2:]``."""
    F = np.asarray(F)
    dim = F.shape[0]
    rest = F.shape[2:]
    out = None
    for k in range(dim):
        for l in range(dim):
            dF = np.zeros(F.shape)
            dF[k, l] = h
            d = (f(F + dF) - f(F - dF)) / (2.0 * h)
            if out is None:
                lead = np.shape(d)[:np.ndim(d) - len(rest)]
                out = np.empty(lead + (dim, dim) + rest)
            out[(slice(None),) * len(lead) + (k, l)] = d
    return out


def fd_stress(m, F, h=H):
    """The stress of material ``m`` by central differences of its energy density (all samples at once)."""
    return fd_derivative(m.energy, F, h)


def fd_tangent(m, F, h=H):
    """The tangent of material ``m`` by central differences of its stress."""
    return fd_derivative(m.stress, F, h)


class Job:
    """Work launched off the frame that the test runs: ``join`` runs it, once."""

    def __init__(self, work):
        self.work, self.done = work, False

    def is_alive(self):
        return not self.done

    def join(self):
        if not self.done:
            self.done = True
            self.work()


class Launcher:
    """A ``launch`` for the engine's background work: it starts nothing; ``finish`` (or a job's ``join``) runs it."""

    def __init__(self):
        self.jobs = []

    def __call__(self, work):
        self.jobs.append(Job(work))
        return self.jobs[-1]

    def finish(self):
        for job in self.jobs:
            job.join()

    def running(self):
        return sum(job.is_alive() for job in self.jobs)
