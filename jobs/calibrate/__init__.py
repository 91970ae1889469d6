"""Material calibration on the farm: ``farm calibrate``.

Region Young's moduli (and optionally wall thicknesses) are tuned until the model's
force-deflection points match reference points: by default the thesis' own (reduced
model 359 N at 30 mm; full model 3933 N at 25 mm / 80 kPa and 4476 N at 30 mm /
200 kPa), or a user CSV. It is a least-squares loop on the client whose evaluations
(one load path per pressure per parameter set) and finite-difference Jacobian columns
run side by side on the workers, cached by content hash like the inverse loops'.

- :mod:`jobs.calibrate.references`: reference points (thesis defaults, CSV)
- :mod:`jobs.calibrate.params`: the fitted parameters and how they change a ModelSpec
- :mod:`jobs.calibrate.evaluate`: the worker task (one load path) and its key
- :mod:`jobs.calibrate.fit`: the loop; :mod:`jobs.calibrate.run`: on Dask
"""
