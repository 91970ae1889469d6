"""Virtual inverse problems of thesis chapter 4 on the farm: ``farm invert``.

- :mod:`jobs.inverse.study`: the study file (conditions, optimisers, noise, masks)
- :mod:`jobs.inverse.problem`: the reference experiment and the forward model
- :mod:`jobs.inverse.objective`: eqs. 4.1/4.2 and the combined residuals, noise
- :mod:`jobs.inverse.guesses`: initial guesses (scaled, uniform, thickness offset, and
  the statistical "tyre distribution" of §6.2, :mod:`jobs.inverse.distribution`)
- :mod:`jobs.inverse.regularisation`: the regularisation weight by the discrepancy principle
- :mod:`jobs.inverse.loop`: one solve; :mod:`jobs.inverse.run`: all of a study on Dask
- :mod:`jobs.inverse.store`: the results group (schema in :mod:`storage.solves`; Tables
  4.1-4.4 from it in :mod:`analysis.report.ch4`)
"""
