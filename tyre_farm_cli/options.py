"""Command-line options shared by every command that runs on a Dask cluster.

``--scheduler`` and ``--workers`` are checked when parsed
(:func:`jobs.validate.addresses.scheduler_address`, :func:`tyre_farm_cli.checks.worker_count`),
so a bad value is a usage error before anything starts: ``--workers -3`` once waited for ever on a
cluster of no workers. :func:`with_cluster` adds the rest - ``--cluster local|slurm``,
``--slurm-*`` and ``--tls-*`` - and hands the command one checked
:class:`jobs.cluster.ClusterSpec` (docs/scale-out.md); :func:`with_tls` adds only the
``--tls-*`` options, for ``farm analyse``, whose client is the analysis layer's.
"""

from __future__ import annotations

import functools
import inspect
from collections.abc import Callable
from enum import StrEnum
from pathlib import Path
from typing import Any, TypedDict, get_type_hints

import typer
from typer.core import MarkupMode, TyperCommand

from jobs.errors import StudyError
from jobs.validate import addresses, locations
from tyre_farm_cli.checks import MAX_WORKERS, worker_count


def checked(check: Callable[[Any, str], Any], name: str) -> Callable[[Any], Any]:
    """A typer callback that runs ``check(value, name)`` and turns its error into a usage
    error (``Invalid value for '--workers': ...``)."""
    def callback(value: Any) -> Any:
        try:
            return check(value, name)
        except StudyError as e:
            raise typer.BadParameter(str(e).removeprefix(f"{name}: ")) from e

    return callback


check_scheduler = checked(addresses.scheduler_address, "--scheduler")
check_workers = checked(worker_count, "--workers")

class AppSettings(TypedDict):
    """Keyword arguments of :class:`typer.Typer` that every app of the CLI shares."""

    rich_markup_mode: MarkupMode


#: Settings of every typer app of the CLI. Without rich markup: in rich mode, help texts
#: lose every ``[...]``, the ``[default: ...]`` of options whose default is computed
#: among them (issue 12); typer shows the other defaults itself.
APP_SETTINGS: AppSettings = {"rich_markup_mode": None}

SCHEDULER_HELP = ("Address of a running Dask scheduler, e.g. tcp://host:8786 [default: "
                  "$FARM_SCHEDULER, then $DASK_SCHEDULER_ADDRESS, else an embedded "
                  "LocalCluster].")  # the order of jobs.cluster.resolve_scheduler
SCHEDULER = typer.Option(None, "--scheduler", callback=check_scheduler, help=SCHEDULER_HELP)
WORKERS = typer.Option(None, "--workers", callback=check_workers,
                       help="Embedded cluster: worker processes [default: one per core]. "
                       f"External: wait for this many workers. 1-{MAX_WORKERS}.")

STORAGE_OPTION_HELP = ("fsspec option of a store URL, KEY=VALUE, repeatable (e.g. "
                       "endpoint_url=http://minio:9000); credentials stay in the environment "
                       "[default: none; a study file's [study.storage_options]].")
STORAGE_OPTION = typer.Option(None, "--storage-option", help=STORAGE_OPTION_HELP)


def _option_value(text: str) -> Any:
    lowered = text.lower()
    return {"true": True, "false": False}.get(lowered, text)


def open_target(store: str, options: list[str] | None) -> Any:
    """``store`` as given, or opened with the ``--storage-option`` pairs (checked as a
    study file's table is: URL stores only, no secrets); bad pairs are usage errors."""
    if not options:
        return store
    import storage

    pairs = {}
    for text in options:
        key, sep, value = text.partition("=")
        if not sep or not key:
            raise typer.BadParameter(f"{text!r}: give KEY=VALUE", param_hint="--storage-option")
        pairs[key.strip()] = _option_value(value.strip())
    try:
        checked_options = locations.storage_options(pairs, "--storage-option", store)
    except StudyError as e:
        raise typer.BadParameter(str(e).removeprefix("--storage-option: "),
                                 param_hint="--storage-option") from e
    return storage.open_store(store, storage_options=checked_options)


