"""The surgery layer (it imports the engine, never the workbook): :mod:`.geometry`, the cut geometry shared by
:mod:`.topology` (cuts along mesh edges, excisions, pieces), :mod:`.element_cuts` (cuts through elements, the virtual
node algorithm) and :mod:`.surfaces` (the contact surface of a body cut through elements); :mod:`.scene`, the
declarative description of a simulation (TOML/JSON); :mod:`.simulation`, a scene built and stepped, with grab, drag,
release, probe, cut, excise and suture between frames; :mod:`.flaps`, local flap procedures and their tension; and
:mod:`.interactive` with :mod:`.widget`, the live view drawn in the browser, and :mod:`.nodelay`, the Jupyter Server
extension that sends its frames without Nagle's delay (imported where used:
``import tissuefem`` loads neither pyplot nor IPython).
"""
