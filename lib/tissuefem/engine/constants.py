"""The numbers the whole workbook shares, defined once: the notes' real-time frame ("Real-time computing"), also the
default time step of an interactive scene (one step per drawn frame), and the exercises' soft tissue."""

#: the notes' frame time, 1/30 s: the budget of one real-time frame and the default time step
FRAME_BUDGET = 1.0 / 30.0

#: Young's modulus of the exercises' tissue (the notes: "typically around 1000")
TISSUE_E = 1000.0

#: Poisson's ratio of the exercises' tissue: clearly compressible (plane strain)
TISSUE_NU = 0.3

#: density rho0 of the exercises' tissue (mass per unit reference area)
TISSUE_DENSITY = 1.0

__all__ = ["FRAME_BUDGET", "TISSUE_E", "TISSUE_NU", "TISSUE_DENSITY"]