# ------------------------------------------------------------------ --cluster, --slurm-*, --tls-*

class ClusterKind(StrEnum):
    local = "local"
    slurm = "slurm"


#: --help sections of the options :func:`with_cluster` and :func:`with_tls` add, shown
#: after each command's own options (:class:`PanelCommand`): 13 of them once came first
SLURM_PANEL = "SLURM cluster options"
TLS_PANEL = "TLS options"
_SLURM = "--cluster slurm: "


#: the options :func:`with_cluster` adds: name -> (type, typer.Option); the SLURM ones are
#: SlurmOptions' fields (their defaults are its defaults, shown in --help)
CLUSTER_OPTIONS: dict[str, tuple[Any, Any]] = {
    "cluster_kind": (ClusterKind, typer.Option(
        ClusterKind.local, "--cluster", case_sensitive=False, rich_help_panel=SLURM_PANEL,
        help="local: the embedded LocalCluster, or the --scheduler one; slurm: workers in "
        "SLURM jobs submitted from here (dask-jobqueue, pip install 'tyre-farm[slurm]').")),
    "tls_ca_file": (Path | None, typer.Option(
        None, "--tls-ca-file", rich_help_panel=TLS_PANEL,
        help="TLS: the CA certificate (PEM) that signed the scheduler's and our certificates; "
        "with --tls-cert and --tls-key; needs a tls:// --scheduler, or encrypts the embedded "
        "cluster [default: dask config distributed.comm.tls.*, else no TLS].")),
    "tls_cert": (Path | None, typer.Option(
        None, "--tls-cert", rich_help_panel=TLS_PANEL,
        help="TLS: this client's certificate (PEM) [default: none].")),
    "tls_key": (Path | None, typer.Option(
        None, "--tls-key", rich_help_panel=TLS_PANEL,
        help="TLS: this client's private key (PEM) [default: none].")),
    "slurm_partition": (str | None, typer.Option(
        None, "--slurm-partition", rich_help_panel=SLURM_PANEL,
        help=f"{_SLURM}partition (sbatch -p) [default: the site's jobqueue.slurm.queue, else "
        "SLURM's default partition].")),
    "slurm_account": (str | None, typer.Option(
        None, "--slurm-account", rich_help_panel=SLURM_PANEL,
        help=f"{_SLURM}account (sbatch -A) [default: the site's jobqueue.slurm.account, else "
        "none].")),
    "slurm_jobs": (int, typer.Option(
        1, "--slurm-jobs", min=1, max=10_000, rich_help_panel=SLURM_PANEL,
        help=f"{_SLURM}SLURM jobs kept running (a job that ends is replaced).")),
    "slurm_cores": (int | None, typer.Option(
        None, "--slurm-cores", min=1, max=1024, rich_help_panel=SLURM_PANEL,
        help=f"{_SLURM}cores per job, one single-threaded worker (one ccx) each "
        "[default: jobqueue.slurm.cores of the site's dask config, else 1].")),
    "slurm_memory": (str | None, typer.Option(
        None, "--slurm-memory", rich_help_panel=SLURM_PANEL,
        help=f"{_SLURM}memory per job, e.g. 4GiB [default: the site's jobqueue.slurm.memory, "
        "else 2GiB].")),
    "slurm_walltime": (str | None, typer.Option(
        None, "--slurm-walltime", rich_help_panel=SLURM_PANEL,
        help=f"{_SLURM}time limit per job (sbatch -t); workers retire about 5 min before it, "
        "so a walltime kill costs no task failure [default: the site's "
        "jobqueue.slurm.walltime, else 01:00:00].")),
    "slurm_interface": (str | None, typer.Option(
        None, "--slurm-interface", rich_help_panel=SLURM_PANEL,
        help=f"{_SLURM}network interface of scheduler and workers, e.g. ib0 or lo "
        "[default: the host name's address].")),
    "slurm_job_name": (str, typer.Option(
        "tyre-farm", "--slurm-job-name", rich_help_panel=SLURM_PANEL,
        help=f"{_SLURM}name of the jobs (sbatch -J), what `squeue -n` finds.")),
    "slurm_dashboard": (str, typer.Option(
        ":8787", "--slurm-dashboard", rich_help_panel=SLURM_PANEL,
        help=f"{_SLURM}address of the scheduler's dashboard (it runs here).")),
}


