"""The recipe of scenes/kidney.msh: a kidney-like body of tetrahedra, made with gmsh's OpenCASCADE kernel.

Run from the project's root, with gmsh's Python wheel installed next to (not into) the package: gmsh is a tool that
made a data file, never a dependency of tissuefem (its licence, GPL-2.0-or-later, covers gmsh itself, not the meshes
it writes)::

    pip install gmsh==4.15.2
    python scenes/make_kidney_mesh.py

The body, in the scene's length unit (about 2.2 long, as the 2 x 1 sheet of the chapters): an ellipsoid with
semi-axes 0.6, 1.1 and 0.4 along x, y and z, two smaller ellipsoids fused on at the poles (the lobes), and the
hilum, the notch where the vessels enter, cut out of its medial (+x) side by a third ellipsoid. Tetrahedra of size
0.12 make about 3800 of them. Two physical surfaces name its boundaries: ``hilum`` (the faces of the notch, where a
scene holds it) and ``capsule`` (the rest); the physical volume ``kidney`` holds the tetrahedra. The file is written
in gmsh's format 2.2, as text.
"""

import sys
from pathlib import Path

import gmsh

SIZE = 0.12  # the tetrahedra's edge length
OUT = Path(__file__).resolve().parent / "kidney.msh"


def ellipsoid(occ, centre, axes):
    """A volume: the unit sphere at the origin scaled by ``axes`` and moved to ``centre``."""
    tag = occ.addSphere(0.0, 0.0, 0.0, 1.0)
    occ.dilate([(3, tag)], 0.0, 0.0, 0.0, *axes)
    occ.translate([(3, tag)], *centre)
    return tag


def on_ellipsoid(surface, centre, axes) -> bool:
    """Whether a surface of the model lies on the ellipsoid (a point of its underlying surface does)."""
    lo, hi = gmsh.model.getParametrizationBounds(2, surface)
    x = gmsh.model.getValue(2, surface, [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])])
    return abs(sum(((x[i] - centre[i]) / axes[i]) ** 2 for i in range(3)) - 1.0) < 1e-6


def main() -> int:
    gmsh.initialize(sys.argv[:1])
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add("kidney")
    occ = gmsh.model.occ
    body = ellipsoid(occ, (0.0, 0.0, 0.0), (0.6, 1.1, 0.4))
    upper = ellipsoid(occ, (-0.05, 0.62, 0.0), (0.5, 0.48, 0.36))
    lower = ellipsoid(occ, (-0.05, -0.62, 0.0), (0.5, 0.48, 0.36))
    fused, _ = occ.fuse([(3, body)], [(3, upper), (3, lower)])
    notch_centre, notch_axes = (0.62, 0.0, 0.0), (0.3, 0.38, 0.22)
    hilum = ellipsoid(occ, notch_centre, notch_axes)
    kidney, _ = occ.cut(fused, [(3, hilum)])
    occ.synchronize()
    volume = kidney[0][1]
    surfaces = [tag for _, tag in gmsh.model.getBoundary(kidney, oriented=False)]
    notch = [s for s in surfaces if on_ellipsoid(s, notch_centre, notch_axes)]
    gmsh.model.addPhysicalGroup(3, [volume], name="kidney")
    gmsh.model.addPhysicalGroup(2, notch, name="hilum")
    gmsh.model.addPhysicalGroup(2, [s for s in surfaces if s not in notch], name="capsule")
    gmsh.option.setNumber("Mesh.MeshSizeMax", SIZE)
    gmsh.option.setNumber("Mesh.MeshSizeMin", 0.5 * SIZE)
    gmsh.option.setNumber("Mesh.Algorithm3D", 1)  # Delaunay
    gmsh.option.setNumber("Mesh.Optimize", 1)
    gmsh.option.setNumber("Mesh.RandomSeed", 1)
    gmsh.model.mesh.generate(3)
    gmsh.option.setNumber("Mesh.MshFileVersion", 2.2)
    gmsh.option.setNumber("Mesh.Binary", 0)
    gmsh.write(str(OUT))
    _, elements, _ = gmsh.model.mesh.getElements(3)
    print(f"{OUT.name}: {sum(len(e) for e in elements)} tetrahedra, gmsh {gmsh.__version__}")
    gmsh.finalize()
    return 0


if __name__ == "__main__":
    sys.exit(main())
