"""The command line of the running ``farm``: what a study's provenance names
(analysis/render/provenance.py). Set once by :func:`tyre_farm_cli.main`."""

from __future__ import annotations

import shlex

ARGS: list[str] = []  # the arguments after ``farm``, as main received them


def command() -> str:
    """The running command as a shell would take it, e.g. ``farm analyse sensor S``."""
    return shlex.join(["farm", *ARGS])
