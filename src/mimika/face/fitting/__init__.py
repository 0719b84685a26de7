"""Fitting seed 002's AU fields to measured shapes, reporting their accuracy, and carrying
fitted fields to other heads."""

from mimika.face.fitting.ict import (
    FACE_RANGE,
    FAMILIES,
    JAW_AUS,
    LID_AUS,
    SUB_OBJECT,
    FitOptions,
    FitResult,
    fit_ict,
    fittable_aus,
)
from mimika.face.fitting.optimize import fit_field, fit_phi, fit_psi, fit_rbf
from mimika.face.fitting.report import AuAccuracy, report_csv, report_markdown
from mimika.face.fitting.splits import (
    eye_split,
    mouth_split,
    refine_mouth_split,
    similarity_transform,
)
from mimika.face.fitting.transfer import (
    ALIGN_TOLERANCE_CM,
    landmark_agreement,
    load_fitted_rig,
    read_fields_json,
    transfer_fields,
)

__all__ = [
    "ALIGN_TOLERANCE_CM",
    "FACE_RANGE",
    "FAMILIES",
    "JAW_AUS",
    "LID_AUS",
    "SUB_OBJECT",
    "AuAccuracy",
    "FitOptions",
    "FitResult",
    "eye_split",
    "fit_field",
    "fit_ict",
    "fit_phi",
    "fit_psi",
    "fit_rbf",
    "fittable_aus",
    "landmark_agreement",
    "load_fitted_rig",
    "mouth_split",
    "read_fields_json",
    "refine_mouth_split",
    "report_csv",
    "report_markdown",
    "similarity_transform",
    "transfer_fields",
]
