"""``farm export``: ParaView (VTU) files of stored experiments."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import typer
from rich.console import Console

from farm.errors import SpecError
from jobs.wording import plural
from tyre_farm_cli.errors import usage


def export(
    store: str = typer.Argument(..., help="Zarr store: directory or fsspec URL."),
    group: str = typer.Option(None, "--group", help="Group [default: the store's only one]."),
    experiment: list[str] = typer.Option(
        [], "--experiment", help="Experiment id or unique prefix (repeat) [default: all done]."),
    out: Path = typer.Option(Path("vtu"), "--out", help="Output folder."),
) -> None:
    """Write the inner surface (U, strains) and tread (road forces) of experiments as VTU."""
    import storage
    from farm.export import surface_vtus
    from farm.mesh import mesh_for
    from farm.specs import ModelSpec
    from tyre_farm_cli.checks import output_folder

    with usage():
        output_folder(out, "--out")  # before reading the store or meshing
    groups = [group] if group else storage.list_groups(store)
    if len(groups) != 1:
        raise SpecError(f"the store has groups {', '.join(groups) or 'none'}: choose one with "
                        "--group")
    ds = storage.done(storage.open_dataset(store, groups[0]))
    ids = [str(i) for i in ds["experiment"].values]
    with usage():  # an id the user typed that no done experiment has
        chosen = [_match(ids, e) for e in experiment] if experiment else ids
    mesh = mesh_for(ModelSpec.from_dict(json.loads(ds.attrs["model_spec"])))
    if not np.array_equal(ds["inner_node"].values, mesh.inner_nodes):
        raise SpecError("the store's inner nodes do not match the model's mesh")
    written = []
    for exp in chosen:
        one = ds.sel(experiment=exp).load()
        arrays = {k: one[k].values for k in ("displacement", "strain", "surface_strain",
                                             "reaction_force")}
        load = f"{float(one['deflection']):g}mm_{1000 * float(one['pressure']):g}kPa"
        stem = out / f"{exp[:12]}_{load}"
        written += surface_vtus(mesh, arrays, stem)
    Console().print(f"wrote {plural(len(written), 'VTU file')} to {out}")


def _match(ids: list[str], prefix: str) -> str:
    found = [i for i in ids if i.startswith(prefix)]
    if len(found) != 1:
        what = "no done experiment matches" if not found else f"{len(found)} experiments match"
        raise SpecError(f"{what} {prefix!r}: give a longer id prefix "
                        "(see `farm sweep list STORE --status done`)")
    return found[0]
