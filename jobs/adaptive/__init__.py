"""Adaptive studies (issue 28): a small space-filling design, then rounds in which a
surrogate of the experiments run so far chooses where to run next.

:mod:`jobs.validate.adaptive` validates a study's ``[study.adaptive]`` table; ``log``
keeps the rounds chosen so far in the study's store group, so that a killed study
resumes at its round; ``loop`` runs the rounds, each an ordinary sweep
(:func:`jobs.sweep.run_sweep`) of the study with the points chosen so far. The
surrogate itself belongs to :mod:`analysis` (jobs may not import it,
tests/test_layering.py): the loop takes it as a :class:`loop.Chooser`, and the CLI
passes :class:`analysis.adaptive.SurrogateChooser`.
"""
