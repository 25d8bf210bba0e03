"""Errors against the cell size, and the orders they show (as MFEM's ConvergenceStudy records
(h, error) pairs and prints rates): the one place where the studies and the tests turn a
sequence of refinements into observed orders.

    study = ConvergenceStudy()
    for h, error in runs:
        study.add("column settlement", h, error, value=found, reference=exact)
    study.final_order("column settlement")  # between the two finest sizes
    study.table()  # quantity, h_m, value, reference, error, observed_order

The observed order between sizes h_i > h_j is log(e_i / e_j) / log(h_i / h_j)
(analytic.observed_orders); a quantity's rows are ordered from the coarsest size to the
finest whatever order they were added in."""

from __future__ import annotations

import math

import pandas as pd

from studies import analytic


class ConvergenceStudy:
    """(h, error) pairs per quantity, with the value and reference they came from."""

    def __init__(self) -> None:
        self._rows: list[dict] = []

    def add(
        self,
        quantity: str,
        h: float,
        error: float,
        value: float | None = None,
        reference: float | None = None,
    ) -> None:
        """Records one refinement of `quantity`: cell size h (m) and its error (>= 0)."""
        if not (h > 0.0 and math.isfinite(h)):
            raise ValueError(f"{quantity}: cell size {h!r} is not a positive number")
        if not (error >= 0.0):
            raise ValueError(f"{quantity}: error {error!r} at h = {h} is not >= 0")
        if any(r["quantity"] == quantity and r["h_m"] == h for r in self._rows):
            raise ValueError(f"{quantity}: h = {h} recorded twice")
        self._rows.append(
            {
                "quantity": quantity,
                "h_m": float(h),
                "value": error if value is None else value,
                "reference": 0.0 if reference is None else reference,
                "error": float(error),
            }
        )

    def quantities(self) -> list[str]:
        """The quantities in the order they were first added."""
        return list(dict.fromkeys(r["quantity"] for r in self._rows))

    def orders(self, quantity: str) -> list[tuple[float, float | None]]:
        """(h, observed order from the next coarser size) from the coarsest size to the finest;
        None for the coarsest and where an error is zero."""
        rows = sorted(
            (r for r in self._rows if r["quantity"] == quantity),
            key=lambda r: -r["h_m"],
        )
        if not rows:
            raise KeyError(quantity)
        h = [r["h_m"] for r in rows]
        return list(zip(h, analytic.observed_orders(h, [r["error"] for r in rows])))

    def final_order(self, quantity: str) -> float | None:
        """The observed order between the two finest sizes (None with fewer than two)."""
        return self.orders(quantity)[-1][1]

    def table(self) -> pd.DataFrame:
        """Every row with its observed order, sorted by quantity, then from coarse to fine."""
        table = pd.DataFrame(self._rows).sort_values(
            ["quantity", "h_m"], ascending=[True, False]
        )
        order_of = {
            (quantity, h): order
            for quantity in self.quantities()
            for h, order in self.orders(quantity)
        }
        table["observed_order"] = [
            order_of[(q, h)] for q, h in zip(table["quantity"], table["h_m"])
        ]
        return table.reset_index(drop=True)
