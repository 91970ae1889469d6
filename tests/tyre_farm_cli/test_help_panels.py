"""--help lists a command's own options first and the cluster options in sections of
their own after them (issue 25: 13 SLURM/TLS options once filled every command's list)."""

from __future__ import annotations

import pytest
from cli_helpers import run_cli

SLURM = ("--cluster", "--slurm-partition", "--slurm-account", "--slurm-jobs", "--slurm-cores",
         "--slurm-memory", "--slurm-walltime", "--slurm-interface", "--slurm-job-name",
         "--slurm-dashboard")
TLS = ("--tls-ca-file", "--tls-cert", "--tls-key")


def _sections(text: str) -> dict[str, str]:
    """Heading ("Options", ...) -> the text under it, in order."""
    sections: dict[str, str] = {}
    title = None
    for line in text.splitlines():
        if line and not line[0].isspace() and line.endswith(":"):
            title = line[:-1]
            sections[title] = ""
        elif title is not None:
            sections[title] += line + "\n"
    return sections


def _options(block: str) -> set[str]:
    """The options a section lists (its lines "  --name ..."; deeper ones wrap help)."""
    return {line.split()[0] for line in block.splitlines() if line.startswith("  --")}


@pytest.mark.parametrize("command", [["sweep", "submit"], ["sweep", "resume"], ["invert"],
                                     ["calibrate"], ["reproduce"]], ids=" ".join)
def test_cluster_options_have_their_own_sections_after_the_commands(command, capsys):
    code, out, _ = run_cli([*command, "--help"], capsys)
    assert code == 0
    sections = _sections(out)
    titles = list(sections)
    assert titles.index("Options") < titles.index("SLURM cluster options") < titles.index(
        "TLS options")
    own = _options(sections["Options"])
    assert {"--scheduler", "--workers", "--help"} <= own
    assert not own & {*SLURM, *TLS}
    assert _options(sections["SLURM cluster options"]) == set(SLURM)
    assert _options(sections["TLS options"]) == set(TLS)


def test_analyse_has_the_tls_section_only(capsys):
    code, out, _ = run_cli(["analyse", "pca", "--help"], capsys)
    assert code == 0
    sections = _sections(out)
    assert "SLURM cluster options" not in sections
    assert _options(sections["TLS options"]) == set(TLS)
    assert not _options(sections["Options"]) & set(TLS)


def test_a_command_without_cluster_options_has_one_options_section(capsys):
    code, out, _ = run_cli(["sweep", "status", "--help"], capsys)
    assert code == 0 and [t for t in _sections(out) if "ptions" in t] == ["Options"]
