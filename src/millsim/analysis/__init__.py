"""The numbers behind the studies, from case files: pure numpy/pandas/xarray.

No numba, no plotting, no scene (tests/test_layers.py): the command line (``millsim aggregate``,
``millsim analyse``) reads and writes the files, ``millsim.plots`` draws what is computed here.

- :mod:`.aggregate`: stack case files along their swept parameters (with the per-scene summaries
  of :mod:`.ballmill` and :mod:`.bed_impact`);
- :mod:`.accuracy`: error against run time (work-precision) of each scene's observables;
- :mod:`.stirred_mill`: the three-stage stirred-mill power-draw calibration;
- :mod:`.tavares_verification`: the single-particle verification aggregate and its pass rule.
"""
