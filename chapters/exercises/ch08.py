"""Chapter 8 exercises: virtual surgery (cutting the mesh).

Fill in each function, then run ``python -m tissuefem grade ch08``.
You may use numpy, scipy and scikit-fem; do not import the answer from tissuefem.

Conventions: a triangle mesh is given by its connectivity ``t``, an integer
array shaped ``(3, m)`` whose column ``e`` lists the three node indices of
triangle ``e``, and by its number of nodes ``n_nodes`` (nodes are numbered
``0 .. n_nodes - 1``). An *edge* is an unordered pair of nodes that appear
together in some triangle.
"""

import numpy as np


def duplicate_cut_nodes(t, n_nodes, cut_edges):
    """Exercise 8.1. Duplicate the nodes along a cut, so that the cut edges open.

    ``cut_edges`` is an integer array shaped ``(2, k)``: column ``j`` holds
    the two nodes of an edge of the mesh that the scalpel goes through (in
    either order). A cut never splits a triangle; it separates the triangles
    on its two sides by giving them *different copies* of the nodes on the
    cut.

    The idea: look at one node ``v`` on the cut and at the triangles around
    it (the triangles that contain ``v``). Two of them are *neighbours* when
    they share an edge ``(v, x)`` that is **not** cut. Group the triangles
    around ``v`` into *fans*: sets of triangles you can walk between from
    neighbour to neighbour without crossing a cut edge. Each fan is one side
    of the wound at ``v``. One fan keeps the node ``v``; every other fan gets
    a new node (a copy of ``v``), and its triangles use the copy instead of
    ``v``.

    Check your understanding on these cases:

    * a cut from boundary to boundary: every node on it has two fans (one on
      each side), so every node on the path gets one copy and the body falls
      apart in two pieces;
    * the tip of a crack inside the body (a node with only one cut edge) has
      a single fan: you can walk around the tip the other way. The tip is not
      copied; the crack is open along its length and closed at its tip;
    * where cut edges cross (an X), the node in the middle has four fans.

    Return ``(new_t, parent)``:

    * ``new_t``: integer array shaped ``(3, m)``, the same triangles in the
      same order with their vertices in the same order; only the index of a
      node that a triangle now reaches through a copy changes;
    * ``parent``: integer array of length ``n_nodes + (number of copies)``.
      The original nodes keep their numbers (``parent[i] = i`` for
      ``i < n_nodes``); the copies are appended, numbered ``n_nodes,
      n_nodes + 1, ...``, and ``parent[c]`` is the node that copy ``c`` was
      made from. So ``parent[new_t]`` is the original ``t`` again.

    Which fan keeps the original node, and in which order you number the
    copies, is up to you: the grader checks the invariants above (how many
    copies, ``parent[new_t] == t``, which edges are still shared by two
    triangles, how many pieces), not one particular numbering. Do not modify
    ``t`` or ``cut_edges``.

    Hint: a dictionary from a sorted node pair ``(a, b)`` to the list of
    triangles that contain that edge gives you the neighbours; then a small
    flood fill (or a union-find) per cut node finds its fans.
    """
    raise NotImplementedError("Exercise 8.1: duplicate the nodes along a cut")


def scene_file_text():
    """Exercise 8.2. Write a scene file (TOML) for this simulation, and return its text.

    An instructor wants a muscle-like strip that students can tug. Describe it
    with the keys of ``tissuefem.surgery.scene.EXAMPLE_TOML`` (print it for a model):

    * name: ``"tug"``;
    * domain: a rectangle 3 wide and 1 high, with about 600 triangles;
    * material: the ``"corotated"`` model, Young's modulus 5000, Poisson's
      ratio 0.4, density 1.1;
    * effects:
      - inertia with time step 0.02;
      - gravity (0, -9.81);
      - fibers of stiffness 2000 along the x axis;
      - a handle named ``"fixed"`` on the boundary ``"left"`` (not moving);
      - a handle named ``"tip"`` on the nodes within 0.1 of the point
        (3, 0.5), pulled by (0.5, 0).

    Nothing else (no probes, cuts or sutures). Return the TOML text as a
    string: ``tomllib.loads`` must read it, and ``Scene.from_toml`` must accept
    it (it names the field of any mistake). You may write the text by hand or
    build a ``Scene`` in Python and call ``to_toml()`` -- the first is the
    point of the exercise.
    """
    raise NotImplementedError("Exercise 8.2: write a scene file")
