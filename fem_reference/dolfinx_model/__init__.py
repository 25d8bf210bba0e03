"""Independent dolfinx (FEniCSx 0.5.2) model of the pfm-mpm cases (plane strain).

API:
    read_case(path) -> Case
    Model(case, degree=2, element_size=None, refine_size=None, refine_distance=None,
          quads=False, updated_lagrangian=False, kappa_measure="plastic_shear")
    run_static(case_or_path, steps=10, collapse=False, ..., **model_options) -> StaticResult
    run_driven(case_or_path, steps=10, end_time=None, ..., **model_options) -> DrivenResult
        (displacement control: the moving supports' displacements in time increments)
    run_explicit(case_or_path, end_time=None, ..., **model_options) -> ExplicitResult
    write_boundary_csv / write_curve_csv / write_series_csv / FieldWriter
CLI: /usr/bin/python3 -m fem_reference.dolfinx_model CASE.json --out DIR [--mode static|explicit] ...
"""
from .case import Case, CaseError, read_case, case_from_dict
from .model import Model, NoConvergence
from .analysis import (
    run_static,
    run_driven,
    run_explicit,
    initial_stress,
    write_boundary_csv,
    write_curve_csv,
    write_series_csv,
    write_table_csv,
    FieldWriter,
    StaticResult,
    DrivenResult,
    ExplicitResult,
)

__all__ = [
    "Case",
    "CaseError",
    "read_case",
    "case_from_dict",
    "Model",
    "NoConvergence",
    "run_static",
    "run_driven",
    "run_explicit",
    "initial_stress",
    "write_boundary_csv",
    "write_curve_csv",
    "write_series_csv",
    "write_table_csv",
    "FieldWriter",
    "StaticResult",
    "DrivenResult",
    "ExplicitResult",
]