class PanelCommand(TyperCommand):
    """A command whose --help lists its own options first, then the options of each
    ``rich_help_panel`` in a section of its own. Typer groups by panel only in rich mode,
    which :data:`APP_SETTINGS` turns off."""

    def format_options(self, ctx: Any, formatter: Any) -> None:
        arguments: list[tuple[str, str]] = []
        sections: dict[str, list[tuple[str, str]]] = {"Options": []}
        for param in self.get_params(ctx):
            record = param.get_help_record(ctx)
            if record is None:
                continue
            if param.param_type_name == "argument":
                arguments.append(record)
            else:
                panel = getattr(param, "rich_help_panel", None) or "Options"
                sections.setdefault(panel, []).append(record)
        for title, records in (("Arguments", arguments), *sections.items()):
            if records:
                with formatter.section(title):
                    formatter.write_dl(records)


def use_panels(app: typer.Typer) -> None:
    """Make every command of ``app`` and of the apps mounted in it a :class:`PanelCommand`
    (before the click command is built)."""
    for info in app.registered_commands:
        if info.cls in (None, TyperCommand):  # typer's default: no class of our own
            info.cls = PanelCommand
    for group in app.registered_groups:
        if group.typer_instance is not None:
            use_panels(group.typer_instance)


def cluster_spec(kind: ClusterKind, scheduler: str | None, workers: int | None,
                 tls: tuple[Path | None, Path | None, Path | None], slurm: dict[str, Any]):
    """The :class:`jobs.cluster.ClusterSpec` of the options, checked; bad combinations
    and bad values are usage errors (one line, exit 2)."""
    from jobs.cluster import DaskCluster
    from jobs.errors import ClusterError
    from jobs.tls import TlsFiles
    from tyre_farm_cli.errors import usage

    with usage():
        files = TlsFiles.from_options(*tls)
        if kind is ClusterKind.local:
            given = [f"--slurm-{k.removeprefix('slurm_')}" for k, v in slurm.items()
                     if v != CLUSTER_OPTIONS[k][1].default]
            if given:
                raise ClusterError(f"{', '.join(given)} apply to --cluster slurm only: add "
                                   "--cluster slurm, or drop them")
            return DaskCluster(scheduler, workers, files)
        for option, value in (("--scheduler", scheduler), ("--workers", workers),
                              ("--tls-ca-file", files)):
            if value is not None:
                raise ClusterError(
                    f"--cluster slurm starts its own scheduler, so {option} does not apply: "
                    "drop it (workers: --slurm-jobs x --slurm-cores; TLS on SLURM is not "
                    "supported yet)")
        options = _slurm_options(slurm)
    _require_jobqueue()
    return options


def _slurm_options(slurm: dict[str, Any]):
    from jobs.slurm import SlurmOptions

    return SlurmOptions(
        queue=slurm["slurm_partition"], account=slurm["slurm_account"],
        jobs=slurm["slurm_jobs"], cores=slurm["slurm_cores"], memory=slurm["slurm_memory"],
        walltime=slurm["slurm_walltime"], interface=slurm["slurm_interface"],
        job_name=slurm["slurm_job_name"], dashboard_address=slurm["slurm_dashboard"])


