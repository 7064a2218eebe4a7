"""The surgery layer: topology operations, scenes, the running simulation and the mouse.

* :mod:`.geometry` -- the cut geometry the three below share (edges, local coordinates, a cut element's material);
* :mod:`.topology` -- cuts along mesh edges (node duplication), excisions, connected pieces;
* :mod:`.element_cuts` -- cuts through elements by the virtual node algorithm;
* :mod:`.surfaces` -- the contact surface of a body cut through elements (where its material ends);
* :mod:`.scene` -- the declarative description of a simulation, read from and written to TOML/JSON;
* :mod:`.simulation` -- a scene built and stepped, with grab, drag, release, probe, cut, excise, suture between frames;
* :mod:`.flaps` -- local flap procedures and their tension reports;
* :mod:`.interactive` -- the view that turns mouse events into those operations, and :mod:`.view_drawing`, what
  it draws within the frame budget (both imported where they are used: ``import tissuefem`` loads no pyplot).

It imports the engine, never the workbook.
"""
