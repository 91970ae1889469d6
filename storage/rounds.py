"""The rounds of an adaptive study, kept in its experiment group (issue 28).

An adaptive study (:mod:`jobs.adaptive`) chooses experiments in rounds; the points each
round chose must outlive the client, so that a killed study resumes at its round
instead of choosing again (a refit on the same data gives the same choice only up to
the optimiser's round-off). They are one JSON attribute of the group,
``adaptive_rounds``, written by the client under the store's client lock like every
metadata write of this package, then published to the consolidated metadata.

The record is the caller's plain JSON value (a dict); this module only stores it: what
it holds is :mod:`jobs.adaptive.log`'s business, and ``docs/schema.md`` documents it.
"""

from __future__ import annotations

import json
from typing import Any

from storage.errors import SchemaError
from storage.lock import client_lock
from storage.paths import StoreLike, names_the_store, open_group, open_store, publish

ATTRIBUTE = "adaptive_rounds"


@names_the_store
def write_rounds(store: StoreLike, group: str, record: dict[str, Any]) -> None:
    """Replace the group's adaptive-study record with ``record`` (JSON values only)."""
    try:
        text = json.dumps(record, allow_nan=False)
    except (TypeError, ValueError) as e:
        raise SchemaError(f"the adaptive record of group {group!r} must be plain JSON "
                          f"(finite numbers, text, lists, tables): {e}") from e
    zs = open_store(store)
    with client_lock(zs):  # metadata has one writer at a time
        open_group(zs, group).attrs[ATTRIBUTE] = json.loads(text)
        publish(zs)


@names_the_store
def read_rounds(store: StoreLike, group: str) -> dict[str, Any] | None:
    """The group's adaptive-study record, or None when no adaptive study wrote one."""
    record = open_group(open_store(store), group).attrs.get(ATTRIBUTE)
    if record is None:
        return None
    if not isinstance(record, dict):
        raise SchemaError(f"group {group!r}: its {ATTRIBUTE!r} attribute is not a table (holds "
                          f"{type(record).__name__}): it was not written by an adaptive study")
    return dict(record)
