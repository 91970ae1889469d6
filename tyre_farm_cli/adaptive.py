"""What ``farm sweep submit`` shows of an adaptive study (issue 28): a line per fit on
stderr while it runs, a table of its rounds on stdout at the end."""

from __future__ import annotations

from rich.table import Table

from jobs.wording import plural
from tyre_farm_cli.progress import LogLines


def _errors(errors: dict, outputs) -> str:
    shown = [f"{o} {errors[o]:.2f}" for o in outputs if errors.get(o) is not None]
    return ", ".join(shown) or "no output varies"


class RoundLines:
    """One timestamped line on stderr per fit of the surrogate."""

    def __init__(self, study, lines: LogLines | None = None) -> None:
        self.study, self.lines = study, lines or LogLines()

    def fitted(self, index: int, fit, chosen: int) -> None:
        spec = self.study.adaptive
        then = (f"round {index} of {spec.rounds}: {plural(chosen, 'experiment')} chosen"
                if chosen else "stopped")
        self.lines.log(f"adaptive {self.study.name}: surrogate of "
                       f"{plural(fit.fitted_on, 'done experiment')}, held-out (LOO) % of "
                       f"range: {_errors(fit.errors, spec.outputs)}; {then}")


def rounds_table(log, study) -> Table:
    """Per round: the fit that chose it and how many points; then the final fit."""
    spec = study.adaptive
    outputs = [o for o in spec.outputs
               if any(r.fit.errors.get(o) is not None for r in log.rounds)
               or (log.final is not None and log.final.errors.get(o) is not None)]
    why = {"budget": "all rounds run", "target": f"every output within {spec.target_pct:g} %"
           if spec.target_pct is not None else "target met", None: "not finished"}[log.stopped]
    table = Table(title=f"adaptive {study.name}: held-out (leave-one-out) RMSE, % of range; "
                  f"{why}")
    for col in ("round", "fitted on", *outputs, "chosen"):
        table.add_column(col, justify="right")
    fits = [(str(r.index), r.fit, str(len(r.points))) for r in log.rounds]
    if log.final is not None:
        fits.append(("final", log.final, "-"))
    for name, fit, chosen in fits:
        table.add_row(name, str(fit.fitted_on),
                      *(f"{fit.errors[o]:.2f}" if fit.errors.get(o) is not None else "-"
                        for o in outputs), chosen)
    return table
