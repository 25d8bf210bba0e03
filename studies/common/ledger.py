"""The energy ledger of a run as a figure (timeseries.csv columns, kJ/m; the terms are those of
mpm/step/energy_ledger.hpp and the README's "energy ledger")."""

from __future__ import annotations

import pandas as pd


def ledger_lines(series: pd.DataFrame) -> list[tuple[str, pd.Series, str]]:
    """(label, values, line style) of the ledger: what gravity and the loads supply (each load
    on its own when a case has several, ``load_work_<k>``), where it goes (stored, dissipated,
    damped), and the scheme's own terms."""
    loads = sorted(
        (c for c in series.columns if c.startswith("load_work_")),
        key=lambda c: int(c.rsplit("_", 1)[1]),
    )
    supplied = [("gravity work", series["gravity_work"], "-")]
    if len(loads) > 1:
        supplied += [
            (f"work of load {c.rsplit('_', 1)[1]}", series[c], "-") for c in loads
        ]
    else:
        supplied.append(("load work", series["load_work"], "-"))
    return supplied + [
        (
            "elastic energy change",
            series["elastic_energy"] - series["elastic_energy"].iloc[0],
            "--",
        ),
        ("kinetic energy", series["kinetic_energy"], "--"),
        ("plastic dissipation", series["plastic_dissipation"], "--"),
        ("damping (removed)", -series["damping_work"], "--"),
        (
            "transfers, particles <-> grid",
            series["transfer_to_grid"] + series["transfer_to_particles"],
            ":",
        ),
        (
            "scheme: internal force work + stress power",
            series["internal_force_work"] + series["internal_work"],
            ":",
        ),
        (
            "constraints, rotation, volume",
            series["constraint_work"] + series["rotation_work"] + series["volume_work"],
            ":",
        ),
    ]


# The energy and ledger columns whose largest magnitude scales energy_error (as
# EnergyBalance::largest_term; internal_work is the ledger's stress_power).
TERMS = (
    "kinetic_energy",
    "elastic_energy",
    "plastic_dissipation",
    "gravity_work",
    "load_work",
    "damping_work",
    "constraint_work",
    "transfer_to_grid",
    "transfer_to_particles",
    "internal_force_work",
    "internal_work",
    "rotation_work",
    "volume_work",
)


def relative_energy_error(series: pd.DataFrame) -> float:
    """The largest |energy_error| of the rows over the largest |term| of the whole run."""
    largest = float(series[list(TERMS)].abs().max().max())
    worst = float(series["energy_error"].abs().max())
    return worst / largest if largest > 0 else worst


def plot_energy_ledger(axis, series: pd.DataFrame, title: str):
    """The ledger against time on ``axis``, titled with the largest |energy error|."""
    for label, values, style in ledger_lines(series):
        axis.plot(series["time"], values, style, label=label)
    axis.set_xlabel("time t [s]")
    axis.set_ylabel("energy [kJ/m]")
    worst = float(series["energy_error"].abs().max())
    axis.set_title(
        f"{title}: largest |energy error| {worst:.2g} kJ/m "
        f"({relative_energy_error(series):.1g} of the largest term)",
        fontsize=9,
    )
    axis.legend(fontsize=7)