def _require_jobqueue() -> None:
    """dask-jobqueue is an extra: say how to install it before anything starts."""
    import importlib.util

    from jobs.errors import ClusterError
    from jobs.slurm import INSTALL_HINT

    try:
        found = importlib.util.find_spec("dask_jobqueue") is not None
    except ValueError:  # a module set to None in sys.modules (tests)
        found = False
    if not found:
        raise ClusterError(f"--cluster slurm needs dask-jobqueue: {INSTALL_HINT}")


def with_cluster(command: Callable[..., Any]) -> Callable[..., Any]:
    """Give ``command`` the options of :data:`CLUSTER_OPTIONS` and call it with
    ``cluster=`` the checked :class:`jobs.cluster.ClusterSpec` they and its own
    ``--scheduler``/``--workers`` make (which it still receives).

    ``command`` must take ``scheduler``, ``workers`` and ``cluster`` parameters. Typer
    reads the signature this sets; decorate below ``@app.command()``.
    """
    def call(kwargs: dict[str, Any], extra: dict[str, Any]) -> Any:
        tls = (extra.pop("tls_ca_file"), extra.pop("tls_cert"), extra.pop("tls_key"))
        spec = cluster_spec(ClusterKind(extra.pop("cluster_kind")), kwargs.get("scheduler"),
                            kwargs.get("workers"), tls, extra)
        return command(**kwargs, cluster=spec)

    return _adding(command, CLUSTER_OPTIONS, call, drop="cluster")


TLS_OPTIONS = {k: CLUSTER_OPTIONS[k] for k in ("tls_ca_file", "tls_cert", "tls_key")}


def with_tls(command: Callable[..., Any]) -> Callable[..., Any]:
    """Give ``command`` the ``--tls-*`` options (:data:`TLS_OPTIONS`) for its own
    ``--scheduler``, checked (:mod:`jobs.tls`), and run it with them in dask's
    configuration, where every ``distributed.Client`` it makes finds them.

    For commands whose client is not the farm's (``farm analyse``); ``command`` must take
    a ``scheduler`` parameter (an address or None: no TLS needed then).
    """
    def call(kwargs: dict[str, Any], extra: dict[str, Any]) -> Any:
        import dask

        from jobs.tls import TlsFiles, check_address
        from tyre_farm_cli.errors import usage

        with usage():
            files = TlsFiles.from_options(*extra.values())
            check_address(kwargs.get("scheduler"), files)
        with dask.config.set(files.dask_config() if files else {}):
            return command(**kwargs)

    return _adding(command, TLS_OPTIONS, call)


def _adding(command: Callable[..., Any], options: dict[str, tuple[Any, Any]],
            call: Callable[[dict[str, Any], dict[str, Any]], Any],
            drop: str | None = None) -> Callable[..., Any]:
    """``command`` with ``options`` (name -> (type, typer.Option)) added to its
    signature (and ``drop`` taken out); ``call(kwargs, extra)`` runs it, ``extra`` the
    added options' values."""
    signature = inspect.signature(command, eval_str=True)
    own = [p for name, p in signature.parameters.items() if name != drop]
    added = [inspect.Parameter(name, inspect.Parameter.KEYWORD_ONLY, default=option,
                               annotation=kind) for name, (kind, option) in options.items()]
    hints = {k: v for k, v in get_type_hints(command).items() if k != drop}

    @functools.wraps(command)
    def wrapper(**kwargs: Any) -> Any:
        return call(kwargs, {name: kwargs.pop(name) for name in options})

    # typeshed declares no __signature__ on functions, yet inspect.signature (hence typer)
    # reads it first (PEP 362): the stubs are narrower than the language here
    wrapper.__signature__ = signature.replace(  # type: ignore[attr-defined]
        parameters=own + added)
    wrapper.__annotations__ = {**hints, **{n: k for n, (k, _) in options.items()}}
    del wrapper.__wrapped__  # typer must see the new signature, not the command's
    return wrapper
