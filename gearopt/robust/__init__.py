"""Robust design at scale: tolerance and misalignment Monte Carlo, design sweeps (DOE), and the
executors that run them in-process, in local processes or on a Dask cluster (docs/scale.md).

Modules:

``tolerances``  ISO 1328-1:2013 flank tolerances of an accuracy class.
``sampling``    distributions of the random inputs, seeded Monte Carlo, Latin hypercube and full
                factorial designs.
``batch``       :class:`TCAKernel`: the TCA of many samples (designs, deviations, misalignments)
                in one mapped call, with the per-sample figures (TE, harmonics, edge contact,
                contact pattern); picklable, so it ships to workers serialised.
``execution``   chunks of samples run serially, in local processes or on Dask, bit-identical.
``study``       :class:`MonteCarlo` and :class:`DesignSweep` (API of the ``montecarlo`` and
                ``sweep`` studies) and their result.
"""
